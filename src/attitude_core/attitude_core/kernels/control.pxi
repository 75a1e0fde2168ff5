# Mirrors attitude_core.fsw.control.pd (commanded_torque: pd_command_reference, the
# PD law of paper eq. 11) and attitude_core.fsw.control.saturation (scale_to_bound: the
# command scaled into the per-axis bound, its direction kept). The same operations in
# the same order as pd_command_reference: equal to the bit (tests/core/test_kernels.py).

from libc.math cimport fabs


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
