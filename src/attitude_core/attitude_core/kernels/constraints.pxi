# Mirrors attitude_core.models.constraints (ConeGeometry): the exact keep-out / keep-in
# margins of paper eq. 5 at an attitude (min_margin_deg_single_reference) and along a
# short eigenaxis rotation (arc_min_margin_deg_single_reference, arc_cos_extremes), the
# nearest MRP-space rim circle (rim_distances_sq and closest_rim_reference's argmin) and
# the closest inflated obstacle (closest_obstacle_single_reference). The margins, the
# rim distances and the obstacle query are their references' operations in the same
# order: equal to the bit (tests/core/test_kernels.py).

from libc.math cimport acos, atan2, cos, fabs, sin, sqrt, INFINITY

import numpy as np


cdef double _min_margin(
    const double[:, ::1] keep_out, const double[:, ::1] keep_in, const double* r
) noexcept nogil:
    """Smallest exact margin at the attitude with DCM rows ``r`` (deg)."""
    cdef Py_ssize_t p
    cdef double best = INFINITY, bx, by, bz, cosang, m
    for p in range(keep_out.shape[0]):
        bx = keep_out[p, 0] * r[0] + keep_out[p, 1] * r[3] + keep_out[p, 2] * r[6]
        by = keep_out[p, 0] * r[1] + keep_out[p, 1] * r[4] + keep_out[p, 2] * r[7]
        bz = keep_out[p, 0] * r[2] + keep_out[p, 1] * r[5] + keep_out[p, 2] * r[8]
        cosang = bx * keep_out[p, 3] + by * keep_out[p, 4] + bz * keep_out[p, 5]
        m = acos(_clip1(cosang)) * _RAD_TO_DEG - keep_out[p, 6]
        if m < best:
            best = m
    for p in range(keep_in.shape[0]):
        bx = keep_in[p, 0] * r[0] + keep_in[p, 1] * r[3] + keep_in[p, 2] * r[6]
        by = keep_in[p, 0] * r[1] + keep_in[p, 1] * r[4] + keep_in[p, 2] * r[7]
        bz = keep_in[p, 0] * r[2] + keep_in[p, 1] * r[5] + keep_in[p, 2] * r[8]
        cosang = _clip1(bx * keep_in[p, 3] + by * keep_in[p, 4] + bz * keep_in[p, 5])
        m = keep_in[p, 6] - acos(cosang) * _RAD_TO_DEG
        if m < best:
            best = m
    return best


cdef inline void _extremes(
    double e1, double e2, double e3, double cos_t, double sin_t, double angle,
    double vx, double vy, double vz, double x, double y, double z, double* out
) noexcept nogil:
    """``(largest, smallest)`` of ``c . v(phi)`` for ``phi`` in ``[0, angle]``."""
    cdef double a = (e1 * vx + e2 * vy + e3 * vz) * (e1 * x + e2 * y + e3 * z)
    cdef double start = x * vx + y * vy + z * vz
    cdef double b = start - a
    cdef double cc = x * (e2 * vz - e3 * vy) + y * (e3 * vx - e1 * vz) + z * (e1 * vy - e2 * vx)
    cdef double end = a + b * cos_t + cc * sin_t
    cdef double r = sqrt(b * b + cc * cc)
    cdef double phi = _pymod(atan2(cc, b), _TWO_PI)
    if phi <= angle:
        out[0] = a + r
    else:
        out[0] = start if start > end else end
    if _pymod(phi + _PI, _TWO_PI) <= angle:
        out[1] = a - r
    else:
        out[1] = start if start < end else end


cdef inline double _circle_d2(
    const double[:, ::1] c, Py_ssize_t i, double sx, double sy, double sz, double s2
) noexcept nogil:
    """Squared distance from ``sigma`` to circle ``i``, in ``rim_distances_sq``'s order:
    ``|sigma - centre|^2 - 2 r rho + r^2`` with ``rho`` the radial offset."""
    cdef double dd = -2.0 * (c[i, 0] * sx + c[i, 1] * sy + c[i, 2] * sz) + c[i, 6]
    dd = dd + s2
    cdef double h = (c[i, 3] * sx + c[i, 4] * sy + c[i, 5] * sz) - c[i, 7]
    h = dd - h * h
    if h < 0.0:
        h = 0.0
    h = sqrt(h) * c[i, 9]
    dd = dd + c[i, 8]
    dd = dd - h
    return dd if dd > 0.0 else 0.0


cdef class ConeKernel:
    """The exact margins and the MRP-space rim search of one ``ConeGeometry``.

    ``keep_out`` rows: boresight (body), object direction (inertial), angle (deg);
    ``keep_in`` rows: body axis, inertial direction, largest angle (deg); ``circles``
    rows: centre (3), unit normal (3), ``centre . centre``, ``centre . normal``,
    ``radius^2``, ``2 radius``, the circles of a rim consecutive, ``samples`` per rim.
    """

    cdef const double[:, ::1] keep_out
    cdef const double[:, ::1] keep_in
    cdef const double[:, ::1] circles
    cdef Py_ssize_t samples
    cdef double[:, ::1] rims  # per rim: body vector, inertial direction, angle, d2 slack
    cdef const double[:, ::1] rim_dirs  # per circle: its rim direction (inertial)
    cdef double[:, ::1] rim_now  # per rim, this query's: the body vector (inertial), bound^2

    def __init__(
        self,
        const double[:, ::1] keep_out,
        const double[:, ::1] keep_in,
        const double[:, ::1] circles,
        Py_ssize_t samples,
        const double[:, ::1] rims=None,
        const double[:, ::1] rim_dirs=None,
    ):
        if keep_out.shape[1] != 7 or keep_in.shape[1] != 7 or circles.shape[1] != 10:
            raise ValueError("ConeKernel: rows of 7, 7 and 10 values expected")
        if samples < 1 or circles.shape[0] % samples != 0:
            raise ValueError("ConeKernel: circles must be whole rims of `samples` each")
        cdef Py_ssize_t n_rims = circles.shape[0] // samples, p, i
        if n_rims > 0 and (rims is None or rims.shape[0] != n_rims or rims.shape[1] != 7):
            raise ValueError("ConeKernel: one row of 7 values per rim expected")
        if n_rims > 0 and (
            rim_dirs is None or rim_dirs.shape[0] != circles.shape[0] or rim_dirs.shape[1] != 3
        ):
            raise ValueError("ConeKernel: one rim direction per circle expected")
        self.rim_dirs = rim_dirs if n_rims > 0 else np.zeros((0, 3))
        self.keep_out = keep_out
        self.keep_in = keep_in
        self.circles = circles
        self.samples = samples
        # The rims' rows and the slack of a computed squared distance: 1e-12 of the
        # largest |centre| + radius (+1) squared of the rim's circles (its rounding is a
        # few ulps of those terms).
        self.rims = np.empty((n_rims, 8))
        self.rim_now = np.empty((n_rims, 4))
        cdef double size, big
        for p in range(n_rims):
            for i in range(7):
                self.rims[p, i] = rims[p, i]
            big = 0.0
            for i in range(p * samples, (p + 1) * samples):
                size = sqrt(circles[i, 6]) + 0.5 * circles[i, 9] + 1.0
                if not (size <= big):  # NaN and infinity too: no pruning of that rim
                    big = size
            self.rims[p, 7] = 1e-12 * big * big

    def min_margin_deg(self, sigma_bn):
        """Smallest exact margin at ``sigma_bn`` over every constraint, degrees
        (``ConeGeometry.min_margin_deg_single``)."""
        return self._margin(sigma_bn[0], sigma_bn[1], sigma_bn[2])

    cdef double _margin(self, double s1, double s2, double s3) noexcept:
        cdef double r[9]
        _dcm_rows(s1, s2, s3, r)
        return _min_margin(self.keep_out, self.keep_in, r)

    def arc_min_margin_deg(self, sigma_a, sigma_b):
        """Smallest exact margin along the short eigenaxis rotation from ``sigma_a`` to
        ``sigma_b``, closed form (``ConeGeometry.arc_min_margin_deg_single``), degrees."""
        return self._arc(sigma_a[0], sigma_a[1], sigma_a[2], sigma_b[0], sigma_b[1], sigma_b[2])

    cdef double _arc(
        self, double a1, double a2, double a3, double b1, double b2, double b3
    ) noexcept:
        cdef const double[:, ::1] keep_out = self.keep_out
        cdef const double[:, ::1] keep_in = self.keep_in
        cdef double q[4]
        _relative_euler(b1, b2, b3, a1, a2, a3, q)
        if q[0] < 0.0:
            q[0], q[1], q[2], q[3] = -q[0], -q[1], -q[2], -q[3]
        cdef double n = sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        cdef double r[9]
        _dcm_rows(a1, a2, a3, r)
        if n == 0.0:
            return _min_margin(keep_out, keep_in, r)
        cdef double angle = 2.0 * atan2(n, q[0])
        if angle == 0.0:
            return _min_margin(keep_out, keep_in, r)
        cdef double f1 = q[1] / n, f2 = q[2] / n, f3 = q[3] / n
        cdef double e1 = f1 * r[0] + f2 * r[3] + f3 * r[6]
        cdef double e2 = f1 * r[1] + f2 * r[4] + f3 * r[7]
        cdef double e3 = f1 * r[2] + f2 * r[5] + f3 * r[8]
        cdef double cos_t = cos(angle), sin_t = sin(angle)
        cdef double best = INFINITY, vx, vy, vz, m
        cdef double ext[2]
        cdef Py_ssize_t p
        for p in range(keep_out.shape[0]):
            vx = keep_out[p, 0] * r[0] + keep_out[p, 1] * r[3] + keep_out[p, 2] * r[6]
            vy = keep_out[p, 0] * r[1] + keep_out[p, 1] * r[4] + keep_out[p, 2] * r[7]
            vz = keep_out[p, 0] * r[2] + keep_out[p, 1] * r[5] + keep_out[p, 2] * r[8]
            _extremes(e1, e2, e3, cos_t, sin_t, angle, vx, vy, vz,
                      keep_out[p, 3], keep_out[p, 4], keep_out[p, 5], ext)
            m = acos(_clip1(ext[0])) * _RAD_TO_DEG - keep_out[p, 6]
            if m < best:
                best = m
        for p in range(keep_in.shape[0]):
            vx = keep_in[p, 0] * r[0] + keep_in[p, 1] * r[3] + keep_in[p, 2] * r[6]
            vy = keep_in[p, 0] * r[1] + keep_in[p, 1] * r[4] + keep_in[p, 2] * r[7]
            vz = keep_in[p, 0] * r[2] + keep_in[p, 1] * r[5] + keep_in[p, 2] * r[8]
            _extremes(e1, e2, e3, cos_t, sin_t, angle, vx, vy, vz,
                      keep_in[p, 3], keep_in[p, 4], keep_in[p, 5], ext)
            m = keep_in[p, 6] - acos(_clip1(ext[1])) * _RAD_TO_DEG
            if m < best:
                best = m
        return best

    cdef Py_ssize_t _nearest(self, double sx, double sy, double sz) noexcept:
        """Index of the rim circle nearest ``sigma``: the first of equal squared
        distances, as the argmin over every circle (``rim_distances_sq``).

        Rims that cannot hold a circle as near as one already measured are skipped: a
        rotation by ``theta`` turns a body vector by at most ``theta``, and a straight
        MRP segment of length ``l`` spans a rotation of at most ``4 l`` (``|omega| =
        4 |sigma_dot| / (1 + |sigma|^2)``, eq. 12), so every circle of a rim of angle
        ``alpha`` is at least ``|angle(C^T s, c) - alpha| / 4`` from ``sigma`` (0.999 of
        it, less 1e-7 rad, is taken; a squared distance counts as nearer only beyond the
        rim's rounding slack). Within a rim, a circle is skipped the same way on the
        angle from the body vector's direction now to the circle's rim direction (every
        attitude of the circle points the body vector there). The circle whose rim
        direction is nearest, on the rim with the least bound, is measured first; the
        others then in order, so the answer is the full scan's to the bit."""
        cdef const double[:, ::1] circles = self.circles
        cdef const double[:, ::1] dirs = self.rim_dirs
        cdef double[:, ::1] rims = self.rims
        cdef double[:, ::1] now = self.rim_now
        cdef Py_ssize_t samples = self.samples, n_rims = rims.shape[0], p, i, first = 0
        cdef Py_ssize_t best_i = 0, lo, near = 0, k
        cdef double s2 = sx * sx + sy * sy + sz * sz
        cdef double r[9]
        cdef double bx, by, bz, m, lb, least = INFINITY, best = INFINITY, d2, ub, c, top
        cdef double theta, cos_min
        _dcm_rows(sx, sy, sz, r)
        for p in range(n_rims):
            bx = rims[p, 0] * r[0] + rims[p, 1] * r[3] + rims[p, 2] * r[6]
            by = rims[p, 0] * r[1] + rims[p, 1] * r[4] + rims[p, 2] * r[7]
            bz = rims[p, 0] * r[2] + rims[p, 1] * r[5] + rims[p, 2] * r[8]
            m = fabs(acos(_clip1(bx * rims[p, 3] + by * rims[p, 4] + bz * rims[p, 5])) - rims[p, 6])
            lb = 0.999 * 0.25 * (m - 1e-7)
            lb = lb * lb if lb > 0.0 else 0.0
            if not (lb >= 0.0):  # NaN: never skip
                lb = 0.0
            now[p, 0], now[p, 1], now[p, 2], now[p, 3] = bx, by, bz, lb
            if lb < least:
                least = lb
                first = p
        # An upper bound: the circles about the nearest rim direction of the least-bound rim.
        bx, by, bz = now[first, 0], now[first, 1], now[first, 2]
        lo = first * samples
        top = -INFINITY
        for i in range(lo, lo + samples):
            c = bx * dirs[i, 0] + by * dirs[i, 1] + bz * dirs[i, 2]
            if c > top:
                top = c
                near = i
        ub = INFINITY
        for k in range(-1, 2):
            d2 = _circle_d2(circles, lo + (near - lo + k + samples) % samples, sx, sy, sz, s2)
            if d2 < ub:
                ub = d2
        if not (ub < INFINITY):  # NaN distances: the full scan decides
            ub = INFINITY
        for p in range(n_rims):
            if now[p, 3] > ub + rims[p, 7]:
                continue
            lo = p * samples
            # The circles whose rim direction is farther than theta: beyond ub too (at
            # theta near pi or beyond, every circle is measured).
            theta = 1e-7 + 4.0 * sqrt(ub + rims[p, 7]) / 0.999
            cos_min = cos(theta) - 1e-12 if theta < 3.0 else -INFINITY
            bx, by, bz = now[p, 0], now[p, 1], now[p, 2]
            for i in range(lo, lo + samples):
                if bx * dirs[i, 0] + by * dirs[i, 1] + bz * dirs[i, 2] < cos_min:
                    continue
                d2 = _circle_d2(circles, i, sx, sy, sz, s2)
                if d2 < best:  # the first of equal distances, as argmin
                    best = d2
                    best_i = i
        return best_i

    def closest_rim(self, sigma):
        """The rim circle nearest ``sigma`` and its two neighbours on the same rim:
        ``(index, d2, d2_before, d2_after, index_before, index_after)``, ``d2`` the
        squared MRP distances (``ConeGeometry.rim_distances_sq`` and its argmin)."""
        cdef const double[:, ::1] circles = self.circles
        cdef double sx = sigma[0], sy = sigma[1], sz = sigma[2]
        cdef double s2 = sx * sx + sy * sy + sz * sz
        cdef Py_ssize_t samples = self.samples
        cdef Py_ssize_t best_i = self._nearest(sx, sy, sz)
        cdef Py_ssize_t base = (best_i // samples) * samples
        cdef Py_ssize_t j = best_i - base
        cdef Py_ssize_t jm = base + (j - 1 + samples) % samples
        cdef Py_ssize_t jp = base + (j + 1) % samples
        return (
            best_i, _circle_d2(circles, best_i, sx, sy, sz, s2),
            _circle_d2(circles, jm, sx, sy, sz, s2),
            _circle_d2(circles, jp, sx, sy, sz, s2), jm, jp,
        )

    cdef void _on_circle(
        self, Py_ssize_t i, double sx, double sy, double sz, double* out
    ) noexcept:
        """Closest point to ``sigma`` on circle ``i`` (``ConeGeometry._closest_on_circle``)."""
        cdef const double[:, ::1] c = self.circles
        cdef double cx = c[i, 0], cy = c[i, 1], cz = c[i, 2]
        cdef double nx = c[i, 3], ny = c[i, 4], nz = c[i, 5]
        cdef double radius = 0.5 * c[i, 9]
        cdef double dx = sx - cx, dy = sy - cy, dz = sz - cz
        cdef double h = dx * nx + dy * ny + dz * nz
        cdef double rx = dx - h * nx, ry = dy - h * ny, rz = dz - h * nz
        cdef double rn = sqrt(rx * rx + ry * ry + rz * rz)
        if rn < 1e-15:  # on the circle's axis: every point is equally close
            rx, ry, rz = ny, -nx, 0.0
            if fabs(nz) > 0.9:
                rx, ry, rz = 0.0, nz, -ny
            rn = sqrt(rx * rx + ry * ry + rz * rz)
        cdef double f = radius / rn
        out[0] = cx + f * rx
        out[1] = cy + f * ry
        out[2] = cz + f * rz

    def closest_obstacle(self, sigma, double inflation_deg):
        """``(distance, (direction), (closest point), constraint)`` of the closest
        inflated region (``ConeGeometry.closest_obstacle_single_reference``, on this
        kernel's rim search)."""
        cdef double out[7]
        cdef Py_ssize_t pair = self._closest(sigma[0], sigma[1], sigma[2], inflation_deg, out)
        return out[0], (out[1], out[2], out[3]), (out[4], out[5], out[6]), pair

    cdef Py_ssize_t _closest(
        self, double sx, double sy, double sz, double inflation_deg, double* out
    ) noexcept:
        """Into ``out``: distance, direction (3, zeros when it has none), closest point
        (3); returns the constraint."""
        cdef const double[:, ::1] circles = self.circles
        cdef double s2 = sx * sx + sy * sy + sz * sz
        cdef Py_ssize_t samples = self.samples
        cdef Py_ssize_t idx = self._nearest(sx, sy, sz)
        cdef Py_ssize_t base = (idx // samples) * samples
        cdef Py_ssize_t j = idx - base
        cdef Py_ssize_t jm = base + (j - 1 + samples) % samples
        cdef Py_ssize_t jp = base + (j + 1) % samples
        cdef double f0 = _circle_d2(circles, idx, sx, sy, sz, s2)
        cdef double fm = _circle_d2(circles, jm, sx, sy, sz, s2)
        cdef double fp = _circle_d2(circles, jp, sx, sy, sz, s2)
        # Parabola through (-1, fm), (0, f0), (1, fp): vertex offset t in [-1/2, 1/2].
        cdef double curv = fm - 2.0 * f0 + fp
        cdef double t = 0.0, best = f0, x
        if curv > 0.0:
            t = 0.5 * (fm - fp) / curv
            if -0.5 > t:  # min(max(t, -0.5), 0.5), as Python's
                t = -0.5
            if 0.5 < t:
                t = 0.5
            x = f0 - 0.25 * (fm - fp) * t
            best = 0.0 if 0.0 > x else x
        cdef double p0[3]
        cdef double pn[3]
        self._on_circle(idx, sx, sy, sz, p0)
        self._on_circle(jp if t >= 0.0 else jm, sx, sy, sz, pn)
        cdef double a = fabs(t)
        cdef double px = p0[0] + a * (pn[0] - p0[0])
        cdef double py = p0[1] + a * (pn[1] - p0[1])
        cdef double pz = p0[2] + a * (pn[2] - p0[2])
        cdef double vx = px - sx, vy = py - sy, vz = pz - sz
        cdef double norm = sqrt(vx * vx + vy * vy + vz * vz)
        cdef double dist = sqrt(best)
        cdef double r[9]
        _dcm_rows(sx, sy, sz, r)
        if _min_margin(self.keep_out, self.keep_in, r) < inflation_deg:
            dist, norm = -dist, -norm
        out[0] = dist
        if norm != 0.0:
            out[1], out[2], out[3] = vx / norm, vy / norm, vz / norm
        else:
            out[1], out[2], out[3] = 0.0, 0.0, 0.0
        out[4], out[5], out[6] = px, py, pz
        return idx // samples


cdef ConeKernel _cone_kernel(geometry, bint rims):
    """``geometry.compiled_kernel(rims)`` (``ConeGeometry.compiled_kernel``: its margins,
    with the rim search when ``rims``) when it is a ConeKernel; None otherwise (a
    geometry made without the compiled kernels)."""
    get = getattr(geometry, "compiled_kernel", None)
    if get is None:
        return None
    kernel = get(rims)
    return kernel if isinstance(kernel, ConeKernel) else None
