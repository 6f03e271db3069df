"""The small declarative validator of :mod:`tilesynth.tileset.manifest` (why not ``jsonschema``: see there):
schema nodes for integers, numbers, strings, booleans, null, unions, lists, objects and maps, each failing with
:class:`~tilesynth.errors.TileSetFormatError` naming the ``manifest.json`` field."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from ..errors import TileSetFormatError

#: Integers in the manifest must fit an int64 (shapes, seeds, offsets, counts).
INT_MAX = (1 << 63) - 1
#: Floats must convert to a finite Python float (a JSON integer of 400 digits does not).
FLOAT_MAX = 1.7976931348623157e308


class Schema:
    """A node of the schema: ``check(value, where)`` raises :class:`TileSetFormatError` or returns."""

    def describe(self) -> str:
        raise NotImplementedError

    def check(self, value: Any, where: str) -> None:
        raise NotImplementedError


def _fail(where: str, value: Any, expected: str) -> None:
    shown = repr(value)
    if len(shown) > 60:
        shown = shown[:57] + "..."
    raise TileSetFormatError(f"manifest.json field {where} = {shown}: expected {expected}")


@dataclass(frozen=True)
class Int(Schema):
    lo: int = -INT_MAX
    hi: int = INT_MAX

    def describe(self) -> str:
        return f"an integer in [{self.lo}, {self.hi}]"

    def check(self, value: Any, where: str) -> None:
        if type(value) is not int or not self.lo <= value <= self.hi:
            _fail(where, value, self.describe())


@dataclass(frozen=True)
class Num(Schema):
    """A finite number (int or float) in [lo, hi]; ``nan_ok`` also accepts NaN (written for "no value")."""

    lo: float = -FLOAT_MAX
    hi: float = FLOAT_MAX
    nan_ok: bool = False

    def describe(self) -> str:
        return f"a finite number in [{self.lo:g}, {self.hi:g}]" + (" or NaN" if self.nan_ok else "")

    def check(self, value: Any, where: str) -> None:
        if type(value) not in (int, float) or (type(value) is int and abs(value) > INT_MAX):
            # integers must fit an int64 even where a float is meant (numpy refuses larger Python ints)
            _fail(where, value, self.describe())
        try:
            f = float(value)
        except OverflowError:
            _fail(where, value, self.describe())
        if math.isnan(f) and self.nan_ok:
            return
        if not math.isfinite(f) or not self.lo <= f <= self.hi:
            _fail(where, value, self.describe())


@dataclass(frozen=True)
class Str(Schema):
    enum: tuple[str, ...] | None = None
    max_len: int = 4096

    def describe(self) -> str:
        return f"one of {', '.join(map(repr, self.enum))}" if self.enum else "a string"

    def check(self, value: Any, where: str) -> None:
        if not isinstance(value, str) or len(value) > self.max_len or (self.enum and value not in self.enum):
            _fail(where, value, self.describe())


@dataclass(frozen=True)
class Bool(Schema):
    def describe(self) -> str:
        return "true or false"

    def check(self, value: Any, where: str) -> None:
        if not isinstance(value, bool):
            _fail(where, value, self.describe())


@dataclass(frozen=True)
class Null(Schema):
    def describe(self) -> str:
        return "null"

    def check(self, value: Any, where: str) -> None:
        if value is not None:
            _fail(where, value, "null")


@dataclass(frozen=True)
class AnyOf(Schema):
    options: tuple[Schema, ...]

    def describe(self) -> str:
        return " or ".join(o.describe() for o in self.options)

    def check(self, value: Any, where: str) -> None:
        errors = []
        for o in self.options:
            try:
                o.check(value, where)
                return
            except TileSetFormatError as exc:
                errors.append((o, exc))
        # an object or a list of the right kind but wrong content: the inner message names the inner field
        for o, exc in errors:
            if (isinstance(o, (Obj, Map)) and isinstance(value, dict)) or (
                isinstance(o, List) and isinstance(value, list)
            ):
                raise exc
        _fail(where, value, self.describe())


def Optional(s: Schema) -> Schema:
    return AnyOf((Null(), s))


@dataclass(frozen=True)
class List(Schema):
    item: Schema
    min_len: int = 0
    max_len: int = 1 << 24
    length: int | None = None

    def describe(self) -> str:
        n = f"of {self.length} " if self.length is not None else ""
        return f"a list {n}of {self.item.describe()}"

    def check(self, value: Any, where: str) -> None:
        if not isinstance(value, list):
            _fail(where, value, self.describe())
        if self.length is not None and len(value) != self.length:
            _fail(where, value, self.describe())
        if not self.min_len <= len(value) <= self.max_len:
            _fail(where, value, f"{self.describe()} with {self.min_len} to {self.max_len} items")
        for k, v in enumerate(value):
            self.item.check(v, f"{where}[{k}]")


@dataclass(frozen=True)
class Obj(Schema):
    """An object; ``required`` and ``optional`` map keys to schemas; other keys: ``extra`` (None = any value)."""

    required: Mapping[str, Schema] = field(default_factory=dict)
    optional: Mapping[str, Schema] = field(default_factory=dict)
    extra: Schema | None = None

    def describe(self) -> str:
        return "an object"

    def check(self, value: Any, where: str) -> None:
        if not isinstance(value, dict):
            _fail(where, value, "an object")
        for k, s in self.required.items():
            if k not in value:
                raise TileSetFormatError(f"manifest.json field {where}.{k}: missing")
            s.check(value[k], f"{where}.{k}")
        for k, s in self.optional.items():
            if k in value:
                s.check(value[k], f"{where}.{k}")
        if self.extra is not None:
            for k, v in value.items():
                if k not in self.required and k not in self.optional:
                    self.extra.check(v, f"{where}.{k}")


@dataclass(frozen=True)
class Map(Schema):
    """An object whose keys are free and whose values all follow ``value``."""

    value: Schema

    def describe(self) -> str:
        return f"an object of {self.value.describe()}"

    def check(self, value: Any, where: str) -> None:
        if not isinstance(value, dict):
            _fail(where, value, self.describe())
        for k, v in value.items():
            self.value.check(v, f"{where}.{k}")
