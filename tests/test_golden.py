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
    "16a": ("33ecd0cb92b9d48753920158", "77bed0df9c523e40007564c2"),
    "32": ("9faf7b88843676217fb3296f", "cce863337bd5ca53b969b7a5"),
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
