# Mirrors attitude_core.fsw.guidance.fuzzy.table (FisTable.__call__): the clipped
# (bi)linear interpolation of a FIS lookup table, which gives the FEPF's magnitudes m_a
# and m_r (paper eq. 6). Equal to the bit (tests/core/test_fepf_kernel.py).

import numpy as np


cdef inline Py_ssize_t _bisect_right(const double[::1] k, double x) noexcept:
    """``bisect.bisect_right`` on a sorted array."""
    cdef Py_ssize_t lo = 0, hi = k.shape[0], mid
    while lo < hi:
        mid = (lo + hi) // 2
        if x < k[mid]:
            hi = mid
        else:
            lo = mid + 1
    return lo


cdef class FisKernel:
    """A 1- or 2-input ``FisTable``: the same clipped (bi)linear interpolation."""

    cdef readonly object table
    cdef double[::1] kx
    cdef double[::1] ix
    cdef double[::1] ky
    cdef double[::1] iy
    cdef double[::1] v
    cdef double lox, hix, loy, hiy
    cdef Py_ssize_t ny
    cdef int ndim

    def __init__(self, table):
        self.table = table
        self.ndim = len(table.axes)
        self.kx = np.asarray(table._kx, dtype=float)
        self.ix = np.asarray(table._ix, dtype=float)
        self.lox, self.hix = table._lox, table._hix
        self.v = np.asarray(table._v, dtype=float)
        if self.ndim == 2:
            self.ky = np.asarray(table._ky, dtype=float)
            self.iy = np.asarray(table._iy, dtype=float)
            self.loy, self.hiy = table._loy, table._hiy
            self.ny = table._ny
        elif self.ndim != 1:
            raise ValueError("FisKernel: a table of 1 or 2 inputs expected")

    cdef double at(self, double x, double y, bint* bad) noexcept:
        """The table at ``x`` (and ``y``); ``bad`` when an input is not finite (the
        Python table then raises its error)."""
        cdef Py_ssize_t i, j, n
        cdef double a, b, fx, fy
        cdef const double[::1] v = self.v
        if self.ndim == 1:
            if x > self.lox:
                if x < self.hix:
                    i = _bisect_right(self.kx, x) - 1
                    a = v[i]
                    return a + (x - self.kx[i]) * self.ix[i] * (v[i + 1] - a)
                return v[v.shape[0] - 1]
            if x <= self.lox:
                return v[0]
            bad[0] = True
            return 0.0
        if x > self.lox:
            if x < self.hix:
                i = _bisect_right(self.kx, x) - 1
                fx = (x - self.kx[i]) * self.ix[i]
            else:
                i = self.kx.shape[0] - 2
                fx = 1.0
        elif x <= self.lox:
            i = 0
            fx = 0.0
        else:
            bad[0] = True
            return 0.0
        if y > self.loy:
            if y < self.hiy:
                j = _bisect_right(self.ky, y) - 1
                fy = (y - self.ky[j]) * self.iy[j]
            else:
                j = self.ny - 2
                fy = 1.0
        elif y <= self.loy:
            j = 0
            fy = 0.0
        else:
            bad[0] = True
            return 0.0
        n = i * self.ny + j
        a = v[n]
        b = v[n + self.ny]
        a += fy * (v[n + 1] - a)
        b += fy * (v[n + self.ny + 1] - b)
        return a + fx * (b - a)


_FIS_KERNELS = {}  # id(table) -> (table, its FisKernel): the tables are shared too


cdef FisKernel _fis_kernel(table):
    """The FisKernel of ``table``, made once per table in this process."""
    hit = _FIS_KERNELS.get(id(table))
    if hit is not None and hit[0] is table:
        return hit[1]
    if len(_FIS_KERNELS) >= 64:
        _FIS_KERNELS.clear()
    made = FisKernel(table)
    _FIS_KERNELS[id(table)] = (table, made)
    return made
