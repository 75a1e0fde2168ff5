# The FEPF planner's step, compiled (included by _kernels.pyx).
#
# FepfCore.propose / advance / hold_rate are FepfPlanner.propose_reference /
# advance_reference / hold_rate_reference (gnc/fepf.py, paper eqs. 6-10 and 12 with the
# step's safety) in C: the same operations in the same order on the planner's own state,
# which stays in the Python object (read at each call, written back), so both forms can
# take turns on one planner. Equal to the bit (tests/core/test_fepf_kernel.py).


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


cdef inline bint _unit(double x, double y, double z, double* out) noexcept:
    """``fepf._unit_or_none``: False for a vector shorter than 1e-9."""
    cdef double n = sqrt(x * x + y * y + z * z)
    if n < 1e-9:
        return False
    out[0] = x / n
    out[1] = y / n
    out[2] = z / n
    return True


cdef inline double _clip01(double x) noexcept:
    """``min(max(x, 0.0), 1.0)``, as Python's."""
    if 0.0 > x:
        x = 0.0
    if 1.0 < x:
        x = 1.0
    return x


cdef class FepfCore:
    """The compiled step of one ``FepfPlanner`` (see the include's header)."""

    cdef double goal_tol, influence, rate_a, rate_r, a_max, tau, stuck_timeout
    cdef double gamma, cos_g, sin_g, rim_floor, sight_tol
    cdef bint relative, paper_axis
    cdef int ia[2]
    cdef int ir[2]
    cdef int na, nr
    cdef object output_cls, tracking, arrived, stuck
    cdef FisKernel ta, tr

    def __init__(self, planner, output_cls, statuses, double rim_floor, double sight_tol):
        cfg = planner.cfg
        self.goal_tol = cfg.goal_tolerance_mrp
        self.influence = cfg.influence_distance_mrp
        self.rate_a = cfg.max_attractive_rate_mrp_s
        self.rate_r = cfg.max_repulsive_rate_mrp_s
        self.a_max = cfg.max_accel_mrp_s2
        self.tau = cfg.terminal_time_constant_s
        self.stuck_timeout = cfg.stuck_timeout_s
        self.gamma, self.cos_g, self.sin_g = planner._gamma, planner._cos_g, planner._sin_g
        self.relative = planner.relative
        self.paper_axis = planner._paper_axis
        self.rim_floor, self.sight_tol = rim_floor, sight_tol
        self.output_cls = output_cls
        self.tracking, self.arrived, self.stuck = statuses
        index = {"goal_distance": 0, "obstacle_distance": 1, "approach": 2}
        names_a, names_r = planner._inputs_a, planner._inputs_r
        if not (1 <= len(names_a) <= 2 and 1 <= len(names_r) <= 2):
            raise ValueError("FepfCore: FIS of 1 or 2 inputs expected")
        self.na, self.nr = len(names_a), len(names_r)
        for i in range(self.na):
            self.ia[i] = index[names_a[i]]
        for i in range(self.nr):
            self.ir[i] = index[names_r[i]]

    # -- the planner's geometry ---------------------------------------------------

    cdef ConeKernel _kernel(self, planner, bint rims):
        geometry = planner.geometry
        if rims and not geometry._rims_built:
            geometry._ensure_rims()
        kernel = getattr(geometry, "_kernel", None)
        return kernel if isinstance(kernel, ConeKernel) else None

    cdef double _margin(self, planner, ConeKernel k):
        """``FepfPlanner.margin_deg`` (its cache written too)."""
        sigma = planner.sigma_t
        if planner._margin_at == sigma:
            return planner._margin
        cdef double m = k._margin(sigma[0], sigma[1], sigma[2])
        planner._margin = m
        planner._margin_at = sigma
        return m

    cdef double _sight(self, planner, ConeKernel k, double buffer):
        """``FepfPlanner.sight_margin_deg``."""
        cdef double here = self._margin(planner, k)
        cdef double low
        if here >= buffer:
            return buffer
        low = self.rim_floor * buffer
        if here < low:
            low = here
        return low - self.sight_tol

    # -- the step's safety ----------------------------------------------------------

    cdef tuple _safe_step(self, planner, ConeKernel k, double* v, double dt):
        """``FepfPlanner._safe_step``: ``v`` shortened in place; returns the end point."""
        sigma = planner.sigma_t
        cdef double sx = sigma[0], sy = sigma[1], sz = sigma[2]
        cdef double vx = v[0], vy = v[1], vz = v[2]
        cdef double d_obs = planner.last_obstacle_distance
        cdef double step_len = dt * sqrt(vx * vx + vy * vy + vz * vz)
        cdef double buffer = planner.geometry.inflation_deg
        cdef double floor = 0.5 * buffer
        cdef double limit, f, m, need, nx, ny, nz
        cdef int tries
        cdef bint ok = False
        if d_obs > 0.0:
            limit = 0.9 * d_obs
            if step_len > limit:
                keeps = False
                if self.relative:  # FepfPlanner._step_keeps_margin
                    need = buffer
                    m = self._margin(planner, k)
                    if m < need:
                        need = m
                    keeps = k._arc(
                        sx, sy, sz, sx + vx * dt, sy + vy * dt, sz + vz * dt
                    ) >= need
                if not keeps:
                    f = limit / step_len
                    vx, vy, vz = vx * f, vy * f, vz * f
        else:
            m = self._margin(planner, k)
            if m < floor:
                floor = m
        nx, ny, nz = sx + vx * dt, sy + vy * dt, sz + vz * dt
        for tries in range(6):
            if k._margin(nx, ny, nz) >= floor:
                ok = True
                break
            vx, vy, vz = 0.5 * vx, 0.5 * vy, 0.5 * vz
            nx, ny, nz = sx + vx * dt, sy + vy * dt, sz + vz * dt
        v[0], v[1], v[2] = vx, vy, vz
        if not ok:
            v[0] = v[1] = v[2] = 0.0
            return sigma
        return (nx, ny, nz)

    cdef tuple _body_rate(self, sigma, double* v):
        """``FepfPlanner._body_rate``."""
        cdef double w[3]
        _omega_from_rate(sigma[0], sigma[1], sigma[2], v[0], v[1], v[2], w)
        return (w[0], w[1], w[2])

    cdef object _output(self, planner, sigma, double* rate, double m_a, double m_r, double d_obs):
        """``FepfPlanner._output``."""
        cdef double w[3]
        cdef double s1 = sigma[0], s2 = sigma[1], s3 = sigma[2]
        _omega_from_rate(s1, s2, s3, rate[0], rate[1], rate[2], w)
        return self.output_cls(
            np.array((s1, s2, s3)),
            np.array((rate[0], rate[1], rate[2])),
            np.array((w[0], w[1], w[2])),
            planner.status,
            m_a,
            m_r,
            d_obs,
        )

    cdef object _hold(self, planner, sigma):
        cdef double zero[3]
        zero[0] = zero[1] = zero[2] = 0.0
        planner._rate = (0.0, 0.0, 0.0)
        planner._omega_held = (0.0, 0.0, 0.0)
        planner._checked = None
        return self._output(planner, sigma, zero, 0.0, 0.0, planner.last_obstacle_distance)

    # -- the law ----------------------------------------------------------------------

    def propose(self, planner, double dt_since, double dt_ahead):
        """``FepfPlanner.propose_reference``."""
        cdef ConeKernel k = self._kernel(planner, False)
        if k is None:
            return planner.propose_reference(dt_since, dt_ahead)
        sigma = planner.sigma_t
        goal = planner.goal
        cdef double sx = sigma[0], sy = sigma[1], sz = sigma[2]
        cdef double g1 = goal[0], g2 = goal[1], g3 = goal[2]
        cdef double e[3]
        cdef double scale, d_goal
        if self.relative:
            _relative(g1, g2, g3, sx, sy, sz, e)  # sigma_D/T, short way
            scale = 1.0 + sx * sx + sy * sy + sz * sz
        else:
            e[0], e[1], e[2] = g1 - sx, g2 - sy, g3 - sz
            scale = 1.0
        d_goal = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
        planner._d_goal = d_goal
        status = planner.status
        if status == self.arrived or (
            status == self.tracking and planner.final_goal and d_goal <= self.goal_tol
        ):
            planner.status = self.arrived
            planner.sigma_t = goal
            return self._hold(planner, goal)
        if status != self.tracking:  # stuck or infeasible: hold
            return self._hold(planner, sigma)
        cdef double buffer = planner.geometry.inflation_deg
        if d_goal == 0.0 and not (planner.evade and self._margin(planner, k) < buffer):
            return self._hold(planner, sigma)
        k = self._kernel(planner, True)
        if k is None:
            return planner.propose_reference(dt_since, dt_ahead)
        cdef double a0 = 0.0, a1 = 0.0, a2 = 0.0
        if d_goal > 0.0:
            a0, a1, a2 = e[0] / d_goal, e[1] / d_goal, e[2] / d_goal
        cdef double q[7]
        k._closest(sx, sy, sz, buffer, q)
        cdef double d_obs = q[0]
        cdef double c0 = q[1], c1 = q[2], c2 = q[3]
        planner.last_obstacle_distance = d_obs
        planner.last_obstacle_direction = (c0, c1, c2)
        cdef double a, sv
        if self.relative:  # fepf._to_target_frame
            a = 1.0 - (sx * sx + sy * sy + sz * sz)
            sv = sx * c0 + sy * c1 + sz * c2
            c0, c1, c2 = (
                (a * c0 - 2.0 * (sy * c2 - sz * c1) + 2.0 * sx * sv) / scale,
                (a * c1 - 2.0 * (sz * c0 - sx * c2) + 2.0 * sy * sv) / scale,
                (a * c2 - 2.0 * (sx * c1 - sy * c0) + 2.0 * sz * sv) / scale,
            )
            d_obs = d_obs / scale
        cdef double ac = a0 * c0 + a1 * c1 + a2 * c2
        cdef double visibility = 1.0  # fepf._goal_occlusion
        if not (d_obs <= 0.0):
            visibility = _clip01(d_goal / d_obs - 1.0)
        cdef bint in_sight = False
        if self.relative and d_goal > 0.0:
            if d_obs < self.influence:
                in_sight = k._arc(sx, sy, sz, g1, g2, g3) >= self._sight(planner, k, buffer)
            else:
                in_sight = visibility == 0.0
            if in_sight:
                visibility = 0.0
        planner.goal_in_sight = in_sight
        cdef double obstacle_input = _clip01(d_obs / self.influence)
        cdef double inputs[3]
        inputs[0] = scale * (d_goal + planner._beyond_mrp)
        if 1.0 < inputs[0]:
            inputs[0] = 1.0
        inputs[1] = 1.0 if in_sight else obstacle_input
        inputs[2] = 0.5 * (1.0 + ac)
        if planner._tables is None:
            planner.prepare()
        tables = planner._tables
        if self.ta is None or self.ta.table is not tables[0] or self.tr.table is not tables[1]:
            self.ta, self.tr = _fis_kernel(tables[0]), _fis_kernel(tables[1])
        cdef bint bad = False
        cdef double m_a = self.rate_a * self.ta.at(
            inputs[self.ia[0]], inputs[self.ia[1]] if self.na == 2 else 0.0, &bad
        )
        if bad:
            return planner.propose_reference(dt_since, dt_ahead)  # raises the table's error
        cdef double m_r = 0.0
        if d_obs < self.influence and visibility > 0.0:
            inputs[1] = obstacle_input
            m_r = visibility * self.rate_r * self.tr.at(
                inputs[self.ir[0]], inputs[self.ir[1]] if self.nr == 2 else 0.0, &bad
            )
            if bad:
                return planner.propose_reference(dt_since, dt_ahead)
        cdef double v[3]
        v[0], v[1], v[2] = m_a * a0, m_a * a1, m_a * a2
        cdef double r[3]
        if m_r > 0.0:
            self._repulsive(sx, sy, sz, a0, a1, a2, c0, c1, c2, ac, r)
            v[0], v[1], v[2] = v[0] + m_r * r[0], v[1] + m_r * r[1], v[2] + m_r * r[2]
        cdef double w[3]
        if self.relative:
            planner.wanted_omega = (4.0 * v[0], 4.0 * v[1], 4.0 * v[2])
        else:
            _omega_from_rate(sx, sy, sz, v[0], v[1], v[2], w)
            planner.wanted_omega = (w[0], w[1], w[2])
        self._shape(planner, v, d_goal, dt_since)
        if self.relative:  # back to sigma_BN rates: sigma_dot = B(sigma) rho_dot
            _mrp_rate(sx, sy, sz, 4.0 * v[0], 4.0 * v[1], 4.0 * v[2], w)
            v[0], v[1], v[2] = w[0], w[1], w[2]
        planner._raw_speed = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) / scale
        self._safe_step(planner, k, v, dt_ahead)
        rate = (v[0], v[1], v[2])
        planner._rate = rate
        planner._omega_held = self._body_rate(sigma, v)
        planner._checked = (rate, dt_ahead)
        return self._output(planner, sigma, v, m_a, m_r, d_obs)

    cdef void _repulsive(
        self, double sx, double sy, double sz, double a0, double a1, double a2,
        double c0, double c1, double c2, double ac, double* out
    ) noexcept:
        """``FepfPlanner._repulsive_direction`` (eqs. 8-10) into ``out``."""
        cdef double o[3]
        cdef double vx = -c0, vy = -c1, vz = -c2
        cdef double dot, cx, cy, cz, kk
        out[0], out[1], out[2] = vx, vy, vz
        if self.gamma == 0.0:
            return
        if self.paper_axis:
            if not _unit(c1 * sz - c2 * sy, c2 * sx - c0 * sz, c0 * sy - c1 * sx, o):
                return
        elif not _unit(a1 * c2 - a2 * c1, a2 * c0 - a0 * c2, a0 * c1 - a1 * c0, o):
            if ac < 0.0:  # obstacle straight behind: nothing to steer around
                return
            # head-on: break the symmetry (fepf._any_perpendicular)
            if fabs(c0) < 0.9:
                _unit(0.0, c2, -c1, o)
            else:
                _unit(-c2, 0.0, c0, o)
        dot = o[0] * vx + o[1] * vy + o[2] * vz  # fepf._rotate
        cx, cy, cz = o[1] * vz - o[2] * vy, o[2] * vx - o[0] * vz, o[0] * vy - o[1] * vx
        kk = (1.0 - self.cos_g) * dot
        out[0] = vx * self.cos_g + cx * self.sin_g + o[0] * kk
        out[1] = vy * self.cos_g + cy * self.sin_g + o[1] * kk
        out[2] = vz * self.cos_g + cz * self.sin_g + o[2] * kk

    cdef void _shape(self, planner, double* v, double d_goal, double dt):
        """``FepfPlanner._shape_rate``, in place."""
        cdef double px, py, pz, dx, dy, dz, dv, dv_max, f, speed, cap
        if self.a_max > 0.0:
            if self.relative:  # the held rate in the target frame: omega / 4
                held = planner._omega_held
                px, py, pz = 0.25 * held[0], 0.25 * held[1], 0.25 * held[2]
            else:
                held = planner._rate
                px, py, pz = held[0], held[1], held[2]
            dx, dy, dz = v[0] - px, v[1] - py, v[2] - pz
            dv = sqrt(dx * dx + dy * dy + dz * dz)
            dv_max = self.a_max * dt
            if dv > dv_max:
                f = dv_max / dv
                v[0], v[1], v[2] = px + dx * f, py + dy * f, pz + dz * f
        if self.tau > 0.0 and planner.final_goal:
            speed = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
            cap = d_goal / self.tau
            if speed > cap:
                f = cap / speed
                v[0], v[1], v[2] = v[0] * f, v[1] * f, v[2] * f

    # -- the held rate and the move ---------------------------------------------------

    def hold_rate(self, planner, rate, double dt_ahead):
        """``FepfPlanner.hold_rate_reference``."""
        cdef ConeKernel k = self._kernel(planner, False)
        if k is None:
            return planner.hold_rate_reference(rate, dt_ahead)
        cdef double v[3]
        v[0], v[1], v[2] = float(rate[0]), float(rate[1]), float(rate[2])
        self._safe_step(planner, k, v, dt_ahead)
        safe = (v[0], v[1], v[2])
        planner._rate = safe
        planner._omega_held = self._body_rate(planner.sigma_t, v)
        planner._checked = (safe, dt_ahead)
        return safe

    def advance(self, planner, double dt):
        """``FepfPlanner.advance_reference``."""
        if planner.status != self.tracking or dt <= 0.0:
            return
        cdef ConeKernel k = self._kernel(planner, False)
        if k is None:
            planner.advance_reference(dt)
            return
        rate = planner._rate
        checked = planner._checked
        s0 = planner.sigma_t
        cdef double s1 = s0[0], s2 = s0[1], s3 = s0[2]
        cdef double v[3]
        v[0], v[1], v[2] = rate[0], rate[1], rate[2]
        cdef double scale = 1.0
        if self.relative:
            scale = 1.0 + pow(s1, 2.0) + pow(s2, 2.0) + pow(s3, 2.0)
        cdef double speed = sqrt(pow(v[0], 2.0) + pow(v[1], 2.0) + pow(v[2], 2.0)) / scale
        if checked is not None and checked[0] == rate and dt <= checked[1]:
            speed = planner._raw_speed  # the terminal rule sees the step before the shortening
            new = (s1 + v[0] * dt, s2 + v[1] * dt, s3 + v[2] * dt)
        else:
            new = self._safe_step(planner, k, v, dt)
            planner._rate = (v[0], v[1], v[2])
            planner._omega_held = self._body_rate(s0, v)
        cdef double d_goal = planner._d_goal
        cdef double n[3]
        cdef double goal_d2
        if planner.final_goal:
            goal = planner.goal
            if self.relative:
                _relative(goal[0], goal[1], goal[2], new[0], new[1], new[2], n)
            else:
                n[0], n[1], n[2] = goal[0] - new[0], goal[1] - new[1], goal[2] - new[2]
            if n[0] * n[0] + n[1] * n[1] + n[2] * n[2] <= pow(self.goal_tol, 2.0) or (
                self.tau == 0.0
                and dt * speed >= d_goal
                and d_goal < planner.last_obstacle_distance
            ):
                new = goal
        self._move(planner, new, d_goal, dt)

    cdef void _move(self, planner, new, double d_goal_before, double dt):
        """``FepfPlanner._advance``."""
        planner.sigma_t = new
        cdef double n1 = new[0], n2 = new[1], n3 = new[2]
        cdef double s2 = pow(n1, 2.0) + pow(n2, 2.0) + pow(n3, 2.0)
        cdef double r1, r2, r3, sr
        if s2 > 1.0:  # the shadow switch keeps the target inside the unit ball (eq. 2)
            planner.sigma_t = (-n1 / s2, -n2 / s2, -n3 / s2)
            r = planner._rate
            r1, r2, r3 = r[0], r[1], r[2]
            sr = n1 * r1 + n2 * r2 + n3 * r3
            planner._rate = (
                -r1 / s2 + 2.0 * sr * n1 / (s2 * s2),
                -r2 / s2 + 2.0 * sr * n2 / (s2 * s2),
                -r3 / s2 + 2.0 * sr * n3 / (s2 * s2),
            )
        if not planner.watchdog:
            return
        if d_goal_before < planner._best_goal_distance - 1e-6:
            planner._best_goal_distance = d_goal_before
            planner._since_progress = 0.0
        else:
            planner._since_progress = planner._since_progress + dt
            if planner._since_progress >= self.stuck_timeout:
                planner.status = self.stuck
