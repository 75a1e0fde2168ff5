"""The bare rclpy limit of our lockstep loop: a ring of three processes, no work.

Run: .venv/bin/python bench/ros_ring.py [--steps N] [--repeats N]   (or from ros_bench.py)

Three processes stand for the simulator, the planner and the controller. They exchange
the messages of one lockstep step of the topic contract (:mod:`attitude_core.contract.topics`),
with its message classes and QoS, over real DDS on a reserved domain with localhost
discovery, each on rclpy's ``EventsExecutor`` spun once at a time as our nodes are:

* plant: ``/clock``, ``/spacecraft/attitude``, ``/spacecraft/angular_velocity`` of step
  k; on the torque of stamp k, ``/spacecraft/applied_torque`` and step k + 1;
* planner: on both state messages of a stamp, ``/planner/target_mrp``,
  ``/planner/target_rate``, ``/planner/keep_out_margin_deg`` and a ``/diagnostics``
  array with the planner's keys (values prebuilt);
* controller: on the state and the target of a stamp, ``/controller/torque``.

No guidance, no physics, no run guard, no recorder: what is left is DDS and rclpy's
Python layer. Prints steps/s per repeat and their median (the plant's wall time over
the steps after the first 100). Not a test; a benchmark figure.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

WARMUP_STEPS = 100
DT_NS = 100_000_000


def _node(role: str):
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    rclpy.init(args=[], signal_handler_options=SignalHandlerOptions.NO)
    return rclpy.create_node(f"ring_{role}")


def _spin(node, until) -> None:
    from rclpy.experimental.events_executor import EventsExecutor

    executor = EventsExecutor()
    executor.add_node(node)
    while not until():
        executor.spin_once(timeout_sec=0.1)


def _stamp(msg, k: int) -> None:
    ns = k * DT_NS
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(ns, 1_000_000_000)


def _key(msg) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def plant(steps: int, readers: int = 2) -> None:
    from attitude_ros import contract as c
    from attitude_ros.endpoints import message, publisher, subscription

    node = _node("plant")
    pubs = {name: publisher(node, name) for name in (c.CLOCK, c.ATTITUDE, c.ANGULAR_VELOCITY)}
    pub_applied = publisher(node, c.APPLIED_TORQUE)
    att, rate, applied = message(c.ATTITUDE), message(c.ANGULAR_VELOCITY), message(c.APPLIED_TORQUE)
    clock = c.message_class("rosgraph_msgs/msg/Clock")()
    att.quaternion.w = 1.0
    state = {"k": 0, "t_warm": 0.0, "t_end": 0.0, "sent": 0.0}

    def send(k: int) -> None:
        clock.clock.sec, clock.clock.nanosec = divmod(k * DT_NS, 1_000_000_000)
        _stamp(att, k)
        _stamp(rate, k)
        pubs[c.CLOCK].publish(clock)
        pubs[c.ATTITUDE].publish(att)
        pubs[c.ANGULAR_VELOCITY].publish(rate)

    def on_torque(msg) -> None:
        k = state["k"]
        if _key(msg) != k * DT_NS:
            return
        applied.header.stamp = msg.header.stamp
        applied.wrench = msg.wrench
        pub_applied.publish(applied)
        state["k"] = k = k + 1
        if k == WARMUP_STEPS:
            state["t_warm"] = time.perf_counter()
        if k == steps:
            state["t_end"] = time.perf_counter()
            return
        state["sent"] = time.monotonic()
        send(k)

    subscription(node, c.TORQUE, on_torque)
    # Start once the planner and the controller take the state and the torque is heard.
    ready = lambda: (
        node.count_subscribers(c.ATTITUDE) >= readers
        and node.count_subscribers(c.ANGULAR_VELOCITY) >= readers
        and node.count_publishers(c.TORQUE) >= 1
    )
    deadline = time.monotonic() + 60.0
    _spin(node, lambda: ready() or time.monotonic() > deadline)
    state["sent"] = time.monotonic()

    def resend() -> None:  # a lockstep re-send, as the simulator's: a step lost in matching
        if state["t_end"] == 0.0 and time.monotonic() - state["sent"] > 1.0:
            state["sent"] = time.monotonic()
            send(state["k"])

    node.create_timer(0.25, resend)
    send(0)
    _spin(node, lambda: state["t_end"] > 0.0)
    rate_s = (steps - WARMUP_STEPS) / (state["t_end"] - state["t_warm"])
    print(json.dumps({"steps_per_s": rate_s}), flush=True)


def planner(steps: int) -> None:
    from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

    from attitude_core.contract import diagnostics as d
    from attitude_ros import contract as c
    from attitude_ros.endpoints import message, publisher, subscription

    node = _node("planner")
    pub_mrp, pub_rate = publisher(node, c.TARGET_MRP), publisher(node, c.TARGET_RATE)
    pub_margin, pub_diag = publisher(node, c.KEEP_OUT_MARGIN), publisher(node, c.DIAGNOSTICS)
    mrp, rate, margin = message(c.TARGET_MRP), message(c.TARGET_RATE), message(c.KEEP_OUT_MARGIN)
    diag = message(c.DIAGNOSTICS)
    values = [KeyValue(key=key, value=repr(0.123456789012345)) for key in d.KEYS]
    diag.status = [DiagnosticStatus(name=d.STATUS_NAME, hardware_id=d.HARDWARE_ID, values=values)]
    seen: dict[int, set[str]] = {}

    def on_state(name: str, msg) -> None:
        key = _key(msg)
        got = seen.setdefault(key, set())
        got.add(name)
        if len(got) < 2:
            return
        del seen[key]
        mrp.header.stamp = rate.header.stamp = diag.header.stamp = msg.header.stamp
        margin.data = 1.0
        pub_mrp.publish(mrp)
        pub_rate.publish(rate)
        pub_margin.publish(margin)
        pub_diag.publish(diag)

    for name in (c.ATTITUDE, c.ANGULAR_VELOCITY):
        subscription(node, name, lambda msg, name=name: on_state(name, msg))
    _spin(node, lambda: False)  # until the ring is over (terminated by ring_once)


def controller(steps: int) -> None:
    from attitude_ros import contract as c
    from attitude_ros.endpoints import message, publisher, subscription

    node = _node("controller")
    pub = publisher(node, c.TORQUE)
    torque = message(c.TORQUE)
    seen: dict[int, set[str]] = {}

    def taker(name: str):
        def on_message(msg) -> None:
            key = _key(msg)
            got = seen.setdefault(key, set())
            got.add(name)
            if len(got) < 4:  # attitude, rate, target attitude, target rate
                return
            del seen[key]
            torque.header.stamp = msg.header.stamp
            pub.publish(torque)

        return on_message

    for name in (c.ATTITUDE, c.ANGULAR_VELOCITY, c.TARGET_MRP, c.TARGET_RATE):
        subscription(node, name, taker(name))
    _spin(node, lambda: False)  # until the ring is over (terminated by ring_once)


def recorder(steps: int) -> None:
    """A raw, keep-all reader of every topic of the ring that keeps nothing (``--recorder``)."""
    from attitude_ros import contract as c
    from attitude_ros.endpoints import raw_subscription

    node = _node("recorder")
    names = (c.CLOCK, c.ATTITUDE, c.ANGULAR_VELOCITY, c.APPLIED_TORQUE, c.TARGET_MRP)
    names += (c.TARGET_RATE, c.KEEP_OUT_MARGIN, c.DIAGNOSTICS, c.TORQUE)
    for name in names:
        raw_subscription(node, name, lambda data: None)
    _spin(node, lambda: False)  # until the ring is over (terminated)


ROLES = {"plant": plant, "planner": planner, "controller": controller, "recorder": recorder}


def ring_once(steps: int, env: dict[str, str], with_recorder: bool = False) -> float:
    """One ring of three processes on the domain of ``env`` (and a reader of everything
    with ``with_recorder``): the plant's steps/s."""
    roles = ("recorder",) * with_recorder + ("controller", "planner", "plant")
    extra = ["--recorder"] if with_recorder else []
    procs = {
        role: subprocess.Popen(
            [sys.executable, os.path.abspath(__file__), "--role", role, "--steps", str(steps)]
            + extra,
            env=env,
            stdout=subprocess.PIPE,
            text=True,
        )
        for role in roles
    }
    try:
        out, _ = procs["plant"].communicate(timeout=120.0)
    finally:  # the others answer until the plant is done (then they are stopped)
        for p in procs.values():
            if p.poll() is None:
                p.kill()
            p.wait()
    if procs["plant"].returncode != 0:
        raise RuntimeError(f"ring plant exited {procs['plant'].returncode}")
    rate_s: float = json.loads(out)["steps_per_s"]
    return rate_s


def ring(steps: int, repeats: int, with_recorder: bool = False) -> list[float]:
    """``repeats`` rings, each on a domain of its own (reserved as attitude-run does)."""
    from attitude_tools.run.domain import reserve_domain
    from attitude_tools.run.environment import ros_environment

    base = ros_environment()  # the colcon workspace on the paths, as the nodes have it
    rates = []
    for _ in range(repeats):
        with reserve_domain() as domain:
            rates.append(ring_once(steps, domain.env(base), with_recorder))
    return rates


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--role", choices=sorted(ROLES))
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--recorder", action="store_true", help="a fourth process reads all")
    args = parser.parse_args()
    if args.role == "plant":
        plant(args.steps, 3 if args.recorder else 2)
        return 0
    if args.role:
        ROLES[args.role](args.steps)
        return 0
    rates = ring(args.steps, args.repeats, args.recorder)
    for i, r in enumerate(rates, 1):
        print(f"  ring {i}: {r:7.0f} steps/s")
    print(f"bare rclpy ring, {args.steps} steps: median {statistics.median(rates):.0f} steps/s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
