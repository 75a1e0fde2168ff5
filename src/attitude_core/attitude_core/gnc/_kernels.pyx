# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False, embedsignature=True
"""Compiled per-step kernels of the closed loop (C through Cython, built ahead of time).

Each function is the compiled form of a Python reference that stays in the core and is
what the tests compare against (``tests/core/test_kernels.py``):

* :func:`angle_between`, :func:`relative`: ``mrp.angle_between_single`` and
  ``mrp.relative_single``;
* :func:`pd_command`: eq. 11 with the controller's bound (``gnc.control.pd_torque``
  then ``gnc.actuators.scale_to_bound``);
* :func:`rk4_step`: one RK4 step of eqs. 3-4 with the shadow switch of eq. 2
  (``gnc.dynamics.RigidBody.step``, the same operations in the same order);
* :class:`LoopPlant`: both of them and the plant's clip for one step of the offline
  loop, written into the run's record (``closed_loop.LoopPlantReference``);
* :class:`ConeKernel`: a geometry's exact keep-out / keep-in margins at an attitude and
  along a short eigenaxis rotation (``ConeGeometry.min_margin_deg_single`` /
  ``arc_min_margin_deg_single``), the nearest MRP-space rim circle
  (``ConeGeometry.rim_distances_sq`` and the search of ``closest_obstacle``), and the
  dense margin of a sampled run's interpolated attitudes, interval by interval
  (``ConeGeometry.dense_interval_minima``: the screen of
  ``record.metrics.dense_min_margin_deg``, which finishes on its NumPy reference).

Arithmetic is IEEE double without contraction (``-ffp-contract=off``), in the
references' order where they are plain floats, with libm's functions as Python's
``math`` calls them (``pow`` too: ``-fno-builtin-pow`` keeps ``x ** 2`` a library call),
so those agree to the last bit; where a
reference goes through NumPy matrix products (the PD law, the rim distances) the sums
may round differently in the last bit. The dense-margin screen takes the attitude's
rotation matrix from its quaternion directly, so its margins differ from the NumPy
reference's in the last bits (about 1e-14 deg); its caller re-measures the few intervals
the screen keeps with the reference itself.
"""

from libc.math cimport acos, atan2, cos, fabs, fmod, pow, sin, sqrt, copysign, INFINITY
from libc.stdlib cimport free, malloc

import numpy as np

cdef double _PI = 3.141592653589793
cdef double _TWO_PI = 2.0 * 3.141592653589793
cdef double _RAD_TO_DEG = 180.0 / 3.141592653589793
cdef double HOLD_GUARD = 1e-9  # loop_plant.HOLD_GUARD


cdef inline double _pymod(double a, double b) noexcept nogil:
    """Python's float ``a % b`` (the result takes the sign of ``b``)."""
    cdef double m = fmod(a, b)
    if m != 0.0:
        if (b < 0.0) != (m < 0.0):
            m += b
    else:
        m = copysign(0.0, b)
    return m


cdef inline double _clip1(double x) noexcept nogil:
    """``min(max(x, -1.0), 1.0)``."""
    if x < -1.0:
        x = -1.0
    if x > 1.0:
        x = 1.0
    return x


cdef inline void _dcm_rows(double s1, double s2, double s3, double* r) noexcept nogil:
    """Rows of ``C_BN(sigma)`` into ``r[0..8]`` (``mrp.dcm_rows_from_mrp``)."""
    cdef double ss = s1 * s1 + s2 * s2 + s3 * s3
    # pow, as Python's ``** 2`` (libm's pow, which can differ from p * p in the last bit)
    cdef double p2 = pow(1.0 + ss, 2.0)
    cdef double k8 = 8.0 / p2
    cdef double k4 = 4.0 * (1.0 - ss) / p2
    r[0] = 1.0 + k8 * (s1 * s1 - ss)
    r[1] = k8 * s1 * s2 + k4 * s3
    r[2] = k8 * s1 * s3 - k4 * s2
    r[3] = k8 * s2 * s1 - k4 * s3
    r[4] = 1.0 + k8 * (s2 * s2 - ss)
    r[5] = k8 * s2 * s3 + k4 * s1
    r[6] = k8 * s3 * s1 + k4 * s2
    r[7] = k8 * s3 * s2 - k4 * s1
    r[8] = 1.0 + k8 * (s3 * s3 - ss)


cdef inline void _relative_euler(
    double b1, double b2, double b3, double r1, double r2, double r3, double* q
) noexcept nogil:
    """Unnormalised ``q_B/R`` (``mrp.relative_euler_single``)."""
    cdef double r0 = 1.0 - (r1 * r1 + r2 * r2 + r3 * r3)
    cdef double b0 = 1.0 - (b1 * b1 + b2 * b2 + b3 * b3)
    r1, r2, r3 = 2.0 * r1, 2.0 * r2, 2.0 * r3
    b1, b2, b3 = 2.0 * b1, 2.0 * b2, 2.0 * b3
    q[0] = r0 * b0 + r1 * b1 + r2 * b2 + r3 * b3
    q[1] = r0 * b1 - b0 * r1 - (r2 * b3 - r3 * b2)
    q[2] = r0 * b2 - b0 * r2 - (r3 * b1 - r1 * b3)
    q[3] = r0 * b3 - b0 * r3 - (r1 * b2 - r2 * b1)


cdef inline void _relative(
    double b1, double b2, double b3, double r1, double r2, double r3, double* out
) noexcept nogil:
    """``sigma_B/R``, short way (``mrp.relative_single``)."""
    cdef double q[4]
    _relative_euler(b1, b2, b3, r1, r2, r3, q)
    cdef double sb = b1 * b1 + b2 * b2 + b3 * b3
    cdef double sr = r1 * r1 + r2 * r2 + r3 * r3
    cdef double norm = (1.0 + sb) * (1.0 + sr)
    cdef double k
    if q[0] >= 0.0:
        k = 1.0 / (norm + q[0])
    else:
        k = -1.0 / (norm - q[0])
    out[0] = q[1] * k
    out[1] = q[2] * k
    out[2] = q[3] * k


cdef inline double _angle(
    double a1, double a2, double a3, double b1, double b2, double b3
) noexcept nogil:
    """Principal angle (rad, ``[0, pi]``) between two attitudes
    (``mrp.angle_between_single_reference``)."""
    cdef double sa = a1 * a1 + a2 * a2 + a3 * a3
    cdef double sb = b1 * b1 + b2 * b2 + b3 * b3
    cdef double a0 = 1.0 - sa, b0 = 1.0 - sb
    a1, a2, a3 = 2.0 * a1, 2.0 * a2, 2.0 * a3
    b1, b2, b3 = 2.0 * b1, 2.0 * b2, 2.0 * b3
    cdef double w = a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3
    cdef double v1 = b0 * a1 - a0 * b1 - (a2 * b3 - a3 * b2)
    cdef double v2 = b0 * a2 - a0 * b2 - (a3 * b1 - a1 * b3)
    cdef double v3 = b0 * a3 - a0 * b3 - (a1 * b2 - a2 * b1)
    return 2.0 * atan2(sqrt(v1 * v1 + v2 * v2 + v3 * v3), fabs(w))


def angle_between(sigma_a, sigma_b):
    """Principal angle (rad, ``[0, pi]``) between two attitudes
    (``mrp.angle_between_single_reference``)."""
    return _angle(sigma_a[0], sigma_a[1], sigma_a[2], sigma_b[0], sigma_b[1], sigma_b[2])


def relative(sigma_bn, sigma_rn):
    """``sigma_B/R``, short way, as a 3-tuple (``mrp.relative_single_reference``)."""
    cdef double out[3]
    _relative(sigma_bn[0], sigma_bn[1], sigma_bn[2], sigma_rn[0], sigma_rn[1], sigma_rn[2], out)
    return out[0], out[1], out[2]


cdef inline bint _pd(
    const double* g, const double* d, const double* s, const double* w, const double* sr,
    const double* wr, const double* bound, double* u
) noexcept nogil:
    """Eq. 11 into ``u``, scaled into ``bound`` (3 limits, or NULL): True when scaled."""
    cdef double e[3]
    cdef double c[9]
    cdef int i
    _relative(s[0], s[1], s[2], sr[0], sr[1], sr[2], e)
    _dcm_rows(e[0], e[1], e[2], c)
    cdef double o1 = wr[0], o2 = wr[1], o3 = wr[2]
    cdef double w1 = w[0] - (c[0] * o1 + c[1] * o2 + c[2] * o3)
    cdef double w2 = w[1] - (c[3] * o1 + c[4] * o2 + c[5] * o3)
    cdef double w3 = w[2] - (c[6] * o1 + c[7] * o2 + c[8] * o3)
    for i in range(3):
        u[i] = -(g[3 * i] * e[0] + g[3 * i + 1] * e[1] + g[3 * i + 2] * e[2]) - (
            d[3 * i] * w1 + d[3 * i + 1] * w2 + d[3 * i + 2] * w3
        )
    if bound == NULL:
        return False
    cdef double ratio = fabs(u[0]) / bound[0]
    cdef double r
    for i in range(1, 3):
        r = fabs(u[i]) / bound[i]
        if r > ratio:
            ratio = r
    if ratio <= 1.0:
        return False
    for i in range(3):
        u[i] = u[i] / ratio
    return True


def pd_command(
    tuple kp, tuple kd, sigma_bn, omega_b, sigma_rn, omega_r, bound
):
    """Eq. 11 scaled into the bound: ``(u1, u2, u3, saturated)``, N m, body axes.

    ``kp``, ``kd``: the gain matrices row-major (9 floats); ``sigma_rn``, ``omega_r``:
    the target and its rate in target axes; ``bound``: 3 per-axis limits or None.
    """
    cdef double g[9]
    cdef double d[9]
    cdef double s[3]
    cdef double w[3]
    cdef double sr[3]
    cdef double wr[3]
    cdef double b[3]
    cdef double u[3]
    cdef int i
    for i in range(9):
        g[i] = kp[i]
        d[i] = kd[i]
    for i in range(3):
        s[i] = sigma_bn[i]
        w[i] = omega_b[i]
        sr[i] = sigma_rn[i]
        wr[i] = omega_r[i]
    if bound is not None:
        for i in range(3):
            b[i] = bound[i]
    cdef bint scaled = _pd(g, d, s, w, sr, wr, NULL if bound is None else b, u)
    return u[0], u[1], u[2], scaled


cdef inline void _deriv(
    const double* j, const double* ji, const double* u, const double* s, const double* w,
    double* ds, double* dw
) noexcept nogil:
    """Eqs. 3-4: ``(sigma_dot, omega_dot)`` (the reference's ``deriv``)."""
    cdef double w1 = w[0], w2 = w[1], w3 = w[2]
    cdef double h1 = j[0] * w1 + j[1] * w2 + j[2] * w3
    cdef double h2 = j[3] * w1 + j[4] * w2 + j[5] * w3
    cdef double h3 = j[6] * w1 + j[7] * w2 + j[8] * w3
    cdef double r1 = u[0] - (w2 * h3 - w3 * h2)
    cdef double r2 = u[1] - (w3 * h1 - w1 * h3)
    cdef double r3 = u[2] - (w1 * h2 - w2 * h1)
    dw[0] = ji[0] * r1 + ji[1] * r2 + ji[2] * r3
    dw[1] = ji[3] * r1 + ji[4] * r2 + ji[5] * r3
    dw[2] = ji[6] * r1 + ji[7] * r2 + ji[8] * r3
    cdef double s1 = s[0], s2 = s[1], s3 = s[2]
    cdef double ss = s1 * s1 + s2 * s2 + s3 * s3
    cdef double sw = s1 * w1 + s2 * w2 + s3 * w3
    cdef double a = 1.0 - ss
    ds[0] = 0.25 * (a * w1 + 2.0 * (s2 * w3 - s3 * w2) + 2.0 * s1 * sw)
    ds[1] = 0.25 * (a * w2 + 2.0 * (s3 * w1 - s1 * w3) + 2.0 * s2 * sw)
    ds[2] = 0.25 * (a * w3 + 2.0 * (s1 * w2 - s2 * w1) + 2.0 * s3 * sw)


cdef inline void _rk4(
    const double* j, const double* ji, const double* u, const double* s0, const double* w0,
    double dt, double* s, double* w
) noexcept nogil:
    """One RK4 step of eqs. 3-4 with ``u`` held, then the shadow switch (eq. 2)."""
    cdef double k1s[3]
    cdef double k1w[3]
    cdef double k2s[3]
    cdef double k2w[3]
    cdef double k3s[3]
    cdef double k3w[3]
    cdef double k4s[3]
    cdef double k4w[3]
    cdef double xs[3]
    cdef double xw[3]
    cdef double h = 0.5 * dt
    cdef int i
    _deriv(j, ji, u, s0, w0, k1s, k1w)
    for i in range(3):
        xs[i] = s0[i] + h * k1s[i]
        xw[i] = w0[i] + h * k1w[i]
    _deriv(j, ji, u, xs, xw, k2s, k2w)
    for i in range(3):
        xs[i] = s0[i] + h * k2s[i]
        xw[i] = w0[i] + h * k2w[i]
    _deriv(j, ji, u, xs, xw, k3s, k3w)
    for i in range(3):
        xs[i] = s0[i] + dt * k3s[i]
        xw[i] = w0[i] + dt * k3w[i]
    _deriv(j, ji, u, xs, xw, k4s, k4w)
    cdef double f = dt / 6.0
    for i in range(3):
        s[i] = s0[i] + f * (k1s[i] + 2.0 * k2s[i] + 2.0 * k3s[i] + k4s[i])
        w[i] = w0[i] + f * (k1w[i] + 2.0 * k2w[i] + 2.0 * k3w[i] + k4w[i])
    cdef double ss = s[0] * s[0] + s[1] * s[1] + s[2] * s[2]
    if ss > 1.0:
        for i in range(3):
            s[i] = -s[i] / ss


def rk4_step(tuple inertia, tuple inertia_inv, sigma_bn, omega_b, torque_b, double dt):
    """One RK4 step of eqs. 3-4 with ``torque_b`` held, then the shadow switch (eq. 2):
    ``(sigma_bn, omega_b)`` after ``dt`` seconds as two 3-tuples. ``inertia``,
    ``inertia_inv``: ``J`` and ``J^-1`` row-major (9 floats)."""
    cdef double j[9]
    cdef double ji[9]
    cdef int i
    for i in range(9):
        j[i] = inertia[i]
        ji[i] = inertia_inv[i]
    cdef double u[3]
    cdef double s0[3]
    cdef double w0[3]
    for i in range(3):
        u[i] = torque_b[i]
        s0[i] = sigma_bn[i]
        w0[i] = omega_b[i]
    cdef double s[3]
    cdef double w[3]
    _rk4(j, ji, u, s0, w0, dt, s, w)
    return (s[0], s[1], s[2]), (w[0], w[1], w[2])


cdef class LoopPlant:
    """The offline loop's controller and plant for one run, writing its record in place
    (the compiled form of ``closed_loop.LoopPlantReference``).

    :meth:`step` at step ``k``: the PD command from the state the loop is fed and the
    target (:func:`pd_command`), the plant's per-axis clip (``actuators.clip_to_bound``),
    the record's row ``k`` (torque, target) and, unless ``k`` is the last row, one RK4
    step of the body from row ``k`` to row ``k + 1`` (:func:`rk4_step`). The arrays are
    the run's ``(n + 1, 3)`` C-contiguous float arrays; row 0 of ``sigma`` and ``omega``
    holds the initial state.
    """

    cdef double g[9]
    cdef double d[9]
    cdef double j[9]
    cdef double ji[9]
    cdef double b[3]
    cdef bint bounded
    cdef double dt
    cdef double[:, ::1] sigma
    cdef double[:, ::1] omega
    cdef double[:, ::1] torque
    cdef double[:, ::1] sigma_t
    cdef double[:, ::1] omega_t

    def __init__(
        self, tuple kp, tuple kd, bound, tuple inertia, tuple inertia_inv, double dt,
        double[:, ::1] sigma, double[:, ::1] omega, double[:, ::1] torque,
        double[:, ::1] sigma_t, double[:, ::1] omega_t,
    ):
        cdef int i
        for i in range(9):
            self.g[i] = kp[i]
            self.d[i] = kd[i]
            self.j[i] = inertia[i]
            self.ji[i] = inertia_inv[i]
        self.bounded = bound is not None
        if self.bounded:
            for i in range(3):
                self.b[i] = bound[i]
        self.dt = dt
        self.sigma, self.omega, self.torque = sigma, omega, torque
        self.sigma_t, self.omega_t = sigma_t, omega_t

    def step(self, Py_ssize_t k, sigma_m, omega_m, target_sigma, target_omega):
        cdef double s[3]
        cdef double w[3]
        cdef double sr[3]
        cdef double wr[3]
        cdef int i
        for i in range(3):
            s[i] = sigma_m[i]
            w[i] = omega_m[i]
            sr[i] = target_sigma[i]
            wr[i] = target_omega[i]
        self._row(k, s, w, sr, wr)

    cdef void _row(
        self, Py_ssize_t k, const double* s, const double* w, const double* sr, const double* wr
    ) noexcept:
        cdef double u[3]
        cdef double x
        cdef int i
        _pd(self.g, self.d, s, w, sr, wr, self.b if self.bounded else NULL, u)
        if self.bounded:  # min(max(x, -b), b), as the plant's clip
            for i in range(3):
                x = u[i]
                if x < -self.b[i]:
                    x = -self.b[i]
                if self.b[i] < x:
                    x = self.b[i]
                u[i] = x
        for i in range(3):
            self.torque[k, i] = u[i]
            self.sigma_t[k, i] = sr[i]
            self.omega_t[k, i] = wr[i]
        if k + 1 < self.sigma.shape[0]:
            _rk4(self.j, self.ji, u, &self.sigma[k, 0], &self.omega[k, 0], self.dt,
                 &self.sigma[k + 1, 0], &self.omega[k + 1, 0])

    def hold(
        self, Py_ssize_t k, Py_ssize_t stop, goal, target_sigma, target_omega,
        double band_deg, double band_rate,
    ):
        """Steps ``k, k + 1, ...`` (before ``stop``) fed the body's own state and one
        target, while the body is inside the band (``loop_plant.LoopPlantReference.hold``);
        returns the first step not taken."""
        cdef double sr[3]
        cdef double wr[3]
        cdef double gl[3]
        cdef double e_lim = band_deg * (1.0 - HOLD_GUARD)
        cdef double r_lim = band_rate * (1.0 - HOLD_GUARD)
        cdef double e, r
        cdef double* s
        cdef double* w
        cdef int i
        for i in range(3):
            sr[i] = target_sigma[i]
            wr[i] = target_omega[i]
            gl[i] = goal[i]
        while k < stop:
            s = &self.sigma[k, 0]
            w = &self.omega[k, 0]
            # the guidance's attitude error, deg
            e = _angle(s[0], s[1], s[2], gl[0], gl[1], gl[2]) * _RAD_TO_DEG
            r = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
            if not (e <= e_lim and r <= r_lim):  # NaN leaves too
                break
            self._row(k, s, w, sr, wr)
            k += 1
        return k


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


include "_fepf_kernel.pxi"
include "_guidance_kernel.pxi"
