# The guidance's step, compiled (included by _kernels.pyx).
#
# GuidanceCore.update is Guidance.update_reference (gnc/guidance.py) in C for a static
# sky and a decision on each state (no decision window): the same operations in the same
# order on the guidance's own state, which stays in the Python object. The rarer parts
# call the Python methods themselves: a route that is pending, the route following, the
# time scaling to actuator limits, the derating, a new route when the target stalls.
# Equal to the bit (tests/core/test_guidance_kernel.py).

import math as _math

_hypot = _math.hypot  # Python's own (a correctly rounded norm, not sqrt of the sum)
_DEG_TO_RAD = _math.pi / 180.0


cdef class GuidanceCore:
    """The compiled step of one ``Guidance`` (see the include's header)."""

    cdef object tracking, arrived, stuck, infeasible, blocked, output_cls
    cdef double progress_rad, progress_mrp

    def __init__(self, statuses, output_cls, double progress_rad, double progress_mrp):
        self.tracking, self.arrived, self.stuck, self.infeasible, self.blocked = statuses
        self.output_cls = output_cls
        self.progress_rad, self.progress_mrp = progress_rad, progress_mrp

    def update(self, g, t_s, sigma_bn, omega_b):
        """``Guidance.update_reference``."""
        planner = g.planner
        cdef FepfCore fepf = planner._core
        cdef double nominal = planner.dt
        t_prev = g.t_prev
        cdef double t = float(t_s)
        cdef double dt = 0.0 if t_prev is None else t - <double>t_prev
        if dt < 0.0 or (dt == 0.0 and t_prev is not None):
            return g.update_reference(t_s, sigma_bn, omega_b)  # raises the error
        g.t_prev = t
        fepf.advance(planner, dt)
        if g._pending is not None:
            g._collect_route(t)
        follower = g.follower
        if planner.status == self.tracking and follower is not None:
            self._follow(follower, planner, fepf)
        cdef double ahead = dt if dt > nominal else nominal
        cdef double since = dt if dt > 0.0 else nominal
        out = fepf.propose(planner, since, ahead)
        cdef double b1 = sigma_bn[0], b2 = sigma_bn[1], b3 = sigma_bn[2]
        target_sigma = out.sigma_t
        cdef double s1 = target_sigma[0], s2 = target_sigma[1], s3 = target_sigma[2]
        goal = g.goal
        cdef double e_track = _angle(b1, b2, b3, s1, s2, s3) * _RAD_TO_DEG
        cdef double e_goal = _angle(b1, b2, b3, goal[0], goal[1], goal[2]) * _RAD_TO_DEG
        cdef double factor = 1.0
        cdef bint settling = t < g.knowledge.settle_s
        cdef double w[3]
        cdef double r[3]
        cdef double safe[3]
        if planner.status == self.tracking:
            lim = g.limits
            if lim.max_rate_rad_s is None and lim.accel_rad_s2 is None:
                shaped = out.omega_t
            else:
                shaped = g._time_scaled(out, since)
            factor = _clip01(2.0 - e_track / g.hold_deg)
            if settling:
                factor = 0.0
            elif factor >= 1.0 or lim.accel_rad_s2 is None:
                g._behind_since = None  # Guidance._derate: nothing to derate
            else:
                g._derate(factor, t)
            w[0], w[1], w[2] = factor * shaped[0], factor * shaped[1], factor * shaped[2]
            _mrp_rate(s1, s2, s3, w[0], w[1], w[2], r)
            held = fepf.hold_rate(planner, (r[0], r[1], r[2]), ahead)
            safe[0], safe[1], safe[2] = held[0], held[1], held[2]
            if safe[0] != r[0] or safe[1] != r[1] or safe[2] != r[2]:
                r[0], r[1], r[2] = safe[0], safe[1], safe[2]
                _omega_from_rate(s1, s2, s3, safe[0], safe[1], safe[2], w)
            omega_t = np.array((w[0], w[1], w[2]))
            g.omega_prev = omega_t
            out.sigma_t_dot = np.array((r[0], r[1], r[2]))
            out.omega_t = omega_t
        else:
            g.omega_prev = np.zeros(3)
            if planner.status == self.stuck:
                factor = 0.0
        cdef double rate_b = _hypot(float(omega_b[0]), float(omega_b[1]), float(omega_b[2]))
        if not settling:
            self._judge(g, planner, dt, e_goal, rate_b)
        out.status = g.status
        return self.output_cls(out, e_track, e_goal, factor, g.derating)

    cdef void _follow(self, follower, planner, FepfCore fepf):
        """``RouteFollower.advance``: pass the waypoints behind the target, then keep
        its goal in sight (aiming back at the leg: the follower's own method)."""
        cdef ConeKernel k = fepf._kernel(planner, False)
        if k is None:
            follower.advance()
            return
        wp = follower._wp
        cdef Py_ssize_t last = len(wp) - 1, leg
        cdef double clearance = follower.route.clearance_deg
        cdef double swing = follower.swing_deg
        cdef bint near
        while True:
            leg = follower.leg
            if leg >= last:
                break
            here = planner.sigma_t
            at = wp[leg]
            near = _angle(here[0], here[1], here[2], at[0], at[1], at[2]) * _RAD_TO_DEG <= swing
            if not near:
                after = wp[leg + 1]
                if k._arc(here[0], here[1], here[2], after[0], after[1], after[2]) < clearance:
                    break
            follower._aim_at(leg + 1)
        # RouteFollower._aim_in_sight: the waypoint in sight, or the follower's carrots
        leg = follower.leg
        at = wp[leg]
        here = planner.sigma_t
        cdef double need = fepf._sight(planner, k, planner.geometry.inflation_deg)
        if k._arc(here[0], here[1], here[2], at[0], at[1], at[2]) >= need:
            if planner.goal != at:
                follower._aim_at(leg)
            return
        follower._aim_in_sight()

    cdef void _judge(self, g, planner, double dt, double e_goal_deg, double rate_dec):
        """``Guidance._judge`` on the body's own error and rate."""
        status = g.status
        if status == self.stuck or status == self.infeasible or status == self.blocked:
            return
        cdef bint on_goal = planner.status == self.arrived
        cdef double tol = g.attitude_tol_deg, rate_tol = g.rate_tol_rad_s
        if on_goal and e_goal_deg <= tol and rate_dec <= rate_tol:
            g.status = self.arrived
        elif status == self.arrived and (e_goal_deg > 2.0 * tol or rate_dec > 2.0 * rate_tol):
            g.status = self.tracking
        if g.status == self.arrived:
            g._since_progress = 0.0
            return
        cdef double body = e_goal_deg * _DEG_TO_RAD
        cdef double target = 0.0
        if not on_goal:
            target = planner._d_goal + planner._beyond_mrp  # FepfPlanner.goal_distance_mrp
        cdef bint progressed = False
        if body < <double>g._best_body - self.progress_rad:
            g._best_body = body
            progressed = True
        if target < <double>g._best_target - self.progress_mrp:
            g._best_target = target
            progressed = True
        if progressed:
            g._since_progress = 0.0
            return
        cdef double since = <double>g._since_progress + dt
        g._since_progress = since
        if since >= 0.5 * planner.cfg.stuck_timeout_s:
            g._replan()
        if <double>g._since_progress >= <double>g.stuck_timeout_s:
            g.status = self.stuck
            planner.hold(self.stuck)

