# Mirrors attitude_core.loop.loop_plant (LoopPlantReference): the offline loop's
# controller (eq. 11, control.pxi), the plant's per-axis clip
# (attitude_core.world.actuator.clip_to_bound) and the body (eqs. 2-4, rigid_body.pxi)
# for one step, written into the run's record; and the hold inside a band about the
# goal. Equal to the bit (tests/core/test_loop_plant.py, tests/tools/test_loop_hold.py).

from libc.math cimport sqrt

cdef double HOLD_GUARD = 1e-9  # loop_plant.HOLD_GUARD


cdef class LoopPlant:
    """The offline loop's controller and plant for one run, writing its record in place
    (the compiled form of ``loop.loop_plant.LoopPlantReference``).

    :meth:`step` at step ``k``: the PD command from the state the loop is fed and the
    target (:func:`pd_command`), the plant's per-axis clip
    (``world.actuator.clip_to_bound``), the record's row ``k`` (torque, target) and,
    unless ``k`` is the last row, one RK4 step of the body from row ``k`` to row
    ``k + 1`` (:func:`rk4_step`). The arrays are the run's ``(n + 1, 3)`` C-contiguous
    float arrays; row 0 of ``sigma`` and ``omega`` holds the initial state.
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
        target, while the body is inside the band (``LoopPlantReference.hold``);
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
