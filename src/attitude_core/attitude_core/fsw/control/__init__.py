"""Control: the PD law of eq. 11 and the controller's torque bound.

* ``pd`` (eq. 11): state, target and ``PdGains`` in; the torque (body axes, N m) out.
* ``saturation``: a torque and the per-axis bound in; the torque scaled into the bound
  (its direction kept) out.
"""
