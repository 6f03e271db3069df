"""Tampered tile-set files exit 2 naming the field, never 1 (issue 16): the manifest schema and the .npy
header checks of tilesynth.tileset.manifest, on the listed cases through every reading subcommand, and by fuzzing
every field of real manifests (hypothesis)."""

from __future__ import annotations

import contextlib
import copy
import io
import json
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import tilesynth
from tilesynth.cli.main import main
from tilesynth.errors import TileSetFormatError


@pytest.fixture(scope="module")
def sets(tmp_path_factory, small_exemplar) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("sets")
    ex = d / "ex.png"
    tilesynth.save_image(ex, small_exemplar)
    runs = {
        "omega_ga": ["--select", "ga", "--generations", "3", "--population", "6", "--polish"],
        # issue 15: the default selection (best-of by ΣD, cut re-ranking) with the cut polish
        "omega_cut": ["--set", "8", "--population", "6", "--rerank", "2", "--polish"],
        "wang": ["--scheme", "wang"],
        "swang": ["--scheme", "swang", "--select", "ais", "--generations", "2", "--population", "6"],
    }
    # issue 14: a material set (its maps, their kinds and the manifest's maps list are fuzzed too)
    lum = small_exemplar.astype(np.float64).mean(axis=2)
    tilesynth.save_image(d / "h.png", np.round(lum * 65535).astype(np.uint16))
    gy, gx = np.gradient(lum * 4)
    nrm = np.stack([-gx, gy, np.ones_like(gx)], axis=-1)
    nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
    tilesynth.save_image(d / "n.png", np.round((nrm * 0.5 + 0.5) * 255).astype(np.uint8))
    tilesynth.save_image(d / "m.png", (lum > 0.5).astype(np.uint8) * 255)
    runs["material"] = ["--set", "4", "--map", f"height={d / 'h.png'}", "--map", f"normal={d / 'n.png'}",
                        "--map", f"mask={d / 'm.png'}"]  # fmt: skip
    out = {}
    for name, extra in runs.items():
        out[name] = d / f"{name}.tiles"
        assert (
            main(["build", str(ex), "-o", str(out[name]), "--tile-size", "24", "--seed", "3", "-q", *extra])
            == 0
        )
        # the listed cases tamper with version 1's members (tiles.npy): the sets written with their pixels;
        # the fuzzer sees the version-2 files too (fuzz_sets)
        tilesynth.load(out[name]).save(out[name], format_version=1)
    return out


def _manifest(path: Path) -> dict:
    with zipfile.ZipFile(path) as zf:
        return json.loads(zf.read("manifest.json"))


def rewrite(
    src: Path, dst: Path, manifest: dict | None = None, members: dict[str, bytes] | None = None
) -> Path:
    """Copy the tile set ``src`` to ``dst`` with ``manifest.json`` and other members replaced."""
    members = dict(members or {})
    if manifest is not None:
        members["manifest.json"] = json.dumps(manifest).encode()
    with zipfile.ZipFile(src) as zi, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zo:
        for info in zi.infolist():
            zo.writestr(info.filename, members.pop(info.filename, None) or zi.read(info.filename))
    return dst


def _npy(a: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, a, allow_pickle=False)
    return buf.getvalue()


def _huge_header() -> bytes:
    """A tiles.npy whose header declares 10^6 x 10^6 x 3 x 3 float32 (36 TB) over 10 bytes of data."""
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buf, {"descr": "<f4", "fortran_order": False, "shape": (10**6, 10**6, 3, 3)}
    )
    return buf.getvalue() + b"\0" * 10


def _cases(src: Path):
    """(name, manifest or None, members, words of the message) of every example of the issue."""
    m = _manifest(src)
    tiles = np.zeros((16, 24, 24, 3), np.float32)
    yield "huge npy header", None, {"tiles.npy": _huge_header()}, "tiles.npy"
    r3 = copy.deepcopy(m)
    r3["arrays"]["tiles"]["shape"] = [16, 24, 72]
    yield "tiles rank 3", r3, {"tiles.npy": _npy(tiles.reshape(16, 24, 72))}, "rank 3"
    r5 = copy.deepcopy(m)
    r5["arrays"]["tiles"]["shape"] = [16, 24, 24, 3, 1]
    yield "tiles rank 5", r5, {"tiles.npy": _npy(tiles[..., None])}, "rank 5"
    yield (
        "tiles rank 3, manifest untouched",
        None,
        {"tiles.npy": _npy(tiles.reshape(16, 24, 72))},
        "array tiles",
    )
    e = copy.deepcopy(m)
    e["E"] = 10**400
    yield "huge integer E", e, {}, "field E"
    e2 = copy.deepcopy(m)
    e2["E"] = -(2**70)  # a float for Python, too large for numpy's isfinite (found by the fuzzer below)
    yield "integer E beyond int64", e2, {}, "field E"
    h = copy.deepcopy(m)
    h["params"]["selection"]["history"]["best"] = ["a", "b", "c"]
    yield "history entries strings", h, {}, "params.selection.history.best[0]"
    pl = copy.deepcopy(m)
    pl["params"] = [1, 2]
    yield "params a list", pl, {}, "field 'params'"
    po = copy.deepcopy(m)
    po["params"]["selection"]["params"]["polish"] = "yes"
    yield "polish yes", po, {}, "params.selection.params.polish"
    la = copy.deepcopy(m)
    la["params"]["lambda"] = "0.8"
    yield "string lambda", la, {}, "params.lambda"
    sc = copy.deepcopy(m)
    sc["scheme"] = "hexagons"
    yield "unknown scheme", sc, {}, "field scheme"


def _commands(path: Path, out: Path) -> list[list[str]]:
    return [
        ["info", str(path)],
        ["info", str(path), "--json"],
        ["sheet", str(path), "-o", str(out / "s.png")],
        ["synth", str(path), "-o", str(out / "o.png"), "--size", "64x64", "--seed", "1", "-q"],
        ["metrics", str(path), "--size", "64x64"],
        ["report", str(path), "-o", str(out / "rep"), "--size", "64x64", "-q"],
        ["export", str(path), "-o", str(out / "exp")],  # issue 13's readers apply the same rules
        ["view", str(path), "-o", str(out / "v.html")],
    ]


@pytest.mark.parametrize("case", range(11))
def test_listed_tampered_files_exit_2_in_every_subcommand(sets, tmp_path, capsys, case):
    name, manifest, members, words = list(_cases(sets["omega_ga"]))[case]
    bad = rewrite(sets["omega_ga"], tmp_path / "bad.tiles", manifest, members)
    for args in _commands(bad, tmp_path):
        assert main(args) == 2, (name, args)
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and words in err, (name, args, err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.tiles"]


def test_header_is_checked_before_allocation(sets, tmp_path, monkeypatch):
    """The huge header is refused without np.load ever being called on it."""
    calls = []
    real = np.load
    monkeypatch.setattr(np, "load", lambda *a, **k: calls.append(1) or real(*a, **k))
    bad = rewrite(sets["wang"], tmp_path / "bad.tiles", None, {"tiles.npy": _huge_header()})
    with pytest.raises(TileSetFormatError, match="36000000000000 bytes"):
        tilesynth.load(bad)
    assert calls == []


def test_untampered_sets_load(sets):
    for p in sets.values():
        tilesynth.load(p)


# ------------------------------------------------------------------------------------------------ fuzzing
def _paths(obj, prefix=()):
    yield prefix
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _paths(v, (*prefix, k))
    elif isinstance(obj, list):
        for k, v in enumerate(obj[:3]):
            yield from _paths(v, (*prefix, k))


def _dotted(path) -> str:
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else p)
    return out


def _kind(v) -> str:
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "bool"
    if isinstance(v, (int, float)):
        return "number"
    return type(v).__name__


_SELECTION_KNOWN = {"polish", "population", "generations", "stagnation"}


def _strict(path) -> bool:
    """Paths whose value has one documented kind (a change of kind must be refused naming the path)."""
    if not path or path[0] in ("format", "format_version", "per_tile"):
        return False
    if path[:2] == ("layout", "tiles") and len(path) > 2:
        return False  # a tile may be written in several forms; checked by the tile-set definition
    # method parameters (params.selection.params.*) are any scalar, except the few with a documented kind
    return not (
        path[:3] == ("params", "selection", "params") and len(path) > 3 and path[3] not in _SELECTION_KNOWN
    )


VALUES = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=4),
    st.lists(st.integers(-3, 3), max_size=3),
    st.dictionaries(st.text(max_size=3), st.integers(), max_size=2),
)

_FUZZ_DIR = tempfile.mkdtemp(prefix="tilesynth-fuzz-")


@pytest.fixture(scope="module")
def fuzz_sets(sets):
    out = dict(sets)
    for (
        k,
        p,
    ) in sets.items():  # and the same sets in format version 2 (provenance), where they are pure copies
        v2 = p.with_name(f"{k}-v2.tiles")
        t = tilesynth.load(p)
        if t.storage() == 2:
            t.save(v2)
            out[f"{k}_v2"] = v2
    return {k: (p, _manifest(p), [q for q in _paths(_manifest(p)) if q]) for k, p in out.items()}


@given(data=st.data())
def test_fuzzed_manifests_exit_2_naming_the_field_never_1(fuzz_sets, data):
    name = data.draw(st.sampled_from(sorted(fuzz_sets)))
    src, manifest, paths = fuzz_sets[name]
    path = data.draw(st.sampled_from(paths))
    value = data.draw(VALUES)
    m = copy.deepcopy(manifest)
    parent = m
    for p in path[:-1]:
        parent = parent[p]
    old = parent[path[-1]]
    parent[path[-1]] = value
    with tempfile.TemporaryDirectory(dir=_FUZZ_DIR) as d:
        bad = rewrite(src, Path(d) / "bad.tiles", m)
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            status = main(["info", str(bad)])
            if status == 0:
                status = main(["sheet", str(bad), "-o", str(Path(d) / "s.png")])
    msg = err.getvalue()
    assert status in (0, 2), (path, value, msg)
    assert "internal error" not in msg
    if status == 2:
        assert msg.count("\n") == 1
    # a change of kind of a field with one documented kind (a null field may take its other form: skipped)
    if _strict(path) and old is not None and _kind(value) not in (_kind(old), "null"):
        assert status == 2, (path, value)
        assert _dotted(path) in msg, (path, value, msg)


def test_manifest_schemes_are_the_registered_ones():
    """The manifest schema's scheme names are the registry's (a new scheme adds its name to both)."""
    from tilesynth.schemes import REGISTRY
    from tilesynth.schemes.base import FILE_KIND
    from tilesynth.tileset.manifest import SCHEME_LAYOUTS

    assert SCHEME_LAYOUTS == {s.name: FILE_KIND[s.layout] for s in REGISTRY}
