# Mirrors attitude_core.models.mrp: the plain-float MRP helpers of the hot paths
# (dcm_rows_from_mrp, relative_euler_single, relative_single_reference,
# angle_between_single_reference, mrp_rate_single, omega_from_mrp_rate_single).
# Paper eqs. 1-3 (the MRP set, its shadow and the kinematics) and 12 (omega from the MRP
# rate). Each is its reference's operations in the same order: equal to the bit
# (tests/core/test_kernels.py).

from libc.math cimport atan2, fabs, pow, sqrt


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
    """``sigma_B/R``, short way (``mrp.relative_single_reference``)."""
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


cdef inline void _omega_from_rate(
    double s1, double s2, double s3, double d1, double d2, double d3, double* w
) noexcept:
    """Eq. 12 (``mrp.omega_from_mrp_rate_single``)."""
    cdef double ss = s1 * s1 + s2 * s2 + s3 * s3
    cdef double sd = s1 * d1 + s2 * d2 + s3 * d3
    cdef double k = 4.0 / pow(1.0 + ss, 2.0)
    cdef double a = 1.0 - ss
    w[0] = k * (a * d1 - 2.0 * (s2 * d3 - s3 * d2) + 2.0 * s1 * sd)
    w[1] = k * (a * d2 - 2.0 * (s3 * d1 - s1 * d3) + 2.0 * s2 * sd)
    w[2] = k * (a * d3 - 2.0 * (s1 * d2 - s2 * d1) + 2.0 * s3 * sd)


cdef inline void _mrp_rate(
    double s1, double s2, double s3, double w1, double w2, double w3, double* out
) noexcept:
    """Eq. 3 (``mrp.mrp_rate_single``)."""
    cdef double ss = s1 * s1 + s2 * s2 + s3 * s3
    cdef double sw = s1 * w1 + s2 * w2 + s3 * w3
    cdef double a = 1.0 - ss
    out[0] = 0.25 * (a * w1 + 2.0 * (s2 * w3 - s3 * w2) + 2.0 * s1 * sw)
    out[1] = 0.25 * (a * w2 + 2.0 * (s3 * w1 - s1 * w3) + 2.0 * s2 * sw)
    out[2] = 0.25 * (a * w3 + 2.0 * (s1 * w2 - s2 * w1) + 2.0 * s3 * sw)
