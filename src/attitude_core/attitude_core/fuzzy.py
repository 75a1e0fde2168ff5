"""Mamdani fuzzy inference systems (FIS) for the fuzzy enhanced potential field.

The planner commands the target MRP rate (paper eq. 6)

    sigma_t_dot = m_a * sigma_a_hat + m_r * sigma_r_hat,

where the magnitudes ``m_a`` (attraction) and ``m_r`` (repulsion) come from two FIS
whose outputs are normalised to [0, 1] and multiplied by a rate scale in MRP/s by
the planner. The FIS are data (``attitude_core/data/fis_*.yaml``); this module
validates them, evaluates them exactly (Mamdani: min AND, min implication, max
aggregation, centroid defuzzification, with the same formulas as scikit-fuzzy) and
tabulates them for the hot path (:class:`FisTable`). See ``docs/fuzzy_design.md``.

YAML schema::

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

import copy
import functools
import json
import math
from bisect import bisect_right
from importlib import resources
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import yaml

__all__ = ["FisError", "MamdaniFis", "FisTable", "load_fis", "lookup_table", "membership",
           "packaged_fis_files"]

#: Membership shapes and their number of parameters.
SHAPES = {"trimf": 3, "trapmf": 4, "gaussmf": 2}

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
_CHUNK = 2048  # grid points per vectorised inference block (bounds memory use)


class FisError(ValueError):
    """Invalid FIS definition (message: ``<file>: <field path>: <problem>``) or input."""


# --------------------------------------------------------------------------- loading


class _UniqueKeyLoader(yaml.SafeLoader):
    """SafeLoader that refuses duplicate mapping keys (PyYAML silently keeps the last)."""


def _construct_mapping(loader: _UniqueKeyLoader, node: yaml.MappingNode, deep: bool = False):
    loader.flatten_mapping(node)
    seen: set = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r}", key_node.start_mark
            )
        seen.add(key)
    return loader.construct_mapping(node, deep=deep)


_UniqueKeyLoader.add_constructor(
    yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping
)


def packaged_fis_files() -> list[str]:
    """Names of the FIS YAML files shipped in ``attitude_core/data/``."""
    data = resources.files("attitude_core") / "data"
    return sorted(p.name for p in data.iterdir() if p.name.endswith(".yaml"))


def load_fis(source: str | Path | Mapping[str, Any]) -> "MamdaniFis":
    """Load and validate a FIS.

    ``source`` is an already-parsed dict, the bare file name of a packaged file in
    ``attitude_core/data/`` (e.g. ``"fis_attractive.yaml"``; a bare name that is not
    packaged is then tried as a path), or a path to a YAML file.
    Raises :class:`FisError` naming the file and the offending field.
    """
    if isinstance(source, Mapping):
        return MamdaniFis(source, label="<dict>")
    if not isinstance(source, (str, Path)):
        raise FisError(
            f"load_fis: source must be a path, a file name or a dict, got {type(source).__name__}"
        )
    text = str(source)
    label = text
    content: str | None = None
    if Path(text).name == text and text:
        res = resources.files("attitude_core") / "data" / text
        if res.is_file():
            content = res.read_text(encoding="utf-8")
    if content is None:
        path = Path(source)
        if not path.is_file():
            raise FisError(
                f"{label}: no such file (and not a packaged FIS; packaged: "
                f"{', '.join(packaged_fis_files())})"
            )
        content = path.read_text(encoding="utf-8")
    try:
        spec = yaml.load(content, Loader=_UniqueKeyLoader)  # noqa: S506 (safe loader subclass)
    except yaml.YAMLError as exc:
        raise FisError(f"{label}: invalid YAML: {exc}") from None
    return MamdaniFis(spec, label=label)


# ------------------------------------------------------------------------ validation


class _Validator:
    def __init__(self, label: str):
        self.label = label

    def fail(self, path: str, msg: str):
        raise FisError(f"{self.label}: {path}: {msg}" if path else f"{self.label}: {msg}")

    def mapping(self, obj, path: str, keys: Mapping[str, bool]) -> Mapping:
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

    def name(self, obj, path: str) -> str:
        if not isinstance(obj, str) or not obj.strip():
            self.fail(path, f"expected a non-empty string, got {obj!r}")
        return obj

    def number(self, obj, path: str) -> float:
        if isinstance(obj, bool) or not isinstance(obj, (int, float, np.integer, np.floating)):
            self.fail(path, f"expected a number, got {obj!r}")
        val = float(obj)
        if not math.isfinite(val):
            self.fail(path, f"expected a finite number, got {obj!r}")
        return val

    def universe(self, obj, path: str) -> tuple[float, float]:
        if not isinstance(obj, Sequence) or isinstance(obj, str) or len(obj) != 2:
            self.fail(path, f"expected [lo, hi], got {obj!r}")
        lo = self.number(obj[0], f"{path}[0]")
        hi = self.number(obj[1], f"{path}[1]")
        if not lo < hi:
            self.fail(path, f"needs lo < hi, got {list(obj)!r}")
        return lo, hi

    def terms(self, obj, path: str, universe: tuple[float, float]) -> dict[str, tuple[str, tuple]]:
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

    def params(self, shape: str, obj, path: str) -> tuple[float, ...]:
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
        elif any(b < a for a, b in zip(vals, vals[1:])):
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


# ----------------------------------------------------------------------- memberships


def _trimf(x: np.ndarray, a: float, b: float, c: float) -> np.ndarray:
    """skfuzzy.trimf on an array of any shape (same branch structure and formulas)."""
    y = np.zeros_like(x)
    if a != b:
        y = np.where((a < x) & (x < b), (x - a) / float(b - a), y)
    if b != c:
        y = np.where((b < x) & (x < c), (c - x) / float(c - b), y)
    return np.where(x == b, 1.0, y)


def _trapmf(x: np.ndarray, a: float, b: float, c: float, d: float) -> np.ndarray:
    """skfuzzy.trapmf on an array of any shape."""
    y = np.ones_like(x)
    y = np.where(x <= b, _trimf(x, a, b, b), y)
    y = np.where(x >= c, _trimf(x, c, c, d), y)
    return np.where((x < a) | (x > d), 0.0, y)


def _gaussmf(x: np.ndarray, mean: float, sigma: float) -> np.ndarray:
    """skfuzzy.gaussmf."""
    return np.exp(-((x - mean) ** 2.0) / (2 * sigma**2.0))


_MF = {"trimf": _trimf, "trapmf": _trapmf, "gaussmf": _gaussmf}


def membership(shape: str, params: Sequence[float], x) -> np.ndarray:
    """Membership degree of ``x`` (any shape) in a term ``{shape, params}``."""
    return _MF[shape](np.asarray(x, dtype=float), *params)


# ------------------------------------------------------------------------- inference


class MamdaniFis:
    """Validated Mamdani FIS: AND = min, implication = min, aggregation = max, centroid.

    Build with :func:`load_fis`. ``evaluate`` takes the crisp inputs positionally in
    the YAML input order, clips them to their universes and returns a float.
    """

    def __init__(self, spec: Mapping[str, Any], label: str = "<dict>"):
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
        self._inputs: list[tuple[str, tuple[float, float], dict]] = []
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
            clauses = []
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
    def spec(self) -> dict:
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

    def evaluate_grid(self, *arrays) -> np.ndarray:
        """Vectorised :meth:`evaluate` over broadcast input arrays (returns their shape)."""
        if len(arrays) != len(self._inputs):
            raise TypeError(
                f"{self._name} takes {len(self._inputs)} inputs ({', '.join(self.input_names)}), "
                f"got {len(arrays)}"
            )
        xs = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in arrays))
        shape = xs[0].shape
        flat = []
        for x, (name, (lo, hi), _) in zip(xs, self._inputs):
            x = x.ravel()
            if not np.isfinite(x).all():
                raise FisError(f"{self._label}: input {name} is not finite")
            flat.append(np.clip(x, lo, hi))
        n = flat[0].size
        out = np.empty(n)
        for start in range(0, n, _CHUNK):
            out[start : start + _CHUNK] = self._infer([x[start : start + _CHUNK] for x in flat])
        return out.reshape(shape)

    def fired_strength(self, *arrays) -> np.ndarray:
        """Activation of each output term (max over its rules), shape ``(..., n_terms)``."""
        if len(arrays) != len(self._inputs):
            raise TypeError(f"{self._name} takes {len(self._inputs)} inputs, got {len(arrays)}")
        xs = [
            np.clip(np.asarray(a, dtype=float), lo, hi)
            for a, (_, (lo, hi), _) in zip(arrays, self._inputs)
        ]
        xs = np.broadcast_arrays(*xs)
        return np.moveaxis(self._strengths(xs), 0, -1)

    def _strengths(self, xs: list[np.ndarray]) -> np.ndarray:
        cache: dict[tuple[int, str], np.ndarray] = {}
        act = np.zeros((len(self._out_terms),) + xs[0].shape)
        for clauses, k in self._rules:
            w = None
            for j, tname in clauses:
                mu = cache.get((j, tname))
                if mu is None:
                    shape, params = self._inputs[j][2][tname]
                    mu = cache[(j, tname)] = membership(shape, params, xs[j])
                w = mu if w is None else np.fmin(w, mu)  # AND = min
            act[k] = np.fmax(act[k], w)  # max over rules with the same consequent
        return act

    def _infer(self, xs: list[np.ndarray]) -> np.ndarray:
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

    def table(
        self,
        points_per_axis: int | Sequence[int] | None = None,
        *,
        tol: float | None = 1e-3,
        max_points_per_axis: int = 2001,
    ) -> "FisTable":
        """Precompute a :class:`FisTable` for the hot path.

        The base grid is regular with ``points_per_axis`` points (default 401 for one
        input, 101x101 for two). Cells whose interpolation error (exact FIS vs table at
        cell centres and edge midpoints) exceeds ``tol`` are then split by inserting
        knots at interval midpoints, until the estimate is <= ``tol`` or an axis would
        exceed ``max_points_per_axis``. ``tol=None`` keeps the plain regular grid.
        """
        return FisTable.build(
            self, points_per_axis, tol=tol, max_points_per_axis=max_points_per_axis
        )


# ---------------------------------------------------------------------- lookup table


def _refine_1d(f, x: np.ndarray, tol: float | None, cap: int):
    """Tabulate ``f`` on knots ``x``; split cells whose midpoint error exceeds ``tol``."""
    v = f(x)
    while True:
        xm = 0.5 * (x[:-1] + x[1:])
        vm = f(xm)
        e = np.abs(vm - 0.5 * (v[:-1] + v[1:]))
        err = float(e.max())
        split = e > tol if tol is not None else np.zeros(e.shape, bool)
        if not split.any() or x.size + split.sum() > cap:
            return (x,), v, err
        x2 = np.empty(2 * x.size - 1)
        x2[0::2], x2[1::2] = x, xm
        v2 = np.empty_like(x2)
        v2[0::2], v2[1::2] = v, vm
        keep = np.ones(x2.size, bool)
        keep[1::2] = split
        x, v = x2[keep], v2[keep]


def _axis_map(n: int, split: np.ndarray):
    """For knots [old knots + midpoints of split intervals], map to old data.

    Returns ``(keep, old_knot, old_mid, old_int)``: ``keep`` selects the new knots from
    the interleaved sequence (knot, mid, knot, ...); ``old_knot[k]`` / ``old_mid[k]`` is
    the old knot / old interval whose midpoint new knot ``k`` is (else -1);
    ``old_int[i]`` is the old interval equal to new interval ``i`` (else -1: a half).
    """
    pos = np.arange(2 * n - 1)
    keep = np.ones(pos.size, bool)
    keep[1::2] = split
    pos = pos[keep]
    even = pos % 2 == 0
    old_knot = np.where(even, pos // 2, -1)
    old_mid = np.where(even, -1, pos // 2)
    old_int = np.where((old_knot[:-1] >= 0) & (old_knot[1:] >= 0), old_knot[:-1], -1)
    return keep, old_knot, old_mid, old_int


def _refine_2d(f, x: np.ndarray, y: np.ndarray, tol: float | None, cap: int):
    """Tensor-product version of :func:`_refine_1d`.

    Errors are checked at cell centres and edge midpoints; a bad cell splits the axis
    (or axes) whose edge midpoints show the error. Exact values at the check points are
    kept between iterations, so each pass evaluates only the new rows and columns.
    """

    def grid(a, b):
        return f(*np.meshgrid(a, b, indexing="ij"))

    v = grid(x, y)
    xm, ym = 0.5 * (x[:-1] + x[1:]), 0.5 * (y[:-1] + y[1:])
    vc, vx, vy = grid(xm, ym), grid(xm, y), grid(x, ym)  # centres, x-edge / y-edge midpoints
    while True:
        ec = np.abs(vc - 0.25 * (v[:-1, :-1] + v[1:, :-1] + v[:-1, 1:] + v[1:, 1:]))
        ex_edge = np.abs(vx - 0.5 * (v[:-1] + v[1:]))
        ey_edge = np.abs(vy - 0.5 * (v[:, :-1] + v[:, 1:]))
        ex = np.maximum(ex_edge[:, :-1], ex_edge[:, 1:])  # per cell
        ey = np.maximum(ey_edge[:-1], ey_edge[1:])
        err = float(max(ec.max(), ex.max(), ey.max()))
        if tol is None or err <= tol:
            return (x, y), v, err
        sx = ((ex > tol) | ((ec > tol) & (ex >= ey))).any(axis=1)
        sy = ((ey > tol) | ((ec > tol) & (ey >= ex))).any(axis=0)
        if x.size + sx.sum() > cap or y.size + sy.sum() > cap:
            return (x, y), v, err
        # values on the refined knots are all known already
        w = np.empty((2 * x.size - 1, 2 * y.size - 1))
        w[0::2, 0::2], w[1::2, 0::2], w[0::2, 1::2], w[1::2, 1::2] = v, vx, vy, vc
        x2, y2 = np.empty(w.shape[0]), np.empty(w.shape[1])
        x2[0::2], x2[1::2] = x, xm
        y2[0::2], y2[1::2] = y, ym
        kx, knot_x, mid_x, int_x = _axis_map(x.size, sx)
        ky, knot_y, mid_y, int_y = _axis_map(y.size, sy)
        x, y, v = x2[kx], y2[ky], w[np.ix_(kx, ky)]
        xm, ym = 0.5 * (x[:-1] + x[1:]), 0.5 * (y[:-1] + y[1:])
        # check points: reuse old exact values on unsplit intervals, evaluate the rest
        ox, nx_ = int_x >= 0, int_x < 0
        oy, ny_ = int_y >= 0, int_y < 0
        kyk, kym = knot_y >= 0, mid_y >= 0
        kxk, kxm = knot_x >= 0, mid_x >= 0
        vx2 = np.empty((xm.size, y.size))
        vx2[np.ix_(ox, kyk)] = vx[np.ix_(int_x[ox], knot_y[kyk])]
        vx2[np.ix_(ox, kym)] = vc[np.ix_(int_x[ox], mid_y[kym])]
        vx2[nx_] = grid(xm[nx_], y)
        vy2 = np.empty((x.size, ym.size))
        vy2[np.ix_(kxk, oy)] = vy[np.ix_(knot_x[kxk], int_y[oy])]
        vy2[np.ix_(kxm, oy)] = vc[np.ix_(mid_x[kxm], int_y[oy])]
        vy2[:, ny_] = grid(x, ym[ny_])
        vc2 = np.empty((xm.size, ym.size))
        vc2[np.ix_(ox, oy)] = vc[np.ix_(int_x[ox], int_y[oy])]
        vc2[nx_] = grid(xm[nx_], ym)
        vc2[np.ix_(ox, ny_)] = grid(xm[ox], ym[ny_])
        vc, vx, vy = vc2, vx2, vy2


class FisTable:
    """Lookup table of a 1- or 2-input FIS: clipped (bi)linear interpolation.

    Build with :meth:`MamdaniFis.table`. ``table(*inputs) -> float`` uses plain Python
    floats and :func:`bisect.bisect_right` on the knot lists (well under 2 us per call).
    ``max_abs_error_estimate`` is the largest difference to the exact FIS found at build
    time at the cell midpoints (1-D) / cell centres and edge midpoints (2-D).
    """

    __slots__ = (
        "name",
        "input_names",
        "output_name",
        "universes",
        "axes",
        "values",
        "tol",
        "max_abs_error_estimate",
        "_kx",
        "_ix",
        "_lox",
        "_hix",
        "_ky",
        "_iy",
        "_loy",
        "_hiy",
        "_ny",
        "_v",
    )

    def __new__(cls, *args, **kwargs):
        if cls is FisTable:
            raise TypeError("build a FisTable with MamdaniFis.table()")
        return super().__new__(cls)

    @staticmethod
    def build(
        fis: MamdaniFis,
        points_per_axis: int | Sequence[int] | None = None,
        *,
        tol: float | None = 1e-3,
        max_points_per_axis: int = 2001,
    ) -> "FisTable":
        """See :meth:`MamdaniFis.table`."""
        ndim = len(fis.input_names)
        if ndim not in (1, 2):
            raise FisError(f"{fis.label}: FisTable supports 1 or 2 inputs, {fis.name} has {ndim}")
        if points_per_axis is None:
            points_per_axis = 401 if ndim == 1 else 101
        if isinstance(points_per_axis, (int, np.integer)):
            counts = (int(points_per_axis),) * ndim
        else:
            counts = tuple(int(c) for c in points_per_axis)
        if len(counts) != ndim or any(c < 2 for c in counts):
            raise FisError(
                f"{fis.label}: points_per_axis must be >= 2 per input, got {points_per_axis!r}"
            )
        if tol is not None and not tol > 0.0:
            raise FisError(f"{fis.label}: tol must be > 0 or None, got {tol!r}")
        cap = max(int(max_points_per_axis), *counts)
        unis = fis.input_universes
        base = [np.linspace(lo, hi, n) for (lo, hi), n in zip(unis, counts)]
        if ndim == 1:
            axes, vals, err = _refine_1d(fis.evaluate_grid, base[0], tol, cap)
            tab: FisTable = _FisTable1D()
        else:
            axes, vals, err = _refine_2d(fis.evaluate_grid, base[0], base[1], tol, cap)
            tab = _FisTable2D()
        tab.name = fis.name
        tab.input_names = fis.input_names
        tab.output_name = fis.output_name
        tab.universes = unis
        tab.tol = tol
        tab.max_abs_error_estimate = err
        for a in (*axes, vals):
            a.flags.writeable = False
        tab.axes = axes
        tab.values = vals
        tab._v = vals.ravel().tolist()
        tab._kx = axes[0].tolist()
        tab._ix = (1.0 / np.diff(axes[0])).tolist()
        tab._lox, tab._hix = tab._kx[0], tab._kx[-1]
        if ndim == 2:
            tab._ky = axes[1].tolist()
            tab._iy = (1.0 / np.diff(axes[1])).tolist()
            tab._loy, tab._hiy = tab._ky[0], tab._ky[-1]
            tab._ny = len(tab._ky)
        return tab

    @property
    def shape(self) -> tuple[int, ...]:
        return self.values.shape

    def __repr__(self) -> str:
        return (
            f"FisTable({self.name!r}, {'x'.join(map(str, self.shape))}, "
            f"max_abs_error_estimate={self.max_abs_error_estimate:.2e})"
        )


def _not_finite(name: str):
    raise FisError(f"FisTable: input {name} is not finite")


class _FisTable1D(FisTable):
    __slots__ = ()

    def __call__(self, x: float) -> float:
        v = self._v
        if x > self._lox:
            if x < self._hix:
                k = self._kx
                i = bisect_right(k, x) - 1
                a = v[i]
                return a + (x - k[i]) * self._ix[i] * (v[i + 1] - a)
            return v[-1]
        if x <= self._lox:
            return v[0]
        return _not_finite(self.input_names[0])


class _FisTable2D(FisTable):
    __slots__ = ()

    def __call__(self, x: float, y: float) -> float:
        if x > self._lox:
            if x < self._hix:
                k = self._kx
                i = bisect_right(k, x) - 1
                fx = (x - k[i]) * self._ix[i]
            else:
                i = len(self._kx) - 2
                fx = 1.0
        elif x <= self._lox:
            i = 0
            fx = 0.0
        else:
            return _not_finite(self.input_names[0])
        if y > self._loy:
            if y < self._hiy:
                k = self._ky
                j = bisect_right(k, y) - 1
                fy = (y - k[j]) * self._iy[j]
            else:
                j = self._ny - 2
                fy = 1.0
        elif y <= self._loy:
            j = 0
            fy = 0.0
        else:
            return _not_finite(self.input_names[1])
        v = self._v
        ny = self._ny
        n = i * ny + j
        a = v[n]
        b = v[n + ny]
        a += fy * (v[n + 1] - a)
        b += fy * (v[n + ny + 1] - b)
        return a + fx * (b - a)


@functools.lru_cache(maxsize=32)
def _table_from_json(spec_json: str, label: str) -> "FisTable":
    return MamdaniFis(json.loads(spec_json), label=label).table()


def lookup_table(fis: "MamdaniFis") -> "FisTable":
    """Hot-path table of ``fis``, built once per process for each distinct definition.

    Building a refined 2-input table takes a few tenths of a second; planners built
    again and again (batch runs, restarts) share it. The cache key is the full
    definition, so an edited FIS file gets its own table.
    """
    return _table_from_json(json.dumps(fis.spec, sort_keys=True), fis.label)
