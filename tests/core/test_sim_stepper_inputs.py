"""Torques the simulator's stepper refuses (:class:`attitude_core.runtime.sim_stepper.SimStepper`):
non-finite, in another frame, unreadable; each counted, none changing the body (the
helpers are ``test_sim_stepper``'s)."""

from __future__ import annotations

import numpy as np
import pytest
from test_sim_stepper import LOCKSTEP, REALTIME, Action, make, start, torques


def test_lockstep_non_finite_torque_is_rejected_and_counted():
    s = make()
    _, t = start(s)
    for n, bad in enumerate(([np.nan, 0.0, 0.0], [0.0, np.inf, 0.0], [0.0, 0.0, -np.inf]), 1):
        d = s.on_torque(t, 0, np.array(bad))
        assert d.action is Action.REJECT and d.state is None
        assert d.reason == f"torque has a non-finite element {list(map(float, bad))}"
        assert s.rejected == n
    assert s.k == 0 and s.waiting_stamp == 0  # still waiting for step 0
    assert s.on_torque(t, 0, np.zeros(3)).action is Action.ADVANCE


def test_lockstep_malformed_torque_message_is_rejected_and_counted():
    """A torque message that could not be read (the node passes why) changes nothing."""
    s = make()
    _, t = start(s)
    d = s.on_torque(t, 0, (0.0, 0.0, 0.0), "body", "not a plain CDR message (header 0007)")
    assert d.action is Action.REJECT and d.state is None and d.applied is None
    assert d.reason == "malformed message: not a plain CDR message (header 0007)"
    assert s.rejected == 1 and s.k == 0 and s.waiting_stamp == 0
    assert s.on_torque(t, 0, np.zeros(3)).action is Action.ADVANCE


@pytest.mark.parametrize("mode", [LOCKSTEP, REALTIME])
def test_torque_in_another_frame_is_rejected_and_counted(mode):
    """The contract's torque is in body axes (frame ``body``): anything else is refused,
    counted, and changes nothing."""
    s = make(time_mode=mode)
    _, t = start(s)
    u = torques(1)[0]
    for n, frame in enumerate(("inertial", "", "Body"), 1):
        d = s.on_torque(t, 0, u, frame)
        assert d.action is Action.REJECT and d.state is None and d.applied is None
        assert d.reason == f"frame_id {frame!r}, expected 'body'"
        assert s.rejected == n
    assert s.k == 0 and s.torque_stamp == -1
    if mode == REALTIME:
        s.on_timer(t, 0)  # state 0 is published: the torque answers it
    accepted = s.on_torque(t, 0, u, "body").action
    assert accepted is (Action.ADVANCE if mode == LOCKSTEP else Action.ACCEPT)
