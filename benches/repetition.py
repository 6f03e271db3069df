"""Repetition bench (issue 12): how much do outputs repeat, per method, on textures of ../shared/textures.

Methods, on each texture (exemplar = the whole file, tile size N = the complete sets' default,
:func:`tilesynth.layouts.complete.default_complete_tile_size`: a quarter of the shorter side rounded down to a multiple
of 8):

- ``16a``: the seed paper's set with the scan-line tiler (the old default), at the default tile size and at N;
- ``c3``, ``c3x2``, ``c4``: complete corner sets (hashed lookup), built by the plain ω construction at N (inscribed
  circle, each tile's best match), and with the levers of :mod:`tilesynth.builder.matching.levers`: ``div1`` (diversity 1),
  ``free`` (free cut region: tapered area reward and ring penalty), ``free+div1`` (both: the defaults of
  complete sets), ``ring+div1`` (the first free region, a uniform area reward 0.02: the default before the
  inner-lattice seam was found);
- ``periodic``: the exemplar itself tiled periodically (the worst case of repetition);
- ``hex``: by-example hex tiling (Heitz & Neyret 2018, Mikkelsen 2022), numpy: a triangle grid of edge N·4/3,
  a random exemplar offset per vertex (kept inside the exemplar), barycentric weights sharpened (w³) and the
  variance-preserving blend mean + Σ wᵢ(sᵢ − mean) / √Σ wᵢ²;
- ``quilt``: image quilting (Efros & Freeman 2001), exact: blocks of N/2 (at least 16) with overlap 1/4 of
  the block, exhaustive SSD over every exemplar position (FFT), random choice among the positions within
  (1 + 0.1)·min, DP minimum-error cuts in the overlaps.

Measures (:mod:`tilesynth.measure.metrics`): periodic-copy fraction, repeated-patch fraction (:func:`tilesynth.measure.metrics.repeated_patches`:
16x16 grid patches whose exact pixels recur anywhere else, e.g. the vertex content of corner tiles), detail-layer autocorrelation peak, exemplar
coverage (the provenance of every pixel: for hex tiling the vertex with the largest weight), histogram distance,
texture-statistics distance (:func:`tilesynth.measure.quality.texture_stats_distance`: Gram matrices of fixed random
filters at scales 1 and 2, the issue's "no loss in texture statistics against 16a"), border seam score and inner-lattice seam score (:func:`tilesynth.measure.metrics.inner_seam_score`, the worst line
1-4 px inside the tile borders; tile sets: tile size N; others: n/a), repeated salient discs (tile sets only, :func:`tilesynth.measure.metrics.repeated_discs`: discs of
the vertex content's radius 0.22·N copied by provenance: ``disc reps`` occurrences of the most repeated one, ``disc
pct`` the saliency percentile of the most salient disc that recurs 4 times or more, ``salient reps`` copies of
repeated discs above the 0.9 percentile per 100 disc centres), build CPU seconds. One Markdown table, then means per
method. ``--quick``: 4 textures, 512² outputs. The machine is shared: CPU times are indicative only.

Second round (after the border-aware draw, :data:`ROUND2`): ``<set> default`` = the library's defaults of
complete sets (free cut, diversity 1, border-aware best-of-32 corner draw, default N), and levers on top of them
(``c4x2``, ``c5``, ``augment`` flip / rotate / all, diversity 2); ``exemplar`` = the exemplar's own copies and
autocorrelation peak (lags up to half the exemplar). ``--methods "c4 default;hex;exemplar"`` runs a selection
(semicolon-separated names of :func:`method_table` and :data:`BASELINES`). ``c5 free8``: the default c5 with the
8-connected geo-cut free region (staircase round, :mod:`tilesynth.builder.matching.levers`). ``c5 periodic-off`` / ``c5
periodic-lock``: the default c5 without the periodic-exemplar tile size (the default before it) / with the
phase lock as well (:mod:`tilesynth.builder.periodic`). ``c5 no-calm``: the default c5 without moving the
sample patches whose centre disc is salient (:data:`tilesynth.builder.genes.omega_borders.VERTEX_SALIENCY_CAP` set to 1 for the
build: the default before the vertex-saliency round, byte for byte). ``c5 cap-draw``: the default c5 before the "stats" draw of
representative sample patches and the periodic rule (``border_criterion="cap"``, ``periodic="off"``: the
default of main before them, byte for byte).

Usage: ``python benches/repetition.py [--quick] [--size 1024] [--textures a,b] [--methods M1;M2] [--out table.md]``
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

import tilesynth as ts
import tilesynth.measure.metrics
from tilesynth.builder.genes import omega_borders as omegaborders
from tilesynth.io.images import load_image
from tilesynth.layouts.complete import default_complete_tile_size
from tilesynth.measure.metrics import (
    coverage,
    detail_repetition,
    histogram_distance,
    inner_seam_score,
    periodic_copies,
    repeated_discs,
    repeated_patches,
    seam_score,
    vertex_disc_radius,
)
from tilesynth.measure.quality import texture_stats_distance
from tilesynth.synth.synthesis import source_map

TEXTURES = Path(__file__).resolve().parents[2] / "shared" / "textures"
if not TEXTURES.exists():
    TEXTURES = Path("/work/shared/textures")
DEFAULT_TEXTURES = [
    "bark-lichen",
    "cracked-mud",
    "dry-soil",
    "grass",
    "roof-tiles",
    "lettuce-leaves",
    "bricks-red",
    "sea-foam",
    "pebbles",
]
QUICK_TEXTURES = ["bark-lichen", "grass", "lettuce-leaves", "pebbles"]
SETS = ["16a", "c3", "c3x2", "c4"]
LEVERS = [
    ("c3x2", "div1", {"cut_region": "circle", "diversity": 1}),
    ("c3x2", "free", {"cut_region": "free", "diversity": 0}),
    ("c3x2", "free+div1", {"cut_region": "free", "diversity": 1}),
    ("c4", "ring+div1", {"cut_region": "ring", "diversity": 1}),
    ("c4", "free+div1", {"cut_region": "free", "diversity": 1}),
]
# the levers of the second round (issue 12 after the border-aware draw): every one on top of the library's
# defaults of complete sets (free cut, diversity 1, border-aware best-of-32 draw, default N)
ROUND2 = [
    ("c4", "default", {}),
    ("c4x2", "default", {}),
    ("c5", "default", {}),
    ("c4", "aug-flip", {"augment": "flip"}),
    ("c4", "aug-rotate", {"augment": "rotate"}),
    ("c4", "aug-all", {"augment": "all"}),
    ("c4x2", "aug-all", {"augment": "all"}),
    ("c4", "div2", {"diversity": 2}),
    ("c5", "free8", {"cut_region": "free8"}),
    ("c5", "periodic-off", {"periodic": "off"}),
    ("c5", "periodic-lock", {"periodic": "lock"}),
    ("c5", "cap-draw", {"border_criterion": "cap", "periodic": "off"}),
    ("c5", "no-calm", {"_vertex_cap": 1.0}),
]
BASELINES = ["periodic", "hex", "quilt", "exemplar"]
"""``exemplar``: the exemplar itself (its own detail-layer autocorrelation peak and copies: how far the target
is achievable on a periodic texture; lags up to half the exemplar)."""


def method_table(n: int) -> dict[str, tuple[str, int | None, dict]]:
    """Every tile-set method of the bench by name: ``name -> (set, tile size or None, build kwargs)``."""
    plain = {"cut_region": "circle", "diversity": 0}  # the plain ω construction (complete sets default to
    # the levers since issue 12)
    out: dict[str, tuple[str, int | None, dict]] = {"16a (default N)": ("16a", None, {})}
    out.update({s: (s, n, plain) for s in SETS})
    out.update({f"{s} {lab}": (s, n, kw) for s, lab, kw in LEVERS})
    out.update({f"{s} {lab}": (s, None, kw) for s, lab, kw in ROUND2})
    return out


DEFAULT_METHODS = ["16a (default N)", *SETS, *(f"{s} {lab}" for s, lab, _ in LEVERS), *BASELINES[:3]]


# ------------------------------------------------------------------------------------------ baselines
def periodic(ex: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    h, w = ex.shape[:2]
    img = np.tile(ex, (size // h + 1, size // w + 1, 1))[:size, :size]
    yy, xx = np.mgrid[0:size, 0:size]
    return img, np.stack([yy % h, xx % w], axis=-1).astype(np.int32)


def hex_tiling(ex: np.ndarray, size: int, edge: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """By-example hex tiling on a triangle grid of side ``edge`` pixels (Mikkelsen 2022's TriangleGrid)."""
    h, w = ex.shape[:2]
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:size, 0:size].astype(np.float64)
    # skew to the triangle lattice: lattice vectors a = (edge, 0), b = (edge/2, edge·√3/2)
    s = xx / edge - yy / (edge * math.sqrt(3))
    t = yy * 2 / (edge * math.sqrt(3))
    bi, bj = np.floor(s).astype(np.int64), np.floor(t).astype(np.int64)
    fs, ft = s - bi, t - bj
    upper = fs + ft > 1
    # barycentric weights of the three vertices
    w0 = np.where(upper, fs + ft - 1, 1 - fs - ft)
    w1 = np.where(upper, 1 - fs, fs)
    w2 = np.where(upper, 1 - ft, ft)
    weights = [w0, w1, w2]
    # the vertices of the weights: lower triangle (i,j), (i+1,j), (i,j+1); upper (i+1,j+1), (i,j+1), (i+1,j)
    verts = [
        (np.where(upper, bi + 1, bi), np.where(upper, bj + 1, bj)),
        (np.where(upper, bi, bi + 1), np.where(upper, bj + 1, bj)),
        (np.where(upper, bi + 1, bi), np.where(upper, bj, bj + 1)),
    ]
    r = math.ceil(edge)
    if w <= 2 * r or h <= 2 * r:
        raise ValueError(f"exemplar {w}x{h} too small for hex tiling of edge {edge}")
    # random exemplar centre per vertex, from a per-vertex table (vertices in the window)
    imin = min(int(v[0].min()) for v in verts)
    jmin = min(int(v[1].min()) for v in verts)
    imax = max(int(v[0].max()) for v in verts)
    jmax = max(int(v[1].max()) for v in verts)
    cy = rng.integers(r, h - r, (imax - imin + 1, jmax - jmin + 1))
    cx = rng.integers(r, w - r, (imax - imin + 1, jmax - jmin + 1))
    mean = ex.reshape(-1, ex.shape[2]).mean(axis=0)
    acc = np.zeros((size, size, ex.shape[2]))
    wsum2 = np.zeros((size, size))
    sharp = [wt**3 for wt in weights]
    norm = sharp[0] + sharp[1] + sharp[2]
    best = np.full((size, size), -1.0)
    src = np.zeros((size, size, 2), np.int32)
    for (vi, vj), wt in zip(verts, sharp):
        wt = wt / norm
        vx = vi * edge + vj * edge / 2  # vertex position in pixels
        vy = vj * edge * math.sqrt(3) / 2
        sy = np.clip(np.rint(yy - vy + cy[vi - imin, vj - jmin]).astype(np.int64), 0, h - 1)
        sx = np.clip(np.rint(xx - vx + cx[vi - imin, vj - jmin]).astype(np.int64), 0, w - 1)
        acc += wt[..., None] * (ex[sy, sx] - mean)
        wsum2 += wt * wt
        take = wt > best
        best = np.where(take, wt, best)
        src[take] = np.stack([sy, sx], axis=-1)[take]
    img = mean + acc / np.sqrt(wsum2)[..., None]
    return np.clip(img, 0, 1).astype(np.float32), src


class _Spectra:
    """FFT spectra of the exemplar for exhaustive masked SSD of B x B blocks (quilting)."""

    def __init__(self, ex: np.ndarray, b: int):
        self.ex, self.b = ex, b
        h, w, _ = ex.shape
        self.shape = (h, w)
        self.fe = np.fft.rfft2(ex, axes=(0, 1))
        self.fe2 = np.fft.rfft2((ex * ex).sum(axis=2))

    def ssd(self, template: np.ndarray, mask: np.ndarray) -> np.ndarray:
        """Σ mask·(E[p + .] − T)² for every top-left p with the block inside the exemplar."""
        h, w = self.shape
        b = self.b
        fm = np.fft.rfft2(mask, s=(h, w))
        fmt = np.fft.rfft2(template * mask[..., None], s=(h, w), axes=(0, 1))
        spec = self.fe2 * fm.conj() - 2 * (self.fe * fmt.conj()).sum(axis=2)
        corr = np.fft.irfft2(spec, s=(h, w))  # circular correlation; keep the non-wrapping positions
        out = corr[: h - b + 1, : w - b + 1] + float((mask[..., None] * template * template).sum())
        return np.maximum(out, 0.0)


def _dp_cut(err: np.ndarray) -> np.ndarray:
    """Minimum-error vertical path through ``err`` (rows x overlap): column index per row."""
    rows, cols = err.shape
    cost = err.copy()
    for i in range(1, rows):
        prev = cost[i - 1]
        left = np.r_[np.inf, prev[:-1]]
        right = np.r_[prev[1:], np.inf]
        cost[i] += np.minimum(np.minimum(left, prev), right)
    path = np.zeros(rows, np.int64)
    path[-1] = int(np.argmin(cost[-1]))
    for i in range(rows - 2, -1, -1):
        j = path[i + 1]
        lo, hi = max(0, j - 1), min(cols, j + 2)
        path[i] = lo + int(np.argmin(cost[i, lo:hi]))
    return path


def quilt(
    ex: np.ndarray, size: int, block: int, seed: int, tol: float = 0.1
) -> tuple[np.ndarray, np.ndarray]:
    """Efros–Freeman image quilting, exhaustive SSD, tolerance ``tol``, DP cuts."""
    rng = np.random.default_rng(seed)
    h, w, c = ex.shape
    ov = max(2, block // 4)
    step = block - ov
    n = -(-(size - ov) // step)
    full = n * step + ov
    out = np.zeros((full, full, c))
    src = np.zeros((full, full, 2), np.int32)
    spectra = _Spectra(ex, block)
    yy, xx = np.mgrid[0:block, 0:block]
    for bi in range(n):
        for bj in range(n):
            y, x = bi * step, bj * step
            if bi == 0 and bj == 0:
                py, px = rng.integers(0, h - block + 1), rng.integers(0, w - block + 1)
            else:
                mask = np.zeros((block, block))
                if bj > 0:
                    mask[:, :ov] = 1
                if bi > 0:
                    mask[:ov, :] = 1
                err = spectra.ssd(out[y : y + block, x : x + block], mask)
                cand = np.argwhere(err <= err.min() * (1 + tol) + 1e-12)
                py, px = cand[rng.integers(0, len(cand))]
            patch = ex[py : py + block, px : px + block]
            keep = np.ones((block, block), bool)  # True: take the new patch
            cur = out[y : y + block, x : x + block]
            if bj > 0:
                e = ((patch[:, :ov] - cur[:, :ov]) ** 2).sum(axis=2)
                path = _dp_cut(e)
                keep &= xx >= path[:, None]
            if bi > 0:
                e = ((patch[:ov, :] - cur[:ov, :]) ** 2).sum(axis=2)
                path = _dp_cut(e.T)
                keep &= yy >= path[None, :]
            out[y : y + block, x : x + block][keep] = patch[keep]
            src[y : y + block, x : x + block][keep] = np.stack([yy + py, xx + px], axis=-1)[keep]
    return out[:size, :size].astype(np.float32), src[:size, :size]


# ------------------------------------------------------------------------------------------ bench
def measure(img: np.ndarray, ex: np.ndarray, src: np.ndarray | None, tile: int | None) -> dict:
    row = {
        "copies": periodic_copies(img).fraction,
        "repeated": repeated_patches(img).fraction,
        "autocorr": detail_repetition(img).peak,
        "coverage": coverage(src, ex.shape).fraction if src is not None else None,
        "hist": histogram_distance(img, ex).distance,
        "seam": seam_score(img, tile).score if tile else None,
        "inner": inner_seam_score(img, tile).max if tile else None,
        "texstats": texture_stats_distance(img, ex),
    }
    if tile and src is not None:  # repeated salient discs of the vertex content's size, by provenance
        rd = repeated_discs(src, ex, vertex_disc_radius(tile))
        row.update(disc_reps=rd.most_repeated, disc_pct=rd.max_percentile, salient=rd.salient_repeats)
    return row


def run(textures: list[str], size: int, seed: int, methods: list[str], out_png: Path | None) -> list[dict]:
    rows = []
    for name in textures:
        ex = load_image(TEXTURES / f"{name}.png")[0]
        h, w = ex.shape[:2]
        n = default_complete_tile_size(ex.shape)
        print(f"{name}: {w}x{h}, N = {n}", file=sys.stderr, flush=True)
        table_n = method_table(n)
        for label in methods:
            if label in BASELINES:
                continue
            set_name, tile, kw = table_n[label]
            kw = dict(kw)
            cap = kw.pop("_vertex_cap", omegaborders.VERTEX_SALIENCY_CAP)
            saved, omegaborders.VERTEX_SALIENCY_CAP = omegaborders.VERTEX_SALIENCY_CAP, cap
            t = time.process_time()
            try:
                tset = ts.build_omega(ex, tileset=set_name, tile_size=tile, seed=seed, **kw)
            finally:
                omegaborders.VERTEX_SALIENCY_CAP = saved
            build = time.process_time() - t
            img, imap = ts.synthesize(tset, size, size, seed=seed)
            src = source_map(tset, imap, size, size)
            r = measure(img, ex, src, tset.tile_size)
            cs = tilesynth.measure.metrics.cut_seam_score(tset)
            r["cut_seam"] = cs["score"] if cs else None
            r.update(
                texture=name,
                method=f"{label}" if tile is None else f"{label} N={tile}",
                build_s=build,
                tiles=tset.n_tiles,
            )
            rows.append(r)
            if out_png is not None and name == textures[0]:
                tag = label.replace(" ", "_").replace("(", "").replace(")", "")
                ts.save_image(out_png / f"{name}-{tag}-{tset.tile_size}.png", img[:512, :512])
            print(f"  {r['method']}: {r}", file=sys.stderr, flush=True)
        if "periodic" in methods:
            img, src = periodic(ex, size)
            rows.append(
                {**measure(img, ex, src, None), "texture": name, "method": "periodic", "build_s": 0.0}
            )
        if "hex" in methods:
            t = time.process_time()
            img, src = hex_tiling(ex, size, edge=n * 4 / 3, seed=seed)
            rows.append(
                {
                    **measure(img, ex, src, None),
                    "texture": name,
                    "method": "hex",
                    "build_s": time.process_time() - t,
                }
            )
            if out_png is not None and name == textures[0]:
                ts.save_image(out_png / f"{name}-hex.png", img[:512, :512])
        if "quilt" in methods:
            t = time.process_time()
            img, src = quilt(ex, size, block=max(16, n // 2), seed=seed)
            rows.append(
                {
                    **measure(img, ex, src, None),
                    "texture": name,
                    "method": "quilt",
                    "build_s": time.process_time() - t,
                }
            )
            if out_png is not None and name == textures[0]:
                ts.save_image(out_png / f"{name}-quilt.png", img[:512, :512])
        if "exemplar" in methods:  # the exemplar's own repetition (no coverage, no seams)
            rows.append(
                {
                    "copies": periodic_copies(ex).fraction,
                    "autocorr": detail_repetition(ex).peak,
                    "coverage": None,
                    "hist": None,
                    "seam": None,
                    "inner": None,
                    "texstats": None,
                    "texture": name,
                    "method": "exemplar",
                    "build_s": 0.0,
                }
            )
        print("  baselines done", file=sys.stderr, flush=True)
    return rows


def _f(v, fmt=".3f") -> str:
    return "n/a" if v is None else format(v, fmt)


def table(rows: list[dict]) -> str:
    lines = [
        "| texture | method | copies | repeated | autocorr peak | coverage | hist dist | tex stats | border seam | inner seam "
        "| cut seam | disc reps | disc pct | salient reps | build CPU s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['texture']} | {r['method']} | {_f(r['copies'])} | {_f(r.get('repeated'))} | {_f(r['autocorr'])} | "
            f"{_f(r['coverage'])} | {_f(r['hist'])} | {_f(r.get('texstats'))} | {_f(r['seam'])} | "
            f"{_f(r.get('inner'))} | "
            f"{_f(r.get('cut_seam'))} | {_f(r.get('disc_reps'), 'd')} | {_f(r.get('disc_pct'))} | "
            f"{_f(r.get('salient'), '.2f')} | "
            f"{_f(r['build_s'], '.2f')} |"
        )
    lines += [
        "",
        "Means over the textures:",
        "",
        "| method | copies | repeated | autocorr peak | coverage | hist dist | tex stats | border seam | inner seam | cut seam "
        "| disc pct | salient reps | build CPU s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    by: dict[str, list[dict]] = {}
    for r in rows:
        key = r["method"].split(" N=")[0]
        by.setdefault(key, []).append(r)
    for key, rs in by.items():

        def mean(k, rs=rs):
            vals = [r[k] for r in rs if r.get(k) is not None]
            return float(np.mean(vals)) if vals else None

        lines.append(
            f"| {key} | {_f(mean('copies'))} | {_f(mean('repeated'))} | {_f(mean('autocorr'))} | {_f(mean('coverage'))} | "
            f"{_f(mean('hist'))} | {_f(mean('texstats'))} | {_f(mean('seam'))} | {_f(mean('inner'))} | "
            f"{_f(mean('cut_seam'))} | {_f(mean('disc_pct'))} | {_f(mean('salient'), '.2f')} | "
            f"{_f(mean('build_s'), '.2f')} |"
        )
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="4 textures, 512² outputs")
    ap.add_argument("--size", type=int, default=None, help="output side (default 1024, 512 with --quick)")
    ap.add_argument("--textures", default=None, help="comma-separated texture names (without .png)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--no-quilt", action="store_true", help="skip the image-quilting baseline (slowest)")
    ap.add_argument(
        "--methods",
        default=None,
        help="semicolon-separated method names (default: the first round's; see method_table, BASELINES)",
    )
    ap.add_argument("--png", default=None, help="directory for 512² crops of the first texture's outputs")
    ap.add_argument("--out", default=None, help="also write the table to this Markdown file")
    a = ap.parse_args()
    textures = a.textures.split(",") if a.textures else (QUICK_TEXTURES if a.quick else DEFAULT_TEXTURES)
    size = a.size or (512 if a.quick else 1024)
    png = Path(a.png) if a.png else None
    if png:
        png.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    methods = a.methods.split(";") if a.methods else list(DEFAULT_METHODS)
    if a.no_quilt and "quilt" in methods:
        methods.remove("quilt")
    known = set(method_table(8)) | set(BASELINES)
    bad = [m for m in methods if m not in known]
    if bad:
        ap.error(f"unknown methods {bad}; known: {sorted(known)}")
    rows = run(textures, size, a.seed, methods, png)
    text = (
        table(rows) + f"\n\n{len(textures)} textures, {size}² outputs, seed {a.seed}, "
        f"{time.perf_counter() - t0:.0f} s wall (shared 2-core machine: times indicative).\n"
    )
    print(text)
    if a.out:
        Path(a.out).write_text(text)


if __name__ == "__main__":
    main()
