"""Estimation: what the flight software knows of its own attitude.

* ``mekf``: gyro and star tracker samples in; the multiplicative EKF's attitude,
  bias-corrected rate, bias and covariance out (Markley and Crassidis, 2014).
* ``knowledge``: the declared sensors (:mod:`attitude_core.models.sensor_spec`) and the
  step in; the guidance's knowledge bounds (settled 3-sigma, decision window, settling
  time) out.
"""
