"""What the simulator publishes of a stepper's decision
(:class:`attitude_core.runtime.sim_stepper.Decision`), in order: ``/clock`` (behind a
link, the decision's clocks first), the truth behind a link, the loop's state (the
sensors' samples with sensors), and the torque applied over the step.

:class:`StatePair` is a pair of state topics: the attitude (quaternion, frame
``inertial``) and the body rate (``omega_B``, frame ``body``), one stamp, refilled for
each state. The simulator has one for the state the loop reads and, behind a rehearsal
link, one for the truth (``/spacecraft/truth/*``, for the record).

With a wheel array each state goes out with ``/spacecraft/wheel_states`` of its stamp
(the wheel speeds, and the motor torques applied over the step that ended at it).
"""

from __future__ import annotations

from typing import Any

from rosgraph_msgs.msg import Clock as ClockMsg

from attitude_core.config.scenario import Scenario
from attitude_core.runtime.sim_stepper import Decision, StateOut
from attitude_ros import contract as c
from attitude_ros import convert as cv
from attitude_ros.endpoints import message, publisher
from attitude_ros.wheel_msgs import fill_joint_state

from .sensor_out import SensorOut

__all__ = ["StatePair", "SimOutputs"]


class StatePair:
    """The publishers and messages of ``node``'s state topics: the truth's
    (``/spacecraft/truth/*``) when ``truth``, else the loop's (``/spacecraft/*``)."""

    def __init__(self, node: Any, truth: bool) -> None:
        att, rate = c.TRUTH_TOPICS if truth else c.STATE_TOPICS
        self.pub_att, self.pub_rate = publisher(node, att), publisher(node, rate)
        self.msg_att, self.msg_rate = message(att), message(rate)

    def fill(self, state: StateOut) -> None:
        """Write ``state`` (its stamp, ``sigma_BN`` as a quaternion, ``omega_B``)."""
        cv.set_stamp(self.msg_att.header.stamp, state.stamp_ns)
        cv.set_stamp(self.msg_rate.header.stamp, state.stamp_ns)
        cv.set_quaternion_from_mrp(self.msg_att.quaternion, state.sigma_bn)
        cv.set_vector3(self.msg_rate.vector, state.omega_b)

    def publish(self) -> None:
        """Publish the messages as last filled (a re-send: the same again)."""
        self.pub_att.publish(self.msg_att)
        self.pub_rate.publish(self.msg_rate)


class SimOutputs:
    """The simulator's publishers of a scenario (its sensors, its link) on ``node``."""

    def __init__(self, node: Any, sc: Scenario, lockstep: bool) -> None:
        sensing = sc.sensors is not None
        self.lockstep = lockstep
        # The loop's state (the truth with sensors); behind a link, the truth apart.
        self.state = StatePair(node, truth=sensing)
        self.truth = None if sc.link is None else StatePair(node, truth=True)
        self.sensors = None if sc.sensors is None else SensorOut(node, sc, sc.sensors)
        self.pub_clock = publisher(node, c.CLOCK)
        self.pub_applied = publisher(node, c.APPLIED_TORQUE)
        self.msg_clock = ClockMsg()
        self.msg_applied = message(c.APPLIED_TORQUE)
        self.wheel_names = None if sc.wheels is None else sc.wheels.names
        self.pub_wheels = None if sc.wheels is None else publisher(node, c.WHEEL_STATES)
        self.msg_wheels = message(c.WHEEL_STATES)

    @property
    def state_publishers(self) -> dict[str, Any]:
        """The state topics the readiness counts listeners of (the gyro's with sensors)."""
        if self.sensors is not None:
            return self.sensors.publishers
        return {c.ATTITUDE: self.state.pub_att, c.ANGULAR_VELOCITY: self.state.pub_rate}

    def publish(self, d: Decision) -> None:
        """Publish what ``d`` says, the state before the applied torque (the loop waits)."""
        for clock_ns in d.clocks:  # behind a link: /clock first, in order
            cv.set_stamp(self.msg_clock.clock, clock_ns)
            self.pub_clock.publish(self.msg_clock)
        if d.truth is not None and self.truth is not None:
            self.truth.fill(d.truth)
            self.truth.publish()
        if d.state is not None:
            if d.state.clock_ns is not None:  # lockstep only
                cv.set_stamp(self.msg_clock.clock, d.state.clock_ns)
            self.state.fill(d.state)
            if self.wheel_names is not None and d.state.wheel_speeds is not None:
                cv.set_stamp(self.msg_wheels.header.stamp, d.state.stamp_ns)
                effort = d.state.wheel_effort
                assert effort is not None
                fill_joint_state(self.msg_wheels, self.wheel_names, d.state.wheel_speeds, effort)
            if self.sensors is not None:
                self.sensors.measure(d.state.k, d.state.stamp_ns, d.state.sigma_bn, d.state.omega_b)
        if d.state is not None or (d.resend and d.resend_state):
            self.state.publish()
            if self.pub_wheels is not None:
                self.pub_wheels.publish(self.msg_wheels)
            if self.sensors is not None:
                self.sensors.publish()
            if self.lockstep and self.truth is None:  # lockstep only; behind a link the
                self.pub_clock.publish(self.msg_clock)  # clocks come in d.clocks
        if d.applied is not None and d.applied_stamp_ns is not None:
            cv.set_stamp(self.msg_applied.header.stamp, d.applied_stamp_ns)
            cv.set_vector3(self.msg_applied.wrench.torque, d.applied)
            self.pub_applied.publish(self.msg_applied)
