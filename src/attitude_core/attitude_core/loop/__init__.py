"""The offline loop: flight software and world wired in one process.

The one place that imports both sides (:mod:`attitude_core.fsw` and
:mod:`attitude_core.world`) to fly a scenario without ROS; the nodes wire the same
pieces over DDS instead.

* ``closed_loop``: a scenario in; its ``RunResult`` (guidance, control and the body,
  with sensors and the MEKF when declared) out.
* ``loop_plant`` (eqs. 2-4, 11): the fed state and the target at step ``k`` in; the PD
  torque, the plant's clip and the next body state, written into the run's record, out.
* ``sensing``: the declared sensors and the true state per step in; the MEKF's estimate
  fed to the guidance, and its record, out.
"""
