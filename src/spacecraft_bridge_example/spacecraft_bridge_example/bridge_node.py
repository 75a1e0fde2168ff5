"""Example HIL bridge (``ros2 run spacecraft_bridge_example bridge``), written from the
contract alone (docs/hil_bridge.md); it replaces ``rigid_body_sim``. Exit code 0 at the end
of the scenario time or on SIGINT/SIGTERM, 1 if the graph never connects, 2 bad parameter.

With ``wheels.names`` in the scenario file it is a wheel plant (:mod:`.wheel_plant`): it
steps on ``/controller/wheel_torque`` instead of ``/controller/torque``, publishes
``/spacecraft/wheel_states`` with each state and the wheels' body torque on
``/spacecraft/applied_torque``."""

import math
import signal
import sys
import time

import numpy as np
import rclpy
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped, WrenchStamped
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import ParameterException
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState

from .plant import Plant, ScipyRigidBody
from .wheel_plant import RPM, RK4WheelBody, Wheel, WheelPlant, wheel_problem

LOOP_S, SETTLE_S = 0.02, 0.2  # start-up poll / lockstep deadline check; settle time, s
OWN = {  # the bridge's own parameters and their defaults
    'time_mode': 'lockstep',
    'lockstep.expected_subscribers': 3,
    'lockstep.resend_period_s': 0.2,
    'lockstep.torque_timeout_s': 2.0,
    'lockstep.max_held_steps': 1,
    'realtime.torque_stale_s': 0.5,
    'startup_timeout_s': 60.0,
}
# The scenario keys a bridge reads (required): floats, and float arrays with their lengths.
FLOATS = ('dt_s', 'sim_time_s')
VECTORS = {'inertia_kgm2': 9, 'initial_mrp': 3, 'initial_rate_rad_s': 3}
# With wheels.names: the keys of each wheel under wheels.<name>. (None: required).
WHEEL_KEYS = {
    'spin_axis_body': None,
    'max_torque_nm': None,
    'max_speed_rpm': None,
    'spin_inertia_kgm2': None,
    'initial_speed_rpm': 0.0,
    'fails_at_s': math.inf,
}
_RELIABLE = {'reliability': ReliabilityPolicy.RELIABLE, 'durability': DurabilityPolicy.VOLATILE}
PUB_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=200, **_RELIABLE)
SUB_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=200, **_RELIABLE)


def quaternion_from_mrp(sigma) -> np.ndarray:
    """MRP sigma_BN -> quaternion (x, y, z, w), w >= 0."""
    s = np.asarray(sigma, dtype=float)
    q = np.append(2.0 * s, 1.0 - s @ s) / (1.0 + s @ s)
    return -q if q[3] < 0.0 else q


def set_stamp(stamp, ns: int) -> None:
    stamp.sec, stamp.nanosec = divmod(int(ns), 1_000_000_000)


def ns_of(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def by_name(names: tuple[str, ...], msg: JointState) -> tuple[np.ndarray | None, str]:
    """A wheel torque's ``effort`` in the order of ``names`` (read by name, any order), or
    (None, why): every declared wheel once, no other, one finite effort each."""
    got = list(msg.name)
    if sorted(got) != sorted(names):
        return None, f'wheel names {got}, expected each of {list(names)} once'
    if len(msg.effort) != len(got):
        return None, f'{len(msg.effort)} efforts for {len(got)} names'
    effort = dict(zip(got, msg.effort, strict=True))
    u = np.array([effort[n] for n in names], dtype=float)
    if not np.all(np.isfinite(u)):
        return None, f'effort has a non-finite element {u.tolist()}'
    return u, ''


class BridgeNode(Node):
    def __init__(self) -> None:
        super().__init__('spacecraft_bridge')  # other keys of the scenario file: ignored
        p = {key: self.declare_parameter(key, value).value for key, value in OWN.items()}
        for key in (*FLOATS, *VECTORS):
            kind = Parameter.Type.DOUBLE if key in FLOATS else Parameter.Type.DOUBLE_ARRAY
            self.declare_parameter(key, kind)
            p[key] = self.get_parameter(key).value  # raises when the file lacks the key
        bad = [k for k, n in VECTORS.items() if len(p[k]) != n or not np.isfinite(p[k]).all()]
        if p['time_mode'] not in ('lockstep', 'realtime') or not p['dt_s'] > 0.0 or bad:
            raise ValueError(f'need time_mode lockstep or realtime, dt_s > 0; bad: {bad}')
        self.p, self.lockstep = p, p['time_mode'] == 'lockstep'
        self.dt_s, self.dt_ns = p['dt_s'], round(p['dt_s'] * 1e9)
        self.n_steps = round(p['sim_time_s'] / p['dt_s'])
        q0 = quaternion_from_mrp(p['initial_mrp'])
        wheels = self.read_wheels(p['inertia_kgm2'])
        self.plant: Plant | None = None  # exactly one of the two plants
        self.wheel_plant: WheelPlant | None = None
        if wheels:
            rate0 = p['initial_rate_rad_s']
            self.wheel_plant = RK4WheelBody(p['inertia_kgm2'], wheels, q0, rate0)
        else:
            self.plant = ScipyRigidBody(p['inertia_kgm2'], q0, p['initial_rate_rad_s'])
        self.names = tuple(w.name for w in wheels)
        self.k, self.stamp_ns = 0, -1  # states published so far (lockstep: the step); stamp
        self.first_stamp_ns = -1  # the first state's stamp: the scenario's time is since then
        # lockstep: the last applied; real time: the latest. The body torque, or with wheels
        # the commanded motor torques (wheel order)
        self.torque = np.zeros(len(wheels) or 3)
        self.torque_stamp = -1  # real time: the stamp of the latest torque, and its arrival
        self.torque_at: float | None = None
        self.held, self.rejected, self.stale = 0, 0, False  # timeouts in a row; bad torques
        self.exit_code: int | None = None  # set: the main loop ends
        self.created = time.monotonic()
        self.ready_since: float | None = None  # since when the graph is connected
        self.sent_at = self.first_sent_at = 0.0  # wall time of the state's last, first send
        pub = lambda kind, name: self.create_publisher(kind, name, PUB_QOS)
        self.pub_att = pub(QuaternionStamped, '/spacecraft/attitude')
        self.pub_rate = pub(Vector3Stamped, '/spacecraft/angular_velocity')
        self.pub_applied = pub(WrenchStamped, '/spacecraft/applied_torque')
        self.pub_clock = pub(ClockMsg, '/clock')
        self.pub_wheels = pub(JointState, '/spacecraft/wheel_states') if wheels else None
        if wheels:  # a wheel plant steps on the motor torques instead of the body torque
            self.sub = self.create_subscription(
                JointState, '/controller/wheel_torque', self.on_wheel_torque, SUB_QOS
            )
        else:
            self.sub = self.create_subscription(
                WrenchStamped, '/controller/torque', self.on_torque, SUB_QOS
            )
        self.att, self.rate, self.clock = QuaternionStamped(), Vector3Stamped(), ClockMsg()
        self.att.header.frame_id, self.rate.header.frame_id = 'inertial', 'body'
        self.wheel_states = JointState()
        self.wheel_states.header.frame_id = 'body'
        self.wheel_states.name = list(self.names)
        self.applied = WrenchStamped()
        self.applied.header.frame_id = 'body'
        self.steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.timer = self.create_timer(LOOP_S, self.on_startup, clock=self.steady)
        plant = f'{len(wheels)} reaction wheels {list(self.names)}' if wheels else 'a rigid body'
        self.get_logger().info(f'{self.n_steps} steps of {self.dt_s} s, {p["time_mode"]}, {plant}')

    def read_wheels(self, inertia) -> list[Wheel]:
        """The wheels of ``wheels.names`` (none without the key); ValueError when one is
        incomplete or cannot fly. Numbers may be written as integers or floats here."""
        names = self.declare_parameter('wheels.names', Parameter.Type.STRING_ARRAY).value
        if not names:
            return []
        any_type = ParameterDescriptor(dynamic_typing=True)
        wheels = []
        for name in names:
            got: dict[str, object] = {}
            for key, default in WHEEL_KEYS.items():
                full = f'wheels.{name}.{key}'
                value = self.declare_parameter(full, None, any_type).value
                if value is None and default is None:
                    raise ValueError(f'{full}: required with wheels.names')
                got[key] = default if value is None else value
            try:
                axis = np.asarray(got.pop('spin_axis_body'), dtype=float)
                num = {key: float(value) for key, value in got.items()}  # type: ignore[arg-type]
            except (TypeError, ValueError):
                raise ValueError(f'wheels.{name}: a key is not a number: {got}') from None
            if axis.shape != (3,) or not np.linalg.norm(axis) > 0.0:
                raise ValueError(f'wheels.{name}.spin_axis_body: need 3 numbers, not all zero')
            axis = axis / np.linalg.norm(axis)
            wheels.append(
                Wheel(
                    name,
                    (float(axis[0]), float(axis[1]), float(axis[2])),
                    num['max_torque_nm'],
                    num['max_speed_rpm'] * RPM,
                    num['spin_inertia_kgm2'],
                    num['initial_speed_rpm'] * RPM,
                    num['fails_at_s'],
                )
            )
        problem = wheel_problem(inertia, wheels)
        if problem:
            raise ValueError(problem)
        return wheels

    def graph_ready(self) -> bool:
        n = self.p['lockstep.expected_subscribers']
        wheels = self.pub_wheels is None or self.pub_wheels.get_subscription_count() >= n - 1
        return (
            self.pub_att.get_subscription_count() >= n
            and self.pub_rate.get_subscription_count() >= n - 1
            and wheels
            and self.sub.get_publisher_count() >= 1
            and self.count_publishers('/planner/target_mrp') >= 1
            and self.count_publishers('/planner/target_rate') >= 1
        )

    def on_startup(self) -> None:
        """Wait until the graph has stayed connected for SETTLE_S, then take step 0."""
        now = time.monotonic()
        if not self.graph_ready():
            self.ready_since = None
            if now - self.created > self.p['startup_timeout_s']:
                self.get_logger().error('graph not connected within startup_timeout_s')
                self.finish(1)
            return
        self.ready_since = self.ready_since or now
        if now - self.ready_since < SETTLE_S:
            return
        self.get_logger().info('graph connected; starting')
        self.timer.cancel()
        period = LOOP_S if self.lockstep else self.dt_s
        self.timer = self.create_timer(period, self.on_timer, clock=self.steady)
        if self.lockstep:
            self.publish_state(0)
        else:
            self.on_timer()  # the first real-time step at once

    def on_torque(self, msg: WrenchStamped) -> None:
        t = msg.wrench.torque
        u = np.array([t.x, t.y, t.z])
        if msg.header.frame_id != 'body':
            return self.reject(f'frame_id {msg.header.frame_id!r}, expected body')
        if not np.all(np.isfinite(u)):
            return self.reject(f'torque has a non-finite element {u.tolist()}')
        self.take(u, ns_of(msg.header.stamp))

    def on_wheel_torque(self, msg: JointState) -> None:
        """The commanded motor torques (``effort``), read by wheel name."""
        if msg.header.frame_id != 'body':
            return self.reject(f'frame_id {msg.header.frame_id!r}, expected body')
        u, why = by_name(self.names, msg)
        if u is None:
            return self.reject(why)
        self.take(u, ns_of(msg.header.stamp))

    def take(self, u: np.ndarray, stamp: int) -> None:
        """An accepted torque (body, or the wheels' motor torques) stamped ``stamp``."""
        if not self.lockstep:  # applied from the next step on
            if stamp < self.torque_stamp:
                return self.reject(f'stamp {stamp} ns is older than the applied one')
            self.torque, self.torque_stamp, self.torque_at = u, stamp, time.monotonic()
            return self.set_stale(False)
        if stamp == self.stamp_ns:  # lockstep: only the answer to the state published
            self.held = 0
            self.set_stale(False)
            self.advance(u)

    def on_timer(self) -> None:
        """Lockstep: re-send, or hold/zero after the timeout. Real time: one step."""
        now, p = time.monotonic(), self.p
        if not self.lockstep:
            if self.k > self.n_steps:
                return self.finish(0)
            if self.torque_at is not None and now - self.torque_at > p['realtime.torque_stale_s']:
                self.set_stale(True)
                self.torque, self.torque_at = np.zeros_like(self.torque), None
            if self.k > 0:
                self.publish_applied(self.torque)
                self.step_plant(self.torque)
            now_ns = self.get_clock().now().nanoseconds
            return self.publish_state(max(now_ns, self.stamp_ns + 1))  # strictly increasing
        if now - self.first_sent_at > p['lockstep.torque_timeout_s']:
            self.held += 1
            if self.held > p['lockstep.max_held_steps']:
                self.set_stale(True)
                self.torque = np.zeros_like(self.torque)
            else:
                text = f'no torque for step {self.k}: holding the last {self.torque.tolist()} N m'
                self.get_logger().warning(text)
            self.advance(self.torque)
        elif now - self.sent_at > p['lockstep.resend_period_s']:
            self.sent_at = now
            self.send()

    def advance(self, u: np.ndarray) -> None:
        """Lockstep: the torque of step k is known; apply it and publish state k + 1."""
        self.torque = u
        self.publish_applied(u)
        if self.k >= self.n_steps:
            return self.finish(0)
        self.step_plant(u)
        self.k += 1
        self.publish_state(self.k * self.dt_ns)

    def t_s(self) -> float:
        """The scenario's time of the state last published: since the first state."""
        return (self.stamp_ns - self.first_stamp_ns) * 1e-9

    def step_plant(self, u: np.ndarray) -> None:
        """Apply ``u`` from the state last published for ``dt_s``."""
        if self.wheel_plant is not None:
            self.wheel_plant.step(u, self.t_s(), self.dt_s)
        else:
            assert self.plant is not None
            self.plant.step(u, self.dt_s)

    def publish_applied(self, u: np.ndarray) -> None:
        """The torque applied from the state last published (stamped with it): ``u``, or
        with wheels the body torque of the motor torques the wheels apply for ``u``."""
        if self.wheel_plant is not None:
            u = self.wheel_plant.body_torque(self.wheel_plant.applied(u, self.t_s()))
        set_stamp(self.applied.header.stamp, self.stamp_ns)
        t = self.applied.wrench.torque
        t.x, t.y, t.z = map(float, u)
        self.pub_applied.publish(self.applied)

    def publish_state(self, stamp_ns: int) -> None:
        if self.wheel_plant is not None:
            q, w, speeds, effort = self.wheel_plant.state()
            self.wheel_states.velocity = [float(x) for x in speeds]
            self.wheel_states.effort = [float(x) for x in effort]  # over the step that ended
        else:
            assert self.plant is not None
            q, w = self.plant.state()
        q = -q if q[3] < 0.0 else q
        a, r = self.att.quaternion, self.rate.vector
        a.x, a.y, a.z, a.w = map(float, q)
        r.x, r.y, r.z = map(float, w)
        stamps = (self.att.header, self.rate.header, self.wheel_states.header)
        for stamp in (*(h.stamp for h in stamps), self.clock.clock):
            set_stamp(stamp, stamp_ns)
        self.stamp_ns = stamp_ns
        if self.first_stamp_ns < 0:
            self.first_stamp_ns = stamp_ns
        self.sent_at = self.first_sent_at = time.monotonic()
        if not self.lockstep:
            self.k += 1  # real time: k counts the states published
        self.send()

    def send(self) -> None:
        if self.lockstep:  # /clock exists only in lockstep: the simulated time
            self.pub_clock.publish(self.clock)
        if self.pub_wheels is not None:  # before the attitude: the state is whole with it
            self.pub_wheels.publish(self.wheel_states)
        self.pub_att.publish(self.att)
        self.pub_rate.publish(self.rate)

    def reject(self, reason: str) -> None:
        self.rejected += 1
        topic = '/controller/wheel_torque' if self.names else '/controller/torque'
        text = f'rejected {topic} message ({self.rejected} so far): {reason}'
        self.get_logger().warning(text, throttle_duration_sec=1.0)

    def set_stale(self, stale: bool) -> None:
        if stale and not self.stale:
            self.get_logger().error('torque is stale: applying zero torque')
        elif self.stale and not stale:
            self.get_logger().info('torque received again')
        self.stale = stale

    def finish(self, code: int) -> None:
        if self.exit_code is None:
            self.exit_code = code
            self.timer.cancel()
            self.get_logger().info(
                f'stopped at step {self.k}: exit {code}, {self.rejected} bad torques'
            )


def main(args=None) -> int:
    stop = []  # SIGINT/SIGTERM only set a flag; the loop below ends cleanly
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, lambda signum, frame: stop.append(signum))
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    node, code = None, 0
    try:
        node = BridgeNode()
        executor = EventsExecutor()  # its spin() ignores SIGINT: spin once at a time
        executor.add_node(node)
        while not stop and rclpy.ok() and node.exit_code is None:
            executor.spin_once(timeout_sec=0.1)
        code = node.exit_code or 0
    except (ValueError, ParameterException) as err:
        print(f'[spacecraft_bridge] error: parameter: {err}', file=sys.stderr, flush=True)
        code = 2
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return code


if __name__ == '__main__':
    raise SystemExit(main())
