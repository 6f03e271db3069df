"""Material builds: an exemplar with pixel-aligned maps (normal, height, roughness, ...) cut as one material.

A colour-only build chooses its matching patches and cuts on the albedo alone; a height map sent through the
same cuts afterwards (``synth --with``) is discontinuous wherever the albedo hid a seam that the height does not
(issue 14: height cliffs along every cut). A **material build** (:func:`tilesynth.build_material`, ``tilesynth.build(img,
maps={...})``, ``tilesynth build EX --map height=H.png``) chooses them on every map jointly:

1. **Features.** Each map (and the albedo) is centred and divided by its own standard deviation (the square
   root of the sum of its channels' variances), then multiplied by ``sqrt(weight)``: a map of weight w
   contributes w times the albedo's share of every SSD and every cut weight, whatever its range or channel
   count. A normal map enters as its decoded vectors (``2·v − 1`` for unsigned encodings), a constant map not at
   all (it has nothing to match).
2. **Projection.** The stacked channels (3 + 3 + 1 + 1 = 8 for albedo, normal, height, roughness) are projected
   on their first :data:`FEATURE_CHANNELS` principal components (exact when there are no more channels than
   that), and the result is mapped into [0, 1] by one affine map common to all channels. Why: the FFT matching
   search, the objective and the cut weights cost in proportion to the channel count; 4 components keep the
   build at 1.1-1.3x the CPU time of a colour-only build (target: at most 1.5x, ``benches/materials.py``)
   while keeping most of the joint variance (recorded as ``params["material"]["variance_kept"]``: 0.90-0.96 on
   the bench's materials). One affine map for every channel keeps SSD rankings exactly (a common scale and offset
   change every SSD by the same factor); the Kwatra ``eps`` is then relative to features of an image's range.
   The feature image reaches the builder as an ordinary 4-channel float image: its 4th channel is a feature,
   never an alpha channel or a mask.
3. **Build.** The scheme's own builder runs on the feature image, unchanged: genes, matching patches, D_j, E and
   cut costs are all in feature units (recorded as such). The tile set then gets the real albedo: the exemplar
   is the albedo, and the tiles are the albedo copied through the provenance (or Poisson-smoothed in the same
   regions, for ``smooth=True``).
4. **Maps travel with the set.** Every map is stored in the tile set (``map_<name>.npy`` in its own sample type,
   with its kind and weight in ``manifest.json`` ``maps``), and :func:`synthesize_maps` lays each out through the
   same provenance and cuts as the colour (``synth``, ``export`` and ``report`` write all of them). Scalar and
   normal maps are blended across their seams by default (:func:`smooths`, :mod:`tilesynth.synth.seams`: a
   smooth map shows the level offset of two patches as a cliff that no cut avoids; near a cut the pieces that
   cover the pixel's neighbourhood are read at the pixel and weighted by their share of the tile labels'
   coverage, the low frequencies of scalar maps over a wider band and variance-preserving, so the relief keeps
   its amplitude: ``benches/relief-results.md``). ``seams="fuse"`` / ``--map-seams fuse`` selects the former
   gradient-domain fusion (:mod:`tilesynth.builder.fusion`: a first stage moves the exemplar's levels by one
   smooth correction shared by every copy of a pixel, :func:`~tilesynth.builder.fusion.exemplar_levels`, then
   the tile interior is fused with the border ring kept; it leaves no level offset but flattens rocks' relief
   to 0.2-0.3x); ``smooth=False`` / ``--map-smooth off`` gives pure copies.

**Default weights** (0.5 for scalar and normal maps, :data:`DEFAULT_WEIGHTS`). Measured on the bench's 4 derived
materials with 2 seeds each (``benches/materials.py``): with the fusion, the maps' cut seams are 0.85-1.34 whatever
the weight (0, 0.25, 0.5, 1), since the cut no longer has to hide a level offset; the albedo's cut seam (copies)
grows with the maps' weight (weight 1: 5.0-10.5, 0.5: 4.4-9.6, colour-only 4.1-8.2), and at weight 1 the cut
follows the normal map's edges so closely (the Kwatra weight divides by the feature gradients) that the normal's
score rose to 1.48-1.57 on the brick material, though its seam itself is fused away (the *reference* column: the
patches' own steps there). 0.5 keeps the maps in the joint matching and cut at about a third of the features'
variance and costs the albedo less.

**The cut of a material build** (:data:`MATERIAL_CUT_EPS`, issue 14). The cut weights of ω and s-Wang are
Kwatra's, ``(‖a − b‖(s) + ‖a − b‖(t)) / (Σ‖g‖ + eps)``: the gradient normalisation makes a step along an edge of
the exemplar cheap, because a colour seam there hides in the edge. In a joint build the gradients are those of the
feature image, so the cut is drawn along the *maps'* own edges too (a normal map's crease, a roughness step), and
there nothing hides it: the maps are fused across the cut afterwards, and where the cut follows an edge that one
patch has and the other does not, the fusion's guidance is not integrable. Measured (``benches/map_levels.py``):
with the default ``eps`` = 1e-6 the s-Wang normals of pbr:tiles and bricks-red scored 1.46 / 1.45 with a
*reference* (the patches' own steps where the cut runs) of 1.14 / 1.22, most of it more than 8 px from the tile
borders; ω ``c5``'s pbr:tiles maps scored 1.52-3.14 (roughness reference 3.15: the cut along the grout). A
joint ω or s-Wang build therefore uses ``eps`` = 1, the feature image's range (typical feature gradients are
0.02-0.1, so the denominator varies by tens of per cent instead of orders of magnitude: a capped normalisation,
close to the plain difference): on seeds 1-3 of the bench's six materials (``c5``: seeds 1-2) the s-Wang maps
fall to 0.4-1.2 and ω's to 0.5-1.1, their references with them (the cut leaves the maps' edges), and so does the
albedo's own cut seam, on nearly every material (``benches/materials-results.md``, "Material cuts with a capped
gradient normalisation"); eps = 0.03 / 0.1 / 0.3 / 3 were measured too (0.3 already helps, 3 is as good as 1).
A caller's ``eps`` is kept; colour-only builds are unchanged; so are Cohen's Wang tiles (their DP path has no
gradient term) and the patch baseline (not measured).

**Map kinds** (:data:`KINDS`), inferred from the name (:func:`infer_kind`) unless given:

=========  =====================================================  ==============  ====================================
kind       meaning                                                default weight  in synthesis
=========  =====================================================  ==============  ====================================
colour     sRGB colour (albedo, base colour, emissive)            1               copied; smoothed with the colour
scalar     linear data (height, roughness, metallic, AO, ...)     0.5             blended across the seams
normal     tangent-space normal, 3 channels, Y up or down         0.5             blended, unit codes
label      mask, material ID, segmentation (any integer value)    0               exact copies, never smoothed
=========  =====================================================  ==============  ====================================

Names containing ``normal``/``nrm``/``nor`` are normals; ``mask``, ``label``, ``id``, ``segment``, ``class`` labels;
``albedo``, ``color``/``colour``, ``diffuse``, ``base``, ``emissive`` colours; everything else (``height``,
``roughness``, ``ao``, ``metallic``, ``disp``, ...) linear scalars. Labels get weight 0 by default (their values are
categories, not distances); a positive ``map_weights`` entry makes them count numerically.

**What is left in smooth maps.** The ω construction keeps the tile border ring of the intermediate tile, whose
central cross (where two sample patches meet) reaches the border at the four side midpoints; a few pixels of that
cross are outside every cut region (in every scheme with a kept border). The fusion of scalar and normal maps
treats them as seams like the cut, so inside the tile they are fused too; what is left is the cross's one pixel
pair on the border ring itself (the ring is shared with the neighbouring tile and kept by the interior fusion),
about which the fused interior bends back within a few pixels; the first (level) stage lowers that pair's step,
since it corrects the exemplar itself, every copy of a ring pixel by the same amount. With the colour's Pérez smoothing (``synth --with`` on a
``--smooth`` set, and the albedo) they stay as they are: invisible in an albedo, a small dot at each tile side
midpoint in a smooth height map.

**Normal maps.** ``normal_y`` records the Y convention of the input normals: ``"up"`` (OpenGL, green up, the
default) or ``"down"`` (DirectX). Outputs can be converted (:func:`convert_normal_y`, ``synth --normal-y``): the
green channel is negated (``max − g`` for unsigned encodings: exact for 8- and 16-bit). A normal map is *unsigned*
(values in [0, 1] encode ``2·v − 1``; every PNG) unless it has negative values (a float map of signed vectors).
Inputs whose vectors are far from unit length are normalised as engines do (:func:`inspect_normal`): a
downscaled map's short vectors renormalised, a map with z on another scale gets z rebuilt from x and y; what was
done is recorded in ``params["material"]["normalised"]`` and shown by ``tilesynth info``. Only what no
normal-map tool writes is refused (a grey image, vectors near zero, x or y not centred, z not positive), with a
message that says how to pass it as a scalar map. After smoothing, every smoothed vector is
renormalised to unit length, and every vector of every output (copies too) is re-encoded by
:func:`tilesynth.io.normal_codes.encode_unit`: decoded as ``v = code / 255 · 2 − 1`` (16-bit: ``/ 65535``), each
8- or 16-bit pixel gets the code nearest its vector among the floor / ceiling combinations whose decoded length is
within 0.0049 of 1, so 100 % of output vectors are within 1 ± 0.005 (plain rounding leaves 0.1-0.8 % outside,
up to 0.007) while the direction moves no more than rounding may.
"""

from __future__ import annotations

import re
import time
import weakref
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ParameterError, ShapeError
from ..io.normal_codes import code_scale, encode_unit

__all__ = [
    "DEFAULT_WEIGHTS",
    "FEATURE_CHANNELS",
    "KINDS",
    "MATERIAL_CUT_EPS",
    "MapSpec",
    "NORMAL_TOLERANCE",
    "build_with_maps",
    "check_maps",
    "convert_normal_y",
    "feature_image",
    "infer_kind",
    "inspect_normal",
    "normal_lengths",
    "renormalise_image",
    "smooths",
    "synthesize_maps",
]

#: The map kinds.
KINDS: tuple[str, ...] = ("colour", "scalar", "normal", "label")
#: Other spellings accepted for a kind.
KIND_ALIASES: dict[str, str] = {
    "color": "colour",
    "srgb": "colour",
    "linear": "scalar",
    "mask": "label",
    "labels": "label",
    "id": "label",
}
#: The weight of a map of each kind when ``map_weights`` does not name it (its share of the distance relative to
#: the albedo's, which is 1).
DEFAULT_WEIGHTS: dict[str, float] = {"colour": 1.0, "scalar": 0.5, "normal": 0.5, "label": 0.0}
#: Channels of the feature image the scheme is built on (see the module docstring, step 2).
FEATURE_CHANNELS = 4
#: Kwatra's ``eps`` of the ω and s-Wang cuts in a joint material build (``Scheme.material_options``), in the units
#: of the feature image (range 1): a capped gradient normalisation, so the cut does not follow the maps' own edges
#: (module docstring, "The cut of a material build").
MATERIAL_CUT_EPS: float = 1.0
#: A normal map is used as it is when at most :data:`NORMAL_BAD_SHARE` of its vectors have a length outside
#: 1 ± NORMAL_TOLERANCE (8-bit quantisation alone stays within 0.007); other maps are normalised or refused by
#: :func:`inspect_normal`.
NORMAL_TOLERANCE = 0.1
NORMAL_BAD_SHARE = 0.01
#: Which of the two fixes of :func:`inspect_normal`: the ratio of each vector's z to the z its x and y call for,
#: ``z / √(1 − x² − y²)``. A map with z on another scale has the same ratio on every pixel (its median more than
#: NORMAL_Z_SCALE from 1, its 90th percentile within NORMAL_Z_SPREAD of the median); z is then rebuilt. A
#: downscaled map's ratio spreads with the local roughness (measured on synthetic height-field normals
#: downscaled 2-8x: 90th percentile 3-24 % above the median, or a median within 5 % of 1); it is renormalised.
NORMAL_Z_SCALE = 0.05
NORMAL_Z_SPREAD = 0.03
#: Refusal limits of :func:`inspect_normal`: median length, mean of x and of y, median z.
NORMAL_MIN_LENGTH = 0.25
NORMAL_MAX_MEAN = 0.3
NORMAL_MIN_Z = 0.1
#: A map whose three decoded channels all correlate above this is a colour image, not vectors (measured: the 24
#: shared photos 0.33-1.0 for their least correlated pair, with most above 0.7; normal maps about 0: x and y vary
#: independently of each other and of z).
NORMAL_MAX_CORRELATION = 0.5
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,63}")
_DTYPES = ("uint8", "uint16", "float32")


@dataclass(frozen=True)
class MapSpec:
    """One map of a material: its name, kind, weight, sample type and channels, and for normals the Y
    convention and encoding. :meth:`to_dict` is its ``manifest.json`` entry."""

    name: str
    kind: str
    weight: float
    dtype: str
    channels: int
    normal_y: str | None = None
    encoding: str | None = None
    suffix: str = ".png"
    #: What :func:`inspect_normal` did to an input normal map (None: used as it is); recorded in the tile set's
    #: ``params["material"]["normalised"]``, not in the map's manifest entry.
    normalised: str | None = None

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "name": self.name,
            "kind": self.kind,
            "weight": float(self.weight),
            "dtype": self.dtype,
            "channels": int(self.channels),
            "suffix": self.suffix,
        }
        if self.kind == "normal":
            d["normal_y"] = self.normal_y
            d["encoding"] = self.encoding
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> MapSpec:
        return cls(
            name=d["name"], kind=d["kind"], weight=float(d["weight"]), dtype=d["dtype"], channels=int(d["channels"]),
            normal_y=d.get("normal_y"), encoding=d.get("encoding"), suffix=d.get("suffix", ".png"),
        )  # fmt: skip


def infer_kind(name: str) -> str:
    """The kind of a map called ``name`` (see the module docstring)."""
    low = name.lower()
    words = set(re.split(r"[^a-z]+", low))  # "rock_nrm16" -> {"rock", "nrm"}
    if "normal" in low or words & {"nrm", "nor", "n", "nml", "normals"}:
        return "normal"
    if any(w in low for w in ("mask", "label", "segment", "class")) or words & {"id", "ids", "matid"}:
        return "label"
    if any(w in low for w in ("albedo", "colour", "color", "diffuse", "basecolor", "base_color", "emissive")):
        return "colour"
    return "scalar"


def _kind(value: Any, name: str) -> str:
    k = KIND_ALIASES.get(str(value).lower(), str(value).lower()) if isinstance(value, str) else None
    if k not in KINDS:
        raise ParameterError(
            f"map {name!r}: unknown map kind {value!r}; expected one of {', '.join(KINDS)} "
            f"(or {', '.join(sorted(KIND_ALIASES))})"
        )
    return k


def _as_map_array(name: str, value: Any, shape: tuple[int, int]) -> np.ndarray:
    """The map as ``(H, W, C)`` uint8 / uint16 / float32 (float16 / float64 converted after the finiteness
    check), checked: pixel-aligned with the exemplar, 1-4 channels, finite."""
    try:
        a = np.asarray(value)
    except (ValueError, TypeError) as exc:
        raise ShapeError(f"map {name!r} is not an array ({exc})") from None
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or not 1 <= a.shape[2] <= 4:
        raise ShapeError(
            f"map {name!r} has shape {np.shape(value)}, expected (H, W) or (H, W, C) with C in 1..4"
        )
    if a.shape[:2] != shape:
        raise ShapeError(
            f"map {name!r} is {a.shape[1]}x{a.shape[0]}, the exemplar {shape[1]}x{shape[0]}: every map must be "
            "pixel-aligned with the exemplar (same width and height)"
        )
    if a.dtype.kind == "f":
        if a.dtype not in (np.float16, np.float32, np.float64):
            raise TypeError(f"map {name!r} has dtype {a.dtype}, expected uint8, uint16 or float32")
        bad = ~np.isfinite(a)
        if bad.any():
            y, x, c = (int(v) for v in np.argwhere(bad)[0])
            raise ParameterError(
                f"map {name!r} has {int(bad.sum())} NaN or infinite value(s) (the first {a[y, x, c]!r} at row {y}, "
                f"column {x}, channel {c}); a map must be finite"
            )
        if a.dtype != np.float32:
            with np.errstate(over="ignore"):
                f = a.astype(np.float32)
            if not np.isfinite(f).all():
                raise ParameterError(f"map {name!r} has values beyond the float32 range")
            a = f
    elif a.dtype not in (np.uint8, np.uint16):
        raise TypeError(
            f"map {name!r} has dtype {a.dtype}, expected uint8, uint16 or float32 (convert explicitly: "
            "arr.astype(np.uint8) for data in [0, 255])"
        )
    return np.ascontiguousarray(a)


def _decoded_normals(a: np.ndarray, encoding: str) -> np.ndarray:
    """The vectors of a normal map as float64 ``(H, W, 3)``."""
    scale = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(a.dtype, 1.0)
    v = a.astype(np.float64) / scale
    return 2.0 * v - 1.0 if encoding == "unorm" else v


def normal_lengths(a: np.ndarray, encoding: str = "unorm") -> np.ndarray:
    """The vector lengths of a normal map ``(H, W, 3)`` (``encoding`` "unorm": values in [0, 1] or uint encode
    ``2·v − 1``; "snorm": the vectors themselves): float64 ``(H, W)``."""
    return np.sqrt((_decoded_normals(np.asarray(a), encoding) ** 2).sum(axis=-1))


def _refuse_normal(name: str, why: str) -> ParameterError:
    return ParameterError(
        f"map {name!r} (kind normal): {why}; this cannot be a tangent-space normal map. To use it anyway, pass it "
        f"as a scalar map (--map {name}:scalar=FILE; map_kinds={{{name!r}: 'scalar'}} in Python; kind = "
        '"scalar" in a batch maps table)'
    )


def inspect_normal(name: str, a: np.ndarray) -> tuple[str, str | None, np.ndarray | None]:
    """Whether ``a`` ``(H, W, 3)`` is a normal map, and how to read it: ``(encoding, note, vectors)``.

    ``note`` is None (and ``vectors`` None) for a map of unit vectors (fewer than :data:`NORMAL_BAD_SHARE` outside
    1 ± :data:`NORMAL_TOLERANCE`): it is used as it is. Otherwise the map is one of the two kinds real tools
    write, and ``vectors`` are its unit vectors (float64):

    * **short vectors** (a downscaled map, whose box or mip filter averages neighbouring unit vectors into
      shorter ones: median length 0.92-0.98): each vector is divided by its length, as engines do when they
      sample;
    * **z on another scale** (x and y centred on 0 and inside the unit disc, z positive, and z the same multiple
      of ``√(1 − x² − y²)`` on every pixel, :data:`NORMAL_Z_SCALE`; median lengths such as 0.78 or 0.51): z is
      rebuilt from x and y, ``z = √(1 − x² − y²)``, as engines do for two-channel normal maps.

    Refused (:class:`ParameterError` naming the map and saying how to pass it as a scalar map), because no
    normal-map tool writes it: a grey image (r = g = b), vectors near zero (median length below
    :data:`NORMAL_MIN_LENGTH`), x or y not centred (mean beyond ± :data:`NORMAL_MAX_MEAN`: a colour photo or a
    height map read as vectors), three channels that vary together (:data:`NORMAL_MAX_CORRELATION`: a photo),
    z not positive (median z below :data:`NORMAL_MIN_Z`), or x and y outside the
    unit disc where z would have to be rebuilt. Vectors shorter than 1e-3 in a renormalised map have no
    direction and become (0, 0, 1)."""
    if a.shape[2] != 3:
        raise ParameterError(f"map {name!r} (kind normal) has {a.shape[2]} channel(s), expected 3 (x, y, z)")
    encoding = "snorm" if a.dtype == np.float32 and float(a.min()) < 0.0 else "unorm"
    v = _decoded_normals(a, encoding)
    length = np.sqrt((v * v).sum(axis=-1))
    bad = np.abs(length - 1.0) > NORMAL_TOLERANCE
    if bad.mean() <= NORMAL_BAD_SHARE:
        return encoding, None, None
    med = float(np.median(length))
    code = 2.0 / (code_scale(a.dtype) or 1e6)  # one code step of a decoded component
    spread = np.ptp(v, axis=-1)
    if med < NORMAL_MIN_LENGTH:
        raise _refuse_normal(name, f"its vectors are near zero (median length {med:.3f})")
    if (spread <= code * 1.01).mean() >= 1.0 - NORMAL_BAD_SHARE:
        raise _refuse_normal(name, "it is a grey image (red = green = blue)")
    flat = v.reshape(-1, 3)
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = np.nan_to_num(np.corrcoef(flat[:: max(1, flat.shape[0] // 65536)].T))
    together = min(corr[0, 1], corr[0, 2], corr[1, 2])
    if together > NORMAL_MAX_CORRELATION:
        raise _refuse_normal(
            name, f"its three channels vary together, as a photo's do (every correlation >= {together:.2f})"
        )
    mx, my = float(v[..., 0].mean()), float(v[..., 1].mean())
    if max(abs(mx), abs(my)) > NORMAL_MAX_MEAN:
        raise _refuse_normal(
            name,
            f"its x and y are not centred on 0 (mean x {mx:+.2f}, mean y {my:+.2f}, read as "
            f"{'2·value − 1' if encoding == 'unorm' else 'the values themselves'})",
        )
    mz = float(np.median(v[..., 2]))
    if mz < NORMAL_MIN_Z:
        raise _refuse_normal(name, f"its z (blue) is not positive (median z {mz:+.2f})")
    outside = 100 * float(bad.mean())
    r2 = v[..., 0] ** 2 + v[..., 1] ** 2
    inside = r2 < 0.98
    ratio = v[..., 2][inside] / np.sqrt(1.0 - r2[inside])  # z against the z that x and y call for
    z_scale, z_q90 = (float(q) for q in np.quantile(ratio, (0.5, 0.9))) if ratio.size else (1.0, 1.0)
    rescaled = abs(z_scale - 1.0) > NORMAL_Z_SCALE and z_q90 <= z_scale * (1.0 + NORMAL_Z_SPREAD)
    if not rescaled:
        unit = v / np.maximum(length, 1e-300)[..., None]
        unit[length < 1e-3] = (0.0, 0.0, 1.0)
        note = (
            f"renormalised (median length {med:.3f}, {outside:.1f}% of the vectors outside 1 ± "
            f"{NORMAL_TOLERANCE}: a downscaled or filtered normal map)"
        )
        return encoding, note, unit
    if (r2 > (1.0 + NORMAL_TOLERANCE) ** 2).mean() > NORMAL_BAD_SHARE:
        raise _refuse_normal(
            name,
            f"{outside:.1f}% of its vectors have a length outside 1 ± {NORMAL_TOLERANCE} (median length "
            f"{med:.3f}) and x² + y² > 1 on {100 * float((r2 > 1.21).mean()):.1f}% of its pixels, so z cannot "
            "be rebuilt from x and y",
        )
    xy = v[..., :2] / np.maximum(np.sqrt(r2), 1.0)[..., None]
    z = np.sqrt(np.maximum(0.0, 1.0 - (xy * xy).sum(axis=-1)))
    note = (
        f"z rebuilt from x and y (median length {med:.3f}; z is {z_scale:.3f} times the z that x and y call for, "
        "on every pixel: z stored on another scale)"
    )
    return encoding, note, np.concatenate([xy, z[..., None]], axis=-1)


def _check_normal(name: str, a: np.ndarray) -> str:
    """Refuse a map that is not a unit normal map as it is; returns its encoding ("unorm" or "snorm")."""
    encoding, note, _ = inspect_normal(name, a)
    if note is not None:
        raise ParameterError(f"map {name!r} (kind normal): not unit vectors as it is (it would be {note})")
    return encoding


def check_maps(
    exemplar_shape: tuple[int, ...],
    maps: Any,
    map_kinds: Any = None,
    map_weights: Any = None,
    normal_y: Any = "up",
    suffixes: dict[str, str] | None = None,
) -> list[tuple[MapSpec, np.ndarray]]:
    """Validate the maps of a material build before any work: ``[(spec, array)]`` in the given order.

    Raises :class:`ShapeError` (not pixel-aligned), :class:`ParameterError` (bad name, duplicate name, NaN or
    infinity, unknown kind, a map that cannot be a normal map, a bad weight) or ``TypeError`` (dtype), each naming
    the map and the value.
    """
    if not isinstance(maps, dict) or not maps:
        raise ParameterError(f"maps = {type(maps).__name__}: expected a non-empty dict {{name: array}}")
    from ..cli.argtypes import normal_y_value

    normal_y = normal_y_value(normal_y)  # 'up' / '+y' (OpenGL) or 'down' / '-y' (DirectX)
    kinds = {} if map_kinds is None else map_kinds
    weights = {} if map_weights is None else map_weights
    for what, d in (("map_kinds", kinds), ("map_weights", weights)):
        if not isinstance(d, dict):
            raise ParameterError(f"{what} = {d!r}: expected a dict {{map name: value}}")
    seen: dict[str, str] = {}
    for name in maps:
        if not isinstance(name, str) or not _NAME.fullmatch(name):
            raise ParameterError(
                f"map name {name!r}: 1-64 letters, digits, '-' and '_', starting with a letter or digit"
            )
        if name.lower() == "albedo":
            raise ParameterError("map name 'albedo' is the exemplar itself; give the map another name")
        if name.lower() in seen:
            raise ParameterError(
                f"duplicate map name {name!r} (and {seen[name.lower()]!r}): map names must differ (ignoring case), "
                "since each names an output file"
            )
        seen[name.lower()] = name
    for what, d in (("map_kinds", kinds), ("map_weights", weights)):
        for key in d:
            if key not in maps and not (what == "map_weights" and key == "albedo"):
                raise ParameterError(f"{what}: {key!r} is not one of the maps ({', '.join(maps)})")
    out = []
    shape = tuple(int(v) for v in exemplar_shape[:2])
    for name, value in maps.items():
        kind = _kind(kinds[name], name) if name in kinds else infer_kind(name)
        a = _as_map_array(name, value, shape)  # type: ignore[arg-type]
        w = _weight(weights.get(name, DEFAULT_WEIGHTS[kind]), name)
        note = None
        if kind == "normal":
            encoding, note, unit = inspect_normal(name, a)
            if unit is not None:  # stored normalised, in the map's own sample type
                a = np.ascontiguousarray(encode_unit(unit, a.dtype, encoding))
        else:
            encoding = None
        suffix = str((suffixes or {}).get(name, "")).lower()
        if suffix not in (".png", ".exr", ".npy", ".tif", ".tiff"):
            suffix = ".exr" if a.dtype == np.float32 else ".png"
        spec = MapSpec(
            name,
            kind,
            w,
            str(a.dtype),
            int(a.shape[2]),
            normal_y if kind == "normal" else None,
            encoding,
            suffix,
            note,
        )
        out.append((spec, a))
    _weight(weights.get("albedo", 1.0), "albedo")
    return out


def _weight(value: Any, name: str) -> float:
    try:
        w = float(value)
    except (TypeError, ValueError):
        w = float("nan")
    if isinstance(value, bool) or not np.isfinite(w) or w < 0:
        raise ParameterError(f"map weight of {name!r} = {value!r}: expected a finite number >= 0")
    return w


def _normalised(x: np.ndarray, w: float) -> np.ndarray | None:
    """``(P, C)`` float64 centred, divided by its total standard deviation and scaled by ``sqrt(w)``; None for a
    constant map or weight 0."""
    if w == 0.0:
        return None
    x = x - x.mean(axis=0)
    s = float(np.sqrt((x * x).sum(axis=0).sum() / x.shape[0]))
    if s <= 1e-12:
        return None
    return x * (np.sqrt(w) / s)


def feature_image(
    albedo: np.ndarray,
    specs: list[tuple[MapSpec, np.ndarray]],
    albedo_weight: float = 1.0,
    channels: int = FEATURE_CHANNELS,
) -> tuple[np.ndarray, dict[str, Any]]:
    """The feature image a material is built on (module docstring, steps 1-2): float32 ``(H, W, k)`` in [0, 1],
    ``k <= channels``, and its record (channels, variance kept, the maps' weights)."""
    h, w = albedo.shape[:2]
    # Only the weights' ratios matter (the feature image is rescaled to [0, 1] at the end); huge weights
    # (--map-weight height=1e308) would overflow the squares below, so they are divided by the largest first.
    # Weights up to 1e6 are used as given (the same bytes as before).
    # A weight below 1e-12 of the largest cannot change a float64 distance; it is taken as 0 (its channels left
    # out), since a channel scaled by 1e-150 would make the later covariance inversions overflow.
    top = max([float(albedo_weight), *(float(spec.weight) for spec, _ in specs)])
    per = 1.0 / top if top > 1e6 else 1.0

    def scaled(weight: float) -> float:
        return 0.0 if weight < 1e-12 * top else weight * per

    cols = []
    a = _normalised(albedo.reshape(h * w, -1).astype(np.float64), scaled(albedo_weight))
    if a is not None:
        cols.append(a)
    for spec, arr in specs:
        if spec.kind == "normal":
            x = _decoded_normals(arr, spec.encoding or "unorm").reshape(h * w, 3)
        else:
            scale = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(arr.dtype, 1.0)
            x = arr.reshape(h * w, -1).astype(np.float64) / scale
        z = _normalised(x, scaled(spec.weight))
        if z is not None:
            cols.append(z)
    if not cols:
        raise ParameterError(
            "material: the albedo and every map are constant or have weight 0; nothing to match"
        )
    f = np.concatenate(cols, axis=1)
    total = float((f * f).sum())
    kept = 1.0
    if f.shape[1] > channels:
        # sums in numpy's own pairwise order, not BLAS (whose result may depend on its thread count): the same
        # bytes in every run and on any number of threads, as every tilesynth build
        d = f.shape[1]
        cov = np.empty((d, d))
        for i in range(d):
            for j in range(i, d):
                cov[i, j] = cov[j, i] = float((f[:, i] * f[:, j]).sum())
        vals, vecs = np.linalg.eigh(cov)
        order = np.argsort(vals)[::-1][:channels]
        vecs = vecs[:, order]
        vecs *= np.where(vecs[np.abs(vecs).argmax(axis=0), np.arange(vecs.shape[1])] < 0, -1.0, 1.0)
        proj = np.zeros((f.shape[0], vecs.shape[1]))
        for i in range(d):
            proj += f[:, i : i + 1] * vecs[i]
        f = proj
        kept = min(1.0, float(vals[order].sum() / total)) if total > 0 else 1.0
    lo, hi = float(f.min()), float(f.max())
    scale = 1.0 / (hi - lo) if hi > lo else 1.0
    feats = np.clip((f - lo) * scale, 0.0, 1.0).astype(np.float32).reshape(h, w, -1)
    record = {
        "feature_channels": int(feats.shape[2]),
        "variance_kept": kept,
        "feature_scale": scale,
        "albedo_weight": float(albedo_weight),
    }
    return np.ascontiguousarray(feats), record


def build_with_maps(
    build: Any,
    exemplar: Any,
    *,
    maps: Any,
    map_kinds: Any = None,
    map_weights: Any = None,
    normal_y: str = "up",
    map_suffixes: dict[str, str] | None = None,
    material_options: dict[str, Any] | None = None,
    **kwargs: Any,
) -> Any:
    """A material build with the scheme builder ``build`` (``Scheme.build``): the body of
    :func:`tilesynth.build_material` (which looks the scheme up; this module does not import the registry).
    ``material_options`` (``Scheme.material_options``): builder options a joint build uses unless ``kwargs``
    give them (ω, s-Wang: ``eps`` = :data:`MATERIAL_CUT_EPS`); a colour-only build (only weight-0 maps) ignores
    them."""
    from ..base.validate import as_image
    from ..synth.synthesis import is_smoothed
    from .compose import exemplar_record
    from .masking import build_mask
    from .smoothing import smooth_tiles

    albedo = as_image(exemplar, "exemplar")
    if np.may_share_memory(albedo, exemplar):
        albedo = albedo.copy()
    # The mask (an alpha channel or mask=) is resolved on the albedo here, and goes to the builder as an
    # ExemplarMask: the feature image's 4th channel is a feature, never an alpha channel.
    albedo, emask = build_mask(albedo, kwargs.pop("mask", None), kwargs.pop("alpha", "auto"))
    kwargs["mask"], kwargs["alpha"] = emask, "colour"
    specs = check_maps(albedo.shape, maps, map_kinds, map_weights, normal_y, map_suffixes)
    aw = _weight((map_weights or {}).get("albedo", 1.0), "albedo")
    joint = aw != 1.0 or any(s.weight > 0 for s, _ in specs)
    if joint:
        # with a mask the search adds a penalty channel, and the image index takes at most 4 channels
        k = FEATURE_CHANNELS - (emask is not None)
        feats, record = feature_image(albedo, specs, aw, channels=k)
        for key, value in (material_options or {}).items():  # the scheme's joint-build defaults
            kwargs.setdefault(key, value)
    else:  # only weight-0 maps (labels): the colour-only build, plus the maps
        feats, record = albedo, {"feature_channels": int(albedo.shape[2]), "variance_kept": 1.0,
                                 "feature_scale": 1.0, "albedo_weight": aw}  # fmt: skip
    info = kwargs.pop("exemplar_info", None)
    ts = build(feats, exemplar_info=info, **kwargs)
    if joint:
        src = ts.source
        tiles = albedo[src[..., 0], src[..., 1]]
        if is_smoothed(ts):
            from .matching.augment import matching_patches  # issue 12: transformed matching patches (augment)

            matching = matching_patches(albedo, ts)
            tiles, _ = smooth_tiles(tiles, matching, ts.cut_masks, threads=kwargs.get("threads"))
        ts.tiles = np.ascontiguousarray(tiles, dtype=np.float32)
        ts.exemplar = albedo
        ts.exemplar_info = exemplar_record(albedo, info)
    record = {**record, "joint": bool(joint), "units": "feature"}
    fixed = {spec.name: spec.normalised for spec, _ in specs if spec.normalised}
    if fixed:
        record["normalised"] = fixed
    ts.params = {**ts.params, "material": record}
    ts.maps = {spec.name: arr for spec, arr in specs}
    ts.map_specs = [spec.to_dict() for spec, _ in specs]
    # The level correction of the fused maps needs the whole set: solved once here and stored with the set, so
    # that a synthesis of any window fuses only the tiles it shows (synthesize_maps).
    t0 = time.perf_counter()
    ts.map_levels = map_levels(ts) or None
    if ts.map_levels:
        ts.timing = {**ts.timing, "map_levels_s": time.perf_counter() - t0}
    return ts


def convert_normal_y(a: np.ndarray, encoding: str) -> np.ndarray:
    """A normal map with its Y (green) channel flipped between OpenGL and DirectX: ``max − g`` for unsigned
    encodings (exact for uint8 / uint16), ``−g`` for signed float vectors."""
    out = np.array(a, copy=True)
    if encoding == "snorm":
        out[..., 1] = -out[..., 1]
    elif out.dtype == np.uint8:
        out[..., 1] = 255 - out[..., 1]
    elif out.dtype == np.uint16:
        out[..., 1] = 65535 - out[..., 1]
    else:
        out[..., 1] = np.float32(1.0) - out[..., 1]
    return out


def _renormalise(tiles: np.ndarray, where: np.ndarray, encoding: str) -> np.ndarray:
    """``tiles`` (K, N, N, 3) with the vectors at ``where`` (K, N, N) set to unit length (re-encoded in the
    tiles' own sample type)."""
    out = tiles.copy()
    out[where] = encode_unit(_decoded_normals(tiles[where], encoding), tiles.dtype, encoding)
    return out


def renormalise_image(a: np.ndarray, encoding: str) -> np.ndarray:
    """A normal image ``(..., 3)`` (any leading shape) with every vector set to unit length and re-encoded in
    its own sample type (:func:`tilesynth.io.normal_codes.encode_unit`; for smoothed and filtered normals: map
    atlases, mip levels, resampled atlases). Vectors shorter than 1e-3 (empty float cells) have no direction and
    are left as they are."""
    flat = np.ascontiguousarray(a).reshape(-1, 1, a.shape[-1])
    length = normal_lengths(flat[:, 0], encoding)
    return _renormalise(flat, length > 1e-3, encoding).reshape(a.shape)


#: The kinds whose maps are smoothed (blended across the seams, :func:`blended_tiles`, or fused,
#: :func:`fuse_map_atlas`: :func:`seams_method`) by default, even when the albedo is not.
SMOOTH_KINDS: tuple[str, ...] = ("scalar", "normal")


def smooths(tileset: Any, spec: MapSpec, smooth: bool | None = None) -> bool:
    """Whether map ``spec`` of ``tileset`` is smoothed (scalar and normal maps: their seams blended or fused,
    :func:`seams_method`; colour maps: the colour's Poisson smoothing): never for labels; for ``smooth=None``
    (the default) when the colour tiles were smoothed, and for every scalar and normal map (:data:`SMOOTH_KINDS`)
    of every scheme (the fusion reads only the provenance's seams, so Cohen's Wang sets, without matching patches,
    are fused too). Why the maps without the albedo: the cuts of the joint build make the maps
    agree along the cut as well as the matching allows, but a smooth map (a height field) still shows the *level*
    offset between the two patches as a cliff along the curve (measured: ``benches/materials.py``, cut seam 4-15
    as copies), while the albedo, whose pixel steps are large, hides the same offset; the seam blend spreads the
    offset over the blend's width and keeps the relief (``benches/relief-results.md``), the gradient-domain
    fusion removes it (cut seam 0.85-1.34) but flattens the relief; both keep tilings seamless.
    ``smooth=False`` gives pure copies."""
    from ..synth.synthesis import is_smoothed

    if spec.kind == "label":
        return False
    if spec.kind in SMOOTH_KINDS:  # the fusion needs only the provenance's seams: every scheme (issue 14:
        return True if smooth is None else bool(smooth)  # Wang maps' seams were 4-43 as copies, 0.9-3.3 fused
    if smooth is None:  # a colour map: as the colour tiles were
        return bool(is_smoothed(tileset))
    if smooth and (np.asarray(tileset.match_offsets) == -1).all():  # no matching patches
        raise ParameterError(
            f"map {spec.name!r}: the tile set has no matching patches (scheme {tileset.scheme!r}), so there is "
            "no smoothing to follow; use map smoothing off"
        )
    return bool(smooth)


def _scale(arr: np.ndarray) -> float | None:
    return {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(arr.dtype)


def _used(tileset: Any) -> np.ndarray:
    """bool ``(H, W)``: the exemplar pixels some tile shows (the continued steps of the fusion read only those);
    found once per set, from the provenance a chunk of tiles at a time."""
    cache = _cache(tileset)
    if "used" not in cache:
        h, w = tileset.exemplar.shape[:2]
        used = np.zeros((h, w), bool)
        for part in _chunks(tileset.n_tiles, tileset.tile_size):
            src = tile_sources(tileset, part)
            used[src[..., 0], src[..., 1]] = True
        cache["used"] = used
    return cache["used"]


def _chunks(k: int, n: int) -> list[np.ndarray]:
    from ..tileset.provenance import CHUNK_PIXELS

    step = max(1, CHUNK_PIXELS // 4 // max(1, n * n))
    return [np.arange(lo, min(k, lo + step)) for lo in range(0, k, step)]


def tile_sources(tileset: Any, tiles: np.ndarray) -> np.ndarray:
    """int32 ``(k, N, N, 2)`` provenance of the tiles ``tiles`` (indices): from ``source`` when the set holds it,
    else gathered from its provenance (a version-2 set), without materialising the other tiles."""
    if tileset.provenance is not None and not tileset.has_pixels():
        from ..tileset.provenance import coordinate_grid, materialise

        cache = _cache(tileset)
        if "grid" not in cache:
            cache["grid"] = coordinate_grid(*tileset.exemplar.shape[:2])
        return materialise(cache["grid"], tileset.provenance, tiles)
    return tileset.source[np.asarray(tiles)]


_CACHES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _cache(tileset: Any) -> dict[str, Any]:
    """The per-set cache of map synthesis (the used pixels, each map's levelled values, fused tiles): computed
    once per set, never per call; kept beside the set object (a shallow copy of a set gets its own)."""
    cache = _CACHES.get(tileset)
    if cache is None:
        cache = _CACHES[tileset] = {}
    return cache


def map_levels(tileset: Any, names: list[str] | None = None) -> dict[str, np.ndarray]:
    """The first stage of the seam treatment of every fused map (scalar and normal kinds) of ``tileset``: the
    solved block and corner levels of :func:`~tilesynth.builder.fusion.level_solution` per map, and the corner
    pixels (``"corners"``, shared by every map), as a material build stores them (:attr:`TileSet.map_levels`).
    The solve needs the whole set (every tile's provenance and copies); it is done once, at build time, and a
    synthesis of any window reads the result (:func:`synthesize_maps`)."""
    from .fusion import LEVEL_BLOCK, level_solution

    out: dict[str, np.ndarray] = {}
    for d in tileset.map_specs or []:
        spec = MapSpec.from_dict(d)
        if spec.kind not in SMOOTH_KINDS or (names is not None and spec.name not in names):
            continue
        arr = tileset.maps[spec.name]
        if arr.dtype == np.float32 and not np.isfinite(arr).all():
            continue  # not fusable (synthesize_maps refuses it with smoothing on)
        scale = _scale(arr)
        f = arr.astype(np.float64) / (scale or 1.0)
        src = tileset.source
        copies = arr[src[..., 0], src[..., 1]].astype(np.float64) / (scale or 1.0)
        x, own = level_solution(f, copies, src, _used(tileset), LEVEL_BLOCK)
        out[spec.name] = x
        out["corners"] = own
    return out


def _levelled(tileset: Any, spec: MapSpec, arr: np.ndarray) -> np.ndarray:
    """The map's values in [0, 1] float64 plus its level correction ``φ`` (the fusion's first stage), once per
    set: from the stored levels (:attr:`TileSet.map_levels`), else solved now and kept with the set."""
    from .fusion import LEVEL_BLOCK, level_field

    cache = _cache(tileset)
    key = ("levelled", spec.name)
    if (
        key not in cache or cache[key][0] is not arr
    ):  # the map itself, kept alive: a replaced map is not reused
        levels = tileset.map_levels or {}
        if spec.name not in levels:
            levels = {**levels, **map_levels(tileset, [spec.name])}
            tileset.map_levels = levels
        f = arr.astype(np.float64) / (_scale(arr) or 1.0)
        cache[key] = (arr, f + level_field(levels[spec.name], levels["corners"], f.shape, LEVEL_BLOCK))
        lru = cache.get("fused")
        for k in [k for k in (lru or {}) if len(k) == 2 and k[0] == spec.name]:
            cache["fused_bytes"] -= lru.pop(k).nbytes
    return cache[key][1]


FUSED_CACHE_BYTES = 64 << 20
"""Bytes of fused map tiles kept per set (least recently used first out): a window's tiles are fused once,
then reused by every window that shows them."""

FUSE_CHUNK = 32
"""Tiles fused at once (:func:`fused_tiles`): the solve holds about 10 float64 copies of a chunk."""


def fused_tiles(tileset: Any, spec: MapSpec, arr: np.ndarray, tiles: np.ndarray) -> np.ndarray:
    """The tiles ``tiles`` of map ``arr`` fused across their seams (:func:`fuse_map_atlas`, the same bytes) in the
    map's sample type, computed for those tiles only (the fusion of one tile reads the levelled map and that
    tile's provenance), normal maps renormalised; recently fused tiles come from the set's cache."""
    from collections import OrderedDict

    from ..synth.synthesis import check_smoothable
    from .fusion import fuse_tiles

    check_smoothable(arr)
    cache = _cache(tileset)
    lru: OrderedDict = cache.setdefault("fused", OrderedDict())
    tiles = np.asarray(tiles, np.int64).reshape(-1)
    levelled = _levelled(tileset, spec, arr)  # first: a replaced map drops its fused tiles
    missing = [int(t) for t in tiles if (spec.name, int(t)) not in lru]
    if missing:
        used = _used(tileset)
        scale = _scale(arr)
        for lo in range(0, len(missing), FUSE_CHUNK):
            part = np.array(missing[lo : lo + FUSE_CHUNK])
            src = tile_sources(tileset, part)
            fused = fuse_tiles(levelled, levelled[src[..., 0], src[..., 1]], src, used)
            if scale:
                fused = np.rint(np.clip(fused, 0.0, 1.0) * scale).astype(arr.dtype)
            else:
                fused = fused.astype(np.float32)
            if spec.kind == "normal":
                fused = renormalise_image(fused, spec.encoding or "unorm")
            for t, tile in zip(part, fused):
                lru[(spec.name, int(t))] = np.ascontiguousarray(tile)
                cache["fused_bytes"] = cache.get("fused_bytes", 0) + tile.nbytes
    out = np.stack([lru[(spec.name, int(t))] for t in tiles]) if tiles.size else np.zeros((0,) + arr.shape)
    for t in tiles:
        lru.move_to_end((spec.name, int(t)))
    while cache.get("fused_bytes", 0) > FUSED_CACHE_BYTES and len(lru) > tiles.size:
        _, old = lru.popitem(last=False)
        cache["fused_bytes"] -= old.nbytes
    return out


SEAMS: tuple[str, ...] = ("blend", "fuse")
"""How the seams of smoothed scalar and normal maps are treated (:func:`seams_method`)."""

DEFAULT_SEAMS = "blend"
"""The default seam treatment: the blend from the labels' coverage (:mod:`tilesynth.synth.seams`), which keeps the
relief (measured, ``benches/relief-results.md``: height std 0.9-1.0x of the exemplar's, cliffs at or below the
exemplar's own) where the fusion flattens it (0.2-0.8x); and it is local, so the GPU can do the same."""


def seams_method(seams: Any) -> str:
    """The seam treatment ``seams`` names: None (:data:`DEFAULT_SEAMS`), "blend" or "fuse"."""
    if seams is None:
        return DEFAULT_SEAMS
    if not isinstance(seams, str) or seams not in SEAMS:
        raise ParameterError(f"seams = {seams!r}: expected None, {' or '.join(repr(v) for v in SEAMS)}")
    return seams


def map_provenance(tileset: Any) -> Any:
    """The labels and source table the seam blend reads: the set's provenance, or for a set held as pixels the
    factorisation of its ``source`` (also for Poisson-smoothed sets, whose maps are laid out from the same
    sources), found once per set; None when some tile has more than 255 pieces (the fusion is used then)."""
    if tileset.provenance is not None:
        return tileset.provenance
    cache = _cache(tileset)
    src = tileset.source
    if "prov" not in cache or cache["prov"][0] is not src:
        from ..tileset.provenance import factorise

        cache["prov"] = (src, factorise(src))
    return cache["prov"][1]


def _blend_sources(tileset: Any, spec: MapSpec, arr: np.ndarray) -> tuple:
    """What the seam blend of a map reads, once per set: ``(codes, values, low, mu, bands)``: the map's samples
    as the copies read them (normal maps renormalised), the values blended (float64: samples over their
    maximum, a normal map's slopes), the low band's mip (or None), the map's mean, the bands for the set's tile
    size (:func:`tilesynth.synth.seams.tile_bands`)."""
    from ..synth import seams

    cache = _cache(tileset)
    key = ("blend", spec.name)
    if key not in cache or cache[key][0] is not arr:
        codes = _copied_map(tileset, spec, arr)
        bands = seams.tile_bands(seams.check_bands(None, spec.kind), tileset.tile_size)
        if spec.kind == "normal":
            values = np.ascontiguousarray(seams.normal_slopes(codes, spec.encoding or "unorm"))
        else:
            values = codes.astype(np.float64) / (_scale(arr) or 1.0)
        low = None
        if "low" in bands:  # the low band at every exemplar pixel: the kernel reads one value per entry
            split = int(bands["split"])
            grid = np.mgrid[0 : values.shape[0], 0 : values.shape[1]].transpose(1, 2, 0)
            low = np.ascontiguousarray(seams.sample_mip(seams.box_mip(values, split), split, grid))
        mu = values.reshape(-1, values.shape[2]).mean(axis=0)
        cache[key] = (arr, (codes, values, low, mu, bands))
    return cache[key][1]


def blend_windows(
    tileset: Any,
    items: list[tuple[MapSpec, np.ndarray]],
    index_map: np.ndarray,
    height: int,
    width: int,
    offset: tuple[int, int] = (0, 0),
    threads: int | None = None,
) -> dict[str, np.ndarray] | None:
    """The windows ``{name: (height, width, C)}`` of maps ``items`` (``[(spec, array)]``, all scalar or one
    normal map: the same bands) laid out by ``index_map`` at ``offset`` with their seams blended
    (:mod:`tilesynth.synth.seams`; the Rust kernel ``seam_blend``, whose oracle is
    :func:`tilesynth.synth.seams.blend_tiles`), each in its sample type. Scalar maps are blended in one call
    (their channels side by side: the weights are found once per pixel; each channel's result is the one it
    has alone). None when the set's provenance has rotated or mirrored entries (then :func:`blended_tiles`
    blends per tile in numpy)."""
    from .. import _core
    from ..io.normal_codes import encode_unit
    from ..tileset.provenance import gather

    prov = map_provenance(tileset)
    if prov is None or (prov.table[..., 0] > 0).any() or not items:
        return None
    srcs = [_blend_sources(tileset, spec, arr) for spec, arr in items]
    bands = srcs[0][4]
    if any(x[4] != bands for x in srcs):
        raise ValueError("blend_windows: the maps' bands differ; blend them apart")
    if len(srcs) == 1:
        values, low, mu = srcs[0][1:4]
    else:  # side by side, once per set
        cache = _cache(tileset)
        key = ("blend-stack", tuple(spec.name for spec, _ in items))
        ids = tuple(id(x[1]) for x in srcs)
        if key not in cache or cache[key][0] != ids:
            low = (
                None if srcs[0][2] is None else np.ascontiguousarray(np.concatenate([x[2] for x in srcs], 2))
            )
            cache[key] = (ids, np.ascontiguousarray(np.concatenate([x[1] for x in srcs], axis=2)), low,
                          np.concatenate([x[3] for x in srcs]))  # fmt: skip
        values, low, mu = cache[key][1:]
    imap = np.ascontiguousarray(index_map, dtype=np.int32)
    out = np.empty((height, width, values.shape[2]), np.float64)
    single = np.empty((height, width), np.uint8)
    lows = low if low is not None else np.zeros((1, 1, values.shape[2]))
    _core.seam_blend(
        values, lows, [float(m) for m in mu], prov.labels, prov.table, imap, offset, float(bands["high"]),
        float(bands["low"]) if low is not None else None, int(bands.get("reach", 1)), out, single, threads,
    )  # fmt: skip
    mixed = single == 0
    result = {}
    ch = 0
    for (spec, arr), (codes, vals, *_rest) in zip(items, srcs):
        part = out[..., ch : ch + vals.shape[2]]
        ch += vals.shape[2]
        img = np.empty((height, width, arr.shape[2]), arr.dtype)
        gather(codes, prov, imap, img, offset, threads=threads)  # the copies, kept where one entry weighs 1
        if spec.kind == "normal":
            sl = part[mixed]
            img[mixed] = encode_unit(np.concatenate([sl, np.ones((sl.shape[0], 1))], axis=1), arr.dtype,
                                     spec.encoding or "unorm")  # fmt: skip
        elif _scale(arr):
            img[mixed] = np.rint(np.clip(part[mixed], 0.0, 1.0) * _scale(arr)).astype(arr.dtype)
        else:
            img[mixed] = part[mixed].astype(np.float32)
        result[spec.name] = img
    return result


def blend_window(
    tileset: Any,
    spec: MapSpec,
    arr: np.ndarray,
    index_map: np.ndarray,
    height: int,
    width: int,
    offset: tuple[int, int] = (0, 0),
    threads: int | None = None,
) -> np.ndarray | None:
    """:func:`blend_windows` of one map: its window ``(height, width, C)``, or None."""
    got = blend_windows(tileset, [(spec, arr)], index_map, height, width, offset, threads)
    return None if got is None else got[spec.name]


def blended_tiles(tileset: Any, spec: MapSpec, arr: np.ndarray, tiles: np.ndarray) -> np.ndarray:
    """The tiles ``tiles`` ``(k, N, N, C)`` of map ``arr`` (scalar or normal kind) with their seams blended, in
    the map's sample type: :func:`blend_window` of a one-column index map, or for a set with rotated or
    mirrored entries :func:`tilesynth.synth.seams.blend_tiles` (numpy, the vectors turned with their entries),
    a bounded chunk of tiles at a time."""
    from ..synth.seams import blend_tiles

    n = tileset.tile_size
    idx = np.asarray(tiles, np.int64).reshape(-1)
    out = np.empty((idx.size, n, n, arr.shape[2]), arr.dtype)
    step = max(1, (1 << 20) // (n * n))  # a bounded chunk: about 1 Mi pixels per call
    for lo in range(0, idx.size, step):
        part = idx[lo : lo + step]
        got = blend_window(tileset, spec, arr, part.reshape(-1, 1), part.size * n, n)
        if got is None:
            src = _copied_map(tileset, spec, arr)
            got = blend_tiles(src, map_provenance(tileset), part, kind=spec.kind, encoding=spec.encoding or "unorm",
                              y_down=spec.normal_y == "down")  # fmt: skip
        out[lo : lo + part.size] = got.reshape(part.size, n, n, arr.shape[2])
    return out


def fuse_map_atlas(
    tileset: Any, arr: np.ndarray, atlas: np.ndarray, level: bool = True, spec: MapSpec | None = None
) -> np.ndarray:
    """The tiles ``atlas`` of map ``arr`` fused across their seams in the gradient domain, in the map's own
    sample type (:mod:`tilesynth.builder.fusion`), in two stages: ``level=True`` (the default) first adds the
    exemplar's smooth level correction (:func:`~tilesynth.builder.fusion.exemplar_levels`: every copy of an
    exemplar pixel moves alike, so tilings stay seamless and tile borders do not crease), then each tile's
    interior is fused with its border ring kept (:func:`~tilesynth.builder.fusion.fuse_tiles`); ``level=False``:
    the second stage alone (the border ring as copied, bit for bit). The continued steps across a seam only
    read exemplar pixels the tile set uses somewhere (so never a masked one).

    With rotated or mirrored matching patches (``--augment``,
    :func:`~tilesynth.builder.matching.augment.pixel_transforms`) the steps follow each patch's orientation, and
    for a normal map (``spec`` of kind normal; ``atlas`` already turned, :func:`map_atlas`) the continued steps
    are turned into the tile's frame too; the level stage is then left out for normal maps, since one level of
    an exemplar pixel would have to be turned differently in each of its copies."""
    from ..synth.synthesis import check_smoothable
    from .fusion import LEVEL_BLOCK, exemplar_levels, fuse_tiles
    from .matching.augment import pixel_transforms, transform_vectors

    check_smoothable(arr)
    src = tileset.source
    used = np.zeros(arr.shape[:2], bool)
    used[src[..., 0], src[..., 1]] = True
    turns = pixel_transforms(tileset)
    turn = None
    if turns is not None and spec is not None and spec.kind == "normal":
        y_down = spec.normal_y == "down"

        def turn(step: np.ndarray, t: np.ndarray) -> np.ndarray:
            return transform_vectors(step, t, y_down)

        level = False
    scale = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(arr.dtype)
    f = arr.astype(np.float64) / (scale or 1.0)
    copies = atlas.astype(np.float64) / (scale or 1.0)
    if level:  # the exemplar's smooth level correction first (ring included), then each tile's interior
        phi = exemplar_levels(f, copies, src, used, LEVEL_BLOCK, turns=turns)
        f = f + phi
        copies = copies + phi[src[..., 0], src[..., 1]]
    fused = fuse_tiles(f, copies, src, used, turns=turns, turn=turn)
    if scale:
        return np.ascontiguousarray(np.rint(np.clip(fused, 0.0, 1.0) * scale).astype(arr.dtype))
    return np.ascontiguousarray(fused, dtype=np.float32)


def map_atlas(
    tileset: Any,
    spec: MapSpec,
    arr: np.ndarray,
    smooth: bool | None = None,
    threads: int | None = None,
    tiles: np.ndarray | None = None,
    seams: str | None = None,
) -> np.ndarray:
    """The tiles ``(k, N, N, C)`` of one map of ``tileset`` (``tiles``: their indices; None: every tile): copied
    through the provenance, or where :func:`smooths` says so (never for labels) scalar and normal maps with
    their seams treated by ``seams`` (:func:`seams_method`: "blend", the default, :func:`blended_tiles`;
    "fuse", the gradient-domain fusion below) and colour maps Poisson-smoothed in the cut regions, normal
    vectors renormalised. With ``seams="fuse"`` scalar and normal maps are fused for the tiles
    asked only (:func:`fused_tiles`, the bytes of :func:`fuse_map_atlas`); a colour map of a Poisson-smoothed set
    needs the whole set. The vectors of a normal map are turned with their pixels where a matching patch was
    rotated or mirrored (``--augment``: :func:`~tilesynth.builder.matching.augment.transform_normal_codes`, exact
    in the map's sample type), so a bump keeps its light side; such sets take the whole-set path, whose fusion
    follows each patch's orientation (the per-tile path does not turn steps)."""
    from ..synth.synthesis import _smooth_map_atlas
    from .matching.augment import pixel_transforms, transform_normal_codes

    idx = np.arange(tileset.n_tiles) if tiles is None else np.asarray(tiles, np.int64).reshape(-1)
    if (
        spec.kind in SMOOTH_KINDS
        and smooths(tileset, spec, smooth)
        and seams_method(seams) == "blend"
        and map_provenance(tileset) is not None
    ):  # the default: the seam blend from the labels (rotated or mirrored entries are turned by the blend)
        return blended_tiles(tileset, spec, arr, idx)
    turns = pixel_transforms(tileset)
    if turns is not None:  # rotated or mirrored patches: every step and vector turns with its patch
        src = tileset.source
        atlas = np.ascontiguousarray(arr[src[..., 0], src[..., 1]])
        if spec.kind == "normal":
            atlas = transform_normal_codes(atlas, turns, spec.encoding or "unorm", spec.normal_y == "down")
        if smooths(tileset, spec, smooth):
            if spec.kind in SMOOTH_KINDS:
                atlas = fuse_map_atlas(tileset, arr, atlas, spec=spec)
            else:  # colour maps follow the colour's own smoothing
                atlas = _smooth_map_atlas(tileset, arr, atlas, threads)
        atlas = atlas if tiles is None else atlas[idx]
    elif smooths(tileset, spec, smooth):
        if spec.kind in SMOOTH_KINDS:
            return fused_tiles(tileset, spec, arr, idx)
        src = tileset.source  # colour maps follow the colour's own smoothing (version-1 sets only)
        atlas = _smooth_map_atlas(tileset, arr, np.ascontiguousarray(arr[src[..., 0], src[..., 1]]), threads)
        atlas = atlas if tiles is None else atlas[idx]
    else:  # copies: of the map with its vectors renormalised once per set (a per-vector operation)
        src = tile_sources(tileset, idx)
        return np.ascontiguousarray(_copied_map(tileset, spec, arr)[src[..., 0], src[..., 1]])
    if spec.kind == "normal":  # every vector, copies too: unit length after decoding (normal_codes)
        atlas = renormalise_image(atlas, spec.encoding or "unorm")
    return atlas


def _copied_map(tileset: Any, spec: MapSpec, arr: np.ndarray) -> np.ndarray:
    """What the copies of a map read: the map itself, or for a normal map the map with every vector renormalised
    (:func:`renormalise_image`, the same bytes as renormalising the copies), once per set."""
    if spec.kind != "normal":
        return arr
    cache = _cache(tileset)
    key = ("unit", spec.name)
    if key not in cache or cache[key][0] is not arr:
        cache[key] = (arr, np.ascontiguousarray(renormalise_image(arr, spec.encoding or "unorm")))
    return cache[key][1]


def _turned(tileset: Any) -> bool:
    """Whether some matching patch of ``tileset`` was rotated or mirrored (``--augment``): the copies of a normal
    map must then turn their vectors, which the provenance gather does not do (:func:`map_atlas` does)."""
    return any(t != 0 for t in (tileset.params.get("match_transforms") or []))


def synthesize_maps(
    tileset: Any,
    index_map: np.ndarray,
    width: int,
    height: int,
    *,
    threads: int | None = None,
    smooth: bool | None = None,
    normal_y: str | None = None,
    offset: tuple[int, int] = (0, 0),
    seams: str | None = None,
) -> dict[str, np.ndarray]:
    """Every map stored in a material tile set, laid out like the colour output of ``index_map``:
    ``{name: (height, width, C)}`` in each map's own sample type. ``smooth``: None (:func:`smooths`: scalar and
    normal maps, and every map of a smoothed set), True or False (labels are never smoothed); ``normal_y``: "up" / "down" converts normal maps recorded in the other
    convention (None: as recorded); ``offset = (oy, ox)``: the window starts that many pixels into the first
    cell of ``index_map`` (as :func:`tilesynth.synthesize` lays a window at any ``origin``); ``seams``: how the
    seams of smoothed scalar and normal maps are treated (:func:`seams_method`): "blend" (None, the default:
    :mod:`tilesynth.synth.seams`, relief kept) or "fuse" (the gradient-domain fusion, flatter).

    **Per window.** Only the pixels the window shows are made: copied maps are gathered from the map through the
    provenance (:func:`tilesynth.tileset.provenance.gather`), blended maps are blended straight into the window
    (:func:`blend_window`, the Rust kernel ``seam_blend``), fused maps are fused for the tiles shown (the level
    correction is solved once per set, at build time, :func:`map_levels`; recently fused tiles are cached with
    the set, :data:`FUSED_CACHE_BYTES`). The bytes are those of laying out the whole set's map atlas."""
    from .. import _core
    from ..base import kernels
    from ..base.validate import MAX_BYTES_ENV, fmt_bytes, memory_limit, positive_int, threads_arg
    from ..tileset.tilefile import TileSet

    if not isinstance(tileset, TileSet):
        raise TypeError(f"tileset is a {type(tileset).__name__}, expected a TileSet")
    if normal_y not in (None, "up", "down"):
        raise ParameterError(f"normal_y = {normal_y!r}: must be None, 'up' or 'down'")
    if smooth is not None and not isinstance(smooth, (bool, np.bool_)):
        raise ParameterError(f"smooth = {smooth!r}: must be None, True or False")
    seams = seams_method(seams)
    threads = threads_arg(threads)
    w, h = positive_int(width, "width"), positive_int(height, "height")
    specs = tileset.map_specs or []
    need = sum(h * w * int(d["channels"]) * np.dtype(d["dtype"]).itemsize for d in specs)
    if need > memory_limit(None):
        raise ParameterError(
            f"width x height = {w}x{h}: the maps need {fmt_bytes(need)}, more than the limit of "
            f"{fmt_bytes(memory_limit(None))} ({MAX_BYTES_ENV})"
        )
    imap = kernels._index_map(index_map)
    n = tileset.tile_size
    try:
        oy, ox = (int(v) for v in offset)
    except (TypeError, ValueError):
        raise ParameterError(f"offset = {offset!r}: expected (oy, ox) pixels into the first cell") from None
    if not (0 <= oy < n and 0 <= ox < n):
        raise ParameterError(f"offset = {offset!r}: each must be in [0, {n}) (the tile size)")
    if imap.ndim != 2 or imap.shape[0] * n < h + oy or imap.shape[1] * n < w + ox:
        raise ShapeError(
            f"index_map has shape {imap.shape}, expected at least ({-(-(h + oy) // n)}, {-(-(w + ox) // n)}) to "
            f"cover {w}x{h} pixels with {n}x{n} tiles"
        )
    if imap.size and (imap.min() < 0 or imap.max() >= tileset.n_tiles):
        raise ParameterError(f"index_map has tile indices outside [0, {tileset.n_tiles})")
    imap = np.ascontiguousarray(imap[: -(-(h + oy) // n), : -(-(w + ox) // n)], dtype=np.int32)
    shown = np.unique(imap)  # the tiles of the window: the only ones made
    local = np.ascontiguousarray(np.searchsorted(shown, imap), dtype=np.int32)
    prov = tileset.provenance
    out = {}
    # blended maps straight into the window: the scalar ones in one call, each normal map alone
    blend = [MapSpec.from_dict(d) for d in specs]
    blend = [s for s in blend if s.kind in SMOOTH_KINDS and smooths(tileset, s, smooth) and seams == "blend"]
    groups = [[s for s in blend if s.kind == "scalar"]] + [[s] for s in blend if s.kind == "normal"]
    windows: dict[str, np.ndarray] = {}
    for group in groups:
        if group:
            items = [(s, tileset.maps[s.name]) for s in group]
            windows.update(blend_windows(tileset, items, imap, h, w, (oy, ox), threads) or {})
    for d in specs:
        spec = MapSpec.from_dict(d)
        arr = tileset.maps[spec.name]
        img = np.empty((h, w, arr.shape[2]), arr.dtype)
        if spec.name in windows:
            img = windows[spec.name]
        elif (
            prov is not None
            and not smooths(tileset, spec, smooth)
            and not (spec.kind == "normal" and _turned(tileset))
        ):
            from ..tileset.provenance import gather

            gather(_copied_map(tileset, spec, arr), prov, imap, img, (oy, ox), threads=threads)  # copies
        else:
            atlas = np.ascontiguousarray(
                map_atlas(tileset, spec, arr, smooth, threads, tiles=shown, seams=seams)
            )
            _core.tile_copy_window(atlas, local, (oy, ox), img, threads)
        if spec.kind == "normal" and normal_y is not None and normal_y != spec.normal_y:
            img = convert_normal_y(img, spec.encoding or "unorm")
        out[spec.name] = img
    return out


def _float_atlas(tileset: Any, spec: MapSpec, atlas: np.ndarray) -> np.ndarray:
    """A map's tiles as float64 for measuring (normals decoded to vectors, uint scaled to [0, 1])."""
    if spec.kind == "normal":
        return _decoded_normals(atlas, spec.encoding or "unorm")
    scale = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(atlas.dtype, 1.0)
    return atlas.astype(np.float64) / scale


def map_cut_seams(tileset: Any, smooth: bool | None = None) -> dict[str, float | None]:
    """The cut seam score (:func:`tilesynth.measure.metrics.cut_seam_score`) of every stored map of ``tileset``, on its
    tiles as :func:`synthesize_maps` lays them out (normals as vectors): ``{name: score or None}``."""
    from types import SimpleNamespace

    from ..measure.metrics import cut_seam_score

    out: dict[str, float | None] = {}
    for d in getattr(tileset, "map_specs", None) or []:
        spec = MapSpec.from_dict(d)
        atlas = map_atlas(tileset, spec, tileset.maps[spec.name], smooth)
        cs = cut_seam_score(
            SimpleNamespace(tiles=_float_atlas(tileset, spec, atlas), cut_masks=tileset.cut_masks)
        )
        out[spec.name] = None if cs is None else cs["score"]
    return out


def report_maps(
    tileset: Any, index_map: np.ndarray, shape: tuple[int, ...]
) -> list[tuple[str, np.ndarray, str]]:
    """For ``tilesynth report``: ``[(map name, displayable image, caption)]`` of every stored map, laid out
    like the report's sample (float maps scaled to [0, 1] for display), captions with each map's cut seam."""
    maps = synthesize_maps(tileset, index_map, int(shape[1]), int(shape[0]))
    seams = map_cut_seams(tileset)
    out = []
    for d in tileset.map_specs or []:
        a = maps[d["name"]]
        if a.dtype == np.float32:
            lo, hi = float(a.min()), float(a.max())
            a = ((a - lo) / (hi - lo) if hi > lo else np.zeros_like(a)).astype(np.float32)
        if a.shape[2] == 2:
            a = np.concatenate([a, np.zeros_like(a[..., :1])], axis=2)
        s = seams[d["name"]]
        caption = (
            f"Map {d['name']} ({d['kind']}, weight {d['weight']:g}), laid out through the same cuts as the sample; "
            f"cut seam score {'n/a' if s is None else format(s, '.3f')} (≈ 1: the cuts do not show in it)."
        )
        out.append((d["name"], a, caption))
    return out


def _with_normal_encoding(name: str, a: np.ndarray) -> str | None:
    """The encoding of a ``synth --with`` map if its name says it is a normal map and it is one, else None."""
    if infer_kind(name) != "normal" or a.ndim != 3 or a.shape[2] != 3:
        return None
    try:
        return _check_normal(name, a)
    except ParameterError:
        return None  # not unit vectors: not ours to change


def requantise_with_map(name: str, aligned: np.ndarray) -> np.ndarray:
    """For ``synth --with``: a map whose name says it is a normal map (:func:`infer_kind`), with 3 channels and
    unit vectors, with every vector re-encoded at unit length (:mod:`tilesynth.io.normal_codes`) before it is sent
    through the cuts, so that its copied pixels are within 1 ± 0.005 too; any other map is returned as it is."""
    a = np.asarray(aligned)
    encoding = _with_normal_encoding(name, a)
    return a if encoding is None else renormalise_image(a, encoding)


def turn_with_tiles(tileset: Any, name: str, aligned: np.ndarray, tiles: np.ndarray) -> np.ndarray:
    """For ``synth --with`` / ``export --with``: the tiles ``(K, N, N, 3)`` of a map whose name says it is a normal
    map (3 channels, unit vectors, +y up) with its vectors turned where a matching patch was rotated or mirrored
    (``--augment``, :func:`map_atlas`); any other map, or a set without turned patches, as it is."""
    from .matching.augment import pixel_transforms, transform_normal_codes

    encoding = _with_normal_encoding(name, np.asarray(aligned))
    turns = None if encoding is None else pixel_transforms(tileset)
    if turns is None or tiles.shape[-1] != 3:
        return tiles
    return transform_normal_codes(tiles, turns, encoding)


def turn_with_map(
    tileset: Any, name: str, aligned: np.ndarray, out: np.ndarray, index_map: np.ndarray
) -> np.ndarray:
    """:func:`turn_with_tiles` for a synthesized ``--with`` map ``out`` laid out by ``index_map``."""
    from ..base import kernels
    from .matching.augment import pixel_transforms, transform_normal_codes

    encoding = _with_normal_encoding(name, np.asarray(aligned))
    turns = None if encoding is None else pixel_transforms(tileset)
    if turns is None or out.shape[2] != 3:
        return out
    img = np.empty((*out.shape[:2], 1), np.uint8)
    kernels.tile_copy(np.ascontiguousarray(turns[..., None]), kernels._index_map(index_map), img)
    return transform_normal_codes(out, img[..., 0], encoding)


def renormalise_with_map(
    tileset: Any, name: str, aligned: np.ndarray, out: np.ndarray, index_map: np.ndarray
) -> np.ndarray:
    """For ``synth --with``: a smoothed map whose name says it is a normal map (:func:`infer_kind`), with 3
    channels and unit vectors, gets its smoothed output vectors renormalised (the pixels inside the cuts);
    any other map is returned as it is."""
    from ..base import kernels

    a = np.asarray(aligned)
    encoding = _with_normal_encoding(name, a)
    if encoding is None or out.shape[2] != 3:
        return out
    masks = np.ascontiguousarray(np.asarray(tileset.cut_masks, np.uint8)[..., None])
    inside = np.empty((*out.shape[:2], 1), np.uint8)
    kernels.tile_copy(masks, kernels._index_map(index_map), inside)
    return _renormalise(out[None], inside[None, ..., 0] == 1, encoding)[0]
