"""Shared models: what both the flight software and the world it flies in read.

Plain NumPy and SciPy, no ROS. The flight software (:mod:`attitude_core.fsw`) and the
world (:mod:`attitude_core.world`) both import these; these import neither.

* ``mrp`` (eqs. 1-3, 12): MRPs ``sigma_BN`` in; ``C_BN``, the shadow set, ``B(sigma)``,
  MRP rates, composition and relative MRPs out. ``quaternion``: scalar-last Hamilton
  quaternions in plain floats (product, conjugate, rotation vectors).
* ``constraints`` (eq. 5): body boresights ``s_i``, inertial directions ``c_j`` and
  half-angles in; exact keep-out and keep-in margins, closed-form margins along an
  eigenaxis rotation and the MRP-space obstacle distance out.
* ``ephemeris``: epoch, orbit elements and times in; the spacecraft's two-body position,
  the Sun's and the Moon's, each body's direction and angular radius out.
* ``sky``: the instruments' per-object exclusions and the objects' motions in;
  directions, radii and margins at any time, and the cone geometry of a time window out.
* ``sensor_spec``: the declared star tracker and gyro (noise, rate, bias, outages) and
  the tracker's sampling schedule.
"""
