"""The ``wheels`` point: a wheel plant's ``/spacecraft/wheel_states``, judged when the
scenario declares ``wheels.*`` (SKIP otherwise). The first of these that fails is the
verdict:

* stamps: a wheel state for every state, stamped exactly with the state's stamp, and
  none with another stamp;
* complete: every declared wheel in ``name`` once, no other name, one finite
  ``velocity`` and ``effort`` each (read by name, any order);
* re-sent alike: a repeated stamp carries the same values;
* the first state: the scenario's initial speeds (``initial_speed_rpm`` as rad/s) and
  zero effort (no step has ended there);
* applied within the step: the effort of the state after each step is the motor torque
  the wheels applied over it by the contract: the command answering the step's state
  (or the held or zero one) clipped to ``max_torque_nm``, zero for a wheel at its speed
  limit that it would spin faster, zero from ``fails_at_s`` on;
* the wheel speeds: each step's are the hub-and-wheel model's from the state before
  (:func:`.physics.reference`, :data:`.physics.SPEED_TOL_RAD_S`).

The body itself (attitude and rate over each step) is ``torque_step``'s.
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from attitude_core.models.wheel_array import RPM

from .physics import SPEED_TOL_RAD_S
from .record import FAIL, PASS, SKIP, JointSample, Recording, Result
from .steps import State, Step, wheel_values

__all__ = ["check_wheels"]

EFFORT_TOL_NM = 1e-9  # the effort is the applied torque, not a re-computation
INITIAL_SPEED_TOL_RAD_S = 1e-6


def _s(ns: int) -> str:
    return f"{ns} ns ({ns * 1e-9:.9g} s)"


def _where(step: Step) -> str:
    return f"step {step.before.index} (stamp {step.before.stamp_ns} ns)"


def _g(x: float) -> str:
    return f"{float(x):.6g}"


def _vec(xs) -> str:
    return "(" + ", ".join(_g(x) for x in xs) + ")"


def _stamps(rec: Recording, seq: list[State]) -> str | None:
    stamps = {st.stamp_ns for st in seq}
    have = {w.stamp_ns for w in rec.wheel_states}
    common = have & stamps
    horizon = max(common) if common else seq[-1].stamp_ns  # later ones may be in flight
    missing = [st for st in seq if st.stamp_ns not in have and st.stamp_ns <= horizon]
    last = max(stamps)  # a wheel state stamped later: its state may be in flight
    stray = sorted(s for s in {w.stamp_ns for w in rec.wheel_states} - stamps if s <= last)
    parts = []
    if missing:
        first = missing[0]
        parts.append(
            f"{len(missing)} of {len(seq)} states without a wheel state of their stamp "
            f"(first: state {first.index}, stamped {_s(first.stamp_ns)})"
        )
    if stray:
        parts.append(f"{len(stray)} wheel state stamps that are no state's (first {_s(stray[0])})")
    if not parts:
        return None
    return "; ".join(parts) + ": each wheel state carries exactly the stamp of its state"


def _resent(rec: Recording) -> str | None:
    first: dict[int, JointSample] = {}
    for w in rec.wheel_states:
        seen = first.setdefault(w.stamp_ns, w)
        if seen[:5] != w[:5]:
            return f"wheel state stamped {_s(w.stamp_ns)} re-sent with other values"
    return None


def _initial(rec: Recording, first: State) -> str | None:
    assert rec.setup.wheels is not None and first.speeds is not None
    want = rec.setup.wheels.initial_speed
    got = np.array(first.speeds)
    if np.max(np.abs(got - want)) > INITIAL_SPEED_TOL_RAD_S:
        text = (
            f"first wheel state: velocity {_vec(got)} rad/s, expected the scenario's initial "
            f"speeds {_vec(want)} rad/s (initial_speed_rpm)"
        )
        if np.allclose(got * RPM, want, rtol=1e-6, atol=INITIAL_SPEED_TOL_RAD_S):
            text += ": published in rpm, the contract is rad/s"
        return text
    if any(first.effort or ()):
        return (
            f"first wheel state: effort {_vec(first.effort or ())} N m, expected zero (the "
            "effort is the torque applied over the step that ended at the stamp)"
        )
    return None


def _effort_hint(rec: Recording, steps: list[Step], k: int, j: int, got: float) -> str:
    """Why wheel ``j``'s effort after step ``k`` may be ``got``."""
    assert rec.setup.wheels is not None
    wheel = rec.setup.wheels.wheels[j]
    step = steps[k]
    command = float((step.torque if step.torque is not None else step.accepted[0][1])[j])
    near = lambda a, b: abs(a - b) <= EFFORT_TOL_NM
    ref = step.expected
    want = float(ref.motor[j]) if ref is not None and ref.motor is not None else float("nan")
    if near(got, 0.0) and not near(command, 0.0):
        return "the wheel applied no torque: its command ignored"
    if near(got, command) and abs(command) > wheel.max_torque_nm:
        return f"the command, not clipped to max_torque_nm {_g(wheel.max_torque_nm)}"
    if near(got, command) and near(want, 0.0):
        if wheel.fails_at_s is not None and step.t_s >= wheel.fails_at_s:
            return f"the command, though the wheel failed at fails_at_s {_g(wheel.fails_at_s)}"
        return "the command, though the wheel is at its speed limit and it spins it faster"

    steps_ = ((k - 1, "the step before: the effort one step late"), (k + 1, "the next step"))
    for other, when in steps_:
        ref_o = steps[other].expected if 0 <= other < len(steps) else None
        if ref_o is not None and ref_o.motor is not None and near(got, float(ref_o.motor[j])):
            return f"the torque applied over {when}"
    return ""


def _effort(rec: Recording, steps: list[Step]) -> str | None:
    """The steps whose next effort is not the torque applied, with the likeliest cause (the
    hint most of them share), the first such step in full."""
    assert rec.setup.wheels is not None
    names = rec.setup.wheels.names
    failed: list[tuple[str, str]] = []  # (hint, detail)
    judged = 0
    for k, step in enumerate(steps):
        ref = step.expected
        if ref is None or ref.motor is None or step.after.effort is None:
            continue
        judged += 1
        got = np.array(step.after.effort)
        diff = np.abs(got - ref.motor)
        if np.max(diff) <= EFFORT_TOL_NM:
            continue
        j = int(np.argmax(diff))
        command = step.torque if step.torque is not None else step.accepted[0][1]
        hint = _effort_hint(rec, steps, k, j, float(got[j]))
        detail = (
            f"{_where(step)}, wheel {names[j]}: effort {_g(got[j])} N m at the next state, "
            f"expected {_g(ref.motor[j])} (the {step.accepted[0][0]} {_g(command[j])} N m "
            f"as the wheel applies it)"
        )
        failed.append((hint, detail))
    if not failed:
        return None
    text = f"{len(failed)} of {judged} steps: the next state's effort is not the torque applied"
    hints = Counter(h for h, _ in failed if h)
    if not hints:
        return f"{text}; first: {failed[0][1]}"
    hint, count = hints.most_common(1)[0]
    first = next(d for h, d in failed if h == hint)
    return f"{text}, {count} of them {hint}; first: {first}"


def _speeds(rec: Recording, steps: list[Step]) -> tuple[str | None, float]:
    assert rec.setup.wheels is not None
    names, worst = rec.setup.wheels.names, 0.0
    for step in steps:
        ref = step.expected
        if ref is None or ref.speeds is None or step.after.speeds is None:
            continue
        diff = np.abs(np.array(step.after.speeds) - ref.speeds)
        worst = max(worst, float(np.max(diff)))
        if np.max(diff) > SPEED_TOL_RAD_S:
            j = int(np.argmax(diff))
            return (
                f"{_where(step)}, wheel {names[j]}: speed {_g(step.after.speeds[j])} rad/s at "
                f"the next state, expected {_g(ref.speeds[j])} from the hub and wheels with "
                f"the applied motor torques (tolerance {SPEED_TOL_RAD_S:g} rad/s)"
            ), worst
    return None, worst


def check_wheels(rec: Recording, seq: list[State], steps: list[Step]) -> Result:
    """The module docstring's point."""
    array = rec.setup.wheels
    if array is None:
        return Result("wheels", SKIP, "the scenario declares no wheels (wheels.names)")
    if not seq:
        return Result("wheels", FAIL, "no state received")
    if not rec.wheel_states:
        return Result(
            "wheels",
            FAIL,
            "no /spacecraft/wheel_states message: a wheel plant publishes one with every "
            "state, stamped like it",
        )
    for problem in (_stamps(rec, seq), _resent(rec)):
        if problem:
            return Result("wheels", FAIL, problem)
    for w in rec.wheel_states:
        values = wheel_values(w, array.names)
        if isinstance(values, str):
            return Result("wheels", FAIL, f"wheel state stamped {_s(w.stamp_ns)}: {values}")
    problem = _initial(rec, seq[0]) or _effort(rec, steps)
    if problem:
        return Result("wheels", FAIL, problem)
    speeds, worst = _speeds(rec, steps)
    if speeds:
        return Result("wheels", FAIL, speeds)
    judged = [s for s in steps if s.expected is not None and s.after.effort is not None]
    if not judged:
        return Result("wheels", FAIL, "no step between two wheel states to judge")
    clipped = zeroed = 0
    for s in judged:
        ref = s.expected
        assert ref is not None and ref.motor is not None
        u = s.torque if s.torque is not None else s.accepted[0][1]
        clipped += int(np.sum((np.abs(u) > array.max_torque) & (ref.motor != 0.0)))
        zeroed += int(np.sum((u != 0.0) & (ref.motor == 0.0)))
    n_states = len({w.stamp_ns for w in rec.wheel_states})
    return Result(
        "wheels",
        PASS,
        f"{n_states} wheel states of {len(array)} wheels, each stamped with its state; over "
        f"{len(judged)} steps each effort is the command as applied ({clipped} clipped to "
        f"max_torque_nm, {zeroed} refused at the speed limit or failed) and the speeds "
        f"follow the hub and wheels to {worst:.2g} rad/s",
    )
