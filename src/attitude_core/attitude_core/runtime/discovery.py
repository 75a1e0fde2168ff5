"""How fast the stack's ROS 2 participants find each other (no ROS import).

Fast DDS announces each participant a few times when it starts, then once per
announcement period (3 s by default). A participant that misses the others' first
announcements, as happens when the processes of a run start together on a loaded
machine, is found only at the next periodic one: a 3 s stall of the bring-up, and a
3 s discovery wait for the domain probe. The stack's nodes therefore announce every
:data:`ANNOUNCEMENT_PERIOD_S` (the Fast DDS profile ``attitude_ros/fastdds_discovery.xml``,
applied by :mod:`attitude_ros.dds_profile`), and the probe of a caller's domain waits
:data:`PROBE_WAIT_S`: two periods and a margin, so it finds every node of another run
even after a missed first announcement.
"""

from __future__ import annotations

__all__ = ["ANNOUNCEMENT_PERIOD_S", "LEASE_DURATION_S", "PROBE_WAIT_S"]

ANNOUNCEMENT_PERIOD_S = 0.5
"""Period of a node's participant announcements, s (Fast DDS ``leaseAnnouncement``)."""

LEASE_DURATION_S = 10.0
"""A participant not heard of for this long is gone, s (Fast DDS ``leaseDuration``)."""

PROBE_WAIT_S = 2 * ANNOUNCEMENT_PERIOD_S + 0.2
"""Discovery time of the busy-domain probe, s."""
