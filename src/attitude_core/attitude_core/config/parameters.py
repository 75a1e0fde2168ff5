"""Parameters as data: one :class:`Param` row per parameter drives validation, error
messages and the ROS 2 descriptor (in the style of ``generate_parameter_library``).

A row holds the dotted key, the value kind, the default (:data:`REQUIRED` when there
is none), a description, numeric :class:`Bounds` or string ``choices``, an optional
extra check and the read-only flag. :func:`convert` turns a raw value (from YAML or
from rclpy) into the typed value or raises :class:`ParameterError` naming the key and
the reason. ``attitude_ros.params`` declares the same rows on a node.

Types are strict because ROS 2 parameters are strongly typed: a float must be written
as a YAML float (``10.0``, not ``10``); NaN and infinity are refused.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any, NamedTuple, TypeVar, get_type_hints

import numpy as np

from attitude_core.models.mrp import to_principal

__all__ = [
    "ParameterError",
    "NodeParameterError",
    "REQUIRED",
    "Bounds",
    "ByVariant",
    "Param",
    "ParamKind",
    "ROS_TYPES",
    "convert",
    "type_name",
    "dotted_fields",
    "typed_values",
]

_NAME_RE = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")
UNIT_TOLERANCE = 0.05


class ParameterError(ValueError):
    """An invalid parameter; ``key`` is the dotted name (None for file-level errors)."""

    def __init__(self, source: str, key: str | None, reason: str) -> None:
        self.source, self.key, self.reason = str(source), key, reason
        where = f"{self.source}: {key}: " if key is not None else f"{self.source}: "
        super().__init__(where + reason)


class NodeParameterError(ParameterError):
    """An invalid node-own parameter (not a scenario key), e.g. the simulator's time mode."""


class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED: Any = _Required()
"""Default of a row that has none: the value must be given."""


class ByVariant(NamedTuple):
    """A default that depends on ``planner.variant``."""

    improved: Any
    paper: Any


def _num(x: float | None) -> str:
    """A bound as written: integers in full, floats to 15 significant digits."""
    return str(x) if isinstance(x, int) else f"{x:.15g}"


@dataclass(frozen=True)
class Bounds:
    """Numeric bounds; ``None`` is unbounded on that side."""

    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False

    def text(self) -> str:
        if self.lo is None and self.hi is None:
            return "any value"
        if self.hi is None:
            return f"{'>' if self.lo_open else '>='} {_num(self.lo)}"
        if self.lo is None:
            return f"{'<' if self.hi_open else '<='} {_num(self.hi)}"
        return (
            f"{'(' if self.lo_open else '['}{_num(self.lo)}, {_num(self.hi)}"
            f"{')' if self.hi_open else ']'}"
        )

    def check(self, x: float) -> str | None:
        ok_lo = self.lo is None or (x > self.lo if self.lo_open else x >= self.lo)
        ok_hi = self.hi is None or (x < self.hi if self.hi_open else x <= self.hi)
        if ok_lo and ok_hi:
            return None
        if self.lo is not None and self.hi is not None:
            return f"must be in {self.text()}, got {x!r}"
        return f"must be {self.text()}, got {x!r}"

    def closed(self) -> tuple[float, float] | None:
        """The closed range for a ROS descriptor (both sides bounded), else None."""
        if self.lo is None or self.hi is None:
            return None
        return (self.lo, self.hi)


def gt(lo: float) -> Bounds:
    return Bounds(lo=lo, lo_open=True)


def ge(lo: float) -> Bounds:
    return Bounds(lo=lo)


class ParamKind(StrEnum):
    """The value kind of a row: how a raw value is converted and which ROS 2 type holds it."""

    STR = "str"
    NAME = "name"  # [A-Za-z][A-Za-z0-9_]*
    NAMES = "names"  # a non-empty list of distinct names
    STR_LIST = "str_list"
    INT = "int"
    FLOAT = "float"
    BOOL = "bool"
    VEC3 = "vec3"
    UNIT3 = "unit3"  # normalised
    MRP = "mrp"  # mapped to the principal set
    MATRIX3 = "matrix3"  # 9 floats, row-major
    FLOATS = "floats"  # a list of floats, any length (empty: none)
    DATA_FILE = "data_file"  # a packaged name or a path, resolved by the row's resolver
    PATH = "path"


# ROS 2 parameter type of each value kind.
ROS_TYPES: dict[ParamKind, str] = {
    ParamKind.STR: "string",
    ParamKind.NAME: "string",
    ParamKind.NAMES: "string_array",
    ParamKind.STR_LIST: "string_array",
    ParamKind.INT: "integer",
    ParamKind.FLOAT: "double",
    ParamKind.BOOL: "bool",
    ParamKind.VEC3: "double_array",
    ParamKind.UNIT3: "double_array",
    ParamKind.MRP: "double_array",
    ParamKind.MATRIX3: "double_array",
    ParamKind.FLOATS: "double_array",
    ParamKind.DATA_FILE: "string",
    ParamKind.PATH: "string",
}


@dataclass(frozen=True)
class Param:
    """One parameter: the single source of its validation and its ROS descriptor."""

    key: str
    kind: ParamKind
    description: str
    default: Any = REQUIRED
    bounds: Bounds | None = None
    choices: tuple[str, ...] | type[StrEnum] | None = None
    check: Callable[[Any], str | None] | None = None
    read_only: bool = True
    resolve: Callable[[str, Path], str] | None = None
    """``data_file`` rows: the file resolver (name, base directory) -> value; it raises
    ``ValueError`` with the reason."""
    enum: type[StrEnum] | None = None
    """Set from ``choices`` given as an enum: the converted value is its member."""

    def __post_init__(self) -> None:
        if self.kind not in tuple(ParamKind):
            raise ValueError(f"parameter {self.key}: unknown kind {self.kind!r}")
        object.__setattr__(self, "kind", ParamKind(self.kind))
        if isinstance(self.choices, type):
            object.__setattr__(self, "enum", self.choices)
            object.__setattr__(self, "choices", tuple(m.value for m in self.choices))

    @property
    def ros_type(self) -> str:
        return ROS_TYPES[self.kind]

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    @property
    def rule(self) -> str | None:
        """The value rule in words, as shown in descriptions and errors."""
        if self.bounds is not None:
            return self.bounds.text()
        if self.choices is not None:
            return "one of " + ", ".join(self.values)
        return None

    @property
    def values(self) -> tuple[str, ...]:
        """The allowed strings (empty without choices)."""
        choices = self.choices
        return () if choices is None or isinstance(choices, type) else choices

    @property
    def full_description(self) -> str:
        rule = self.rule
        return self.description if rule is None else f"{self.description} ({rule})"

    def default_for(self, variant: str) -> Any:
        """The default, resolved for a planner variant."""
        if isinstance(self.default, ByVariant):
            return getattr(self.default, variant)
        return self.default

    def renamed(self, key: str) -> Param:
        """The same row under another key (per-instrument and per-object keys): a copy
        of this checked row (what ``dataclasses.replace`` gives, without checking it
        again: a scenario's per-name keys are renamed rows, thousands per campaign)."""
        row = object.__new__(Param)
        row.__dict__.update(self.__dict__)
        object.__setattr__(row, "key", key)
        return row


# --- converters: raw value -> typed value, raising _Bad(reason) ---------------------------


class _Bad(Exception):
    pass


def type_name(v: Any) -> str:
    names = {
        bool: "boolean",
        int: "integer",
        float: "float",
        str: "string",
        list: "list",
        dict: "mapping",
        type(None): "null",
    }
    return names.get(type(v), type(v).__name__)


def _float(v: Any, what: str = "") -> float:
    if type(v) is not float:
        hint = ""
        if type(v) is int:
            with contextlib.suppress(OverflowError):  # beyond a double: no float to suggest
                hint = (
                    f"; write it as a YAML float, e.g. {float(v)!r} "
                    "(ROS 2 parameters are strongly typed)"
                )
        elif isinstance(v, str):
            with contextlib.suppress(ValueError):
                hint = f"; write it as a YAML float, e.g. {float(v)!r}"
        raise _Bad(f"{what}expected float, got {type_name(v)} {v!r}{hint}")
    if not math.isfinite(v):
        raise _Bad(f"{what}must be finite, got {v!r}")
    return v


def _str(v: Any) -> str:
    if not isinstance(v, str):
        raise _Bad(f"expected string, got {type_name(v)} {v!r}")
    return v


def _name(v: Any) -> str:
    if not _NAME_RE.match(_str(v)):
        raise _Bad(f"invalid name {v!r}: must match [A-Za-z][A-Za-z0-9_]*")
    return str(v)


def _int(v: Any) -> int:
    if type(v) is not int:
        raise _Bad(f"expected integer, got {type_name(v)} {v!r}")
    return v


def _bool(v: Any) -> bool:
    if type(v) is not bool:
        raise _Bad(f"expected boolean, got {type_name(v)} {v!r}")
    return v


def _floats(v: Any, n: int) -> np.ndarray:
    if not isinstance(v, list):
        raise _Bad(f"expected a list of {n} floats, got {type_name(v)} {v!r}")
    if len(v) != n:
        raise _Bad(f"expected a list of {n} floats, got {len(v)} elements")
    return np.array([_float(x, f"element {k}: ") for k, x in enumerate(v)])


def _float_list(v: Any) -> tuple[float, ...]:
    if not isinstance(v, list):
        raise _Bad(f"expected a list of floats, got {type_name(v)} {v!r}")
    return tuple(_float(x, f"element {k}: ") for k, x in enumerate(v))


def _unit3(v: Any) -> np.ndarray:
    u = _floats(v, 3)
    norm = float(np.linalg.norm(u))
    if norm == 0.0:
        raise _Bad("must be a non-zero vector")
    if abs(norm - 1.0) > UNIT_TOLERANCE:
        raise _Bad(
            f"must be a unit vector (norm within {UNIT_TOLERANCE:.0%} of 1), got norm {norm:.4g}"
        )
    return u / norm


def _names(v: Any) -> tuple[str, ...]:
    if not isinstance(v, list) or not v:
        raise _Bad(f"expected a non-empty list of names, got {type_name(v)} {v!r}")
    names = tuple(_name(x) for x in v)
    dup = sorted({x for x in names if names.count(x) > 1})
    if dup:
        raise _Bad(f"duplicate names {dup}")
    return names


def _str_list(v: Any) -> tuple[str, ...]:
    if not isinstance(v, list):
        raise _Bad(f"expected a list of strings, got {type_name(v)} {v!r}")
    return tuple(_str(x) for x in v)


def _data_file(v: Any, base_dir: Path, resolve: Callable[[str, Path], str] | None) -> str:
    """A data file: ``resolve`` (the row's) gives its value, else the string as given."""
    if not _str(v):
        raise _Bad("must be a non-empty string")
    if resolve is None:
        return str(v)
    try:
        return resolve(v, base_dir)
    except ValueError as exc:
        raise _Bad(str(exc)) from None


_CONVERTERS: dict[str, Callable[[Any, Path], Any]] = {
    "str": lambda v, _: _str(v),
    "path": lambda v, _: _str(v),
    "name": lambda v, _: _name(v),
    "names": lambda v, _: _names(v),
    "str_list": lambda v, _: _str_list(v),
    "int": lambda v, _: _int(v),
    "bool": lambda v, _: _bool(v),
    "float": lambda v, _: _float(v),
    "vec3": lambda v, _: _floats(v, 3),
    "unit3": lambda v, _: _unit3(v),
    "mrp": lambda v, _: to_principal(_floats(v, 3)),
    "matrix3": lambda v, _: _floats(v, 9).reshape(3, 3),
    "floats": lambda v, _: _float_list(v),
}


def convert(
    param: Param,
    raw: Any,
    source: str,
    base_dir: Path | None = None,
    error: type[ParameterError] = ParameterError,
) -> Any:
    """The typed, checked value of ``raw`` for ``param``; raises ``error`` naming the key."""
    try:
        base = Path(".") if base_dir is None else base_dir
        value: Any
        if param.kind is ParamKind.DATA_FILE:
            value = _data_file(raw, base, param.resolve)
        else:
            value = _CONVERTERS[param.kind](raw, base)
        reason = None
        if param.bounds is not None:
            reason = param.bounds.check(value)
        elif param.choices is not None and value not in param.values:
            reason = f"must be one of {list(param.values)}, got {value!r}"
        if reason is None and param.check is not None:
            reason = param.check(value)
        if reason is None and param.enum is not None:
            value = param.enum(value)
    except _Bad as exc:
        reason = str(exc)
    if reason:
        raise error(source, param.key, reason)
    return value


def values_from(
    params: tuple[Param, ...],
    given: Mapping[str, Any],
    source: str,
    error: type[ParameterError] = NodeParameterError,
) -> dict[str, Any]:
    """Typed values of ``params`` from ``given`` (defaults for absent keys)."""
    out: dict[str, Any] = {}
    for p in params:
        if p.key in given:
            out[p.key] = convert(p, given[p.key], source, error=error)
        elif p.required:
            raise error(source, p.key, "missing required parameter")
        else:
            out[p.key] = p.default if p.enum is None else p.enum(p.default)
    return out


_T = TypeVar("_T")


def dotted_fields(cls: type[Any], prefix: str = "") -> list[str]:
    """The dotted keys of a parameters dataclass: a field whose type is a dataclass is a
    group (``lockstep.resend_period_s``)."""
    keys: list[str] = []
    for name, hint in get_type_hints(cls).items():
        if dataclasses.is_dataclass(hint) and isinstance(hint, type):
            keys += dotted_fields(hint, f"{prefix}{name}.")
        else:
            keys.append(prefix + name)
    return keys


def typed_values(cls: type[_T], values: Mapping[str, Any], prefix: str = "") -> _T:
    """A parameters dataclass filled from dotted ``values`` (:func:`values_from`)."""
    kwargs: dict[str, Any] = {}
    for name, hint in get_type_hints(cls).items():
        if dataclasses.is_dataclass(hint) and isinstance(hint, type):
            kwargs[name] = typed_values(hint, values, f"{prefix}{name}.")
        else:
            kwargs[name] = values[prefix + name]
    return cls(**kwargs)
