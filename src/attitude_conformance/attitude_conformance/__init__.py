"""Conformance check of a hardware-in-the-loop bridge (a replacement for ``rigid_body_sim``).

``bridge_check`` (:mod:`.check_node`) stands in for the planner and the controller, drives
the bridge through a short script (:mod:`.driver`), records what it publishes
(:mod:`.record`) and judges each contract point (:mod:`.checker`, plain data, no ROS).
"""
