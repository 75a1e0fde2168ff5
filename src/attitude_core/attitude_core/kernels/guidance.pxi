# Mirrors attitude_core.fsw.guidance.guidance (Guidance.update_reference, with _judge,
# _derate and stuck_timeout_s) and attitude_core.fsw.guidance.guidance_state
# (GuidanceState, the guidance's mutable state): the FEPF target closed on the measured
# state (paper eqs. 6-10, 12 through fepf.pxi), the tracking governor and the arrival
# judged on the body (eq. 11's error, the principal angle of sigma_B/R), for a static
# sky and a decision on each state (no decision window).
#
# The state handover: the guidance keeps its mutable state in one record, a
# GuidanceState, the compiled one below when the kernels are built (the Python record's
# fields and meanings); its attributes of the same names read and write it. GuidanceCore
# steps that record and the planner's FepfState (through its FepfCore) in C, the same
# operations in the same order as the Python reference: equal to the bit
# (tests/core/test_guidance_kernel.py). The configuration is read once, at
# construction. Three hooks stay Python, called mid-step only when their case arises
# (GuidanceCore's docstring): the collection of a route that is pending, the time scaling
# to actuator limits, and a new route when the target stalls; the route following is
# route_following.pxi, through the follower's own interface.

import math as _math
from weakref import WeakMethod as _WeakMethod

_hypot = _math.hypot  # Python's own (a correctly rounded norm, not sqrt of the sum)
_DEG_TO_RAD = _math.pi / 180.0


cdef class GuidanceState:
    """The guidance's mutable state in C fields (``guidance_state.GuidanceState``: the
    same fields, the same meanings, the same defaults). ``t_prev`` and ``behind_since``
    are floats or None, ``omega_prev`` a float array (3,), ``pending`` a future route or
    None, ``follower`` the ``RouteFollower`` flown or None."""

    cdef public object t_prev, omega_prev, status, behind_since, pending, follower
    cdef public double derating, derated_at, since_progress, best_body, best_target

    def __init__(self):
        self.t_prev = None
        self.omega_prev = np.zeros(3)
        self.status = None
        self.behind_since = None
        self.pending = None
        self.follower = None
        self.derating = 1.0
        self.derated_at = -INFINITY
        self.since_progress = 0.0
        self.best_body = INFINITY
        self.best_target = INFINITY


cdef class GuidanceCore:
    """The compiled step of one ``Guidance`` (see the include's header).

    Handed over at construction: ``state``, the guidance's own record, and ``fepf``, the
    planner's compiled step (with its state), both read and written in place; the
    statuses and the output class; ``constants``: the progress thresholds (rad, MRP),
    the derating's period (s) and floor; and the guidance's configuration, read once from
    ``guidance``: its ``goal``, ``hold_deg``, ``attitude_tol_deg``, ``rate_tol_rad_s``,
    ``limits`` (rate and acceleration bounds), ``knowledge`` (settling time, decision
    window) and its planner's step ``dt`` and ``cfg.stuck_timeout_s``. ``hooks``, the
    Python calls it makes mid-step: ``collect_route(t)`` while a route is pending
    (``Guidance._collect_route``: takes it when its time has come), ``time_scaled(out,
    dt)`` with actuator limits (``Guidance._time_scaled``: the FEPF rate within them),
    ``replan()`` when the target stalls (``Guidance._replan``: asks for a new route);
    held weakly (they are the guidance's, which holds the core).
    """

    cdef readonly GuidanceState state
    cdef FepfCore fepf
    cdef object tracking, arrived, stuck, infeasible, blocked, output_cls
    cdef object collect_route, time_scaled, replan
    cdef double progress_rad, progress_mrp, derate_every, min_derating
    cdef double goal[3]
    cdef double nominal, hold_deg, tol, rate_tol, settle_s, window_s, stuck_base
    cdef double max_rate, accel
    cdef bint has_rate, has_accel

    def __init__(
        self, GuidanceState state, FepfCore fepf, guidance, tuple statuses, output_cls,
        tuple constants, tuple hooks,
    ):
        self.state, self.fepf = state, fepf
        self.tracking, self.arrived, self.stuck, self.infeasible, self.blocked = statuses
        self.output_cls = output_cls
        self.progress_rad, self.progress_mrp, self.derate_every, self.min_derating = constants
        self.collect_route, self.time_scaled, self.replan = (_WeakMethod(h) for h in hooks)
        goal = guidance.goal
        self.goal[0], self.goal[1], self.goal[2] = goal[0], goal[1], goal[2]
        self.hold_deg = guidance.hold_deg
        self.tol, self.rate_tol = guidance.attitude_tol_deg, guidance.rate_tol_rad_s
        self.settle_s = guidance.knowledge.settle_s
        self.window_s = guidance.knowledge.decision_window_s
        lim = guidance.limits
        self.has_rate, self.has_accel = lim.max_rate_rad_s is not None, lim.accel_rad_s2 is not None
        self.max_rate = lim.max_rate_rad_s if self.has_rate else 0.0
        self.accel = lim.accel_rad_s2 if self.has_accel else 0.0
        planner = guidance.planner
        self.nominal = planner.dt
        self.stuck_base = planner.cfg.stuck_timeout_s

    def update(self, t_s, sigma_bn, omega_b):
        """``Guidance.update_reference``."""
        cdef GuidanceState gs = self.state
        cdef FepfCore fepf = self.fepf
        cdef FepfState fs = fepf.state
        cdef double nominal = self.nominal
        t_prev = gs.t_prev
        cdef double t = float(t_s)
        cdef double dt = 0.0 if t_prev is None else t - <double>t_prev
        if dt < 0.0:
            raise ValueError(f"state time {t_s} s is before the previous {t_prev} s")
        if dt == 0.0 and t_prev is not None:
            raise ValueError(f"state time {t_s} s repeats the previous one")
        gs.t_prev = t
        fepf._advance(dt)
        if gs.pending is not None:
            self.collect_route()(t)
        follower = gs.follower
        if fs.status == self.tracking and follower is not None:
            _follow_route(follower, fepf)
        cdef double ahead = dt if dt > nominal else nominal
        cdef double since = dt if dt > 0.0 else nominal
        out = fepf._propose(since, ahead)
        cdef double b1 = sigma_bn[0], b2 = sigma_bn[1], b3 = sigma_bn[2]
        target_sigma = out.sigma_t
        cdef double s1 = target_sigma[0], s2 = target_sigma[1], s3 = target_sigma[2]
        cdef double e_track = _angle(b1, b2, b3, s1, s2, s3) * _RAD_TO_DEG
        cdef double e_goal = _angle(b1, b2, b3, self.goal[0], self.goal[1], self.goal[2]) * _RAD_TO_DEG
        cdef double factor = 1.0
        cdef bint settling = t < self.settle_s
        cdef double w[3]
        cdef double r[3]
        cdef double safe[3]
        if fs.status == self.tracking:
            if not self.has_rate and not self.has_accel:
                shaped = out.omega_t
            else:
                shaped = self.time_scaled()(out, since)
            factor = _clip01(2.0 - e_track / self.hold_deg)
            if settling:
                factor = 0.0
            elif factor >= 1.0 or not self.has_accel:
                gs.behind_since = None  # Guidance._derate: nothing to derate
            else:
                self._derate(factor, t)
            w[0], w[1], w[2] = factor * shaped[0], factor * shaped[1], factor * shaped[2]
            _mrp_rate(s1, s2, s3, w[0], w[1], w[2], r)
            safe[0], safe[1], safe[2] = r[0], r[1], r[2]
            fepf._hold_rate(safe, ahead)
            if safe[0] != r[0] or safe[1] != r[1] or safe[2] != r[2]:
                r[0], r[1], r[2] = safe[0], safe[1], safe[2]
                _omega_from_rate(s1, s2, s3, safe[0], safe[1], safe[2], w)
            omega_t = np.array((w[0], w[1], w[2]))
            gs.omega_prev = omega_t
            out.sigma_t_dot = np.array((r[0], r[1], r[2]))
            out.omega_t = omega_t
        else:
            gs.omega_prev = np.zeros(3)
            if fs.status == self.stuck:
                factor = 0.0
        cdef double rate_b = _hypot(float(omega_b[0]), float(omega_b[1]), float(omega_b[2]))
        if not settling:
            self._judge(dt, e_goal, rate_b)
        out.status = gs.status
        return self.output_cls(out, e_track, e_goal, factor, gs.derating)

    cdef int _derate(self, double factor, double t) except -1:
        """``Guidance._derate`` for a factor below 1 with an acceleration bound."""
        cdef GuidanceState gs = self.state
        cdef double d
        if gs.behind_since is None:
            gs.behind_since = t
        if t - <double>gs.behind_since < self.window_s:
            return 0
        if t - gs.derated_at < self.derate_every:
            return 0
        d = 0.5 * gs.derating  # max(0.5 * derating, floor), as Python's
        if self.min_derating > d:
            d = self.min_derating
        gs.derating = d
        gs.derated_at = t
        return 0

    cdef double _stuck_timeout(self):
        """``Guidance.stuck_timeout_s``."""
        cdef double timeout = self.stuck_base
        cdef double derating = self.state.derating
        if self.has_accel and self.has_rate:
            if 0.25 > derating:  # max(derating, 0.25), as Python's
                derating = 0.25
            timeout += self.max_rate / (self.accel * derating)
        return timeout

    cdef int _judge(self, double dt, double e_goal_deg, double rate_dec) except -1:
        """``Guidance._judge`` on the body's own error and rate."""
        cdef GuidanceState gs = self.state
        cdef FepfState fs = self.fepf.state
        status = gs.status
        if status == self.stuck or status == self.infeasible or status == self.blocked:
            return 0
        cdef bint on_goal = fs.status == self.arrived
        cdef double tol = self.tol, rate_tol = self.rate_tol
        if on_goal and e_goal_deg <= tol and rate_dec <= rate_tol:
            gs.status = self.arrived
        elif status == self.arrived and (e_goal_deg > 2.0 * tol or rate_dec > 2.0 * rate_tol):
            gs.status = self.tracking
        if gs.status == self.arrived:
            gs.since_progress = 0.0
            return 0
        cdef double body = e_goal_deg * _DEG_TO_RAD
        cdef double target = 0.0
        if not on_goal:
            target = fs.d_goal + fs.beyond_mrp  # FepfPlanner.goal_distance_mrp
        cdef bint progressed = False
        if body < gs.best_body - self.progress_rad:
            gs.best_body = body
            progressed = True
        if target < gs.best_target - self.progress_mrp:
            gs.best_target = target
            progressed = True
        if progressed:
            gs.since_progress = 0.0
            return 0
        gs.since_progress = gs.since_progress + dt
        if gs.since_progress >= 0.5 * self.stuck_base:
            self.replan()()
        if gs.since_progress >= self._stuck_timeout():
            gs.status = self.stuck
            fs.status = self.stuck  # FepfPlanner.hold: the target holds where it is
        return 0
