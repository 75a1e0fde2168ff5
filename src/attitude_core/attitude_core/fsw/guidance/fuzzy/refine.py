"""Adaptive grid refinement for the FIS lookup tables: start from a regular grid and
split the cells whose (bi)linear interpolation misses the exact FIS by more than a
tolerance."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

__all__ = ["refine_1d", "refine_2d"]

_Floats = npt.NDArray[np.float64]
_Bools = npt.NDArray[np.bool_]
_Ints = npt.NDArray[np.intp]
#: Exact FIS evaluated on broadcast input arrays (``MamdaniFis.evaluate_grid``).
GridFunction = Callable[..., _Floats]
#: ``(axes, values at the knots, largest interpolation error found)``.
Refined = tuple[tuple[_Floats, ...], _Floats, float]


def refine_1d(f: GridFunction, x: _Floats, tol: float | None, cap: int) -> Refined:
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


def _axis_map(n: int, split: npt.ArrayLike) -> tuple[_Bools, _Ints, _Ints, _Ints]:
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


def refine_2d(f: GridFunction, x: _Floats, y: _Floats, tol: float | None, cap: int) -> Refined:
    """Tensor-product version of :func:`refine_1d`.

    Errors are checked at cell centres and edge midpoints; a bad cell splits the axis
    (or axes) whose edge midpoints show the error. Exact values at the check points are
    kept between iterations, so each pass evaluates only the new rows and columns.
    """

    def grid(a: _Floats, b: _Floats) -> _Floats:
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
