# Mirrors attitude_core.fsw.guidance.route_following (RouteFollower.advance): once per
# state, before the FEPF proposes, the waypoints behind the target are passed and the
# FEPF's goal kept in sight (paper eq. 5's exact margins along the rotation to it).
#
# Through the follower's documented interface: its ``waypoints``, ``leg``, ``swing_deg``
# and ``route.clearance_deg`` are read; its ``aim_at(leg)`` and ``aim_in_sight()`` are
# the hooks that move the goal (FepfPlanner.set_goal, into the planner's FepfState).
# Equal to the bit (tests/core/test_guidance_kernel.py).


cdef int _follow_route(follower, FepfCore fepf) except -1:
    """``RouteFollower.advance`` on the planner of ``fepf``: pass the waypoints behind
    the target, then keep its goal in sight (aiming back at the leg: the follower's own
    ``aim_in_sight``)."""
    cdef ConeKernel k = fepf.margins
    if k is None:
        follower.advance()
        return 0
    cdef FepfState st = fepf.state
    cdef list wp = follower.waypoints
    cdef Py_ssize_t last = len(wp) - 1, leg
    cdef double clearance = follower.route.clearance_deg
    cdef double swing = follower.swing_deg
    cdef bint near
    cdef tuple here, at, after
    while True:
        leg = follower.leg
        if leg >= last:
            break
        here = st.sigma_t
        at = wp[leg]
        near = _angle(here[0], here[1], here[2], at[0], at[1], at[2]) * _RAD_TO_DEG <= swing
        if not near:
            after = wp[leg + 1]
            if k._arc(here[0], here[1], here[2], after[0], after[1], after[2]) < clearance:
                break
        follower.aim_at(leg + 1)
    # RouteFollower.aim_in_sight: the waypoint in sight, or the follower's carrots
    leg = follower.leg
    at = wp[leg]
    here = st.sigma_t
    cdef double need = fepf._sight(k, fepf.buffer)
    if k._arc(here[0], here[1], here[2], at[0], at[1], at[2]) >= need:
        if st.goal != at:
            follower.aim_at(leg)
        return 0
    follower.aim_in_sight()
    return 0
