"""Guidance: the FEPF walked around the keep-out cones, closed on the measured state.

* ``planner_config``: ``planner.*`` as a record and its mode enums (a leaf).
* ``fuzzy``: FIS specifications in; Mamdani inference and lookup tables out.
* ``fepf`` (eqs. 6-10, 12): target, goal and cone geometry in; one FEPF step
  (``sigma_t_dot``, ``omega_t``) out.
* ``route``: start, goal and cone geometry in; a global route over SO(3), or the reason
  none exists, out. ``route_following``: a route in; intermediate goals and turn and
  braking speeds out.
* ``profile_limits``: inertia, torque and rate bounds in; the target profile's rate cap
  and acceleration, the rest-to-rest time bound out.
* ``goal_watch``: a sky and the goal in; the windows in which the goal is blocked out.
  ``moving_sky``: the guidance's windowed cones, swept-cone routes and places to wait.
* ``guidance`` (eqs. 6-12): measured ``sigma_BN``, ``omega_BN`` and time in; the target
  ``sigma_RN``, ``omega_RN`` and the planner status out.
"""
