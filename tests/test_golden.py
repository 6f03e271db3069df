"""Golden results: fixed inputs and seeds must keep producing the same bytes.

The ω-tiles are pure copies of exemplar pixels chosen by exact searches (exact SSD re-ranking, exact max-flow),
so their bytes do not depend on FFT rounding, the platform or the thread count. If a change alters these hashes
*on purpose* (a new default, a different tie-break), rerun this file with ``TILESYNTH_PRINT_GOLDEN=1``, check
the new pictures by eye (``tilesynth sheet``), paste the printed hashes here and say why in the CHANGELOG.
"""

from __future__ import annotations

import hashlib
import os

import numpy as np
import pytest

import tilesynth

GOLDEN = {
    "16a": ("f5211b4c119fa520391a5852", "f5e2e60b6f773c7e5ad52ac6"),
    "32": ("ca3eeabbc9434580a9a7e192", "1c03f497c969cdcd621b4f07"),
}


def digest(a: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()[:24]


@pytest.mark.parametrize("name", sorted(GOLDEN))
@pytest.mark.parametrize("threads", [1, 2])
def test_golden(name, threads, small_exemplar):
    ts = tilesynth.build_omega(small_exemplar, tileset=name, tile_size=32, seed=2026, threads=threads)
    img, imap = tilesynth.synthesize(ts, 200, 150, seed=7, dtype=np.uint8, threads=threads)
    got = (digest(ts.tiles), digest(img))
    if os.environ.get("TILESYNTH_PRINT_GOLDEN"):
        print(f'\n    "{name}": ("{got[0]}", "{got[1]}"),')
    assert got == GOLDEN[name]
