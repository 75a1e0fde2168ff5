"""The lockstep start of :class:`attitude_core.runtime.sim_stepper.SimStepper`: the first
state waits for the loop's first answer longer than a step's deadline (the helpers are
``test_sim_stepper``'s)."""

from __future__ import annotations

import numpy as np
from test_sim_stepper import Action, make, start

from attitude_core.runtime.sim_stepper import STARTUP_RESEND_FRACTION


def test_lockstep_the_first_state_waits_for_the_loop_up_to_the_startup_timeout():
    """Before any torque has come, a state is re-sent, not timed out, for up to
    ``startup_timeout_s`` (the planner and the controller may not have matched each
    other yet); then the step deadline applies as usual."""
    s = make(torque_timeout_s=1.0, resend_period_s=0.2)
    _, t = start(s)
    startup = s.cfg.startup_timeout_s
    assert startup > 10.0
    assert s.on_timer(t + 5.0).action is Action.RESEND  # far beyond the 1 s deadline
    assert s.k == 0 and s.timeouts == 0
    d = s.on_timer(t + startup + 0.01)
    assert d.action is Action.HOLD and s.timeouts == 1 and s.k == 1
    assert d.logs[0] == (
        "warning",
        f"no torque for step 0 after {startup} s; holding the last torque [0.0, 0.0, 0.0] N m",
    )


def test_lockstep_the_first_state_is_resent_sooner_until_the_loop_has_answered():
    """A node still matching when the first state went out asks for it again within a
    fraction of ``resend_period_s``; once answered, the step's period."""
    s = make(torque_timeout_s=1.0, resend_period_s=0.2)
    _, t = start(s)
    STARTUP_RESEND_S = STARTUP_RESEND_FRACTION * s.cfg.resend_period_s
    assert 0.0 < STARTUP_RESEND_S < s.cfg.resend_period_s
    assert s.on_timer(t + 0.5 * STARTUP_RESEND_S).action is Action.NONE
    d = s.on_timer(t + 1.5 * STARTUP_RESEND_S)
    assert d.action is Action.RESEND and d.resend and d.state is None
    assert s.on_timer(t + 2.0 * STARTUP_RESEND_S).action is Action.NONE  # since the re-send
    assert s.on_timer(t + 3.0 * STARTUP_RESEND_S).action is Action.RESEND
    assert s.resends == 2 and s.k == 0
    t2 = t + 3.0 * STARTUP_RESEND_S
    assert s.on_torque(t2, 0, np.zeros(3)).action is Action.ADVANCE
    assert s.on_timer(t2 + 1.5 * STARTUP_RESEND_S).action is Action.NONE  # the step's period
    assert s.on_timer(t2 + s.cfg.resend_period_s + 0.01).action is Action.RESEND
