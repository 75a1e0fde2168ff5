# Shared by every kernel (included first by _kernels.pyx): the constants and the float
# helpers with no Python module of their own; each does what the Python expression in
# its docstring does, to the bit.

from libc.math cimport copysign, fmod

cdef double _PI = 3.141592653589793
cdef double _TWO_PI = 2.0 * 3.141592653589793
cdef double _RAD_TO_DEG = 180.0 / 3.141592653589793


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


cdef inline double _clip01(double x) noexcept nogil:
    """``min(max(x, 0.0), 1.0)``, as Python's."""
    if 0.0 > x:
        x = 0.0
    if 1.0 < x:
        x = 1.0
    return x
