"""The ω cut of two builds on the same inputs: every cut of the golden cases, recorded once, solved by both.

Issue 15 changed the ω cut's solver (BK max-flow → shortest path in the planar dual). This script checks that
the minimum-cut *values* agree to rounding on every ``omega_cuts`` call the golden builds make
(``tests/test_golden.py``), and counts the masks that differ (only ties of equal cost may differ; both must be
minimum cuts, which the script checks by recomputing each mask's cost from ``kwatra_weights``)::

    # 1. record the calls (inputs and results) with the old build
    PYTHONPATH=/path/to/old/python python benches/cut_equivalence.py record /tmp/cuts.npz
    # 2. solve the recorded inputs with the current build and compare
    python benches/cut_equivalence.py check /tmp/cuts.npz

Plus random tiles (``--random K``, N in 8..96, both ``keep_border``) recorded the same way.
"""

from __future__ import annotations

import argparse
import sys
from importlib import resources
from pathlib import Path

import numpy as np

import tilesynth
from tilesynth import _core

GOLDEN_BUILDS = [
    ("default 16a", dict(tileset="16a", tile_size=32, seed=2026)),
    ("default 32", dict(tileset="32", tile_size=32, seed=2026)),
    ("random 16a", dict(tileset="16a", tile_size=32, seed=2026, select="random")),
    ("random 32", dict(tileset="32", tile_size=32, seed=2026, select="random")),
    ("random 16a tries=1", dict(tileset="16a", tile_size=32, seed=2026, select="random", border_tries=1)),
    ("random 32 tries=1", dict(tileset="32", tile_size=32, seed=2026, select="random", border_tries=1)),
    ("ga 8", dict(tileset="8", tile_size=24, seed=5, select="ga", population=12, generations=5)),
    ("ais 8", dict(tileset="8", tile_size=24, seed=5, select="ais", population=12, generations=5)),
    ("best-of 8", dict(tileset="8", tile_size=24, seed=5, select="best-of", population=12)),
]


def small_exemplar() -> np.ndarray:
    with resources.as_file(resources.files("tilesynth") / "data" / "lettuce-leaves.png") as p:
        img, _ = tilesynth.load_image(Path(p))
    return np.ascontiguousarray(img[100:196, 60:156])


def record(path: Path, n_random: int) -> None:
    calls: list[tuple[str, tuple, np.ndarray, np.ndarray]] = []
    original = _core.omega_cuts
    case = ["?"]

    def spy(i, o, eps, threads, g, keep_border):  # noqa: ANN001, ANN202
        masks, costs = original(i, o, eps, threads, g, keep_border)
        calls.append(
            (
                case[0],
                (np.array(i), np.array(o), eps, None if g is None else np.array(g), keep_border),
                np.array(masks),
                np.array(costs),
            )
        )
        return masks, costs

    _core.omega_cuts = spy
    ex = small_exemplar()
    for name, kw in GOLDEN_BUILDS:
        case[0] = name
        tilesynth.build_omega(ex, threads=1, **kw)
    _core.omega_cuts = original
    rng = np.random.default_rng(15)
    for k in range(n_random):
        n = int(rng.integers(4, 49)) * 2
        a = rng.random((1, n, n, 3), dtype=np.float32)
        # Smooth-ish content with exact ties: quantised to 8 bits, half of the tiles with a copied region.
        a = np.round(a * 255) / 255
        b = a.copy() if k % 2 else rng.random((1, n, n, 3), dtype=np.float32)
        if k % 2:
            b[0, : n // 3] = np.round(rng.random((n // 3, n, 3)) * 255) / 255
        kb = bool(k % 4 < 2)
        masks, costs = original(a, b.astype(np.float32), 1e-6, 1, None, kb)
        calls.append(
            (f"synthetic {k}", (a, b.astype(np.float32), 1e-6, None, kb), np.array(masks), np.array(costs))
        )
    out: dict[str, object] = {"n": np.array(len(calls))}
    for j, (name, (i, o, eps, g, kb), masks, costs) in enumerate(calls):
        out[f"{j}_name"] = np.array(name)
        out[f"{j}_i"], out[f"{j}_o"], out[f"{j}_eps"], out[f"{j}_kb"] = i, o, np.array(eps), np.array(kb)
        if g is not None:
            out[f"{j}_g"] = g
        out[f"{j}_masks"], out[f"{j}_costs"] = masks, costs
    np.savez_compressed(path, **out)
    print(f"recorded {len(calls)} omega_cuts calls ({sum(len(c[3]) for c in calls)} cuts) to {path}")


def mask_cost(
    i: np.ndarray, o: np.ndarray, g: np.ndarray | None, eps: float, kb: bool, mask: np.ndarray
) -> float:
    """The cost of a mask on the ω weights (kwatra_weights in the circle; an infinite cost if it breaks a tie)."""
    n = i.shape[0]
    c = (n - 1) / 2.0
    yy, xx = np.mgrid[:n, :n]
    inside = (yy - c) ** 2 + (xx - c) ** 2 <= (n / 2.0) ** 2
    wx, wy = tilesynth.kwatra_weights(i, o, region=inside, eps=eps, a_grad=g)
    src = ~inside
    cross = np.zeros((n, n), bool)
    cross[n // 2 - 1 : n // 2 + 1] = True
    cross[:, n // 2 - 1 : n // 2 + 1] = True
    cross &= inside
    if kb:
        ring = np.zeros((n, n), bool)
        ring[[0, -1]] = True
        ring[:, [0, -1]] = True
        src |= ring
        cross &= ~ring
    if mask[src].any() or not mask[cross].all():
        return float("inf")
    return float(
        (wx[:, :-1] * (mask[:, :-1] != mask[:, 1:])).sum() + (wy[:-1] * (mask[:-1] != mask[1:])).sum()
    )


def check(path: Path) -> int:
    d = np.load(path)
    worst = 0.0
    n_cuts = n_masks_differ = n_px_differ = bad = 0
    by_case: dict[str, list[int]] = {}
    for j in range(int(d["n"])):
        name = str(d[f"{j}_name"])
        i, o, eps, kb = d[f"{j}_i"], d[f"{j}_o"], float(d[f"{j}_eps"]), bool(d[f"{j}_kb"])
        g = d[f"{j}_g"] if f"{j}_g" in d else None
        masks, costs = _core.omega_cuts(i, o, eps, 1, g, kb)
        old_m, old_c = d[f"{j}_masks"], d[f"{j}_costs"]
        stats = by_case.setdefault("synthetic tiles" if name.startswith("synthetic ") else name, [0, 0, 0])
        for t in range(len(costs)):
            n_cuts += 1
            stats[0] += 1
            rel = abs(costs[t] - old_c[t]) / max(abs(old_c[t]), 1e-300)
            worst = max(worst, rel)
            if rel > 1e-9:
                bad += 1
                print(f"{name} tile {t}: cost {costs[t]!r} vs old {old_c[t]!r} (rel {rel:.2e})")
            if not np.array_equal(masks[t], old_m[t]):
                n_masks_differ += 1
                stats[1] += 1
                n_px_differ += int((masks[t] != old_m[t]).sum())
                stats[2] += int((masks[t] != old_m[t]).sum())
                gt = None if g is None else g[t]
                new_cost = mask_cost(i[t], o[t], gt, eps, kb, masks[t])
                old_cost = mask_cost(i[t], o[t], gt, eps, kb, old_m[t])
                # Both are minimum cuts: equal cost up to rounding, neither breaks a tie.
                if not abs(new_cost - old_cost) <= 1e-9 * max(abs(old_cost), 1e-12):
                    bad += 1
                    print(f"{name} tile {t}: mask costs {new_cost!r} (new) vs {old_cost!r} (old)")
    print("| case | cuts | masks differing | pixels differing |")
    print("|---|---|---|---|")
    for name, (c, m, p) in by_case.items():
        print(f"| {name} | {c} | {m} | {p} |")
    print(
        f"{n_cuts} cuts: largest relative cost difference {worst:.2e}; {n_masks_differ} masks differ "
        f"({n_px_differ} pixels); {bad} problems"
    )
    return 1 if bad else 0


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("mode", choices=["record", "check"])
    p.add_argument("path", type=Path)
    p.add_argument("--random", type=int, default=200, help="random tiles to record besides the golden cases")
    a = p.parse_args()
    if a.mode == "record":
        record(a.path, a.random)
        return 0
    return check(a.path)


if __name__ == "__main__":
    sys.exit(main())
