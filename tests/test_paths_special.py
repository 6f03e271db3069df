"""Outputs that are not regular files, and outputs through symbolic links (found by the hostile sweep of issue 16:
``tilesynth build in.png -o /dev/full``, run as root, replaced the device node with the ZIP and exited 0).

Outputs are written to a temporary file that is renamed over the target, so a device, FIFO or socket would be
replaced rather than written into: they are refused up front (exit 2, nothing created). A symbolic link to a
file is written through: the linked file gets the content and the link stays a link."""

from __future__ import annotations

import os
import socket
import stat

import numpy as np
import pytest

import tilesynth
from tilesynth.cli.main import main


@pytest.fixture
def exemplar(tmp_path):
    img, _ = tilesynth.load_image(tilesynth.data.example_path())
    p = tmp_path / "ex.png"
    tilesynth.save_image(p, img[:96, :96])
    return p


@pytest.fixture
def tiles(tmp_path, exemplar):
    p = tmp_path / "in.tiles"
    assert main(["build", str(exemplar), "-o", str(p), "--tile-size", "24", "--seed", "1", "-q"]) == 0
    return p


def _specials(tmp_path, suffix):
    """A FIFO, a socket, a link to the FIFO and, when root, a character device (a copy of /dev/null's), each
    named with ``suffix``."""
    out = {}
    fifo = tmp_path / f"fifo{suffix}"
    os.mkfifo(fifo)
    out["fifo"] = fifo
    sock_path = tmp_path / f"sock{suffix}"
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.bind(str(sock_path))
    out["socket"] = sock_path
    link = tmp_path / f"link{suffix}"
    link.symlink_to(fifo.name)
    out["link to fifo"] = link
    if os.geteuid() == 0:
        dev = tmp_path / f"null{suffix}"
        os.mknod(dev, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
        out["char device"] = dev
    return out, s


def _kinds(d):
    return {p.name: stat.S_IFMT(os.lstat(p).st_mode) for p in d.iterdir()}


@pytest.mark.parametrize("command", ["build", "synth", "sheet", "synth --save-map"])
def test_outputs_that_are_not_regular_files_are_refused(tmp_path, exemplar, tiles, capsys, command):
    suffix = {"build": ".tiles", "synth --save-map": ".npy"}.get(command, ".png")
    specials, sock = _specials(tmp_path, suffix)
    try:
        for what, target in specials.items():
            argv = {
                "build": ["build", str(exemplar), "-o", str(target), "-q"],
                "synth": ["synth", str(tiles), "-o", str(target), "--size", "48", "-q"],
                "sheet": ["sheet", str(tiles), "-o", str(target)],
                "synth --save-map": [
                    *("synth", str(tiles), "-o", str(tmp_path / "ok.png"), "--size", "48"),
                    *("--save-map", str(target), "-q"),
                ],
            }[command]
            before = _kinds(tmp_path)
            assert main(argv) == 2, what
            err = capsys.readouterr().err
            assert "is not a regular file" in err, (what, err)
            assert _kinds(tmp_path) == before, (what, "the directory changed")
    finally:
        sock.close()


def test_output_through_a_symbolic_link_updates_the_linked_file(tmp_path, tiles):
    real = tmp_path / "real.png"
    tilesynth.save_image(real, np.zeros((4, 4, 3), np.uint8))
    link = tmp_path / "out.png"
    link.symlink_to(real.name)
    assert main(["synth", str(tiles), "-o", str(link), "--size", "48", "--seed", "2", "-q"]) == 0
    assert link.is_symlink() and os.readlink(link) == real.name
    img, _ = tilesynth.load_image(real)
    assert img.shape == (48, 48, 3)
    # a dangling link: the file it names is created, the link kept
    dangling = tmp_path / "d.png"
    dangling.symlink_to("made.png")
    assert main(["synth", str(tiles), "-o", str(dangling), "--size", "48", "--seed", "2", "-q"]) == 0
    assert dangling.is_symlink() and (tmp_path / "made.png").is_file()
    assert not list(tmp_path.glob(".*part"))


def test_api_save_refuses_a_fifo(tmp_path):
    fifo = tmp_path / "f.png"
    os.mkfifo(fifo)
    with pytest.raises(tilesynth.ParameterError, match="not a regular file"):
        tilesynth.save_image(fifo, np.zeros((4, 4, 3), np.uint8))
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


def test_a_fifo_given_as_tile_set_is_named_as_such(tmp_path, capsys):
    fifo = tmp_path / "f.tiles"
    os.mkfifo(fifo)
    assert main(["info", str(fifo)]) == 2
    assert "not a regular file" in capsys.readouterr().err


def test_sigint_during_a_build_takes_effect_within_seconds(tmp_path):
    """The matching of a build (one call for every template before) is chunked, so Ctrl-C during it stops the
    build promptly: exit 130, no output, no temporary file. The bound is on the CPU time spent after the signal
    and loose; the whole matching was 18 s on this input."""
    import signal
    import subprocess
    import sys
    import time

    from signal_timing import interrupt

    rng = np.random.default_rng(5)
    ex = tmp_path / "ex.png"
    tilesynth.save_image(ex, rng.integers(0, 256, (512, 512, 3), dtype=np.uint8))
    out = tmp_path / "x.tiles"
    code = (
        "import sys, tilesynth.base.kernels as k\n"
        "orig = k._best_matches_in_chunks\n"
        "def noisy(*a, **kw):\n"
        "    print('MATCHING', flush=True)\n"
        "    return orig(*a, **kw)\n"
        "k._best_matches_in_chunks = noisy\n"
        "from tilesynth.cli.main import main\n"
        f"sys.exit(main(['build', {str(ex)!r}, '-o', {str(out)!r}, '--tile-size', '32', '--seed', '1', '-q']))\n"
    )
    p = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    assert p.stdout.readline().strip() == "MATCHING"
    time.sleep(0.3)
    rc, err, wall, cpu = interrupt(p, signal.SIGINT)
    if rc == 0:
        pytest.skip("the build finished before the signal arrived")
    assert rc == 130, err
    # CPU after the signal (tests/signal_timing.py), not wall time, which the machine's load inflates
    assert cpu < 5, f"the build did {cpu:.1f} CPU s of work after Ctrl-C (wall {wall:.1f} s)"
    assert not out.exists() and not list(tmp_path.glob(".*part"))


@pytest.mark.parametrize("kind", ["fifo", "directory"])
def test_a_fifo_or_folder_given_as_an_input_says_what_it_is(tmp_path, exemplar, tiles, capsys, kind):
    """A FIFO or a folder given as an exemplar, a map (build --map, synth --with, export --with) or an index
    map (synth --map): one line saying what it is, never "no such file" (and never blocking on the FIFO)."""
    from tilesynth.io.images import load_image, load_raster

    bad = tmp_path / f"bad-{kind}.png"
    os.mkfifo(bad) if kind == "fifo" else bad.mkdir()
    npy = tmp_path / f"bad-{kind}.npy"
    os.mkfifo(npy) if kind == "fifo" else npy.mkdir()
    said = "is not a regular file (a FIFO" if kind == "fifo" else "is a directory"
    for fn in (load_image, load_raster):
        with pytest.raises(tilesynth.ParameterError, match=said.replace("(", r"\(")):
            fn(bad)
    out = str(tmp_path / "o.png")
    for args in (
        ["build", str(bad), "-o", str(tmp_path / "x.tiles"), "-q"],
        ["build", str(exemplar), "--map", f"height={bad}", "-o", str(tmp_path / "x.tiles"), "-q"],
        ["synth", str(tiles), "-o", out, "--size", "48x48", "--with", str(bad), "-q"],
        ["synth", str(tiles), "-o", out, "--size", "48x48", "--map", str(npy), "-q"],
        ["export", str(tiles), "-o", str(tmp_path / "exp"), "--with", str(bad)],
    ):
        assert main(args) == 2, args
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and said in err and "no such file" not in err, (args, err)
    assert not (tmp_path / "x.tiles").exists() and not (tmp_path / "o.png").exists()
