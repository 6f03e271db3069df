"""Tile-set files damaged at the ZIP level (the hostile sweep of issue 16): a member whose compression method is
unknown, or claims bzip2 / LZMA for deflate data (LZMA raised ``LZMAError``: exit 1, "internal error"), an
encrypted-member flag, a duplicated manifest. Every subcommand that reads a tile set exits 2 with one line naming
the file."""

from __future__ import annotations

import io
import struct
import warnings
import zipfile

import pytest

import tilesynth
from tilesynth.cli.main import main


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    d = tmp_path_factory.mktemp("zip")
    img, _ = tilesynth.load_image(tilesynth.data.example_path())
    ex = d / "ex.png"
    tilesynth.save_image(ex, img[:96, :96])
    p = d / "good.tiles"
    assert main(["build", str(ex), "-o", str(p), "--tile-size", "24", "--seed", "1", "-q"]) == 0
    # the damage below names version 1's members (tiles.npy): the set written with its pixels
    tilesynth.load(p).save(p, format_version=1)
    return p.read_bytes()


def _patch_central(data: bytes, member: str | None, offset: int, fn) -> bytes:
    """Applies ``fn(old) -> new`` to the 16-bit field at ``offset`` of the central directory entry of
    ``member`` (every member for None)."""
    out = bytearray(data)
    i = 0
    while (i := out.find(b"PK\x01\x02", i)) >= 0:
        nlen = struct.unpack_from("<H", out, i + 28)[0]
        if member is None or bytes(out[i + 46 : i + 46 + nlen]).decode() == member:
            struct.pack_into("<H", out, i + offset, fn(struct.unpack_from("<H", out, i + offset)[0]))
        i += 4
    return bytes(out)


def _duplicate_manifest(data: bytes) -> bytes:
    b = io.BytesIO()
    with zipfile.ZipFile(io.BytesIO(data)) as zi, zipfile.ZipFile(b, "w") as zo:
        for info in zi.infolist():
            zo.writestr(info, zi.read(info.filename))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "Duplicate name"
            zo.writestr("manifest.json", b"{}")
    return b.getvalue()


METHOD, FLAGS = 10, 8
DAMAGE = {
    "unknown method (99) on tiles.npy": lambda d: _patch_central(d, "tiles.npy", METHOD, lambda _: 99),
    "bzip2 claimed for deflate data": lambda d: _patch_central(d, "manifest.json", METHOD, lambda _: 12),
    "LZMA claimed for deflate data": lambda d: _patch_central(d, "tiles.npy", METHOD, lambda _: 14),
    "LZMA claimed for every member": lambda d: _patch_central(d, None, METHOD, lambda _: 14),
    "encrypted flag on tiles.npy": lambda d: _patch_central(d, "tiles.npy", FLAGS, lambda f: f | 1),
    "a second, empty manifest.json": _duplicate_manifest,
}


@pytest.mark.parametrize("damage", sorted(DAMAGE))
def test_zip_level_damage_exits_2_in_every_reader(tmp_path, good, capsys, damage):
    p = tmp_path / "bad.tiles"
    p.write_bytes(DAMAGE[damage](good))
    for argv in (
        ["info", str(p)],
        ["info", str(p), "--json"],
        ["synth", str(p), "-o", str(tmp_path / "o.png"), "--size", "32", "-q"],
        ["sheet", str(p), "-o", str(tmp_path / "s.png")],
        ["metrics", str(p), "--size", "48", "-q"],
        ["report", str(p), "-o", str(tmp_path / "rep"), "--size", "48", "-q"],
    ):
        assert main(argv) == 2, (damage, argv)
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("tilesynth: error: tileset = "), (damage, argv, err)
    assert not (tmp_path / "o.png").exists() and not (tmp_path / "s.png").exists()
    with pytest.raises(tilesynth.TileSetFormatError):
        tilesynth.TileSet.load(p)
