"""Wheel health (fsw/control/wheel_health.py): a wheel that ignores its command is
taken out for good; one at its speed limit refusing to spin faster, or one commanded
nothing, is not."""

import numpy as np

from attitude_core.fsw.control.wheel_health import WheelHealth

TOP = np.full(4, 600.0)


def test_a_wheel_that_applies_nothing_is_taken_out_for_good():
    health = WheelHealth(4)
    speeds = np.array([100.0, -50.0, 0.0, 10.0])
    usable = health.observe([0.01, -0.01, 0.005, 0.0], [0.01, 0.0, 0.005, 0.0], speeds, TOP)
    assert usable.tolist() == [True, False, True, True] and health.changed
    usable = health.observe([0.01, -0.01, 0.005, 0.0], [0.01, -0.01, 0.005, 0.0], speeds, TOP)
    assert usable.tolist() == [True, False, True, True] and not health.changed


def test_a_wheel_at_its_speed_limit_or_without_a_command_stays():
    health = WheelHealth(4)
    speeds = np.array([600.0, -600.0, 0.0, 0.0])
    # wheels 0 and 1 refuse to spin faster (the plant's rule); 2 got no command; 3 a
    # command below MIN_COMMAND_NM
    usable = health.observe([0.01, -0.01, 0.0, 1e-9], [0.0, 0.0, 0.0, 0.0], speeds, TOP)
    assert usable.all() and not health.changed
    # wheel 0 at its limit commanded to slow down, applying nothing: failed
    usable = health.observe([-0.01, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], speeds, TOP)
    assert usable.tolist() == [False, True, True, True]
