"""Mamdani inference of a FIS: AND = min, implication = min, aggregation = max,
centroid defuzzification, with scikit-fuzzy's formulas (the FEPF magnitudes ``m_a``,
``m_r`` of paper eq. 6, evaluated exactly)."""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from typing import Any, cast

import numpy as np
import numpy.typing as npt

from attitude_core.fsw.guidance.fuzzy.membership import membership
from attitude_core.fsw.guidance.fuzzy.spec import (
    _INPUT_KEYS,
    _MIN_RESOLUTION,
    _OUTPUT_KEYS,
    _RULE_KEYS,
    _TOP_KEYS,
    FisError,
    Term,
    _Validator,
)

__all__ = ["MamdaniFis"]

_Floats = npt.NDArray[np.float64]

_CHUNK = 2048  # grid points per vectorised inference block (bounds memory use)


class MamdaniFis:
    """Validated Mamdani FIS: AND = min, implication = min, aggregation = max, centroid.

    Build with :func:`load_fis`. ``evaluate`` takes the crisp inputs positionally in
    the YAML input order, clips them to their universes and returns a float.
    """

    def __init__(self, spec: Mapping[str, Any], label: str = "<dict>") -> None:
        v = _Validator(label)
        self._label = label
        v.mapping(spec, "", _TOP_KEYS)
        self._name = v.name(spec["name"], "name")
        desc = spec.get("description", "")
        if not isinstance(desc, str):
            v.fail("description", f"expected a string, got {type(desc).__name__}")
        self._description = desc.strip()

        inputs = spec["inputs"]
        if not isinstance(inputs, list) or not inputs:
            v.fail("inputs", "expected a non-empty list of inputs")
        self._inputs: list[tuple[str, tuple[float, float], dict[str, Term]]] = []
        names: set[str] = set()
        for i, inp in enumerate(inputs):
            path = f"inputs[{i}]"
            v.mapping(inp, path, _INPUT_KEYS)
            name = v.name(inp["name"], f"{path}.name")
            if name in names:
                v.fail(f"{path}.name", f"duplicate input name {name!r}")
            names.add(name)
            uni = v.universe(inp["universe"], f"{path}.universe")
            terms = v.terms(inp["terms"], f"{path}.terms", uni)
            self._inputs.append((name, uni, terms))

        out = v.mapping(spec["output"], "output", _OUTPUT_KEYS)
        self._output_name = v.name(out["name"], "output.name")
        if self._output_name in names:
            v.fail("output.name", f"{self._output_name!r} is also an input name")
        res = out["resolution"]
        if isinstance(res, bool) or not isinstance(res, (int, np.integer)) or res < _MIN_RESOLUTION:
            v.fail("output.resolution", f"expected an integer >= {_MIN_RESOLUTION}, got {res!r}")
        self._resolution = int(res)
        self._out_universe = v.universe(out["universe"], "output.universe")
        lo, hi = self._out_universe
        self._default = v.number(out["default"], "output.default")
        if not lo <= self._default <= hi:
            v.fail("output.default", f"{self._default!r} is outside the output universe {[lo, hi]}")
        self._out_terms = v.terms(out["terms"], "output.terms", self._out_universe)
        self._x = np.linspace(lo, hi, self._resolution)
        term_index = {t: k for k, t in enumerate(self._out_terms)}
        x, dx = self._x, np.diff(self._x)
        # skfuzzy.defuzz 'centroid' sums, per segment [x1, x2] with samples y1, y2:
        # area = dx (y1 + y2) / 2, moment * area = dx^2 (y2 + y1 / 2) / 3 + x1 * area.
        self._w_area = np.zeros_like(x)
        self._w_area[:-1] += 0.5 * dx
        self._w_area[1:] += 0.5 * dx
        self._w_moment = np.zeros_like(x)
        self._w_moment[:-1] += dx * dx / 6.0 + 0.5 * x[:-1] * dx
        self._w_moment[1:] += dx * dx / 3.0 + 0.5 * x[:-1] * dx
        self._out_mf = np.stack([membership(s, p, self._x) for s, p in self._out_terms.values()])
        for k, tname in enumerate(self._out_terms):
            if not self._out_mf[k].any():
                v.fail(
                    f"output.terms.{tname}.params",
                    "zero membership on the discretised output universe "
                    f"(resolution {self._resolution})",
                )
        nz = [np.flatnonzero(row) for row in self._out_mf]
        self._out_support = [(int(i[0]), int(i[-1]) + 1) for i in nz]

        rules = spec["rules"]
        if not isinstance(rules, list) or not rules:
            v.fail("rules", "expected a non-empty list of rules")
        in_index = {name: j for j, (name, _, _) in enumerate(self._inputs)}
        self._rules: list[tuple[tuple[tuple[int, str], ...], int]] = []
        for r, rule in enumerate(rules):
            path = f"rules[{r}]"
            v.mapping(rule, path, _RULE_KEYS)
            ante = rule["if"]
            if not isinstance(ante, Mapping) or not ante:
                v.fail(f"{path}.if", "expected a non-empty mapping input -> term")
            clauses: list[tuple[int, str]] = []
            for iname, tname in ante.items():
                cpath = f"{path}.if.{iname}"
                if iname not in in_index:
                    v.fail(cpath, f"unknown input {iname!r} (inputs: {', '.join(in_index)})")
                terms = self._inputs[in_index[iname]][2]
                if not isinstance(tname, str) or tname not in terms:
                    v.fail(
                        cpath,
                        f"unknown term {tname!r} of input {iname} (terms: {', '.join(terms)})",
                    )
                clauses.append((in_index[iname], tname))
            then = rule["then"]
            if not isinstance(then, str) or then not in term_index:
                v.fail(
                    f"{path}.then",
                    f"unknown output term {then!r} (terms: {', '.join(self._out_terms)})",
                )
            self._rules.append((tuple(clauses), term_index[then]))
        self._spec = copy.deepcopy(dict(spec))

    # -- properties
    @property
    def name(self) -> str:
        return self._name

    @property
    def description(self) -> str:
        return self._description

    @property
    def label(self) -> str:
        """Where the FIS came from (file name or ``<dict>``)."""
        return self._label

    @property
    def input_names(self) -> tuple[str, ...]:
        return tuple(name for name, _, _ in self._inputs)

    @property
    def input_universes(self) -> tuple[tuple[float, float], ...]:
        return tuple(uni for _, uni, _ in self._inputs)

    @property
    def output_name(self) -> str:
        return self._output_name

    @property
    def output_universe(self) -> tuple[float, float]:
        return self._out_universe

    @property
    def default(self) -> float:
        return self._default

    @property
    def spec(self) -> dict[str, Any]:
        """A deep copy of the (validated) definition."""
        return copy.deepcopy(self._spec)

    def __repr__(self) -> str:
        ins = ", ".join(self.input_names)
        n = len(self._rules)
        return f"MamdaniFis({self._name!r}: ({ins}) -> {self._output_name}, {n} rules)"

    # -- inference
    def evaluate(self, *inputs: float) -> float:
        """Crisp output for crisp inputs given positionally in the YAML input order."""
        return float(self.evaluate_grid(*inputs))

    def evaluate_grid(self, *arrays: npt.ArrayLike) -> _Floats:
        """Vectorised :meth:`evaluate` over broadcast input arrays (returns their shape)."""
        if len(arrays) != len(self._inputs):
            raise TypeError(
                f"{self._name} takes {len(self._inputs)} inputs ({', '.join(self.input_names)}), "
                f"got {len(arrays)}"
            )
        xs = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in arrays))
        shape = xs[0].shape
        flat = []
        for x, (name, (lo, hi), _) in zip(xs, self._inputs, strict=True):
            x = x.ravel()
            if not np.isfinite(x).all():
                raise FisError(f"{self._label}: input {name} is not finite")
            flat.append(np.clip(x, lo, hi))
        n = flat[0].size
        out = np.empty(n)
        for start in range(0, n, _CHUNK):
            out[start : start + _CHUNK] = self._infer([x[start : start + _CHUNK] for x in flat])
        return out.reshape(shape)

    def fired_strength(self, *arrays: npt.ArrayLike) -> _Floats:
        """Activation of each output term (max over its rules), shape ``(..., n_terms)``."""
        if len(arrays) != len(self._inputs):
            raise TypeError(f"{self._name} takes {len(self._inputs)} inputs, got {len(arrays)}")
        clipped = [
            np.clip(np.asarray(a, dtype=float), lo, hi)
            for a, (_, (lo, hi), _) in zip(arrays, self._inputs, strict=True)
        ]
        xs = np.broadcast_arrays(*clipped)
        return np.moveaxis(self._strengths(xs), 0, -1)

    def _strengths(self, xs: Sequence[_Floats]) -> _Floats:
        cache: dict[tuple[int, str], _Floats] = {}
        act = np.zeros((len(self._out_terms),) + xs[0].shape)
        for clauses, k in self._rules:
            w: _Floats | None = None
            for j, tname in clauses:
                mu = cache.get((j, tname))
                if mu is None:
                    shape, params = self._inputs[j][2][tname]
                    mu = cache[(j, tname)] = membership(shape, params, xs[j])
                w = mu if w is None else np.fmin(w, mu)  # AND = min
            w = cast("_Floats", w)  # not None: every rule has a clause (validated)
            act[k] = np.fmax(act[k], w)  # max over rules with the same consequent
        return act

    def _infer(self, xs: Sequence[_Floats]) -> _Floats:
        act = self._strengths(xs)  # (terms, n)
        agg = np.zeros((act.shape[1], self._resolution))
        for k, (lo, hi) in enumerate(self._out_support):
            # implication = min (clip the consequent), aggregation = max over terms
            clipped = np.fmin(self._out_mf[k, lo:hi], act[k][:, None])
            np.fmax(agg[:, lo:hi], clipped, out=agg[:, lo:hi])
        # centroid = (sum of trapezoid moment*area) / (sum of trapezoid area): both are
        # linear in the samples of agg, so they are dot products with fixed weights.
        area = agg @ self._w_area
        res = (agg @ self._w_moment) / np.fmax(area, np.finfo(float).eps)
        return np.where(area > 0.0, res, self._default)  # nothing fired -> default
