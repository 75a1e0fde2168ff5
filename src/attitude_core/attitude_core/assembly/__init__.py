"""Assembly: the flight software built from a scenario.

Above both the configuration (:mod:`attitude_core.config`, the scenario as a record) and
the flight software (:mod:`attitude_core.fsw`, which knows nothing of scenarios): the
one place where a ``Scenario`` becomes a planner, a guidance, a route planner and the
safety buffer they share. Every caller (the offline loop, the planner node, a campaign
worker, a test) builds them here, so they are built the same way everywhere.

* ``guidance``: a scenario (and a start) in; the FEPF planner, the guidance closed on
  the measured state, what is worth preparing before the first state (FIS tables,
  roadmap, first route), the planner's safety buffer and the expected slew time out.
"""
