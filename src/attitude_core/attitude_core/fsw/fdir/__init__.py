"""Fault detection, isolation and recovery for a state link that drops or dies.

* :mod:`.fdir_config`: the ``fdir.*`` limits (a leaf).
* :mod:`.state_watchdog`: the age of the newest measured state on the stack's clock, the
  mode it puts the flight software in, and the faults it records; used by the planner
  and the controller alike.
* :mod:`.state_predictor`: the body model flown on when no state comes, propagated from
  the last measured state with the torques actually commanded.
* :mod:`.tracker_watch`: the star tracker's gaps (no solution) as faults.
* :mod:`.outage_control`: what the controller commands at each loop tick without a
  fresh state (predict, brake, zero, safe).
"""
