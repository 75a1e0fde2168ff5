# Mirrors attitude_core.fsw.guidance.fepf (FepfPlanner.propose_reference,
# hold_rate_reference, advance_reference: paper eqs. 6-10, the target's rate 12 and its
# shadow switch 2, with the step's safety) and attitude_core.fsw.guidance.fepf_state
# (FepfState, the planner's mutable state).
#
# The state handover: the planner keeps its mutable state in one record, a FepfState,
# the compiled one below when the kernels are built (C fields, the Python record's names
# and meanings). FepfCore steps that record in C, the Python reference steps the same
# record through the same fields, so both forms can take turns on one planner: the same
# operations in the same order, equal to the bit (tests/core/test_fepf_kernel.py).
# Everything else the core needs is handed over explicitly: the configuration at
# construction, the geometry (set_geometry) and the FIS tables (set_tables) when they
# change, and one hook, ``reference`` (FepfCore's docstring), for what it does not
# compile.

from libc.math cimport fabs, pow, sqrt, INFINITY, NAN

from weakref import ref as _weak


cdef inline bint _unit(double x, double y, double z, double* out) noexcept:
    """``fepf._unit_or_none``: False for a vector shorter than 1e-9."""
    cdef double n = sqrt(x * x + y * y + z * z)
    if n < 1e-9:
        return False
    out[0] = x / n
    out[1] = y / n
    out[2] = z / n
    return True


cdef class FepfState:
    """The FEPF planner's mutable state in C fields (``fepf_state.FepfState``: the same
    fields, the same meanings, the same defaults). Vectors are tuples of 3 floats, never
    None; ``checked`` is ``(rate, dt)`` or None, ``margin_at`` and ``arc_key`` the keys
    of the memos ``margin`` and ``arc`` (None: nothing kept)."""

    cdef public tuple sigma_t, goal, rate, omega_held, last_obstacle_direction, wanted_omega
    cdef public object status, checked, margin_at, arc_key
    cdef public bint final_goal, goal_in_sight, evade
    cdef public double beyond_mrp, d_goal, raw_speed, last_obstacle_distance
    cdef public double best_goal_distance, since_progress, margin, arc

    def __init__(self):
        cdef tuple zero = (0.0, 0.0, 0.0)
        self.sigma_t = self.goal = self.rate = self.omega_held = zero
        self.last_obstacle_direction = self.wanted_omega = zero
        self.status = None
        self.checked = self.margin_at = self.arc_key = None
        self.final_goal = True
        self.goal_in_sight = self.evade = False
        self.beyond_mrp = 0.0
        self.d_goal = INFINITY
        self.raw_speed = 0.0
        self.last_obstacle_distance = NAN
        self.best_goal_distance = INFINITY
        self.since_progress = 0.0
        self.margin = self.arc = NAN


cdef class FepfCore:
    """The compiled step of one ``FepfPlanner`` on its state (the include's header).

    Handed over at construction: ``state``, the planner's own record (read and written
    in place); the configuration, read once (``cfg``, a ``PlannerConfig``: tolerances,
    rates, acceleration, time constants; ``gamma`` and its cosine and sine, eq. 9;
    ``relative``: the target frame; ``paper_axis``: eq. 10 as printed; ``watchdog``;
    the FIS input names; the output class and the statuses; the rim floor and the sight
    tolerance of ``sight_margin_deg``); and ``reference``, the planner (held weakly: it
    holds the core), as the one hook:
    its ``propose_reference`` / ``hold_rate_reference`` / ``advance_reference`` run a
    step the core does not compile (a geometry without a compiled kernel; a FIS input
    that is not finite, whose error the reference raises), and its ``prepare()`` builds
    the FIS tables when they are first needed and hands them over (:meth:`set_tables`).
    The geometry is handed over at each change (:meth:`set_geometry`).
    """

    cdef readonly FepfState state
    cdef object reference, geometry, output_cls, tracking, arrived, stuck
    cdef ConeKernel margins  # the geometry's kernel: exact margins and arcs (None: none)
    cdef ConeKernel rims  # the same with its rim search, made at the first need
    cdef bint rims_asked
    cdef double buffer  # the geometry's inflation_deg
    cdef double goal_tol, influence, rate_a, rate_r, a_max, tau, stuck_timeout
    cdef double gamma, cos_g, sin_g, rim_floor, sight_tol
    cdef bint relative, paper_axis, watchdog
    cdef int ia[2]
    cdef int ir[2]
    cdef int na, nr
    cdef FisKernel ta, tr

    def __init__(
        self, FepfState state, reference, cfg, double gamma, double cos_g, double sin_g,
        bint relative, bint paper_axis, bint watchdog, tuple inputs_a, tuple inputs_r,
        output_cls, tuple statuses, double rim_floor, double sight_tol,
    ):
        self.state = state
        self.reference = _weak(reference)
        self.goal_tol = cfg.goal_tolerance_mrp
        self.influence = cfg.influence_distance_mrp
        self.rate_a = cfg.max_attractive_rate_mrp_s
        self.rate_r = cfg.max_repulsive_rate_mrp_s
        self.a_max = cfg.max_accel_mrp_s2
        self.tau = cfg.terminal_time_constant_s
        self.stuck_timeout = cfg.stuck_timeout_s
        self.gamma, self.cos_g, self.sin_g = gamma, cos_g, sin_g
        self.relative, self.paper_axis, self.watchdog = relative, paper_axis, watchdog
        self.rim_floor, self.sight_tol = rim_floor, sight_tol
        self.output_cls = output_cls
        self.tracking, self.arrived, self.stuck = statuses
        index = {"goal_distance": 0, "obstacle_distance": 1, "approach": 2}
        if not (1 <= len(inputs_a) <= 2 and 1 <= len(inputs_r) <= 2):
            raise ValueError("FepfCore: FIS of 1 or 2 inputs expected")
        self.na, self.nr = len(inputs_a), len(inputs_r)
        for i in range(self.na):
            self.ia[i] = index[inputs_a[i]]
        for i in range(self.nr):
            self.ir[i] = index[inputs_r[i]]

    # -- what is handed over when it changes ------------------------------------------

    def set_geometry(self, geometry):
        """Plan on ``geometry`` from now on (``FepfPlanner.set_geometry``): its compiled
        kernel (``ConeGeometry.compiled_kernel``) and its buffer (``inflation_deg``)."""
        self.geometry = geometry
        self.buffer = geometry.inflation_deg
        self.margins = _cone_kernel(geometry, False)
        self.rims = None
        self.rims_asked = False

    def set_tables(self, table_a, table_r):
        """The attractive and repulsive FIS lookup tables (``FepfPlanner.prepare``)."""
        self.ta, self.tr = _fis_kernel(table_a), _fis_kernel(table_r)

    cdef ConeKernel _rim_kernel(self):
        """The geometry's kernel with its rim search (built now at the first need)."""
        if not self.rims_asked:
            self.rims = _cone_kernel(self.geometry, True)
            self.rims_asked = True
        return self.rims

    # -- the planner's geometry ---------------------------------------------------

    cdef double _margin(self, ConeKernel k):
        """``FepfPlanner.margin_deg`` (its memo in the state written too)."""
        cdef FepfState st = self.state
        cdef tuple sigma = st.sigma_t
        at = st.margin_at
        if at is sigma or (at is not None and at == sigma):
            return st.margin
        cdef double m = k._margin(sigma[0], sigma[1], sigma[2])
        st.margin = m
        st.margin_at = sigma
        return m

    cdef double _sight(self, ConeKernel k, double buffer):
        """``FepfPlanner.sight_margin_deg``."""
        cdef double here = self._margin(k)
        cdef double low
        if here >= buffer:
            return buffer
        low = self.rim_floor * buffer
        if here < low:
            low = here
        return low - self.sight_tol

    # -- the step's safety ----------------------------------------------------------

    cdef tuple _safe_step(self, ConeKernel k, double* v, double dt):
        """``FepfPlanner._safe_step``: ``v`` shortened in place; returns the end point."""
        cdef FepfState st = self.state
        cdef tuple sigma = st.sigma_t
        cdef double sx = sigma[0], sy = sigma[1], sz = sigma[2]
        cdef double vx = v[0], vy = v[1], vz = v[2]
        cdef double d_obs = st.last_obstacle_distance
        cdef double step_len = dt * sqrt(vx * vx + vy * vy + vz * vz)
        cdef double buffer = self.buffer
        cdef double floor = 0.5 * buffer
        cdef double limit, f, m, need, nx, ny, nz
        cdef int tries
        cdef bint ok = False, keeps
        if d_obs > 0.0:
            limit = 0.9 * d_obs
            if step_len > limit:
                keeps = False
                if self.relative:  # FepfPlanner._step_keeps_margin
                    need = buffer
                    m = self._margin(k)
                    if m < need:
                        need = m
                    keeps = k._arc(
                        sx, sy, sz, sx + vx * dt, sy + vy * dt, sz + vz * dt
                    ) >= need
                if not keeps:
                    f = limit / step_len
                    vx, vy, vz = vx * f, vy * f, vz * f
        else:
            m = self._margin(k)
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

    cdef tuple _body_rate(self, tuple sigma, double* v):
        """``FepfPlanner._body_rate``."""
        cdef double w[3]
        _omega_from_rate(sigma[0], sigma[1], sigma[2], v[0], v[1], v[2], w)
        return (w[0], w[1], w[2])

    cdef object _output(self, tuple sigma, double* rate, double m_a, double m_r, double d_obs):
        """``FepfPlanner._output``."""
        cdef double w[3]
        cdef double s1 = sigma[0], s2 = sigma[1], s3 = sigma[2]
        _omega_from_rate(s1, s2, s3, rate[0], rate[1], rate[2], w)
        return self.output_cls(
            np.array((s1, s2, s3)),
            np.array((rate[0], rate[1], rate[2])),
            np.array((w[0], w[1], w[2])),
            self.state.status,
            m_a,
            m_r,
            d_obs,
        )

    cdef object _hold(self, tuple sigma):
        cdef FepfState st = self.state
        cdef double zero[3]
        zero[0] = zero[1] = zero[2] = 0.0
        st.rate = (0.0, 0.0, 0.0)
        st.omega_held = (0.0, 0.0, 0.0)
        st.checked = None
        return self._output(sigma, zero, 0.0, 0.0, st.last_obstacle_distance)

    # -- the law ----------------------------------------------------------------------

    def propose(self, double dt_since, double dt_ahead):
        """``FepfPlanner.propose_reference``."""
        return self._propose(dt_since, dt_ahead)

    cdef object _propose(self, double dt_since, double dt_ahead):
        cdef FepfState st = self.state
        cdef ConeKernel k = self.margins
        if k is None:
            return self.reference().propose_reference(dt_since, dt_ahead)
        cdef tuple sigma = st.sigma_t
        cdef tuple goal = st.goal
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
        st.d_goal = d_goal
        status = st.status
        if status == self.arrived or (
            status == self.tracking and st.final_goal and d_goal <= self.goal_tol
        ):
            st.status = self.arrived
            st.sigma_t = goal
            return self._hold(goal)
        if status != self.tracking:  # stuck or infeasible: hold
            return self._hold(sigma)
        cdef double buffer = self.buffer
        if d_goal == 0.0 and not (st.evade and self._margin(k) < buffer):
            return self._hold(sigma)
        k = self._rim_kernel()
        if k is None:
            return self.reference().propose_reference(dt_since, dt_ahead)
        cdef double a0 = 0.0, a1 = 0.0, a2 = 0.0
        if d_goal > 0.0:
            a0, a1, a2 = e[0] / d_goal, e[1] / d_goal, e[2] / d_goal
        cdef double q[7]
        k._closest(sx, sy, sz, buffer, q)
        cdef double d_obs = q[0]
        cdef double c0 = q[1], c1 = q[2], c2 = q[3]
        st.last_obstacle_distance = d_obs
        st.last_obstacle_direction = (c0, c1, c2)
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
                in_sight = k._arc(sx, sy, sz, g1, g2, g3) >= self._sight(k, buffer)
            else:
                in_sight = visibility == 0.0
            if in_sight:
                visibility = 0.0
        st.goal_in_sight = in_sight
        cdef double obstacle_input = _clip01(d_obs / self.influence)
        cdef double inputs[3]
        inputs[0] = scale * (d_goal + st.beyond_mrp)
        if 1.0 < inputs[0]:
            inputs[0] = 1.0
        inputs[1] = 1.0 if in_sight else obstacle_input
        inputs[2] = 0.5 * (1.0 + ac)
        if self.ta is None:
            self.reference().prepare()  # hands the tables over (set_tables)
            if self.ta is None:
                raise RuntimeError("FepfCore: the planner's prepare() handed over no FIS tables")
        cdef bint bad = False
        cdef double m_a = self.rate_a * self.ta.at(
            inputs[self.ia[0]], inputs[self.ia[1]] if self.na == 2 else 0.0, &bad
        )
        if bad:
            return self.reference().propose_reference(dt_since, dt_ahead)  # the table's error
        cdef double m_r = 0.0
        if d_obs < self.influence and visibility > 0.0:
            inputs[1] = obstacle_input
            m_r = visibility * self.rate_r * self.tr.at(
                inputs[self.ir[0]], inputs[self.ir[1]] if self.nr == 2 else 0.0, &bad
            )
            if bad:
                return self.reference().propose_reference(dt_since, dt_ahead)
        cdef double v[3]
        v[0], v[1], v[2] = m_a * a0, m_a * a1, m_a * a2
        cdef double r[3]
        if m_r > 0.0:
            self._repulsive(sx, sy, sz, a0, a1, a2, c0, c1, c2, ac, r)
            v[0], v[1], v[2] = v[0] + m_r * r[0], v[1] + m_r * r[1], v[2] + m_r * r[2]
        cdef double w[3]
        if self.relative:
            st.wanted_omega = (4.0 * v[0], 4.0 * v[1], 4.0 * v[2])
        else:
            _omega_from_rate(sx, sy, sz, v[0], v[1], v[2], w)
            st.wanted_omega = (w[0], w[1], w[2])
        self._shape(v, d_goal, dt_since)
        if self.relative:  # back to sigma_BN rates: sigma_dot = B(sigma) rho_dot
            _mrp_rate(sx, sy, sz, 4.0 * v[0], 4.0 * v[1], 4.0 * v[2], w)
            v[0], v[1], v[2] = w[0], w[1], w[2]
        st.raw_speed = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) / scale
        self._safe_step(k, v, dt_ahead)
        cdef tuple rate = (v[0], v[1], v[2])
        st.rate = rate
        st.omega_held = self._body_rate(sigma, v)
        st.checked = (rate, dt_ahead)
        return self._output(sigma, v, m_a, m_r, d_obs)

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

    cdef void _shape(self, double* v, double d_goal, double dt):
        """``FepfPlanner._shape_rate``, in place."""
        cdef FepfState st = self.state
        cdef tuple held
        cdef double px, py, pz, dx, dy, dz, dv, dv_max, f, speed, cap
        if self.a_max > 0.0:
            if self.relative:  # the held rate in the target frame: omega / 4
                held = st.omega_held
                px, py, pz = 0.25 * held[0], 0.25 * held[1], 0.25 * held[2]
            else:
                held = st.rate
                px, py, pz = held[0], held[1], held[2]
            dx, dy, dz = v[0] - px, v[1] - py, v[2] - pz
            dv = sqrt(dx * dx + dy * dy + dz * dz)
            dv_max = self.a_max * dt
            if dv > dv_max:
                f = dv_max / dv
                v[0], v[1], v[2] = px + dx * f, py + dy * f, pz + dz * f
        if self.tau > 0.0 and st.final_goal:
            speed = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
            cap = d_goal / self.tau
            if speed > cap:
                f = cap / speed
                v[0], v[1], v[2] = v[0] * f, v[1] * f, v[2] * f

    # -- the held rate and the move ---------------------------------------------------

    def hold_rate(self, rate, double dt_ahead):
        """``FepfPlanner.hold_rate_reference``."""
        cdef double v[3]
        v[0], v[1], v[2] = float(rate[0]), float(rate[1]), float(rate[2])
        return self._hold_rate(v, dt_ahead)

    cdef tuple _hold_rate(self, double* v, double dt_ahead):
        """``v`` made safe in place; returns the rate held (a tuple)."""
        cdef FepfState st = self.state
        cdef ConeKernel k = self.margins
        cdef tuple safe
        if k is None:
            safe = self.reference().hold_rate_reference((v[0], v[1], v[2]), dt_ahead)
            v[0], v[1], v[2] = safe[0], safe[1], safe[2]
            return safe
        self._safe_step(k, v, dt_ahead)
        safe = (v[0], v[1], v[2])
        st.rate = safe
        st.omega_held = self._body_rate(st.sigma_t, v)
        st.checked = (safe, dt_ahead)
        return safe

    def advance(self, double dt):
        """``FepfPlanner.advance_reference``."""
        self._advance(dt)

    cdef int _advance(self, double dt) except -1:
        cdef FepfState st = self.state
        if st.status != self.tracking or dt <= 0.0:
            return 0
        cdef ConeKernel k = self.margins
        if k is None:
            self.reference().advance_reference(dt)
            return 0
        cdef tuple rate = st.rate
        checked = st.checked
        cdef tuple s0 = st.sigma_t
        cdef double s1 = s0[0], s2 = s0[1], s3 = s0[2]
        cdef double v[3]
        v[0], v[1], v[2] = rate[0], rate[1], rate[2]
        cdef double scale = 1.0
        if self.relative:
            scale = 1.0 + pow(s1, 2.0) + pow(s2, 2.0) + pow(s3, 2.0)
        cdef double speed = sqrt(pow(v[0], 2.0) + pow(v[1], 2.0) + pow(v[2], 2.0)) / scale
        cdef tuple new
        if checked is not None and checked[0] == rate and dt <= checked[1]:
            speed = st.raw_speed  # the terminal rule sees the step before the shortening
            new = (s1 + v[0] * dt, s2 + v[1] * dt, s3 + v[2] * dt)
        else:
            new = self._safe_step(k, v, dt)
            st.rate = (v[0], v[1], v[2])
            st.omega_held = self._body_rate(s0, v)
        cdef double d_goal = st.d_goal
        cdef double n[3]
        cdef tuple goal
        if st.final_goal:
            goal = st.goal
            if self.relative:
                _relative(goal[0], goal[1], goal[2], new[0], new[1], new[2], n)
            else:
                n[0], n[1], n[2] = goal[0] - new[0], goal[1] - new[1], goal[2] - new[2]
            if n[0] * n[0] + n[1] * n[1] + n[2] * n[2] <= pow(self.goal_tol, 2.0) or (
                self.tau == 0.0
                and dt * speed >= d_goal
                and d_goal < st.last_obstacle_distance
            ):
                new = goal
        self._move(new, d_goal, dt)
        return 0

    cdef void _move(self, tuple new, double d_goal_before, double dt):
        """``FepfPlanner._advance``."""
        cdef FepfState st = self.state
        st.sigma_t = new
        cdef double n1 = new[0], n2 = new[1], n3 = new[2]
        cdef double s2 = pow(n1, 2.0) + pow(n2, 2.0) + pow(n3, 2.0)
        cdef double r1, r2, r3, sr
        cdef tuple r
        if s2 > 1.0:  # the shadow switch keeps the target inside the unit ball (eq. 2)
            st.sigma_t = (-n1 / s2, -n2 / s2, -n3 / s2)
            r = st.rate
            r1, r2, r3 = r[0], r[1], r[2]
            sr = n1 * r1 + n2 * r2 + n3 * r3
            st.rate = (
                -r1 / s2 + 2.0 * sr * n1 / (s2 * s2),
                -r2 / s2 + 2.0 * sr * n2 / (s2 * s2),
                -r3 / s2 + 2.0 * sr * n3 / (s2 * s2),
            )
        if not self.watchdog:
            return
        if d_goal_before < st.best_goal_distance - 1e-6:
            st.best_goal_distance = d_goal_before
            st.since_progress = 0.0
        else:
            st.since_progress = st.since_progress + dt
            if st.since_progress >= self.stuck_timeout:
                st.status = self.stuck
