"""GNC math: attitude kinematics, keep-out geometry, guidance, control and dynamics.

Plain NumPy and SciPy, no ROS, no files but the packaged FIS data. Inputs and outputs:

* ``mrp`` (eqs. 1-3, 12): MRPs ``sigma_BN`` and quaternions in; ``C_BN``, the shadow
  set, ``B(sigma)``, MRP rates and relative MRPs out.
* ``constraints`` (eq. 5): body boresights ``s_i``, inertial directions ``c_j`` and
  half-angles in; exact keep-out and keep-in margins, closed-form margins along an
  eigenaxis rotation and the MRP-space obstacle distance out.
* ``ephemeris``: epoch, orbit elements and times in; the spacecraft's two-body position,
  the Sun's and the Moon's, each body's direction and angular radius out.
* ``sky``: the instruments' per-object exclusions and the objects' motions in; directions,
  radii and margins at any time, and the cone geometry of a time window, out.
  ``goal_watch``: a sky and the goal in; the windows in which the goal is blocked out.
  ``moving_sky``: the guidance's windowed cones, swept-cone routes and places to wait.
* ``fuzzy``: FIS specifications in; Mamdani inference and lookup tables out.
* ``fepf`` (eqs. 6-10, 12): target, goal and cone geometry in; one FEPF step
  (``sigma_t_dot``, ``omega_t``) out.
* ``route``: start, goal and cone geometry in; a global route over SO(3), or the reason
  none exists, out. ``route_following``: a route in; intermediate goals and turn and
  braking speeds out.
* ``guidance`` (eqs. 6-12): measured ``sigma_BN``, ``omega_BN`` and time in; the
  target ``sigma_RN``, ``omega_RN`` and the planner status out.
* ``control`` (eq. 11): state, target and gains in; the PD torque (body axes, N m) out.
  ``actuators``: a vector and a bound in; the vector clipped or scaled out.
* ``dynamics`` (eqs. 3-4): inertia and torque in; the rigid-body state propagated
  (RK4, shadow switching) out.
* ``sensors``: the declared star tracker and gyro and the true state in; their samples
  (reproducible from the seed) out. ``mekf``: gyro and star tracker samples in; the
  multiplicative EKF's attitude, bias-corrected rate, bias and covariance out.
  ``knowledge``: the declared sensors in; the guidance's knowledge bounds (3-sigma,
  decision window, settling time) out. ``sensing``: sensors and filter of one offline run.
"""
