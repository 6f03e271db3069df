"""Atomic writes: every output goes to a temporary file beside it and is renamed over it only when complete
(:func:`atomic_path`, :func:`atomic_open`), alone or with the other files of a set committed together
(:func:`file_set`), so an error, Ctrl-C or SIGTERM never leaves a partial file or a mixed set."""

from __future__ import annotations

import contextlib
import contextvars
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO

from ..errors import ParameterError


def _write_target(path: str | os.PathLike[str]) -> Path:
    """The file an output ``path`` names: ``path`` itself, or for a symbolic link the file it points to (so that
    writing through a link updates the linked file and keeps the link, as ``open(path, "w")`` would, instead of
    replacing the link by a file)."""
    target = Path(path)
    return Path(os.path.realpath(target)) if target.is_symlink() else target


def check_writable(path: str | os.PathLike[str], label: str = "output") -> Path:
    """Raise :class:`ParameterError` (naming ``label``) unless ``path`` can be written as a file: its directory
    exists, it is not a directory, and if it exists it is a regular file. Returns the directory.

    Not a regular file (``build in.png -o /dev/full`` once replaced the device node with a ZIP when run as
    root): outputs are written to a temporary file renamed over the target, which would replace a device, FIFO
    or socket instead of writing into it, so they are refused with the reason."""
    shown = Path(path)
    target = _write_target(path)
    parent = target.parent if str(target.parent) else Path(".")
    if not parent.is_dir():
        raise ParameterError(f"{label} = {str(shown)!r}: directory {str(parent)!r} does not exist")
    if target.is_dir():
        raise ParameterError(f"{label} = {str(shown)!r}: is a directory, expected a file name")
    try:
        mode = target.stat().st_mode
    except OSError:
        return parent  # does not exist yet (or cannot be examined: the write reports it)
    if not stat.S_ISREG(mode):
        raise ParameterError(
            f"{label} = {str(shown)!r}: is not a regular file (a device, FIFO or socket); tilesynth writes a "
            "temporary file and renames it over the output, which would replace it: name a file"
        )
    return parent


# The files written inside a file_set() block: [(temporary path, target)], renamed into place together at its end.
_file_set: contextvars.ContextVar[list[tuple[Path, Path]] | None] = contextvars.ContextVar(
    "file_set", default=None
)


@contextlib.contextmanager
def file_set() -> Iterator[None]:
    """Commit every atomic write inside the block as a unit: each file is written to its temporary name as
    usual, but renamed over its target only when the whole block succeeds, all at the end, with SIGINT and
    SIGTERM held back during the renames; on any error (Ctrl-C, SIGTERM, a full disk) every temporary file is
    removed and the previous files stay as they were.

    Why: a command that writes a set of files that belong together (an export: atlases, mips and the manifest
    that lists them; a material synth: the colour and its maps) must never leave new files beside old ones.
    The renames are quick metadata operations in one directory; only SIGKILL or a crash between two of them
    can leave a mixed set. A block inside another joins the outer one."""
    if _file_set.get() is not None:
        yield
        return
    pending: list[tuple[Path, Path]] = []
    token = _file_set.set(pending)
    try:
        yield
    except BaseException:
        _file_set.reset(token)
        _discard(pending)
        raise
    _file_set.reset(token)
    with _signals_held():
        for k, (tmp, target) in enumerate(pending):
            try:
                os.replace(tmp, target)
            except BaseException:
                _discard(pending[k:])
                raise


def pending_path(path: str | os.PathLike[str]) -> Path:
    """Where the content of ``path`` is now: its temporary file if it was written in the current
    :func:`file_set` block and not yet committed, else ``path`` itself (for a writer that reads back a file
    it wrote in the same set)."""
    target = _write_target(path)
    for tmp, t in _file_set.get() or []:
        if t == target:
            return tmp
    return Path(path)


def _discard(pending: list[tuple[Path, Path]]) -> None:
    for tmp, _ in pending:
        with contextlib.suppress(OSError):
            tmp.unlink()


@contextlib.contextmanager
def _signals_held() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back (delivered when the block ends) in the main thread; elsewhere a no-op
    (signals are delivered to the main thread)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "pthread_sigmask"):
        yield
        return
    held = {signal.SIGINT, signal.SIGTERM}
    old = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success move it into place (at the end of the enclosing
    :func:`file_set` block, if any), on any error remove it.

    An ``OSError`` without a file name (``write`` on a full disk says only "No space left on device") gets the
    output's name, so that the message says which file could not be written."""
    parent = check_writable(path)
    target = _write_target(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part", dir=parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        # mkstemp creates 0600 files; give the result the permissions a plain open() would have
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp_path, 0o666 & ~umask)
        pending = _file_set.get()
        if pending is None:
            os.replace(tmp_path, target)
        else:
            for k, (old, t) in enumerate(pending):
                if t == target:  # written twice in one set: the last write wins
                    with contextlib.suppress(OSError):
                        old.unlink()
                    del pending[k]
                    break
            pending.append((tmp_path, target))
    except BaseException as exc:
        with contextlib.suppress(OSError):
            tmp_path.unlink()
        if isinstance(exc, OSError) and exc.filename in (None, str(tmp_path)):
            exc.filename = str(path)
        raise


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike[str], mode: str = "wb") -> Iterator[IO]:
    """Open a temporary file next to ``path`` for writing; it replaces ``path`` only if the block succeeds."""
    with atomic_path(path) as tmp, open(tmp, mode) as fh:
        yield fh
