"""Checks of the stepping: ``torque_step``, ``applied_torque``, ``resend``, ``stale``.

With wheels the torques are the commanded motor torques and the physics is the hub and
its wheels (:func:`.physics.reference`); ``applied_torque`` is then the body torque of
the motor torques the wheels applied, ``-G u``."""

from __future__ import annotations

from collections import Counter

import numpy as np

from attitude_core.contract.topics import BODY_FRAME

from .physics import ATTITUDE_TOL_RAD, RATE_TOL_RAD_S, matches
from .record import FAIL, PASS, SKIP, Recording, Result, Window
from .steps import POSITIONAL, State, Step, step_reference

APPLIED_TOL = 1e-9  # N m: the applied torque is the torque, not a re-computation
LATE_SHARE = 0.25  # real time: at most this share of steps may use the previous torque
TIMEOUT_EARLY_S, TIMEOUT_LATE_S = 0.15, 1.5  # lockstep timeout: allowed wall-time slack
HINTS = {
    "the torque of the previous step": "the torque is applied one step late",
    "the torque of the next step": "the torque is applied one step early",
    "zero torque": "the torque was ignored",
    POSITIONAL: "the wheel torque's arrays are read by name, in any order",
}


def _vec(u) -> str:
    return "(" + ", ".join(f"{float(x):.6g}" for x in u) + ")"


def _where(step: Step) -> str:
    return f"step {step.before.index} (stamp {step.before.stamp_ns} ns)"


def model(rec: Recording) -> str:
    """The reference physics, as the verdicts name it."""
    return "RigidBody" if rec.setup.wheels is None else "the hub and wheels (WheelPlant)"


def alternative(rec: Recording, step: Step) -> str | None:
    """The other torque (previous step's, next step's, zero; with wheels the efforts read
    by position) the step matches, if any."""
    expected = step.accepted[0][1]
    for label, u in step.alternatives:
        if np.array_equal(u, expected):
            continue
        if matches(step_reference(rec, step, u).errors):
            return label
    return None


def explain(rec: Recording, step: Step, alt: str | None = None) -> str:
    """Why a step failed the physics, naming the torque it matches instead (``alt``)."""
    label, u = step.accepted[0]
    what = "torque" if rec.setup.wheels is None else "motor torques"
    text = (
        f"{_where(step)}: next state off by {step.errors[0]:.3g} rad / {step.errors[1]:.3g} rad/s "
        f"from {model(rec)} with the {label} {what} {_vec(u)} N m held over "
        f"dt = {rec.setup.dt_s} s (tolerance {ATTITUDE_TOL_RAD:g} rad, {RATE_TOL_RAD_S:g} rad/s)"
    )
    alt = alt or alternative(rec, step)
    if alt is not None:
        return f"{text}; it matches {alt}: {HINTS.get(alt, alt)}"
    if step.before.quat == step.after.quat and step.before.rate == step.after.rate:
        return f"{text}; the state did not change"
    return text


def _not_reached(rec: Recording, what: str) -> str:
    return f"{what} not reached" + (f": {rec.aborted}" if rec.aborted else "")


def check_torque_step(rec: Recording, steps: list[Step]) -> Result:
    """Each answered step is the rigid body propagated over dt with that torque held."""
    commanded = [s for s in steps if s.kind == "commanded"]
    if rec.setup.wheels is not None and not steps and len(rec.attitude) > 1:
        return Result(
            "torque_step",
            FAIL,
            "no step starts from a state with its wheel speeds (/spacecraft/wheel_states of "
            "its stamp): the wheel plant cannot be judged (point wheels)",
        )
    failed = [s for s in commanded if s.matched is None]
    if failed:
        found = [(s, alternative(rec, s)) for s in failed]
        alts = Counter(a for _, a in found if a is not None)
        text = f"{len(failed)} of {len(commanded)} steps fail"
        if not alts:
            return Result("torque_step", FAIL, f"{text}; first: {explain(rec, failed[0])}")
        alt, count = alts.most_common(1)[0]
        first = next(s for s, a in found if a == alt)
        text += f", {count} of them match {alt}: {HINTS.get(alt, alt)}; first: "
        return Result("torque_step", FAIL, text + explain(rec, first, alt))
    if rec.aborted:
        return Result(
            "torque_step", FAIL, f"script stopped after {len(steps)} steps: {rec.aborted}"
        )
    nonzero = [s for s in commanded if s.torque is not None and np.any(s.torque)]
    if not nonzero:
        return Result("torque_step", FAIL, "no step with a non-zero commanded torque was taken")
    late = [s for s in commanded if s.matched == "late"]
    if len(late) > LATE_SHARE * len(commanded):
        return Result(
            "torque_step",
            FAIL,
            f"{len(late)} of {len(commanded)} steps applied the previous step's torque, not the "
            f"latest (first: {_where(late[0])}): the torque is applied a step late",
        )
    exact = [s.errors for s in commanded if s.matched == s.accepted[0][0]]
    att, rate = max((e[0] for e in exact), default=0.0), max((e[1] for e in exact), default=0.0)
    extra = f"; {len(late)} with the previous torque (arrived after the tick)" if late else ""
    return Result(
        "torque_step",
        PASS,
        f"{len(commanded)} steps ({len(nonzero)} non-zero torques) match {model(rec)} over "
        f"dt = {rec.setup.dt_s} s to {att:.2g} rad, {rate:.2g} rad/s{extra}",
    )


def check_applied(rec: Recording, seq: list[State], steps: list[Step]) -> Result:
    """``/spacecraft/applied_torque`` stamped with the step's state, the torque it applied
    (with wheels: the body torque of the motor torques the wheels applied)."""
    if not rec.applied:
        return Result("applied_torque", SKIP, "never published (optional for a bridge)")
    wrong = next((a for a in rec.applied if a.frame != BODY_FRAME), None)
    if wrong is not None:
        return Result("applied_torque", FAIL, f"frame {wrong.frame!r}, expected {BODY_FRAME!r}")
    stamps = {st.stamp_ns for st in seq}
    stray = next((a for a in rec.applied if a.stamp_ns not in stamps), None)
    if stray is not None:
        return Result("applied_torque", FAIL, f"stamped {stray.stamp_ns} ns, no state's stamp")
    by_stamp: dict[int, np.ndarray] = {}
    for a in rec.applied:
        by_stamp.setdefault(a.stamp_ns, np.array(a.values))
    missing = [s for s in steps if s.before.stamp_ns not in by_stamp]
    if missing:
        return Result(
            "applied_torque",
            FAIL,
            f"none for {len(missing)} of {len(steps)} steps (first: {_where(missing[0])})",
        )
    for s in steps:
        got = by_stamp[s.before.stamp_ns]
        tried = [(lab, u) for lab, u in s.accepted if s.matched in (None, lab)]
        want = [(s.refs.get(lab) or step_reference(rec, s, u)).body for lab, u in tried]
        if not any(np.allclose(got, u, rtol=0.0, atol=APPLIED_TOL) for u in want):
            return Result(
                "applied_torque",
                FAIL,
                f"{_where(s)}: applied {_vec(got)} N m, expected {_vec(want[0])} ({s.kind})",
            )
    return Result("applied_torque", PASS, f"{len(steps)} steps, each the torque applied over it")


def _window(rec: Recording, kind: str) -> Window | None:
    return next((w for w in rec.windows if w.kind == kind), None)


def check_resend(rec: Recording, seq: list[State]) -> Result:
    """Lockstep: while the torque is withheld, the identical state again every period."""
    if not rec.setup.lockstep:
        return Result("resend", SKIP, "lockstep only (real time re-sends nothing)")
    for samples, name in ((rec.attitude, "attitude"), (rec.rate, "rate")):
        first: dict[int, tuple[float, ...]] = {}
        for m in samples:
            if first.setdefault(m.stamp_ns, m.values) != m.values:
                return Result(
                    "resend", FAIL, f"{name} stamped {m.stamp_ns} ns re-sent with other values"
                )
    w = _window(rec, "resend")
    if w is None:
        return Result("resend", FAIL, _not_reached(rec, "the torque-withholding step"))
    period = rec.setup.limits.resend_period_s
    sends = [
        a.wall_s for a in rec.attitude if a.stamp_ns == w.stamp_ns and a.wall_s <= w.end_s + 0.05
    ]
    resends, held = len(sends) - 1, w.end_s - w.start_s
    gaps = np.diff(sends)
    advanced = [st for st in seq if w.start_s < st.wall_s < w.end_s and st.stamp_ns != w.stamp_ns]
    what = f"torque of the state stamped {w.stamp_ns} ns withheld {held:.2f} s"
    if advanced:
        return Result("resend", FAIL, f"{what}: advanced to {advanced[0].stamp_ns} ns without it")
    if resends < 1:
        return Result("resend", FAIL, f"{what}: no re-send (expected every {period} s)")
    if resends > held / period + 1 or gaps.min() < 0.5 * period:
        return Result(
            "resend",
            FAIL,
            f"{what}: {resends} re-sends, {gaps.min():.3f} s apart at least (period {period} s)",
        )
    return Result(
        "resend",
        PASS,
        f"{what}: {resends} identical re-sends, {gaps.mean():.3f} s apart (period {period} s)",
    )


def _stale_lockstep(rec: Recording, steps: list[Step], w: Window) -> Result:
    lim = rec.setup.limits
    held = [s for s in steps if s.kind == "held"]
    zero = [s for s in steps if s.kind == "zero"]
    if len(held) < lim.max_held_steps or not zero:
        return Result(
            "stale",
            FAIL,
            f"{len(held)} held and {len(zero)} zero-torque steps after withholding the torque "
            f"{w.end_s - w.start_s:.2f} s"
            + (f" ({rec.aborted})" if rec.aborted else "")
            + f"; expected {lim.max_held_steps} held then zero after {lim.torque_timeout_s} s each",
        )
    for s in held + zero:
        if s.matched is None:
            return Result("stale", FAIL, explain(rec, s))
        waited = s.after.wall_s - s.before.wall_s
        if (
            not lim.torque_timeout_s - TIMEOUT_EARLY_S
            <= waited
            <= lim.torque_timeout_s + TIMEOUT_LATE_S
        ):
            return Result(
                "stale",
                FAIL,
                f"{_where(s)} ({s.kind}) advanced {waited:.2f} s after its state, expected "
                f"after torque_timeout_s = {lim.torque_timeout_s} s",
            )
    after = [s for s in steps if s.kind == "commanded" and s.before.index > zero[-1].before.index]
    if not after or after[0].matched is None:
        return Result(
            "stale",
            FAIL,
            explain(rec, after[0])
            if after
            else _not_reached(rec, "the step after the stale torque"),
        )
    return Result(
        "stale",
        PASS,
        f"held the last torque {len(held)} step(s), then zero torque for {len(zero)} step(s), "
        f"each after {lim.torque_timeout_s} s; the next torque was applied again",
    )


def _stale_realtime(rec: Recording, steps: list[Step], w: Window) -> Result:
    inside = [s for s in steps if w.start_s < s.after.wall_s <= w.end_s + 2.0 * rec.setup.dt_s]
    inside = [s for s in inside if s.kind in ("held", "either", "zero")]
    bad = next((s for s in inside if s.matched is None), None)
    if bad is not None:
        return Result("stale", FAIL, explain(rec, bad))
    labels = [s.matched for s in inside]
    held, zero = labels.count("held") + labels.count("late"), labels.count("zero")
    if "zero" in labels and any(lab != "zero" for lab in labels[labels.index("zero") :]):
        return Result("stale", FAIL, f"torque came back while withheld: {labels}")
    if held < 1 or zero < 2:
        return Result(
            "stale",
            FAIL,
            f"{held} held and {zero} zero-torque steps while the torque was withheld "
            f"{w.end_s - w.start_s:.2f} s (stale after {rec.setup.limits.torque_stale_s} s)",
        )
    resumed = [s for s in steps if s.kind == "commanded" and s.before.wall_s > w.end_s]
    if not any(s.matched == "latest" for s in resumed):
        return Result("stale", FAIL, _not_reached(rec, "a commanded step after the stale torque"))
    return Result(
        "stale",
        PASS,
        f"held the last torque {held} steps, zero torque for {zero} steps once it was older than "
        f"{rec.setup.limits.torque_stale_s} s; applied again on the next torque",
    )


def check_stale(rec: Recording, steps: list[Step]) -> Result:
    """A withheld torque: lockstep hold-one-step then zero; real time zero once stale."""
    w = _window(rec, "stale")
    if w is None:
        return Result("stale", FAIL, _not_reached(rec, "the stale-torque stretch"))
    return _stale_lockstep(rec, steps, w) if rec.setup.lockstep else _stale_realtime(rec, steps, w)
