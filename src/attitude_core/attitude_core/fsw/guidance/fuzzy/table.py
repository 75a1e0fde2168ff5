"""Lookup tables of the FIS for the planner's hot path (the FEPF magnitudes of paper
eq. 6 at each step): clipped (bi)linear interpolation on adaptively refined knots, and a
per-process cache of the tables."""

from __future__ import annotations

import functools
import json
from bisect import bisect_right
from collections.abc import Callable, Sequence
from typing import NoReturn, Self

import numpy as np
import numpy.typing as npt

from attitude_core.fsw.guidance.fuzzy import table_cache
from attitude_core.fsw.guidance.fuzzy.mamdani import MamdaniFis
from attitude_core.fsw.guidance.fuzzy.refine import refine_1d, refine_2d
from attitude_core.fsw.guidance.fuzzy.spec import FisError

__all__ = ["FisTable", "lookup_table"]

_Floats = npt.NDArray[np.float64]


class FisTable:
    """Lookup table of a 1- or 2-input FIS: clipped (bi)linear interpolation.

    Build with :meth:`FisTable.build`. ``table(*inputs) -> float`` uses plain Python
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
    name: str
    input_names: tuple[str, ...]
    output_name: str
    universes: tuple[tuple[float, float], ...]
    axes: tuple[_Floats, ...]
    values: _Floats
    tol: float | None
    max_abs_error_estimate: float
    _kx: list[float]
    _ix: list[float]
    _lox: float
    _hix: float
    _ky: list[float]
    _iy: list[float]
    _loy: float
    _hiy: float
    _ny: int
    _v: list[float]
    __call__: Callable[..., float]  # table(*inputs), one float per input (the subclasses)

    def __new__(cls, *args: object, **kwargs: object) -> Self:
        if cls is FisTable:
            raise TypeError("build a FisTable with FisTable.build(fis)")
        return super().__new__(cls)

    @staticmethod
    def build(
        fis: MamdaniFis,
        points_per_axis: int | Sequence[int] | None = None,
        *,
        tol: float | None = 1e-3,
        max_points_per_axis: int = 2001,
    ) -> FisTable:
        """Precompute the table of ``fis`` for the hot path.

        The base grid is regular with ``points_per_axis`` points (default 401 for one
        input, 101x101 for two). Cells whose interpolation error (exact FIS vs table at
        cell centres and edge midpoints) exceeds ``tol`` are then split by inserting
        knots at interval midpoints, until the estimate is <= ``tol`` or an axis would
        exceed ``max_points_per_axis``. ``tol=None`` keeps the plain regular grid.
        """
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
        base = [np.linspace(lo, hi, n) for (lo, hi), n in zip(unis, counts, strict=True)]
        if ndim == 1:
            axes, vals, err = refine_1d(fis.evaluate_grid, base[0], tol, cap)
        else:
            axes, vals, err = refine_2d(fis.evaluate_grid, base[0], base[1], tol, cap)
        return FisTable.assemble(fis, tuple(axes), vals, err, tol)

    @staticmethod
    def assemble(
        fis: MamdaniFis,
        axes: tuple[_Floats, ...],
        vals: _Floats,
        err: float,
        tol: float | None,
    ) -> FisTable:
        """The table of ``fis`` on the knots ``axes`` with the values ``vals`` (as
        :meth:`build` computed them, or as the disk cache kept them)."""
        tab: FisTable = _FisTable1D() if len(axes) == 1 else _FisTable2D()
        tab.name = fis.name
        tab.input_names = fis.input_names
        tab.output_name = fis.output_name
        tab.universes = fis.input_universes
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
        if len(axes) == 2:
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


def _not_finite(name: str) -> NoReturn:
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
def _table_from_json(spec_json: str, label: str) -> FisTable:
    fis = MamdaniFis(json.loads(spec_json), label=label)
    key = table_cache.cache_key(spec_json, "table()")  # the default build arguments
    cached = table_cache.load(key, len(fis.input_names))
    if cached is not None:
        return FisTable.assemble(fis, *cached)
    table = FisTable.build(fis)
    table_cache.store(key, (table.axes, table.values, table.max_abs_error_estimate, table.tol))
    return table


def lookup_table(fis: MamdaniFis) -> FisTable:
    """Hot-path table of ``fis``, built once per machine for each distinct definition.

    Building a refined 2-input table takes a few tenths of a second; planners built
    again and again (batch runs, restarts, every node start) share it: in this process
    and, through :mod:`.table_cache`, on disk. The cache key is the full definition and
    the builder's code, so an edited FIS file gets its own table.
    """
    return _table_of(fis)


@functools.lru_cache(maxsize=32)
def _table_of(fis: MamdaniFis) -> FisTable:
    """:func:`lookup_table` per FIS object (a :class:`MamdaniFis` does not change after
    it is made, and the loader shares one per file text): its definition's key is made
    once, not at every planner's start."""
    return _table_from_json(json.dumps(fis.spec, sort_keys=True), fis.label)
