"""The run's defences and the simulator's stepping, given time and inputs (no ROS).

* ``stamp_gate``: incoming stamps in; which may become a receiver's time reference out.
* ``stamp_pairing``: the planner's or controller's inputs in; values checked and paired
  by stamp out.
* ``plausibility``: torques, rates and MRPs received in; refusals of implausible values
  out.
* ``run_identity``: node names and the scenario in; the run namespace, foreign
  publishers and the scenario fingerprint out.
* ``process_identity``: a PID in; an identity that a reused PID does not match out.
* ``recording``: planner statuses and stamps in; the recorder's stop rule out.
* ``sim_stepper``: wall time and torques received in; the simulator's start-up gate,
  lockstep handshake and real-time ticks out.
* ``planner_stepper``: measured states (stamp, attitude, rate) in; the planner's
  targets, held target, margin, diagnostics and status changes out.
* ``lifecycle_manager``: the managed nodes' names, transition events, identities and
  command lines in; their bring-up and bring-down and the manager's event lines out.
"""
