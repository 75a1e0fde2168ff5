"""The recorder's timeline (``attitude_bringup.timeline``) past the recording's stop: a
loop that runs on, far past the stop, until it is brought down is the run's own
timeline, not a stray: nothing of it is recorded and none of it is counted implausible;
a stray stamp is still caught."""

from __future__ import annotations

from rclpy.serialization import serialize_message

from attitude_bringup.timeline import Timeline, open_bag
from attitude_core.contract.status import PlannerStatus
from attitude_core.contract.topics import NS_PER_S
from attitude_core.runtime.recording import STAMP_AHEAD_LIMIT_S, StopRule
from attitude_ros import contract as c
from attitude_tools.bag.reader import read_bag

DT_NS = NS_PER_S // 10
LOOP = (c.ATTITUDE, c.ANGULAR_VELOCITY, c.TORQUE)


def raw(name: str, stamp_ns: int) -> bytes:
    msg = c.message_class(c.topic(name).type_name)()
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, NS_PER_S)
    return serialize_message(msg)


def test_a_loop_running_far_past_the_stop_is_not_recorded_nor_implausible(tmp_path):
    rule = StopRule({PlannerStatus.ARRIVED}, stop_delay_s=1.0, started=0.0, scenario_time_s=600)
    warnings: list[str] = []
    timeline = Timeline(open_bag(str(tmp_path / "bag"), None), rule, 600.0, warnings.append)
    wall = 1_700_000_000 * NS_PER_S
    topics = {name: c.topic(name) for name in LOOP}
    past = []
    for k in range(2000):  # 200 s of run time; the stop is at 6 s
        if k == 50:
            assert rule.on_status(PlannerStatus.ARRIVED, 50 * DT_NS)
        for name in LOOP:
            done = timeline.record(topics[name], raw(name, k * DT_NS), wall, 0.0)
            if k * DT_NS > rule.stop_at_ns:
                past.append(done.past_stop)
    assert all(past) and len(past) == 3 * (2000 - 61)
    assert rule.stop_at_ns + STAMP_AHEAD_LIMIT_S * NS_PER_S < 2000 * DT_NS  # far past it
    assert timeline.bad_stamps == 0 and warnings == []
    # A stray stamp beyond the limit of the run's timeline is still implausible.
    stray = (2000 * DT_NS) + int(2 * STAMP_AHEAD_LIMIT_S * NS_PER_S)
    timeline.record(topics[c.ATTITUDE], raw(c.ATTITUDE, stray), wall, 0.0)
    assert timeline.bad_stamps == 1 and len(warnings) == 1
    timeline.close()
    stamps = sorted(m.log_time_ns for m in read_bag(str(tmp_path / "bag"), [c.ATTITUDE]))
    assert max(stamps) == rule.stop_at_ns  # nothing past the stop (the stray at the stop)
    assert len(stamps) == 61 + 1  # steps 0..60 and the stray, written at the latest stamp
