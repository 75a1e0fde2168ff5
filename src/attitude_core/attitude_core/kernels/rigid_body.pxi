# Mirrors attitude_core.world.rigid_body (RigidBody.step_reference): one RK4 step of
# paper eqs. 3-4 (MRP kinematics, Euler's equation) with the torque held, then the
# shadow switch of eq. 2. The same operations in the same order: equal to the bit
# (tests/core/test_kernels.py).


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
