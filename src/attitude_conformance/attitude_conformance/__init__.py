"""Conformance check of a hardware-in-the-loop bridge (a replacement for ``rigid_body_sim``).

``bridge_check`` (:mod:`.check_node`, the ROS shell, run by :mod:`.loop`) stands in for the
planner and the controller, drives the bridge through a short script (:mod:`.driver`;
:mod:`.watch` gives up), records what it publishes (:mod:`.sampling` into :mod:`.record`;
the connection: :mod:`.qos_probe`) and judges each contract point (:mod:`.checker`, plain
data, no ROS; printed by :mod:`.verdict`).
"""
