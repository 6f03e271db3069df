"""Material builds and masks in batch files: the job / preset keys ``mask``, ``alpha``, ``normal_y`` and
the table form of ``maps`` entries (:mod:`tilesynth.cli.batch`).

.. code-block:: toml

    [[jobs]]
    exemplar = "rock/*-albedo.png"
    name = "rock/{stem}"
    mask = "rock/{stem}-mask.png"              # white = never used (as tilesynth build --mask)
    alpha = "mask"                             # auto | mask | colour (as --alpha; default auto)
    normal_y = "up"                            # up | down: the Y convention of the normal maps (as --normal-y)
    maps.normal = { file = "rock/{stem}-normal.png", kind = "normal", weight = 0.5 }   # --map normal:normal=...
    maps.height = { file = "rock/{stem}-height.png", weight = 1 }                      # kind from the name
    maps.ao = "rock/{stem}-ao.png"             # a plain string: sent through the cuts afterwards (--with)

A ``maps`` entry given as a **table** is a map of the material: it takes part in matching and cutting
(``tilesynth build --map NAME[:KIND]=FILE --map-weight NAME=W``), the tile set stores it, and every preview with
``maps = true`` writes it (``NAME-preview-<map>.png``, ``.npy`` for a float ``.npy`` map, ``.exr`` for an EXR one)
through the same cuts, smoothed by the rules of :func:`tilesynth.builder.materials.smooths`; the engine export writes
its atlas. Keys: ``file`` (required; relative to the batch file, ``{stem}`` filled in), ``kind`` (colour, scalar,
normal, label, or their aliases; default: inferred from the name, :func:`tilesynth.builder.materials.infer_kind`),
``weight`` (a number >= 0; default :data:`tilesynth.builder.materials.DEFAULT_WEIGHTS`). A ``maps`` entry given as a
**string** keeps its old meaning: a map sent through the colour's cuts afterwards (``synth --with``), its
smoothing chosen by ``map_kinds``. ``map_kinds`` cannot name a material map (its kind says how it is smoothed),
``normal_y`` needs a material map of kind normal, ``mask`` names a file (``{stem}`` filled in) and is hashed into the
job's key by content like the exemplar. Every value is checked before any work, with the job and the field named;
the maps' alignment with the exemplar, their values (NaN, normals far from unit length) and the mask's coverage
are checked when the job runs (its error is recorded, the batch goes on), exactly as ``tilesynth build`` checks
them; ``tilesynth batch --dry-run`` runs the same checks on every job it would build.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ...errors import ParameterError
from ...io.images import check_input_file

__all__ = [
    "ALPHA_CHOICES",
    "MATERIAL_KEYS",
    "build_keywords",
    "params",
    "parse_material_keys",
    "split_maps",
    "write_previews",
]

#: The job / preset keys of this module (``maps`` itself belongs to jobs).
MATERIAL_KEYS = ("mask", "alpha", "normal_y")
ALPHA_CHOICES = ("auto", "mask", "colour")
_MAP_TABLE_KEYS = ("file", "kind", "weight")


def _err(msg: str) -> Exception:
    return ParameterError(
        msg
    )  # tilesynth.cli.batch raises it again as its BatchError (this module never imports it)


def _fill(value: str, stem: str, where: str) -> str:
    try:
        return value.format(stem=stem)
    except (KeyError, IndexError, ValueError, AttributeError) as exc:
        raise _err(f"{where} = {value!r}: bad placeholder ({exc}); only {{stem}} exists") from None


def split_maps(maps_raw: dict[str, Any], where: str) -> tuple[dict[str, Any], dict[str, dict[str, Any]]]:
    """The ``maps`` table of a job split into the ``--with`` maps (strings, returned as they are) and the material
    maps (tables, checked: keys, kind, weight, name)."""
    from ...builder.materials import _NAME, DEFAULT_WEIGHTS, _kind, _weight, infer_kind

    plain: dict[str, Any] = {}
    material: dict[str, dict[str, Any]] = {}
    seen: dict[str, str] = {}
    for name, value in maps_raw.items():
        wm = f"{where}: field 'maps' entry {name!r}"
        if str(name).lower() in seen:
            raise _err(
                f"{wm}: duplicate map name (and {seen[str(name).lower()]!r}; names differ ignoring case)"
            )
        seen[str(name).lower()] = str(name)
        if not isinstance(value, dict):
            plain[name] = value
            continue
        if not _NAME.fullmatch(str(name)) or str(name).lower() == "albedo":
            raise _err(
                f"{wm}: a material map's name is 1-64 letters, digits, '-' and '_', starting with a letter or "
                "digit, and not 'albedo' (the exemplar itself)"
            )
        unknown = sorted(set(value) - set(_MAP_TABLE_KEYS))
        if unknown:
            raise _err(
                f"{wm}: unknown key(s) {', '.join(map(repr, unknown))} (known: {', '.join(_MAP_TABLE_KEYS)})"
            )
        if not isinstance(value.get("file"), str) or not value["file"]:
            raise _err(f"{wm}: key 'file' is missing or not a string (the map's path, relative to the file)")
        if "weight" in value and (
            isinstance(value["weight"], bool) or not isinstance(value["weight"], (int, float))
        ):
            raise _err(f"{wm}: key 'weight' = {value['weight']!r}: expected a number >= 0")
        try:
            kind = _kind(value["kind"], name) if "kind" in value else infer_kind(name)
            weight = _weight(value.get("weight", DEFAULT_WEIGHTS[kind]), name)
        except ParameterError as exc:
            raise _err(f"{wm}: {exc}") from None
        material[name] = {"file": value["file"], "kind": kind, "weight": weight}
    return plain, material


def parse_material_keys(
    merged: dict[str, Any],
    material_raw: dict[str, dict[str, Any]],
    kinds: dict[str, Any],
    stem: str,
    base: Path,
    where: str,
) -> dict[str, Any]:
    """The material part of one expanded job: ``{"material": {name: {path, kind, weight}}, "mask": Path | None,
    "alpha": str | None, "normal_y": str | None}`` (``None``: not given), every value checked."""
    alpha = merged.get("alpha")
    if alpha is not None and alpha not in ALPHA_CHOICES:
        raise _err(f"{where}: field 'alpha' = {alpha!r}: expected one of {', '.join(ALPHA_CHOICES)}")
    normal_y = merged.get("normal_y")
    if normal_y is not None and normal_y not in ("up", "down"):
        raise _err(f"{where}: field 'normal_y' = {normal_y!r}: expected 'up' (OpenGL) or 'down' (DirectX)")
    if normal_y is not None and not any(m["kind"] == "normal" for m in material_raw.values()):
        raise _err(
            f"{where}: field 'normal_y': only used with a material map of kind normal (a 'maps' entry "
            '{ file = ..., kind = "normal" })'
        )
    for name in kinds:
        if name in material_raw:
            raise _err(
                f"{where}: field 'map_kinds' entry {name!r}: {name!r} is a material map (a table in 'maps'); "
                "its kind decides how it is smoothed"
            )
    mask = None
    if merged.get("mask") is not None:
        if not isinstance(merged["mask"], str) or not merged["mask"]:
            raise _err(f"{where}: field 'mask' = {merged['mask']!r}: expected a file path")
        rel = _fill(merged["mask"], stem, f"{where}: field 'mask'")
        mask = (base / rel).resolve()
        _check_file(mask, f"{where}: field 'mask' = {rel!r}")
    material: dict[str, dict[str, Any]] = {}
    for name, m in material_raw.items():
        wm = f"{where}: field 'maps' entry {name!r} key 'file'"
        rel = _fill(m["file"], stem, wm)
        path = (base / rel).resolve()
        _check_file(path, f"{wm} = {rel!r}")
        material[name] = {"path": path, "kind": m["kind"], "weight": m["weight"]}
    return {"material": material, "mask": mask, "alpha": alpha, "normal_y": normal_y}


def params(
    material: dict[str, dict[str, Any]], mask: Path | None, alpha: str | None, normal_y: str | None
) -> dict:
    """The job parameters these keys add (hashed into the key; empty when none is given, so that the keys of
    jobs without them are unchanged)."""
    out: dict[str, Any] = {}
    if material:
        out["material_maps"] = {
            k: {"kind": m["kind"], "weight": m["weight"]} for k, m in sorted(material.items())
        }
        out["normal_y"] = normal_y or "up"
    if mask is not None:
        out["mask"] = True
    if alpha is not None:
        out["alpha"] = alpha
    return out


def build_keywords(spec: dict[str, Any]) -> dict[str, Any]:
    """The builder keywords of a job's material maps, mask and alpha (the maps loaded), as ``tilesynth build``
    passes them."""
    from ...io.images import load_raster

    kw: dict[str, Any] = {}
    mat = spec.get("material") or {}
    if mat:
        maps = {}
        for name, m in mat.items():
            try:
                maps[name] = load_raster(m["path"])
            except ParameterError as exc:
                raise ParameterError(f"material map {name!r} = {m['path']!r}: {exc}") from None
        kw.update(
            maps=maps,
            map_kinds={k: m["kind"] for k, m in mat.items()},
            map_weights={k: m["weight"] for k, m in mat.items()},
            normal_y=spec.get("normal_y") or "up",
            map_suffixes={k: Path(m["path"]).suffix.lower() or ".png" for k, m in mat.items()},
        )
    if spec.get("mask") is not None:
        kw["mask"] = spec["mask"]
    if spec.get("alpha") is not None:
        kw["alpha"] = spec["alpha"]
    return kw


def write_previews(
    ts: Any, staged: dict[str, Path], role: str, imap: Any, size: tuple[int, int], threads: Any
) -> None:
    """The stored maps of a material set for one preview (``synth``'s outputs of them)."""
    import numpy as np

    from ...builder.materials import synthesize_maps
    from ...io.images import atomic_open, save_image

    if not getattr(ts, "map_specs", None):
        return
    outs = synthesize_maps(ts, imap, size[0], size[1], threads=threads)
    for name, arr in outs.items():
        target = staged.get(f"{role}-{name}")
        if target is None:
            continue
        if target.suffix == ".npy":
            with atomic_open(target) as fh:
                np.save(fh, arr, allow_pickle=False)
        else:
            save_image(target, arr)


def _check_file(path: Path, where: str) -> None:
    """The one input-file check (:func:`~tilesynth.io.images.check_input_file`: missing, a folder, or a FIFO or
    device, each said as what it is), as a batch error with the resolved path."""
    try:
        check_input_file(path, where)
    except ParameterError as exc:
        raise _err(f"{exc} ({path})") from None
