"""The world the flight software flies in: the plant and its sensors' errors.

What a hardware-in-the-loop bench replaces. Imports the shared models
(:mod:`attitude_core.models`) and the compiled kernels; never the flight software.

* ``rigid_body`` (eqs. 3-4): inertia and torque in; the rigid-body state propagated
  (RK4, shadow switching) out.
* ``actuator``: a commanded torque and the per-axis bound in; the torque the plant
  applies (each axis clipped on its own) out.
* ``sensors``: the declared sensors and the true state in; star tracker and gyro
  samples (reproducible from the seed) out.
"""
