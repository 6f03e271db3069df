#!/usr/bin/env python3
"""Material builds (issue 14): a colour-only build (maps sent through its cuts afterwards, ``synth --with``)
against the joint material build (``build --map``), on albedo + normal + height + roughness materials.

For each material and both builds (same seed, the default set ``c4`` of ``tilesynth build``):

* the cut seam score (:func:`tilesynth.measure.metrics.cut_seam_score`, 1 = the cuts are as invisible as any pair of
  neighbouring pixels) of the albedo and of every map, on the tiles as they are laid out (normals as vectors);
* the share of output normals within 1 ± 0.005 of unit length, on a 512x512 synthesis, for plain and
  ``--smooth`` builds (smoothed normals are renormalised);
* the build cost: CPU time (``time.process_time``, all threads) of the 4-map build over the colour-only build of
  the same exemplar, runs interleaved, medians of ``--repeat``.

**Real PBR materials** (``--pbr DIR``): the PyPI wheel of ``pypbr`` 0.1.0b5 (MIT licence, © 2024 Giuseppe
Vecchio, ``LICENSE`` in the wheel) ships two 1024² materials as test data, ``tests/data/rocks`` and
``tests/data/tiles`` (basecolor, normal 8-bit, height 16-bit, roughness, ...); the wheel names no other source or
licence for the images, so they are taken as covered by the package's MIT licence. They are not copied into this
repository; get them with ``pip download --no-deps pypbr==0.1.0b5`` and unzip ``tests/data`` from the wheel, then
``python benches/materials.py --pbr DATA/rocks --pbr DATA/tiles``. (Also inspected, without usable images:
``bd-materials``, ``materialxmaterials``, ``materialx``, ``panda3d-assetcoop``.)

**The other materials are derived, not real PBR sets.** Each is made from a photo of
``../shared/textures`` (BSD-3-Clause ones by default): the albedo is the photo; the **height** is 0.6 x its
detrended, blurred luminance (σ 1.5 minus σ 24) plus 0.4 x an independent smooth random field (blurred noise, σ 6,
own seed), so the height is *not* a function of the colour; the **normal** (OpenGL, Y up) comes from the height's
gradient (strength 6); the **roughness** is 0.5 x the local contrast of the luminance (5x5 std) plus 0.5 x a
second independent field. The table therefore measures what the cuts do to maps that carry structure the albedo
does not, which is the case of real materials, but its figures are not figures of real scans.

Usage::

    python benches/materials.py                          # writes benches/materials-results.md
    python benches/materials.py --textures rust --repeat 1 --out /tmp/m.md
    python benches/materials.py --pbr DATA/rocks --pbr DATA/tiles         # real materials first (see below)
    python benches/materials.py --pbr DATA/rocks --figure docs/figures/material-rock.png   # the rock figure
    python benches/materials.py --pbr DATA/tiles --shaded docs/figures/material-tiles-shaded.png
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

import tilesynth as ts
from tilesynth.builder import materials
from tilesynth.measure.metrics import _gaussian_blur, cut_seam_score, luminance

SET = "c4"  # the default set of `tilesynth build`
TEXTURES = ("rust", "roof-tiles", "bricks-red", "lettuce-leaves")
SHARED = Path(__file__).resolve().parents[2] / "shared" / "textures"


def _norm01(x: np.ndarray) -> np.ndarray:
    lo, hi = np.percentile(x, [0.5, 99.5])
    return np.clip((x - lo) / max(hi - lo, 1e-9), 0.0, 1.0)


def derive_material(albedo: np.ndarray, seed: int = 0) -> dict[str, np.ndarray]:
    """Height (uint16), normal (uint8, Y up) and roughness (uint8) derived from ``albedo`` (module docstring)."""
    r = np.random.default_rng(seed)
    y = luminance(albedo)
    detail = _gaussian_blur(y, 1.5) - _gaussian_blur(y, 24.0)
    field = _gaussian_blur(r.standard_normal(y.shape), 6.0)
    height = _norm01(0.6 * _norm01(detail) + 0.4 * _norm01(field))
    gy, gx = np.gradient(height * 6.0)
    n = np.stack([-gx, gy, np.ones_like(gx)], axis=-1)  # OpenGL: +y up = towards row 0
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    mean = _gaussian_blur(y, 1.5)
    contrast = np.sqrt(np.maximum(_gaussian_blur(y * y, 1.5) - mean * mean, 0.0))
    rough = _norm01(0.5 * _norm01(contrast) + 0.5 * _norm01(_gaussian_blur(r.standard_normal(y.shape), 4.0)))
    return {
        "normal": np.round((n * 0.5 + 0.5) * 255).astype(np.uint8),
        "height": np.round(height * 65535).astype(np.uint16),
        "roughness": np.round(rough * 255).astype(np.uint8),
    }


def _crop(a: np.ndarray, size: int) -> np.ndarray:
    h, w = a.shape[:2]
    c = min(size, h, w)
    return np.ascontiguousarray(a[(h - c) // 2 : (h - c) // 2 + c, (w - c) // 2 : (w - c) // 2 + c])


def load_pbr(directory: str, crop: int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """A real PBR material (module docstring): the albedo and its normal (8-bit), height (16-bit) and roughness
    maps, centre-cropped to ``crop``."""
    d = Path(directory)
    albedo = _crop(ts.load_raster(d / "basecolor.png"), crop)[..., :3]
    maps = {k: _crop(ts.load_raster(d / f"{k}.png"), crop) for k in ("normal", "height", "roughness")}
    # pypbr's rocks normal map is not unit length (36 % of its vectors outside 1 ± 0.1, which tilesynth refuses
    # as "not a unit normal map"): renormalised first, as a user would after that message
    maps["normal"] = materials.renormalise_image(maps["normal"], "unorm")
    return albedo, maps


def _cpu(fn):  # noqa: ANN001, ANN202
    t0 = time.process_time()
    out = fn()
    return out, time.process_time() - t0


def _score(t: ts.TileSet, x: np.ndarray) -> float:
    return cut_seam_score(SimpleNamespace(tiles=x, cut_masks=t.cut_masks))["score"]


def _specs(t: ts.TileSet) -> dict[str, materials.MapSpec]:
    return {d["name"]: materials.MapSpec.from_dict(d) for d in t.map_specs}


def _perez_atlas(t: ts.TileSet, spec: materials.MapSpec) -> np.ndarray:
    """**Before** (main at 6153131): the map Poisson-smoothed inside the cut only, the colour's smoothing
    (Pérez, Dirichlet boundary = the intermediate tile next to the cut), normals renormalised by rounding."""
    from tilesynth.synth.synthesis import _smooth_map_atlas

    arr = t.maps[spec.name]
    atlas = _smooth_map_atlas(t, arr, np.ascontiguousarray(arr[t.source[..., 0], t.source[..., 1]]), None)
    if spec.kind == "normal":  # renormalised and rounded where smoothed (inside the cut), copies elsewhere
        inside = np.asarray(t.cut_masks, bool)
        v = materials._decoded_normals(atlas[inside], "unorm")
        v /= np.linalg.norm(v, axis=-1, keepdims=True)
        atlas = atlas.copy()
        atlas[inside] = np.rint((v + 1) * 0.5 * 255).astype(np.uint8)
    return atlas


def _reference(t: ts.TileSet, spec: materials.MapSpec, fused: np.ndarray) -> float:
    """The no-seam reference: the mean squared step the two patches themselves have at the cut's pixel pairs (each
    side's patch continued one pixel across, averaged, as the fusion's guidance) over the same denominator as the
    score. What a perfectly hidden seam would score where the cut runs (the cut prefers high-gradient places)."""
    x = materials._float_atlas(t, spec, t.maps[spec.name])
    h, w = x.shape[:2]
    m = np.asarray(t.cut_masks, np.int8)
    src = t.source.astype(np.int64)
    num = den = 0.0
    cut = pairs = 0
    for ax, d in ((1, (1, 0)), (2, (0, 1))):
        across = np.diff(m, axis=ax) != 0
        k, i, j = np.nonzero(across)
        p = src[k, i, j]
        q = src[k, i + d[0], j + d[1]]
        sp = x[np.minimum(p[:, 0] + d[0], h - 1), np.minimum(p[:, 1] + d[1], w - 1)] - x[p[:, 0], p[:, 1]]
        sq = x[q[:, 0], q[:, 1]] - x[np.maximum(q[:, 0] - d[0], 0), np.maximum(q[:, 1] - d[1], 0)]
        num += float((((sp + sq) * 0.5) ** 2).sum())
        cut += int(across.sum())
        f = materials._float_atlas(t, spec, fused)
        den += float((np.diff(f, axis=ax) ** 2).sum())
        pairs += int(np.diff(f, axis=ax)[..., 0].size)
    return (num / cut) / (den / pairs)


def _albedo_perez(t: ts.TileSet) -> float:
    """The albedo's cut seam after the colour's Poisson smoothing (what ``--smooth`` gives) on this set."""
    from tilesynth.builder.smoothing import smooth_tiles

    n = t.tile_size
    a = t.exemplar.astype(np.float32) / (np.float32(255) if t.exemplar.dtype == np.uint8 else np.float32(1))
    matching = np.stack([a[r : r + n, c : c + n] for r, c in np.asarray(t.match_offsets)])
    tiles, _ = smooth_tiles(np.asarray(t.tiles, np.float32), matching, t.cut_masks)
    return _score(t, tiles)


def _kink_profile(
    t: ts.TileSet, spec: materials.MapSpec, atlas: np.ndarray, imap: np.ndarray, size: int
) -> np.ndarray:
    """The tile-border kink of a map laid out by ``imap``, by distance ``d`` from the nearest tile border (``d =
    0``: the border ring of either tile; ``d = 1``: the pixels next to it, ...): the mean absolute second
    difference across the border direction (along y near horizontal borders, along x near vertical ones) at
    distance ``d`` over its mean at the pixels farther than ``n / 4`` from every border. A smooth map whose tiles
    were corrected inside a fixed border ring bends there: a faint grid line in shading, which neither the
    border seam score (steps) nor the cut seam sees. Returned for ``d = 0 .. n / 4``."""
    from tilesynth.base import kernels

    img = np.empty((size, size, atlas.shape[3]), atlas.dtype)
    kernels.tile_copy(np.ascontiguousarray(atlas), imap, img)
    x = materials._float_atlas(t, spec, img[None])[0]
    n = t.tile_size
    idx = np.arange(1, size - 1)
    dist = np.minimum(idx % n, n - 1 - idx % n)
    far = n // 4
    num = np.zeros(far + 1)
    den = 0.0
    for ax in (0, 1):
        d2 = np.abs(np.diff(x, n=2, axis=ax)).sum(axis=-1)
        d2 = d2 if ax == 0 else d2.T
        den += float(d2[dist > far].mean())
        num += [float(d2[dist == d].mean()) for d in range(far + 1)]
    return num / den


def _kink(t: ts.TileSet, spec: materials.MapSpec, atlas: np.ndarray, imap: np.ndarray, size: int) -> tuple:
    """``(ring, band)``: the kink ratio on the border ring (``d = 0``) and the worst one over the band ``d = 0 ..
    n / 4`` (:func:`_kink_profile`): a correction clamped at the ring must not just move its bend inwards."""
    prof = _kink_profile(t, spec, atlas, imap, size)
    return float(prof[0]), float(prof.max())


def _map_scores(t: ts.TileSet, size: int = 384) -> dict[str, dict[str, float]]:
    out = {}
    _, imap = ts.synthesize(t, size, size, seed=7)
    for name, spec in _specs(t).items():
        fused = materials.map_atlas(t, spec, t.maps[name])
        copies = materials.map_atlas(t, spec, t.maps[name], False)
        perez = _perez_atlas(t, spec)
        out[name] = {
            "kink_copies": _kink(t, spec, copies, imap, size),
            "kink_before": _kink(t, spec, perez, imap, size),
            "kink_after": _kink(t, spec, fused, imap, size),
            "copies": _score(
                t, materials._float_atlas(t, spec, materials.map_atlas(t, spec, t.maps[name], False))
            ),
            "before": _score(t, materials._float_atlas(t, spec, _perez_atlas(t, spec))),
            "after": _score(t, materials._float_atlas(t, spec, fused)),
            "reference": _reference(t, spec, fused),
        }
    return out


def _unit_share(a: np.ndarray) -> float:
    return float((np.abs(materials.normal_lengths(a) - 1.0) <= 0.005).mean())


def _normal_shares(t: ts.TileSet, size: int = 512, seed: int = 7) -> dict[str, float]:
    """Share of output normals within 1 ± 0.005: before (copies keep the input's codes; smoothed pixels rounded)
    and after (every vector re-encoded, ``normal_codes``)."""
    from tilesynth.base import kernels

    _, imap = ts.synthesize(t, size, size, seed=seed)
    spec = _specs(t)["normal"]
    out = {}
    for label, atlas in (
        ("copies_before", np.ascontiguousarray(t.maps["normal"][t.source[..., 0], t.source[..., 1]])),
        ("smoothed_before", _perez_atlas(t, spec)),
    ):
        img = np.empty((size, size, 3), np.uint8)
        kernels.tile_copy(atlas, imap, img)
        out[label] = _unit_share(img)
    out["copies_after"] = _unit_share(materials.synthesize_maps(t, imap, size, size, smooth=False)["normal"])
    out["smoothed_after"] = _unit_share(materials.synthesize_maps(t, imap, size, size)["normal"])
    return out


def _with_maps(t: ts.TileSet, maps: dict[str, np.ndarray]) -> ts.TileSet:
    """The colour-only set with the maps attached at weight 0 (as ``synth --with`` sends them)."""
    import copy

    out = copy.copy(t)
    specs = materials.check_maps(t.exemplar.shape, maps, map_weights=dict.fromkeys(maps, 0.0))
    out.maps = {s.name: a for s, a in specs}
    out.map_specs = [s.to_dict() for s, _ in specs]
    return out


def measure(name: str, albedo: np.ndarray, maps: dict, seed: int, repeat: int) -> dict:
    colour_t, joint_t = [], []
    colour = joint = None
    for _ in range(repeat):  # interleaved
        colour, c = _cpu(lambda: ts.build(albedo, tileset=SET, seed=seed))
        joint, j = _cpu(lambda: ts.build(albedo, tileset=SET, seed=seed, maps=maps))
        colour_t.append(c)
        joint_t.append(j)
    colour_m = _with_maps(colour, maps)
    return {
        "name": name,
        "shape": albedo.shape,
        "tile_size": joint.tile_size,
        "tiles": joint.n_tiles,
        "kept": joint.params["material"]["variance_kept"],
        "weights": {d["name"]: d["weight"] for d in joint.map_specs},
        "albedo": (cut_seam_score(colour)["score"], cut_seam_score(joint)["score"]),
        "albedo_perez": (_albedo_perez(colour), _albedo_perez(joint)),
        "colour": _map_scores(colour_m),
        "joint": _map_scores(joint),
        "normals": _normal_shares(joint),
        "cpu_colour": statistics.median(colour_t),
        "cpu_joint": statistics.median(joint_t),
    }


def table(rows: list[dict], repeat: int) -> str:
    f = "{:.2f}".format
    maps = ("height", "normal", "roughness")
    lines = [
        "# Material builds: colour-only + `--with` maps against the joint build (`benches/materials.py`)",
        "",
        "Rows `pbr:*` are **real PBR materials** (`--pbr`: pypbr 0.1.0b5's test data `rocks` and `tiles`, MIT, see",
        "the bench's docstring; their normal maps renormalised on loading, so their *copies before* column is at",
        "100 %). The other rows are **derived materials, not real PBR sets**: height, normal and roughness computed",
        "from each photo of `../shared/textures` plus independent random structure (see the bench's docstring).",
        "",
        f"Default build (`{SET}`, seed 1, centre crops: 256² of the PBR materials, 192² of the photos, default map weights "
        f"{', '.join(f'{k} {v:g}' for k, v in rows[0]['weights'].items())}). Cut seam score (1 = the cuts are as "
        "invisible as any pair of neighbouring pixels of the tiles). CPU time: medians of "
        f"{repeat} interleaved runs, process CPU time of all threads (the machine was shared with other jobs).",
        "",
        "## The albedo and the build cost",
        "",
        "*copies*: the tiles as built (the default: no smoothing); *`--smooth`*: after the colour's Poisson "
        "smoothing inside the cuts. Colour-only build → joint build. The albedo's *copies* figure is the one to set "
        "beside the maps' *copies*, its *`--smooth`* figure beside their smoothed ones.",
        "",
        "| material | tiles | albedo copies | albedo `--smooth` | variance kept | CPU colour s | CPU joint s | ratio |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['name']} {r['shape'][1]}x{r['shape'][0]} | {r['tiles']} x {r['tile_size']}² | "
            f"{f(r['albedo'][0])} → {f(r['albedo'][1])} | {f(r['albedo_perez'][0])} → {f(r['albedo_perez'][1])} | "
            f"{r['kept']:.3f} | {r['cpu_colour']:.2f} | {r['cpu_joint']:.2f} | "
            f"**{r['cpu_joint'] / r['cpu_colour']:.2f}** |"
        )
    lines += [
        "",
        "## The maps: before (Poisson inside the cut) and after (seam-free fusion over the tile interior)",
        "",
        "Same run, same tile sets. *copies*: copied through the cuts (`--map-smooth off`); *before*: smoothed as on "
        "main at 6153131 (the colour's Pérez smoothing inside the cut, the intermediate tile next to it fixed); "
        "*after*: the default now (`tilesynth.builder.fusion`: gradient-domain fusion of every seam over the tile "
        "interior, border ring kept); *reference*: what a perfectly hidden seam scores where the cut runs (the two "
        "patches' own steps at the cut's pixel pairs). Joint build; the colour-only build's *after* for comparison. "
        "*Border kink*: the mean absolute second difference at the pixels beside every tile border over its mean "
        "farther than n/4 from every border (band: the worst row within n/4), on a 384² synthesis (1: the borders bend no more than the texture; the price of correcting "
        "each tile inside a fixed border ring).",
        "",
        "| material | map | copies | before | **after** | reference | colour-only: copies | colour-only: after "
        "| border kink: copies / before / after |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        for k in maps:
            j, c = r["joint"][k], r["colour"][k]
            lines.append(
                f"| {r['name']} | {k} | {f(j['copies'])} | {f(j['before'])} | **{f(j['after'])}** | "
                f"{f(j['reference'])} | {f(c['copies'])} | {f(c['after'])} | {f(j['kink_copies'][0])} / "
                f"{f(j['kink_before'][0])} / {f(j['kink_after'][0])} (band {f(j['kink_after'][1])}) |"
            )
    lines += [
        "",
        "## Normals within 1 ± 0.005 of unit length (512² output of the joint build, 8-bit normal maps)",
        "",
        "*before*: copies keep the input's own 8-bit codes, smoothed pixels renormalised and rounded; *after*: every "
        "vector re-encoded by `tilesynth.io.normal_codes.encode_unit` (decoding `v = code / 255 · 2 − 1`).",
        "",
        "| material | copies before | copies after | smoothed before | smoothed after |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        n = r["normals"]
        lines.append(
            f"| {r['name']} | {100 * n['copies_before']:.2f} % | {100 * n['copies_after']:.2f} % | "
            f"{100 * n['smoothed_before']:.2f} % | {100 * n['smoothed_after']:.2f} % |"
        )
    med = statistics.median(r["cpu_joint"] / r["cpu_colour"] for r in rows)
    worst = {k: max(r["joint"][k]["after"] for r in rows) for k in maps}
    worst_before = {k: max(r["joint"][k]["before"] for r in rows) for k in maps}
    unit = min(min(r["normals"]["copies_after"], r["normals"]["smoothed_after"]) for r in rows)
    ok = all(v <= 1.3 for v in worst.values())
    lines += [
        "",
        f"Targets: cut seams of every map ≤ 1.3 in the joint build: **{'met' if ok else 'not met'}** (worst after: "
        + ", ".join(f"{k} {worst[k]:.2f}" for k in maps)
        + "; before: "
        + ", ".join(f"{k} {worst_before[k]:.2f}" for k in maps)
        + f"); 4-map build ≤ 1.5x the colour-only build (median ratio {med:.2f}, worst "
        f"{max(r['cpu_joint'] / r['cpu_colour'] for r in rows):.2f}); 99.9 % of normals within 1 ± 0.005 "
        f"(lowest after: {100 * unit:.2f} %).",
        "",
    ]
    return "\n".join(lines)


def figure(path: str, albedo: np.ndarray, maps: dict, seed: int, size: int = 200) -> None:
    """Albedo, normal and height of ``size``² syntheses side by side, one row per build: colour-only with the
    maps copied through its cuts (``synth --with``); colour-only with the maps fused (``synth`` on a set built with
    weight-0 maps); the joint build with the maps smoothed as before (Pérez inside the cut, main at 6153131); the
    joint build as ``synth`` writes it now (seam-free fusion)."""
    from tilesynth.base import kernels

    colour = _with_maps(ts.build(albedo, tileset=SET, seed=seed), maps)
    joint = ts.build(albedo, tileset=SET, seed=seed, maps=maps)
    rows = []
    for t, how in ((colour, "copies"), (colour, "after"), (joint, "before"), (joint, "after")):
        img, imap = ts.synthesize(t, size, size, seed=7, dtype=np.uint8)
        if how == "before":
            m = {}
            for name in ("normal", "height"):
                atlas = _perez_atlas(t, _specs(t)[name])
                m[name] = np.empty((size, size, atlas.shape[3]), atlas.dtype)
                kernels.tile_copy(atlas, imap, m[name])
        else:
            m = materials.synthesize_maps(t, imap, size, size, smooth=how != "copies")
        h8 = np.repeat((m["height"] >> 8).astype(np.uint8), 3, axis=2)
        rows.append(np.concatenate([img[..., :3], m["normal"], h8], axis=1))
    gap = np.full((6, rows[0].shape[1], 3), 255, np.uint8)
    out = [rows[0]]
    for r in rows[1:]:
        out += [gap, r]
    ts.save_image(path, np.concatenate(out, axis=0))


LIGHT = np.array([0.5, 0.5, 0.7]) / np.linalg.norm([0.5, 0.5, 0.7])
"""The light of the shaded-height figures (upper left, unit length)."""


def height_normals(height: np.ndarray, relief: float) -> np.ndarray:
    """Unnormalised normals ``(H, W, 3)`` of a height field ``(H, W)`` with its relief exaggerated."""
    gy, gx = np.gradient(height * relief)
    return np.dstack([-gx, -gy, np.ones_like(gx)])


def lambert(normals: np.ndarray) -> np.ndarray:
    """Lambert shading ``(H, W)`` uint8 of ``normals`` ``(H, W, 3)`` (normalised here, in place) lit by
    :data:`LIGHT`."""
    normals /= np.linalg.norm(normals, axis=2, keepdims=True)
    return np.clip((normals @ LIGHT) * 255, 0, 255).astype(np.uint8)


def shaded(
    path: str, albedo: np.ndarray, maps: dict, seed: int, size: int = 320, relief: float = 60.0
) -> None:
    """The joint build's height, ``size``² of a synthesis, lit from the upper left with the relief exaggerated
    (``relief``): copies, before (Pérez inside the cut) and after (fusion), side by side."""
    from PIL import Image

    from tilesynth.base import kernels

    t = ts.build(albedo, tileset=SET, seed=seed, maps=maps)
    _, imap = ts.synthesize(t, size, size, seed=7)
    spec = _specs(t)["height"]
    panels = []
    for atlas in (materials.map_atlas(t, spec, t.maps["height"], False), _perez_atlas(t, spec),
                  materials.map_atlas(t, spec, t.maps["height"])):  # fmt: skip
        out = np.empty((size, size, 1), atlas.dtype)
        kernels.tile_copy(np.ascontiguousarray(atlas), imap, out)
        height = materials._float_atlas(t, spec, out[None])[0][..., 0]
        panels += [lambert(height_normals(height, relief)), np.full((size, 4), 255, np.uint8)]
    Image.fromarray(np.concatenate(panels[:-1], axis=1)).save(path, optimize=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--textures", default=",".join(TEXTURES))
    ap.add_argument(
        "--dir", default=str(SHARED), help="directory of the textures (default ../shared/textures)"
    )
    ap.add_argument("--crop", type=int, default=192, help="centre crop of each photo (default 192)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default=str(Path(__file__).with_name("materials-results.md")))
    ap.add_argument(
        "--pbr",
        action="append",
        default=[],
        metavar="DIR",
        help="a real PBR material: a directory with basecolor.png, normal.png, height.png, roughness.png (see "
        "the module docstring: pypbr's rocks and tiles); measured first, and used for --figure; repeatable",
    )
    ap.add_argument(
        "--pbr-crop", type=int, default=256, help="centre crop of each PBR material (default 256)"
    )
    ap.add_argument(
        "--figure", default=None, help="write the rock figure of the first material here and stop"
    )
    ap.add_argument(
        "--shaded", default=None, help="write the shaded height figure of the first material and stop"
    )
    args = ap.parse_args(argv)
    rows = []
    inputs = [(f"pbr:{Path(d).name}", *load_pbr(d, args.pbr_crop)) for d in args.pbr]
    inputs += [(name, None, None) for name in args.textures.split(",") if name]
    for name, ex, maps in inputs:
        if ex is None:
            ex, _ = ts.load_image(Path(args.dir) / f"{name}.png")
            ex = _crop(ex, args.crop)[..., :3]
            maps = derive_material(ex, seed=args.seed)
        if args.shaded:
            shaded(args.shaded, ex, maps, args.seed)
            print(f"wrote {args.shaded}")
            return 0
        if args.figure:
            figure(args.figure, ex, maps, args.seed)
            print(f"wrote {args.figure}")
            return 0
        rows.append(measure(name, ex, maps, args.seed, args.repeat))
        print(f"{name}: done", file=sys.stderr)
    text = table(rows, args.repeat)
    Path(args.out).write_text(text, encoding="utf-8")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
