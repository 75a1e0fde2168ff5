"""The FIS definition (data, not code) and its validation.

Each FEPF magnitude (paper eq. 6: attraction ``m_a``, repulsion ``m_r``) is a Mamdani
FIS written as YAML; every error names the file and the field path. Schema::

    name: attractive_magnitude
    description: free text            # optional
    inputs:
      - name: goal_distance
        universe: [0.0, 1.0]
        terms:
          near: {shape: trapmf, params: [0.0, 0.0, 0.1, 0.3]}
    output:
      name: attraction
      universe: [0.0, 1.0]
      resolution: 201                 # points of the discretised output universe
      default: 0.0                    # returned when no rule fires
      terms:
        slow: {shape: trimf, params: [0.0, 0.2, 0.45]}
    rules:
      - {if: {goal_distance: near}, then: slow}
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from typing import Any, NoReturn

import numpy as np

from attitude_core.fsw.guidance.fuzzy.membership import SHAPES

__all__ = ["FisError"]

#: Shape and parameters of a validated term.
Term = tuple[str, tuple[float, ...]]

_TOP_KEYS = {"name": True, "description": False, "inputs": True, "output": True, "rules": True}
_INPUT_KEYS = {"name": True, "universe": True, "terms": True}
_OUTPUT_KEYS = {
    "name": True,
    "universe": True,
    "resolution": True,
    "default": True,
    "terms": True,
}
_TERM_KEYS = {"shape": True, "params": True}
_RULE_KEYS = {"if": True, "then": True}
_MIN_RESOLUTION = 21


class FisError(ValueError):
    """Invalid FIS definition (message: ``<file>: <field path>: <problem>``) or input."""


class _Validator:
    def __init__(self, label: str):
        self.label = label

    def fail(self, path: str, msg: str) -> NoReturn:
        raise FisError(f"{self.label}: {path}: {msg}" if path else f"{self.label}: {msg}")

    def mapping(self, obj: Any, path: str, keys: Mapping[str, bool]) -> Mapping[Any, Any]:
        if not isinstance(obj, Mapping):
            self.fail(path, f"expected a mapping, got {type(obj).__name__}")
        for k in obj:
            if k not in keys:
                self.fail(
                    _join(path, str(k)),
                    f"unknown key (allowed: {', '.join(sorted(keys))})",
                )
        for k, required in keys.items():
            if required and k not in obj:
                self.fail(_join(path, k), "required key is missing")
        return obj

    def name(self, obj: Any, path: str) -> str:
        if not isinstance(obj, str) or not obj.strip():
            self.fail(path, f"expected a non-empty string, got {obj!r}")
        return obj

    def number(self, obj: Any, path: str) -> float:
        if isinstance(obj, bool) or not isinstance(obj, (int, float, np.integer, np.floating)):
            self.fail(path, f"expected a number, got {obj!r}")
        val = float(obj)
        if not math.isfinite(val):
            self.fail(path, f"expected a finite number, got {obj!r}")
        return val

    def universe(self, obj: Any, path: str) -> tuple[float, float]:
        if not isinstance(obj, Sequence) or isinstance(obj, str) or len(obj) != 2:
            self.fail(path, f"expected [lo, hi], got {obj!r}")
        lo = self.number(obj[0], f"{path}[0]")
        hi = self.number(obj[1], f"{path}[1]")
        if not lo < hi:
            self.fail(path, f"needs lo < hi, got {list(obj)!r}")
        return lo, hi

    def terms(self, obj: Any, path: str, universe: tuple[float, float]) -> dict[str, Term]:
        if not isinstance(obj, Mapping) or not obj:
            self.fail(path, "expected a non-empty mapping of term name -> {shape, params}")
        out = {}
        for tname, tspec in obj.items():
            tpath = _join(path, str(tname))
            self.name(tname, tpath)
            self.mapping(tspec, tpath, _TERM_KEYS)
            shape = tspec["shape"]
            if shape not in SHAPES:
                self.fail(f"{tpath}.shape", f"unknown shape {shape!r} (known: {', '.join(SHAPES)})")
            params = self.params(shape, tspec["params"], f"{tpath}.params")
            if not _touches(shape, params, universe):
                self.fail(
                    f"{tpath}.params",
                    f"{shape} {list(params)} has zero membership over the universe "
                    f"{list(universe)}",
                )
            out[tname] = (shape, params)
        return out

    def params(self, shape: str, obj: Any, path: str) -> tuple[float, ...]:
        n = SHAPES[shape]
        what = {
            "trimf": "trimf needs 3 non-decreasing numbers",
            "trapmf": "trapmf needs 4 non-decreasing numbers",
            "gaussmf": "gaussmf needs [mean, sigma] with sigma > 0",
        }[shape]
        if not isinstance(obj, Sequence) or isinstance(obj, str) or len(obj) != n:
            self.fail(path, f"{what}, got {obj!r}")
        vals = tuple(self.number(v, f"{path}[{i}]") for i, v in enumerate(obj))
        if shape == "gaussmf":
            if not vals[1] > 0.0:
                self.fail(path, f"{what}, got {list(obj)!r}")
        elif any(b < a for a, b in itertools.pairwise(vals)):
            self.fail(path, f"{what}, got {list(obj)!r}")
        return vals


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _touches(shape: str, p: tuple[float, ...], universe: tuple[float, float]) -> bool:
    """Whether the membership function is positive somewhere on the closed universe."""
    lo, hi = universe
    if shape == "gaussmf":
        return True
    a, b, c = p[0], p[1], p[-2] if shape == "trapmf" else p[1]
    d = p[-1]
    core = b <= hi and c >= lo  # [b, c] has membership 1
    slope = a < hi and d > lo and a < d  # open support (a, d)
    return core or slope
