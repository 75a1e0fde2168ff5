# Mirrors attitude_core.record.metrics (dense_min_margin_deg): the compiled screen of a
# sampled run's dense margin (paper eq. 5 at every interpolated attitude), reached
# through ConeGeometry.dense_interval_minima. It only chooses which intervals the NumPy
# reference (dense_min_margin_deg_reference) measures, so the result is the reference's
# to the bit (tests/core/test_dense_margin.py); its own margins are within 1e-12 deg.

from libc.math cimport acos, cos, fabs, sin, sqrt, INFINITY
from libc.stdlib cimport free, malloc


cdef inline void _quat_rows(
    double q0, double q1, double q2, double q3, double* r
) noexcept nogil:
    """Rows of ``C_BN`` of the scalar-first Euler parameters ``q`` of any non-zero norm
    (those of ``q / |q|``): ``C = (q0^2 - v.v) I + 2 v v^T - 2 q0 [v x]``, over ``|q|^2``."""
    cdef double n2 = q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3
    cdef double k = 1.0 / n2
    cdef double d = (q0 * q0 - (q1 * q1 + q2 * q2 + q3 * q3)) * k
    cdef double k2 = 2.0 * k
    r[0] = d + k2 * q1 * q1
    r[1] = k2 * (q1 * q2 + q0 * q3)
    r[2] = k2 * (q1 * q3 - q0 * q2)
    r[3] = k2 * (q1 * q2 - q0 * q3)
    r[4] = d + k2 * q2 * q2
    r[5] = k2 * (q2 * q3 + q0 * q1)
    r[6] = k2 * (q1 * q3 + q0 * q2)
    r[7] = k2 * (q2 * q3 - q0 * q1)
    r[8] = d + k2 * q3 * q3


cdef inline double _screened_margin(
    const double[:, ::1] keep_out, const double[:, ::1] keep_in,
    const double* lo, const double* hi, const double* r
) noexcept nogil:
    """Smallest exact margin (deg) at the attitude with DCM rows ``r`` over the
    constraints whose cosine passes its screen: a keep-out cosine below ``lo[p]`` or a
    keep-in cosine above ``hi[k]`` is not measured (its margin is above the level the
    screens were set for). ``INFINITY`` when none passes."""
    cdef Py_ssize_t p
    cdef double best = INFINITY, bx = 0.0, by = 0.0, bz = 0.0, c, m
    cdef double sx = INFINITY, sy = INFINITY, sz = INFINITY
    for p in range(keep_out.shape[0]):
        if keep_out[p, 0] != sx or keep_out[p, 1] != sy or keep_out[p, 2] != sz:
            sx, sy, sz = keep_out[p, 0], keep_out[p, 1], keep_out[p, 2]
            bx = sx * r[0] + sy * r[3] + sz * r[6]
            by = sx * r[1] + sy * r[4] + sz * r[7]
            bz = sx * r[2] + sy * r[5] + sz * r[8]
        c = bx * keep_out[p, 3] + by * keep_out[p, 4] + bz * keep_out[p, 5]
        if c < lo[p]:
            continue
        m = acos(_clip1(c)) * _RAD_TO_DEG - keep_out[p, 6]
        if m < best:
            best = m
    for p in range(keep_in.shape[0]):
        bx = keep_in[p, 0] * r[0] + keep_in[p, 1] * r[3] + keep_in[p, 2] * r[6]
        by = keep_in[p, 0] * r[1] + keep_in[p, 1] * r[4] + keep_in[p, 2] * r[7]
        bz = keep_in[p, 0] * r[2] + keep_in[p, 1] * r[5] + keep_in[p, 2] * r[8]
        c = bx * keep_in[p, 3] + by * keep_in[p, 4] + bz * keep_in[p, 5]
        if c > hi[p]:
            continue
        m = keep_in[p, 6] - acos(_clip1(c)) * _RAD_TO_DEG
        if m < best:
            best = m
    return best


cdef void _screens(
    const double[:, ::1] keep_out, const double[:, ::1] keep_in, double level,
    double* lo, double* hi
) noexcept nogil:
    """Cosine screens for margins up to ``level`` (deg): a keep-out margin
    ``acos(c) - angle`` is above ``level`` when ``c < lo``, a keep-in margin
    ``angle - acos(c)`` when ``c > hi``. ``acos`` is monotonic with a slope of magnitude
    at least 1, so the 1e-12 of slack in the cosine covers the rounding of ``cos`` and
    ``acos`` many times over."""
    cdef Py_ssize_t p
    cdef double a
    for p in range(keep_out.shape[0]):
        a = (level + keep_out[p, 6]) / _RAD_TO_DEG
        if a >= _PI or a != a:
            lo[p] = -INFINITY  # measure every cosine
        elif a < 0.0:
            lo[p] = INFINITY  # none
        else:
            lo[p] = cos(a) - 1e-12
    for p in range(keep_in.shape[0]):
        a = (keep_in[p, 6] - level) / _RAD_TO_DEG
        if a <= 0.0 or a != a:
            hi[p] = INFINITY
        elif a > _PI:
            hi[p] = -INFINITY
        else:
            hi[p] = cos(a) + 1e-12


cdef inline void _hermite(
    const double[::1] t, const double[:, ::1] q, const double[:, ::1] qd,
    const double[:, ::1] basis, Py_ssize_t i, Py_ssize_t j, double* out
) noexcept nogil:
    """The cubic Hermite quaternion of interval ``i`` at substep ``j``, unnormalised:
    ``h00 q_i + h10 h qd_i + h01 q_i+1 + h11 h qd_i+1`` (``basis`` rows h00, h10, h01,
    h11), the reference's operations in its order."""
    cdef double h = t[i + 1] - t[i]
    cdef double a = basis[0, j], b = basis[1, j] * h, c = basis[2, j], d = basis[3, j] * h
    cdef Py_ssize_t k
    for k in range(4):
        out[k] = a * q[i, k] + b * qd[i, k] + c * q[i + 1, k] + d * qd[i + 1, k]


cdef inline bint _any_passes(
    const double[:, ::1] keep_out, const double[:, ::1] keep_in,
    const double* lo, const double* hi, const double* r
) noexcept nogil:
    """Whether a constraint's cosine at the attitude with DCM rows ``r`` passes its
    screen (:func:`_screens`)."""
    cdef Py_ssize_t p
    cdef double bx = 0.0, by = 0.0, bz = 0.0, c
    cdef double sx = INFINITY, sy = INFINITY, sz = INFINITY
    for p in range(keep_out.shape[0]):
        if keep_out[p, 0] != sx or keep_out[p, 1] != sy or keep_out[p, 2] != sz:
            sx, sy, sz = keep_out[p, 0], keep_out[p, 1], keep_out[p, 2]
            bx = sx * r[0] + sy * r[3] + sz * r[6]
            by = sx * r[1] + sy * r[4] + sz * r[7]
            bz = sx * r[2] + sy * r[5] + sz * r[8]
        c = bx * keep_out[p, 3] + by * keep_out[p, 4] + bz * keep_out[p, 5]
        if not c < lo[p]:
            return True
    for p in range(keep_in.shape[0]):
        bx = keep_in[p, 0] * r[0] + keep_in[p, 1] * r[3] + keep_in[p, 2] * r[6]
        by = keep_in[p, 0] * r[1] + keep_in[p, 1] * r[4] + keep_in[p, 2] * r[7]
        bz = keep_in[p, 0] * r[2] + keep_in[p, 1] * r[5] + keep_in[p, 2] * r[8]
        c = bx * keep_in[p, 3] + by * keep_in[p, 4] + bz * keep_in[p, 5]
        if not c > hi[p]:
            return True
    return False


cdef inline double _reach(
    const double[::1] t, const double[:, ::1] q, const double[:, ::1] qd, Py_ssize_t i
) noexcept nogil:
    """A bound of ``|q(s) - q_i| / |q_i|`` over interval ``i``'s Hermite curve, ``s`` in
    [0, 1]: ``q(s) - q_i = h01 (q_i+1 - q_i) + h h10 qd_i + h h11 qd_i+1`` with
    ``0 <= h01 <= 1`` and ``|h10|, |h11| <= 4/27``."""
    cdef double h = t[i + 1] - t[i], dq = 0.0, d0 = 0.0, d1 = 0.0, n0 = 0.0, x
    cdef Py_ssize_t k
    for k in range(4):
        x = q[i + 1, k] - q[i, k]
        dq += x * x
        d0 += qd[i, k] * qd[i, k]
        d1 += qd[i + 1, k] * qd[i + 1, k]
        n0 += q[i, k] * q[i, k]
    return (sqrt(dq) + (4.0 / 27.0) * fabs(h) * (sqrt(d0) + sqrt(d1))) / sqrt(n0)


cdef bint _conditioned(
    const double[:, ::1] keep_out, const double[:, ::1] keep_in, double margin
) noexcept nogil:
    """Whether every constraint that can have ``margin`` (deg) has it at an angle from
    its direction whose sine is at least 0.1 (more than 5.7 deg from 0 and 180 deg):
    there ``acos`` turns a difference of ``d`` in the cosine into at most ``10 d`` rad."""
    cdef Py_ssize_t p
    cdef double a
    for p in range(keep_out.shape[0] + keep_in.shape[0]):
        if p < keep_out.shape[0]:
            a = margin + keep_out[p, 6]
        else:
            a = keep_in[p - keep_out.shape[0], 6] - margin
        if a > -1.0 and a < 181.0 and sin(a / _RAD_TO_DEG) < 0.1:
            return False
    return True


# Largest reach (:func:`_reach`) for which an interval's rotation bound is used: with
# ``x`` the reach, the attitude turns by at most ``4 asin(x) <= _ASIN_RATIO 4 x`` from
# the interval's start (``asin(x) / x`` grows with ``x``; ``asin(1/2) = pi / 6``).
cdef double _MAX_REACH = 0.5
cdef double _ASIN_RATIO = 1.0472


def dense_interval_minima(
    ConeKernel kernel,
    const double[::1] t,
    const double[:, ::1] q,
    const double[:, ::1] qd,
    const double[:, ::1] basis,
    double[::1] out,
    double slack,
):
    """The dense margin screen of a sampled run (``ConeGeometry.dense_interval_minima``).

    ``t`` (N,), ``q`` (N, 4) scalar-first Euler parameters with a continuous sign, ``qd``
    (N, 4) their rates, ``basis`` (4, S + 1) the Hermite basis at the substeps. Into
    ``out`` (N - 1,): per interval the smallest exact margin (deg) over its S + 1
    interpolated attitudes, exactly for each interval whose smallest is within ``slack``
    of the run's; any other holds a larger value (``INFINITY`` when none of its margins
    was measured). Returns the run's smallest margin, or ``INFINITY`` (nothing screened)
    when an input is not finite or a constraint is ill-conditioned there (4.).

    The margins differ from the NumPy reference's through the cosines' rounding (a few
    1e-16, far below 5e-14) and ``acos``'s; where every constraint that can hold the
    smallest margin is at an angle whose sine is at least 0.1 (4.), that is at most
    5e-13 rad, 3e-11 deg (1e-13 deg in practice), so a ``slack`` of 1e-9 deg keeps every
    interval that can hold the reference's minimum.

    1. An upper bound of the run's smallest margin: the margins at every eighth
       interval's start and at the run's end. ``level``: that bound plus ``slack``.
    2. Each interval's attitudes stay within a rotation ``theta_i`` of its start
       (:func:`_reach`), and a margin changes by at most the rotation. With ``theta``
       the largest of them, an interval none of whose margins at its start is within
       ``level + theta`` holds no margin at or below ``level``: it is skipped.
    3. The others' interpolated attitudes are measured, only the margins at or below
       ``level`` (cosine screens, :func:`_screens`).
    4. The conditioning at the smallest margin (:func:`_conditioned`).
    """
    cdef const double[:, ::1] keep_out = kernel.keep_out
    cdef const double[:, ::1] keep_in = kernel.keep_in
    cdef Py_ssize_t n = t.shape[0], s1 = basis.shape[1], n_out = keep_out.shape[0]
    cdef Py_ssize_t n_in = keep_in.shape[0], n_c = n_out + n_in, i, j, k
    if n < 2 or q.shape[0] != n or qd.shape[0] != n or q.shape[1] != 4 or qd.shape[1] != 4:
        raise ValueError("dense_interval_minima: t (N >= 2,), q and qd (N, 4) expected")
    if basis.shape[0] != 4 or s1 < 2 or out.shape[0] != n - 1:
        raise ValueError("dense_interval_minima: basis (4, S + 1) and out (N - 1,) expected")
    if not slack >= 0.0:
        raise ValueError("dense_interval_minima: slack must be >= 0")
    cdef double* lo = <double*>malloc((2 * n_c + 1) * sizeof(double))
    if lo == NULL:
        raise MemoryError()
    cdef double* hi = lo + n_out
    cdef double* lo2 = lo + n_c
    cdef double* hi2 = lo2 + n_out
    cdef double r[9]
    cdef double qi[4]
    cdef double level, best = INFINITY, m, low, reach, theta = 0.0
    cdef bint finite = True, conditioned = False
    with nogil:
        for i in range(n):
            finite = finite and t[i] - t[i] == 0.0
            for k in range(4):
                finite = finite and q[i, k] - q[i, k] == 0.0 and qd[i, k] - qd[i, k] == 0.0
        if finite:
            # 1.
            for i in range(n_out):
                lo[i] = -INFINITY
            for i in range(n_in):
                hi[i] = INFINITY
            for i in range(0, n + 7, 8):
                if i < n - 1:
                    _hermite(t, q, qd, basis, i, 0, qi)
                else:
                    _hermite(t, q, qd, basis, n - 2, s1 - 1, qi)
                _quat_rows(qi[0], qi[1], qi[2], qi[3], r)
                m = _screened_margin(keep_out, keep_in, lo, hi, r)
                if m < best:
                    best = m
            level = best + slack
            # 2. theta in deg, with a relative margin far above its rounding
            for i in range(n - 1):
                reach = _reach(t, q, qd, i)
                if reach <= _MAX_REACH and reach > theta:
                    theta = reach
            theta = (4.0 * _ASIN_RATIO * theta * _RAD_TO_DEG) * (1.0 + 1e-9) + 1e-9
            _screens(keep_out, keep_in, level + theta, lo2, hi2)
            _screens(keep_out, keep_in, level, lo, hi)
            # 3.
            best = INFINITY
            for i in range(n - 1):
                low = INFINITY
                _quat_rows(q[i, 0], q[i, 1], q[i, 2], q[i, 3], r)
                if _reach(t, q, qd, i) > _MAX_REACH or _any_passes(keep_out, keep_in, lo2, hi2, r):
                    for j in range(s1):
                        _hermite(t, q, qd, basis, i, j, qi)
                        _quat_rows(qi[0], qi[1], qi[2], qi[3], r)
                        m = _screened_margin(keep_out, keep_in, lo, hi, r)
                        if m < low:
                            low = m
                out[i] = low
                if low < best:
                    best = low
            # 4.
            conditioned = _conditioned(keep_out, keep_in, best)
    free(lo)
    return best if finite and conditioned else INFINITY
