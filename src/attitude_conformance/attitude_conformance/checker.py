"""The checker: a :class:`~.record.Recording` in, one :class:`~.record.Result` per contract
point out. Pure Python on plain data (no ROS), so every verdict is unit-testable.

=================  ==========================================================================
point              judged from
=================  ==========================================================================
``stamps``         lockstep: state k stamped exactly ``k dt_ns`` from 0; real time: strictly
                   increasing, about ``dt`` apart; both: rate stamp = attitude stamp
``clock``          lockstep: ``/clock`` carries each state's stamp; real time: no ``/clock``
``frames``         attitude ``inertial``; rate and applied torque ``body``
``quaternion``     unit norm; the first state is the scenario's initial attitude (x, y, z, w)
``torque_step``    each answered step is RigidBody over ``dt`` from the bridge's own state
                   with that torque held (with wheels: the hub and wheels with the motor
                   torques)
``applied_torque`` stamped with the step's state, the torque applied (SKIP if never sent)
``wheels``         with ``wheels.*``: wheel states stamped with each state, complete, the
                   commanded motor torques applied within the step (:mod:`.checks_wheels`)
``resend``         lockstep: the identical state again every resend period without torque
``stale``          lockstep: hold one step, then zero torque; real time: zero once stale
``link``           the states' latency, jitter, losses and longest wait against the stack's
                   ``fdir.state_timeout_s`` (:mod:`.checks_link`)
=================  ==========================================================================

``qos``, ``plant`` and ``sigint`` are judged in :mod:`.checks_process`.
"""

from __future__ import annotations

from .checks_link import check_link
from .checks_messages import check_clock, check_frames, check_quaternion, check_stamps
from .checks_physics import check_applied, check_resend, check_stale, check_torque_step
from .checks_wheels import check_wheels
from .record import Recording, Result
from .steps import states, steps

__all__ = ["judge"]


def judge(rec: Recording) -> list[Result]:
    """The verdicts on the recorded points, in report order."""
    seq = states(rec)
    taken = steps(rec, seq)
    return [
        check_stamps(rec, seq),
        check_clock(rec, seq),
        check_frames(rec),
        check_quaternion(rec, seq),
        check_torque_step(rec, taken),
        check_applied(rec, seq, taken),
        check_wheels(rec, seq, taken),
        check_resend(rec, seq),
        check_stale(rec, taken),
        check_link(rec, seq),
    ]
