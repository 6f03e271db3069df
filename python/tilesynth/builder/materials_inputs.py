"""The inputs of a material build (:mod:`tilesynth.builder.materials`): map kinds and :class:`MapSpec`, the
checks of the maps (:func:`check_maps`, :func:`inspect_normal`), the normalisation of normal maps and the feature
image the scheme is built on."""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ParameterError, ShapeError
from ..io.normal_codes import code_scale, encode_unit

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
