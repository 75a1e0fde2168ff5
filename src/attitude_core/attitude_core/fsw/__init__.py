"""Flight software: what runs on board, from measured state to commanded torque.

Imports the shared models (:mod:`attitude_core.models`), the compiled kernels and the
status vocabulary (:mod:`attitude_core.contract.status`); never the world
(:mod:`attitude_core.world`), the scenario (:mod:`attitude_core.config`) or ROS
(import-linter contracts in ``pyproject.toml``). Built from a scenario by
:mod:`attitude_core.assembly`.

* ``guidance`` (eqs. 6-12): the measured ``sigma_BN``, ``omega_BN`` and time in; the
  target ``sigma_RN``, ``omega_RN`` and the planner status out (FEPF, fuzzy, global
  route, time scaling, moving sky, goal watch).
* ``control`` (eq. 11): state, target and gains in; the PD torque, scaled into the
  actuator bound, out.
* ``estimation``: gyro and star tracker samples in; the MEKF's attitude, rate, bias and
  covariance out; the guidance's knowledge bounds from the declared sensors.
"""
