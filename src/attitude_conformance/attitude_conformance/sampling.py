"""What the node hears and sends, recorded (plain data, no ROS).

Each message of the bridge goes into the :class:`~.record.Recording` as it arrives; a
state is complete when its attitude and its rate (one stamp) are both in, and is then
handed to the :class:`~.driver.Driver`, whose torques the node sends and records here.
"""

from __future__ import annotations

import numpy as np

from attitude_core.contract.topics import (
    ANGULAR_VELOCITY,
    APPLIED_TORQUE,
    ATTITUDE,
    BODY_FRAME,
    CLOCK,
    WHEEL_STATES,
)

from .driver import Driver
from .record import JointSample, Recording, Sample

Torques = list[tuple[int, np.ndarray]]  # (stamp_ns, torque N m, or motor torques) to send


class Sampler:
    """Records the bridge's messages and the tool's torques; pairs the state's messages."""

    def __init__(self, rec: Recording, driver: Driver) -> None:
        self.rec, self.driver = rec, driver
        self.samples: dict[str, list] = {
            WHEEL_STATES: rec.wheel_states,
            CLOCK: rec.clock,
            APPLIED_TORQUE: rec.applied,
            ATTITUDE: rec.attitude,
            ANGULAR_VELOCITY: rec.rate,
        }
        self.stamps: dict[str, set[int]] = {ATTITUDE: set(), ANGULAR_VELOCITY: set()}
        self.complete: set[int] = set()

    def heard(self, name: str, sample: Sample | JointSample) -> Torques:
        """Record a message of topic ``name``; the torques to send now (the driver's
        answer when it completes a state)."""
        self.samples[name].append(sample)
        if name not in self.stamps:
            return []
        stamp = sample.stamp_ns
        self.stamps[name].add(stamp)
        if not all(stamp in s for s in self.stamps.values()):
            return []
        first = stamp not in self.complete
        self.complete.add(stamp)
        if first or name == ATTITUDE:  # a re-send is answered once, on its attitude
            return self.driver.on_state(stamp, sample.wall_s)
        return []

    def sent(
        self, stamp: int, u: np.ndarray, now: float, order: tuple[int, ...] | None = None
    ) -> None:
        """Record a torque the tool published (with wheels: the motor torques in the
        scenario's order, sent in ``order``)."""
        self.rec.torques.append(Sample(stamp, BODY_FRAME, tuple(float(x) for x in u), now))
        if order is not None and order != tuple(range(len(order))):
            self.rec.wheel_orders.setdefault(stamp, order)
