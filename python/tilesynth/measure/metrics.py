"""Quality metrics of synthesized textures and tile sets: the numbers to judge a result by.

Every metric takes float32 ``(H, W, C)`` images in [0, 1] (anything :func:`tilesynth.base.validate.as_image`
accepts) and returns a small frozen dataclass with a ``to_dict()`` (JSON-able, non-finite values become
``None``). Sums run over the C channels; "SSD" is Σ over pixels and channels of squared differences, as in the
rest of tilesynth.

**Border seam score** (:func:`seam_score`). For tiles of N x N pixels laid from the top-left corner (as
:func:`tilesynth.synthesize` lays them), a horizontal neighbour pair (y, x)–(y, x+1) *crosses a border* when
(x+1) is a multiple of N, otherwise it lies inside a tile; likewise vertically. With d²(p, q) = Σ_c (I_c(p) −
I_c(q))², let B_x, B_y be the mean d² over the pairs crossing vertical / horizontal borders and I_x, I_y the
mean over the pairs inside tiles along the same direction. The score is

    S = (B_x + B_y) / (I_x + I_y),

a direction is left out of both sums when the image has no border across it (an output one tile wide). S ≈ 1
means the tile borders look like any other pixel step of the texture (invisible); a visible seam gives S > 1.
We pool the two directions with equal weight rather than pooling all pairs, so that an anisotropic texture
(stronger steps along x than along y) in a non-square output, whose border pairs and interior pairs come in
different x/y proportions, does not move S away from 1 by itself. The per-direction ratios B_x/I_x and B_y/I_y
are reported too. Cost O(H·W·C). For ω-tiles the border pixels come from a few exemplar rows and columns only
(the side midlines of the sample patches), so S of a valid ω tiling scatters around 1 (about 0.8-1.3 in our
tests) with the content of those lines, while a random placement that ignores the corner colours gives S well
above 1 (about 3 on the 128x128 gravel, 15 on the lettuce crop of the tests: the busier the texture, the smaller
a seam is against its own steps).

**Coherence energy** (:func:`coherence_energy`): Kwatra et al.'s texture energy, which 000 says its objective
resembles. For every output patch P of p x p pixels at the positions (y, x) ∈ {0, s, 2s, ...} (the last H−p
mod s rows / columns are not the top-left of any patch), e(P) = min over every fully-overlapping exemplar
patch Q of SSD(P, Q); the energy is the mean of e over the patches (defaults p = 8, s = 4), and rms = √(energy
/ (p²·C)) is the same number as a root-mean-square pixel difference in [0, 1] units. The minimum is exact: a
patch that is a bit-identical copy of some exemplar patch has e = 0 (found by a 64-bit hash of the patch's
float bits with a random linear key, confirmed by comparing the pixels, so a hash collision can never produce
a wrong 0); every other patch is searched exhaustively by :meth:`tilesynth.SsdIndex.best_matches` (FFT maps of
the cached exemplar spectrum, candidates within the FFT error bound re-ranked by the direct float64 sum), in
batches. Cost: O(H_e·W_e·p²·C) for the exemplar hash, and O(C·H_e·W_e·log(H_e·W_e)) per searched patch; an
ω-tile output copies exemplar content everywhere but near its cutting curves, so only the patches that
straddle a cut (typically 15-40%) are searched. About 0.4 ms per searched patch for a 128x128 exemplar and
4-8 ms for 378x378 (2 shared cores): a 512x512 output (16,129 patches) costs about 2-3 s on a 128x128
exemplar, 15-20 s on the 378x378 lettuce.

**Coverage** (:func:`coverage`), from a provenance map (the exemplar (row, col) of every output pixel, see
:func:`tilesynth.source_map`): with n(q) the number of output pixels copied from exemplar pixel q,
``fraction`` is the share of exemplar pixels with n(q) > 0; ``evenness`` = H(n / Σn) / log(H_e·W_e), the
Shannon entropy of the usage distribution over *all* exemplar pixels divided by its largest possible value (1
= every exemplar pixel used equally often, 0 = one pixel used for everything); ``cv`` = std(n) / mean(n) over
all exemplar pixels (0 = even).

**Repetition** (:func:`repetition`): the normalised autocorrelation of the output is, for an offset d = (dy,
dx), the Pearson correlation between the image and itself shifted by d over their overlap, pooled over
channels:

    r(d) = Σ_c cov_c(d) / √(Σ_c var_c^A(d) · Σ_c var_c^B(d)),

with A the pixels p whose partner p + d is inside the image and B = A + d, each channel centred by its mean
over A (resp. B). r(0) = 1 and |r| ≤ 1; an image periodic with period d has r(d) = 1. Offsets are limited to
|dy| ≤ H/2, |dx| ≤ W/2 (at least a quarter of the image overlaps). The reported *peak* is the largest r over
the offsets d ≠ 0 that are local maxima of r (≥ their 8 neighbours), so the central lobe around d = 0 — high
for any smooth texture — is never reported; its offset is given with dy > 0 or dy = 0, dx > 0 (r(d) = r(−d));
among peaks within 1e-9 of each other the shortest offset wins. A seamless but repetitive tiling shows a peak
at a multiple of the tile size. Cost: FFTs of size (H + H/2) x (W + W/2) per channel plus O(1) per offset from
summed-area tables.

**Objective** (:func:`objective`): of a tile set, E = λ·ΣD_j + (1−λ)·Var(D_j) over its intermediate tiles (λ =
0.8, the stored ``TileSet.E``), f = 1/E, the same with 003's normalisation (D_j divided by the N·N pixels of
the tile: ``E_normalised``, ``f_normalised``, the affinity 003's Table 2 reports), the spread of D_j (min,
max, mean, std, max/min) and the cut costs (min, max, mean, sum).

**Cut seam** (:func:`cut_seam_score`): of a tile set, the mean squared colour step across its cuts (ω and s-Wang:
the cutting curve; Wang: the quilting cuts between the diamonds, where ``cut_masks`` changes value) (pixel pairs with one pixel on each side of the cut) divided by the mean squared step
over every pixel pair of the tiles. 1 means the cut is as invisible as any pair of neighbours; a visible cut
scores above 1. It is the score that Poisson smoothing (``smooth=True``) lowers; the seam score above measures
the tile borders, which smoothing never changes.

**Lattice and objects** (:mod:`tilesynth.measure.lattice`, issue 29): with a tile size, ``lattice`` holds the
lattice (gradient) and (folded) of the image on its tile grid and the exemplar's own on the same grid (a
texture whose own period divides N scores high there too, whatever lays it out); with an exemplar of separate
objects, ``objects`` holds the share of object pixels in whole exemplar objects (None otherwise).

:func:`tileset_metrics` and :func:`image_metrics` compute everything that can be computed for a tile set
(after synthesizing a sample, default 512x512 with seed 1) or for a plain image (seam score only with a tile
size, coherence only with an exemplar, coverage only with a provenance map, objective never); what was skipped
and why is listed in ``notes``. ``tilesynth metrics`` is the command line of these two.

The metrics live in modules by subject: ``metrics_seams`` (border, cut and inner-lattice seam scores),
``metrics_coherence``, ``metrics_repetition`` (autocorrelation, luminance and detail layer, periodic copies,
repeated patches), ``metrics_distribution`` (coverage, histogram distance), ``metrics_discs`` (vertex saliency,
repeated discs) and ``metrics_common``; this module keeps the objective, the all-in-one measures and their text
format, and re-exports every name, so ``tilesynth.measure.metrics.<name>`` stays the public path.
"""

from __future__ import annotations

import contextlib
import time
from typing import Any

import numpy as np

from ..base.validate import as_image
from ..errors import ShapeError
from .energy import LAMBDA, energy
from .lattice import lattice_folded, lattice_gradient, objects_intact
from .metrics_coherence import (  # noqa: F401 - re-exported: tilesynth.measure.metrics.<name> is the public path
    COHERENCE_BATCH,
    DEFAULT_PATCH,
    DEFAULT_STRIDE,
    Coherence,
    _coherence_args,
    _exact_copies,
    _float_bits,
    _patch_gatherers,
    _patch_keys,
    _search_the_rest,
    coherence_energy,
)
from .metrics_common import (  # noqa: F401 - re-exported: tilesynth.measure.metrics.<name> is the public path
    _HASH_SEED,
    _finite,
    _ratio,
)
from .metrics_discs import (  # noqa: F401 - re-exported: tilesynth.measure.metrics.<name> is the public path
    COPY_SHARE,
    REPEAT_COUNT,
    SALIENT_PERCENTILE,
    VERTEX_DISC,
    DiscSaliency,
    RepeatedDiscs,
    _disc_kernel,
    _disc_sums,
    repeated_discs,
    vertex_disc_radius,
    vertex_saliency,
)
from .metrics_distribution import (  # noqa: F401 - re-exported: tilesynth.measure.metrics.<name> is the public path
    HISTOGRAM_SCALES,
    Coverage,
    HistogramDistance,
    _downsample,
    _gradient_magnitude,
    _wasserstein1,
    coverage,
    histogram_distance,
)
from .metrics_repetition import (  # noqa: F401 - re-exported: tilesynth.measure.metrics.<name> is the public path
    COPY_LAGS,
    COPY_PATCH,
    COPY_TOLERANCE,
    DETAIL_SIGMA,
    DetailRepetition,
    PeriodicCopies,
    RepeatedPatches,
    Repetition,
    _autocorr_peaks,
    _box_sums,
    _copy_distances,
    _gaussian_blur,
    _lag_maxima,
    _luminance,
    _window_keys,
    autocorrelation,
    detail_layer,
    detail_repetition,
    luminance,
    periodic_copies,
    repeated_patches,
    repetition,
)
from .metrics_seams import (  # noqa: F401 - re-exported: tilesynth.measure.metrics.<name> is the public path
    INNER_DEPTHS,
    InnerSeamScore,
    SeamScore,
    _border_pairs,
    _pair_differences,
    _squared_steps,
    cut_seam_score,
    inner_seam_score,
    seam_profiles,
    seam_score,
)

DEFAULT_SAMPLE_SIZE = (512, 512)
"""(width, height) of the sample :func:`tileset_metrics` synthesizes."""
DEFAULT_SAMPLE_SEED = 1
"""Tiling seed of that sample."""


# ------------------------------------------------------------------------------------------------ objective
def objective(tileset: Any) -> dict[str, Any]:
    """E, f = 1/E (plain and with 003's normalisation), the spread of D_j and the cut costs of a tile set.

    E is over the intermediate tiles, i.e. the D_j of the variant-0 tile of every distinct corner tuple (a
    tile set's variants share their intermediate tile); it equals the stored ``tileset.E``.
    """
    lam = float(tileset.params.get("lambda", LAMBDA))
    variants = getattr(tileset.definition, "variants", None)
    if variants is None:  # a set without variants: every tile has its own D_j
        variants = [0] * tileset.n_tiles
    per_tuple: dict[tuple[int, ...], float] = {}
    for k in range(tileset.n_tiles):
        if variants[k] == 0:
            per_tuple.setdefault(tuple(int(v) for v in tileset.tile_patches[k]), float(tileset.D[k]))
    d = np.array(list(per_tuple.values()), dtype=np.float64)
    n2 = float(tileset.tile_size) ** 2
    e = energy(d, lam)
    en = energy(d / n2, lam)
    costs = np.asarray(tileset.cut_costs, dtype=np.float64)
    return _finite(
        {
            "E": e,
            "f": _ratio(1.0, e),
            "E_stored": float(tileset.E),
            "E_normalised": en,
            "f_normalised": _ratio(1.0, en),
            "lambda": lam,
            "intermediate_tiles": int(d.size),
            "D": {
                "min": float(d.min()),
                "max": float(d.max()),
                "mean": float(d.mean()),
                "std": float(d.std()),
                "max_over_min": _ratio(float(d.max()), float(d.min())),
            },
            "cut_costs": {
                "min": float(costs.min()),
                "max": float(costs.max()),
                "mean": float(costs.mean()),
                "sum": float(costs.sum()),
            },
            "selection": tileset.params.get("selection", {}).get("method"),
            "cut_score": _cut_score(costs, int(tileset.tile_size)),
        }
    )


def _cut_score(costs: np.ndarray, n: int) -> float:
    from .quality import cut_score

    return cut_score(costs, n)


# ---------------------------------------------------------------------------------------------- everything
def image_metrics(
    image: np.ndarray,
    tile_size: int | None = None,
    exemplar: np.ndarray | None = None,
    source: np.ndarray | None = None,
    patch: int = DEFAULT_PATCH,
    stride: int = DEFAULT_STRIDE,
    threads: int | None = None,
    progress: Any = None,
) -> dict[str, Any]:
    """Every metric that the given facts allow, as a JSON-able dict (``progress``: an optional
    ``(stage, done, total)`` callable, e.g. :class:`tilesynth.base.progress.Progress`, called around every step).

    Keys ``input``, ``seam``, ``coherence``, ``coverage``, ``repetition`` (a dict each, or None when skipped)
    and ``notes`` (why something was skipped). The seam score needs ``tile_size``, the coherence energy the
    ``exemplar``, the coverage the provenance ``source`` and the exemplar (its shape).
    """
    return _measure(image, tile_size, exemplar, source, patch, stride, threads, progress)[0]


def _measure(
    image: np.ndarray,
    tile_size: int | None,
    exemplar: np.ndarray | None,
    source: np.ndarray | None,
    patch: int,
    stride: int,
    threads: int | None,
    progress: Any = None,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """:func:`image_metrics` and the metric objects themselves (for pictures: per-patch values, counts, r)."""
    step = _Steps(progress)
    img = as_image(image)
    notes: list[str] = []
    objs: dict[str, Any] = {}
    out: dict[str, Any] = {"input": {"width": img.shape[1], "height": img.shape[0], "channels": img.shape[2]}}
    if tile_size is None:
        out["seam"] = None
        notes.append("seam score skipped: it needs the tile grid (give the tile size)")
    else:
        with step("seam score"):
            objs["seam"] = seam_score(img, tile_size)
        out["seam"] = objs["seam"].to_dict()
        if tile_size > 2 * INNER_DEPTHS[0]:  # lattice-parallel seams inside the tiles
            objs["inner_seam"] = inner_seam_score(img, tile_size)
        out["inner_seam"] = objs["inner_seam"].to_dict() if "inner_seam" in objs else None
    with step("lattice"):
        out["lattice"] = None if tile_size is None else _lattice(img, tile_size, exemplar)
        out["objects"] = _objects(img, exemplar)
    if exemplar is None:
        out["coherence"] = None
        notes.append("coherence energy skipped: it needs the exemplar")
    else:
        with step("coherence energy"):
            objs["coherence"] = coherence_energy(img, exemplar, patch, stride, threads)
        out["coherence"] = objs["coherence"].to_dict()
    if source is None or exemplar is None:
        out["coverage"] = None
        notes.append("coverage skipped: it needs the provenance of every pixel (a tile set) and the exemplar")
    else:
        with step("coverage"):
            objs["coverage"] = coverage(source, np.shape(exemplar))
        out["coverage"] = objs["coverage"].to_dict()
    t = time.perf_counter()
    with step("repetition"):
        objs["repetition"] = repetition(img)
    out["repetition"] = objs["repetition"].to_dict()
    out["repetition"]["seconds"] = time.perf_counter() - t
    if min(img.shape[:2]) >= COPY_PATCH:  # the non-periodicity measures
        objs["detail_repetition"] = detail_repetition(img)
        out["detail_repetition"] = objs["detail_repetition"].to_dict()
        objs["periodic_copies"] = periodic_copies(img)
        out["periodic_copies"] = objs["periodic_copies"].to_dict()
    else:
        out["detail_repetition"] = out["periodic_copies"] = None
        notes.append(f"detail repetition and periodic copies skipped: the image is under {COPY_PATCH} pixels")
    if exemplar is not None:
        objs["histogram"] = histogram_distance(img, exemplar)
        out["histogram"] = objs["histogram"].to_dict()
    else:
        out["histogram"] = None
    out["texture_stats"] = _texture_stats(img, exemplar)
    out["notes"] = notes
    return out, objs


def _texture_stats(img: np.ndarray, exemplar: np.ndarray | None) -> dict[str, Any] | None:
    """``{"distance"}`` of :func:`tilesynth.measure.quality.texture_stats_distance`, None without an exemplar (or one
    too small for its filters)."""
    if exemplar is None:
        return None
    from .quality import texture_stats_distance

    try:
        return _finite({"distance": texture_stats_distance(img, exemplar)})
    except ShapeError:
        return None


def tileset_metrics(
    tileset: Any,
    width: int = DEFAULT_SAMPLE_SIZE[0],
    height: int = DEFAULT_SAMPLE_SIZE[1],
    seed: int = DEFAULT_SAMPLE_SEED,
    patch: int = DEFAULT_PATCH,
    stride: int = DEFAULT_STRIDE,
    threads: int | None = None,
    index_map: np.ndarray | None = None,
    progress: Any = None,
) -> dict[str, Any]:
    """All metrics of a tile set: a ``width`` x ``height`` sample synthesized with ``seed`` (or ``index_map``)
    measured by :func:`image_metrics` with its tile size, exemplar and provenance, plus the ``objective``.

    The dict also holds ``sample`` (size, seed, tiles used) and ``tileset`` (what was measured); the sample
    image is not kept: :func:`tilesynth.synthesize` with the same size and seed gives it back.
    """
    return measure_tileset(tileset, width, height, seed, patch, stride, threads, index_map, progress)[0]


def measure_tileset(
    tileset: Any,
    width: int = DEFAULT_SAMPLE_SIZE[0],
    height: int = DEFAULT_SAMPLE_SIZE[1],
    seed: int = DEFAULT_SAMPLE_SEED,
    patch: int = DEFAULT_PATCH,
    stride: int = DEFAULT_STRIDE,
    threads: int | None = None,
    index_map: np.ndarray | None = None,
    progress: Any = None,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """:func:`tileset_metrics` and what it measured: ``{"image", "index_map", "source"}`` plus the metric
    objects (:class:`SeamScore`, :class:`Coherence`, :class:`Coverage`, :class:`Repetition`) by name."""
    from ..synth.synthesis import source_map, synthesize

    step = _Steps(progress)
    with step("sample synthesis"):
        img, imap = synthesize(tileset, width, height, seed=seed, index_map=index_map, threads=threads)
        src = source_map(tileset, imap, width, height)
    out, objs = _measure(img, tileset.tile_size, tileset.exemplar, src, patch, stride, threads, progress)
    out["sample"] = {
        "width": int(width),
        "height": int(height),
        "seed": None if index_map is not None else int(seed),
        "tiles": [int(imap.shape[1]), int(imap.shape[0])],
        "distinct_tiles_used": int(np.unique(imap).size),
    }
    with step("objective and cut seams"):
        out["objective"] = objective(tileset)
        out["cut_seam"] = cut_seam_score(tileset)
    out["tileset"] = {
        "scheme": tileset.scheme,
        "set": tileset.params.get("set"),
        "n_tiles": tileset.n_tiles,
        "tile_size": tileset.tile_size,
        "exemplar": tileset.exemplar_info.get("file"),
        "exemplar_shape": list(tileset.exemplar.shape),
    }
    objs.update({"image": img, "index_map": imap, "source": src})
    return out, objs


def _lattice(img: np.ndarray, n: int, exemplar: np.ndarray | None) -> dict[str, Any] | None:
    """Lattice (gradient) and (folded) of ``img`` on its N-grid (:mod:`tilesynth.measure.lattice`; issue 29), and
    the exemplar's own on the same grid where it holds two tiles: a texture whose own period divides N scores
    high there whatever lays it out. None where the image is too small for either measure."""

    def both(a: np.ndarray) -> tuple[Any, Any]:
        try:
            g = lattice_gradient(a, n)
        except ShapeError:
            g = None
        try:
            f = lattice_folded(a, n)
        except ShapeError:
            f = None
        return g, f

    g, f = both(img)
    if g is None and f is None:
        return None
    eg, ef = both(as_image(exemplar, "exemplar")) if exemplar is not None else (None, None)
    return {
        "gradient": None if g is None else g.to_dict(),
        "folded": None if f is None else f.to_dict(),
        "exemplar_gradient": None if eg is None else eg.score,
        "exemplar_folded": None if ef is None else ef.score,
    }


def _objects(img: np.ndarray, exemplar: np.ndarray | None) -> dict[str, Any] | None:
    """Objects intact (:func:`tilesynth.measure.lattice.objects_intact`) where the exemplar is one of separate
    objects (``applies``), else None."""
    if exemplar is None:
        return None
    o = objects_intact(img, exemplar)
    return o.to_dict() if o.applies else None


class _Steps:
    """``with step(name):`` reports ``(name, 0, 1)`` before and ``(name, 1, 1)`` after to ``progress`` (if any),
    so every metric step that takes more than a second shows up (``metrics`` used to run for minutes
    silently)."""

    def __init__(self, progress: Any) -> None:
        self.progress = progress

    @contextlib.contextmanager
    def __call__(self, name: str):  # noqa: ANN204
        if self.progress is not None:
            self.progress(name, 0, 1)
        yield
        if self.progress is not None:
            self.progress(name, 1, 1)


def format_metrics(m: dict[str, Any]) -> str:
    """Human-readable lines of a dict from :func:`image_metrics` / :func:`tileset_metrics`."""
    lines = _format_header(m) + _format_measures(m) + _format_objective(m)
    for note in m.get("notes", []):
        lines.append(f"note          {note}")
    return "\n".join(lines)


def _num(v: Any, fmt: str = ".4g") -> str:
    return "n/a" if v is None else format(v, fmt)


def _format_header(m: dict[str, Any]) -> list[str]:
    """What was measured: the tile set and its sample, or the image."""
    lines = []
    inp = m["input"]
    if "tileset" in m:
        t, s = m["tileset"], m["sample"]
        how = f"seed {s['seed']}" if s["seed"] is not None else "given map"
        lines.append(
            f"tile set      {t['scheme']} {t['set']}, {t['n_tiles']} tiles of {t['tile_size']}x"
            f"{t['tile_size']}, exemplar {t['exemplar'] or '?'}"
        )
        lines.append(
            f"sample        {s['width']}x{s['height']}, {how}, {s['tiles'][0]}x{s['tiles'][1]} tiles, "
            f"{s['distinct_tiles_used']} distinct"
        )
    else:
        lines.append(f"image         {inp['width']}x{inp['height']}, {inp['channels']} channel(s)")
    return lines


def _format_measures(m: dict[str, Any]) -> list[str]:
    """The image measures: seam, coherence, coverage, repetition, detail peak, copies, histograms."""
    lines = []
    sm = m.get("seam")
    if sm:
        lines.append(
            f"seam score    {_num(sm['score'], '.4f')}  (border / interior mean squared step; x "
            f"{_num(sm['ratio_x'], '.4f')}, y {_num(sm['ratio_y'], '.4f')}; tile {sm['tile_size']})"
        )
    ins = m.get("inner_seam")
    if ins:
        lines.append(
            f"inner seam    {_num(ins['max'], '.4f')}  (worst lattice-parallel line {ins['depth_of_max']:+d} px "
            f"inside the tile borders; mean over ±{len(ins['scores']) // 2} depths {_num(ins['mean'], '.4f')})"
        )
    la = m.get("lattice")
    if la:
        g, f = la["gradient"] or {}, la["folded"] or {}  # either is None under two tiles / cells
        lines.append(
            f"lattice       gradient {_num(g.get('score'), '.3f')}  (worst step phase: x "
            f"{_num(g.get('phase_x'), 'd')}, y {_num(g.get('phase_y'), 'd')}; exemplar on this grid "
            f"{_num(la['exemplar_gradient'], '.3f')}), folded {_num(f.get('score'), '.3f')}  "
            f"({_num(f.get('cells'), 'd')} cells; exemplar {_num(la['exemplar_folded'], '.3f')}); 1 = no tile grid"
        )
    ob = m.get("objects")
    if ob:
        lines.append(
            f"objects       {_num(ob['share'], '.3f')} of object pixels in whole exemplar objects  (the exemplar's "
            f"own {_num(ob['exemplar_share'], '.3f')}; {ob['n_intact']} of {ob['n_counted']} objects)"
        )
    co = m.get("coherence")
    if co:
        lines.append(
            f"coherence     {_num(co['energy'], '.5g')}  (mean min SSD of {co['patch']}x{co['patch']} "
            f"patches, stride {co['stride']}; rms {_num(co['rms'], '.4f')}; {co['n_patches']} patches, "
            f"{co['exact_copies']} exact copies, {co['searched']} searched, {co['seconds']:.2f} s)"
        )
    cv = m.get("coverage")
    if cv:
        lines.append(
            f"coverage      {_num(cv['fraction'], '.4f')} of exemplar pixels used  (evenness "
            f"{_num(cv['evenness'], '.4f')}, cv {_num(cv['cv'], '.3f')})"
        )
    rp = m.get("repetition")
    if rp:
        where = "none" if rp["offset"] is None else f"at (dy, dx) = ({rp['offset'][0]}, {rp['offset'][1]})"
        lines.append(
            f"repetition    {_num(rp['peak'], '.4f')}  (strongest non-zero autocorrelation peak, {where})"
        )
    dr = m.get("detail_repetition")
    if dr:
        where = "none" if dr["offset"] is None else f"at (dy, dx) = ({dr['offset'][0]}, {dr['offset'][1]})"
        lines.append(
            f"detail peak   {_num(dr['peak'], '.4f')}  (autocorrelation peak of the detail layer, σ "
            f"{dr['sigma']:g}, {where})"
        )
    pc = m.get("periodic_copies")
    if pc:
        lines.append(
            f"copies        {_num(pc['fraction'], '.4f')} of {pc['n_patches']} {pc['patch']}x{pc['patch']} "
            f"patches copy the patch one dominant lag away (lags {pc['lags']})"
        )
    hd = m.get("histogram")
    if hd:
        lines.append(
            f"histograms    {_num(hd['distance'], '.4f')}  (mean 1-D Wasserstein of colour channels and of "
            f"gradient magnitude at scales {hd['scales']})"
        )
    tx = m.get("texture_stats")
    if tx:
        lines.append(
            f"texture stats {_num(tx['distance'], '.4f')}  (relative distance of the Gram matrices of fixed random "
            "filter responses to the exemplar's)"
        )
    return lines


def _format_objective(m: dict[str, Any]) -> list[str]:
    """The tile set's own measures: the objective E, D_j, the cut costs and the cut seam."""
    lines = []
    ob = m.get("objective")
    if ob:
        d, c = ob["D"], ob["cut_costs"]
        lines.append(
            f"objective     E {_num(ob['E'], '.6g')}, f = 1/E {_num(ob['f'], '.4g')}; normalised (003) E "
            f"{_num(ob['E_normalised'], '.4g')}, f {_num(ob['f_normalised'], '.4f')}  "
            f"({ob['intermediate_tiles']} intermediate tiles, selection {ob['selection']})"
        )
        lines.append(
            f"D_j           min {_num(d['min'])}, max {_num(d['max'])}, mean {_num(d['mean'])}, std "
            f"{_num(d['std'])}, max/min {_num(d['max_over_min'], '.3g')}"
        )
        lines.append(
            f"cut costs     min {_num(c['min'])}, max {_num(c['max'])}, mean {_num(c['mean'])}, "
            f"sum {_num(c['sum'])}" + (f", cut score {_num(ob['cut_score'])}" if "cut_score" in ob else "")
        )
    cs = m.get("cut_seam")
    if cs:
        lines.append(
            f"cut seam      {_num(cs['score'], '.4f')}  (mean squared step across the cutting curves / over "
            f"all pixel pairs of the tiles; {cs['cut_pairs']} pairs on the cuts)"
        )
    return lines


__all__ = [
    "DiscSaliency",
    "RepeatedDiscs",
    "repeated_discs",
    "vertex_disc_radius",
    "vertex_saliency",
    "INNER_DEPTHS",
    "InnerSeamScore",
    "inner_seam_score",
    "DetailRepetition",
    "HistogramDistance",
    "PeriodicCopies",
    "detail_layer",
    "detail_repetition",
    "histogram_distance",
    "periodic_copies",
    "RepeatedPatches",
    "repeated_patches",
    "Coherence",
    "Coverage",
    "Repetition",
    "SeamScore",
    "autocorrelation",
    "coherence_energy",
    "coverage",
    "cut_seam_score",
    "format_metrics",
    "image_metrics",
    "measure_tileset",
    "objective",
    "repetition",
    "seam_profiles",
    "seam_score",
    "tileset_metrics",
]
