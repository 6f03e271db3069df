"""Regenerate ``hash_vectors.json`` (the test vectors of ``HASH-SPEC.md``) with the plain-Python reference.

Run ``python tests/data/make_hash_vectors.py`` from the repository root; the file is committed and read by
``tests/test_lookup.py`` and by the shader tests of the engine exports.
"""

from __future__ import annotations

import json
from pathlib import Path

from tilesynth.layouts.hashed import LookupScheme, cell_index_reference, pcg3d_reference, ts_hash_reference

COORDS = [0, 1, -1, 2**31 - 1, -(2**31), 12345, -54321]
SEEDS = [0, 1, 2**32 - 1, 0xDEADBEEF]
ROLES = [0, 1, 2, 3]
CELLS = [(0, 0), (-1, -1), (5, -3), (2**31 - 1, -(2**31)), (-54321, 12345)]
SCHEMES = [
    ("corner", (2,), 1),
    ("corner", (3,), 2),
    ("corner", (4,), 3),
    ("edge", (2, 2), 1),
    ("edge", (2, 3), 2),
]


def vectors() -> dict:
    return {
        "hash": "pcg3d",
        "spec": "HASH-SPEC.md: ts_hash(x, y, seed, role) = pcg3d(uint(x), uint(y), seed ^ (role * 0x9E3779B9)).x",
        "constants": {"pcg_mul": 1664525, "pcg_inc": 1013904223, "role_mul": 0x9E3779B9},
        "roles": {"vertex": 0, "hedge": 1, "vedge": 2, "variant": 3},
        "pcg3d": [
            {"in": [x & 0xFFFFFFFF, y & 0xFFFFFFFF, s], "out": list(pcg3d_reference(x, y, s))}
            for x in COORDS
            for y in COORDS
            for s in SEEDS
        ],
        "ts_hash": [
            {"x": x, "y": y, "seed": s, "role": r, "value": ts_hash_reference(x, y, s, r)}
            for x in COORDS
            for y in COORDS
            for s in SEEDS
            for r in ROLES
        ],
        "cells": [
            {
                "kind": kind,
                "colours": list(colours),
                "variants": v,
                "seed": s,
                "cx": cx,
                "cy": cy,
                "wrap": wrap,
                "index": cell_index_reference(
                    LookupScheme(kind, colours, v), s, cx, cy, tuple(wrap) if wrap else None
                ),
            }
            for kind, colours, v in SCHEMES
            for s in SEEDS
            for cx, cy in CELLS
            for wrap in (None, [3, 5])
        ],
    }


if __name__ == "__main__":
    path = Path(__file__).with_name("hash_vectors.json")
    data = vectors()
    lines = ["{"]
    items = list(data.items())
    for i, (key, value) in enumerate(items):
        end = "," if i + 1 < len(items) else ""
        if isinstance(value, list):  # one vector a line
            rows = ",\n".join("  " + json.dumps(v, separators=(",", ":")) for v in value)
            lines.append(f"{json.dumps(key)}: [\n{rows}\n]{end}")
        else:
            lines.append(f"{json.dumps(key)}: {json.dumps(value)}{end}")
    lines.append("}")
    path.write_text("\n".join(lines) + "\n")
    print(f"wrote {path}")
