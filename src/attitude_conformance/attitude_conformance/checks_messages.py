"""Checks of the messages themselves: ``stamps``, ``clock``, ``frames``, ``quaternion``."""

from __future__ import annotations

import statistics

import numpy as np

from attitude_core.contract.topics import BODY_FRAME, INERTIAL_FRAME
from attitude_core.models.mrp import quat_from_mrp

from .physics import rotation_angle
from .record import FAIL, PASS, Recording, Result
from .steps import State

NORM_TOL = 1e-3
INITIAL_ANGLE_TOL_RAD = 1e-3  # first state against the scenario's initial attitude
RT_GAP_REL_TOL, RT_MAX_GAP_STEPS = 0.2, 5.0  # real time: median gap within 20 % of dt


def _s(ns: int) -> str:
    return f"{ns} ns ({ns * 1e-9:.9g} s)"


def _pairing(rec: Recording) -> str | None:
    att = {a.stamp_ns for a in rec.attitude}
    rate = {r.stamp_ns for r in rec.rate}
    if not att & rate:
        return "no attitude and rate of the same stamp"
    horizon = max(att & rate)  # later ones may be in flight when the check ends
    att, rate = {s for s in att if s <= horizon}, {s for s in rate if s <= horizon}
    if att - rate:
        return f"attitude stamps without a rate of the same stamp: {_few(att - rate)}"
    if rate - att:
        return f"rate stamps without an attitude of the same stamp: {_few(rate - att)}"
    return None


def _few(stamps: set[int]) -> str:
    ordered = sorted(stamps)
    more = f" and {len(ordered) - 3} more" if len(ordered) > 3 else ""
    return ", ".join(_s(s) for s in ordered[:3]) + more


def check_stamps(rec: Recording, seq: list[State]) -> Result:
    """Lockstep: ``k dt`` exactly from 0, no gap; real time: strictly increasing, about
    ``dt`` apart. Both: a rate of the same stamp for every attitude."""
    if not seq:
        return Result("stamps", FAIL, "no state received")
    dt_ns = rec.setup.dt_ns
    last = None
    for a in rec.attitude:  # receipt order
        if last is not None and (
            a.stamp_ns < last or (a.stamp_ns == last and not rec.setup.lockstep)
        ):
            what = "repeated" if a.stamp_ns == last else "went back"
            return Result("stamps", FAIL, f"stamp {what}: {_s(a.stamp_ns)} after {_s(last)}")
        last = a.stamp_ns if last is None else max(last, a.stamp_ns)
    if rec.setup.lockstep:
        if seq[0].stamp_ns != 0:
            return Result(
                "stamps",
                FAIL,
                f"first state stamped {_s(seq[0].stamp_ns)}, expected 0 (k dt from 0)",
            )
        for st in seq:
            if st.stamp_ns != st.index * dt_ns:
                return Result(
                    "stamps",
                    FAIL,
                    f"state {st.index} stamped {_s(st.stamp_ns)}, expected k dt = "
                    f"{_s(st.index * dt_ns)} (dt_ns = {dt_ns})",
                )
    problem = _pairing(rec)
    if problem:
        return Result("stamps", FAIL, problem)
    if rec.setup.lockstep:
        return Result(
            "stamps",
            PASS,
            f"{len(seq)} states stamped exactly k dt (dt_ns = {dt_ns}) from 0, "
            "attitude and rate stamps equal",
        )
    if len(seq) < 2:
        return Result("stamps", FAIL, "fewer than 2 states received")
    gaps = np.diff([st.stamp_ns for st in seq]) * 1e-9
    median, worst = statistics.median(gaps.tolist()), float(gaps.max())
    if abs(median - rec.setup.dt_s) > RT_GAP_REL_TOL * rec.setup.dt_s:
        return Result(
            "stamps", FAIL, f"median stamp gap {median:.4f} s, expected dt = {rec.setup.dt_s} s"
        )
    if worst > RT_MAX_GAP_STEPS * rec.setup.dt_s:
        return Result("stamps", FAIL, f"a stamp gap of {worst:.3f} s (dt = {rec.setup.dt_s} s)")
    return Result(
        "stamps",
        PASS,
        f"{len(seq)} states strictly increasing, gaps median {median:.4f} s, max {worst:.4f} s "
        f"(dt {rec.setup.dt_s} s), attitude and rate stamps equal",
    )


def check_clock(rec: Recording, seq: list[State]) -> Result:
    """Lockstep: ``/clock`` carries every state's stamp and nothing else; real time: none."""
    if not rec.setup.lockstep:
        if rec.clock:
            return Result(
                "clock",
                FAIL,
                f"{len(rec.clock)} /clock messages in real time (first "
                f"{_s(rec.clock[0].stamp_ns)}); the contract has /clock only in lockstep",
            )
        return Result("clock", PASS, "no /clock in real time")
    if not rec.clock:
        return Result("clock", FAIL, "no /clock message (lockstep: /clock = the state's stamp)")
    times = [c.stamp_ns for c in rec.clock]
    back = next((b for a, b in zip(times, times[1:], strict=False) if b < a), None)
    if back is not None:
        return Result("clock", FAIL, f"/clock went back to {_s(back)}")
    clocks, stamps = set(times), {st.stamp_ns for st in seq}
    if clocks - stamps:
        return Result(
            "clock", FAIL, f"/clock times that are no state's stamp: {_few(clocks - stamps)}"
        )
    if stamps - clocks:
        return Result("clock", FAIL, f"states without that /clock time: {_few(stamps - clocks)}")
    return Result("clock", PASS, f"/clock carried each of the {len(stamps)} state stamps")


def check_frames(rec: Recording) -> Result:
    """``inertial`` on the attitude, ``body`` on the rate, the applied torque and the wheel
    states."""
    problems = []
    for name, samples, want in (
        ("attitude", rec.attitude, INERTIAL_FRAME),
        ("angular_velocity", rec.rate, BODY_FRAME),
        ("applied_torque", rec.applied, BODY_FRAME),
        ("wheel_states", rec.wheel_states, BODY_FRAME),
    ):
        wrong = [s.frame for s in samples if s.frame != want]
        if wrong:
            problems.append(
                f"{name}: {len(wrong)} of {len(samples)} messages in frame {wrong[0]!r}, "
                f"expected {want!r}"
            )
    if problems:
        return Result("frames", FAIL, "; ".join(problems))
    if not rec.attitude:
        return Result("frames", FAIL, "no state received")
    what = "rate and applied torque"
    what = "rate, applied torque and wheel states" if rec.wheel_states else what
    return Result("frames", PASS, f"attitude '{INERTIAL_FRAME}', {what} '{BODY_FRAME}'")


def check_quaternion(rec: Recording, seq: list[State]) -> Result:
    """Unit norm; the first state is the scenario's initial attitude as (x, y, z, w)."""
    if not seq:
        return Result("quaternion", FAIL, "no state received")
    norms = [float(np.linalg.norm(a.values)) for a in rec.attitude]
    worst = max(norms, key=lambda n: abs(n - 1.0))
    if abs(worst - 1.0) > NORM_TOL:
        return Result("quaternion", FAIL, f"norm {worst:.6g}, expected 1 within {NORM_TOL}")
    want = quat_from_mrp(rec.setup.initial_mrp)
    x, y, z, w = seq[0].quat
    angle = rotation_angle((x, y, z, w), want)
    if angle <= INITIAL_ANGLE_TOL_RAD:
        return Result(
            "quaternion",
            PASS,
            f"unit norm (worst {worst:.9f}); first state is the scenario's initial attitude "
            f"(x, y, z, w) to {angle:.2g} rad",
        )
    seen = f"first state {tuple(round(v, 6) for v in seq[0].quat)}, expected (x, y, z, w) = "
    seen += (
        f"{tuple(round(float(v), 6) for v in want)} up to sign ({np.degrees(angle):.3g} deg off)"
    )
    if rotation_angle((y, z, w, x), want) <= INITIAL_ANGLE_TOL_RAD:
        return Result("quaternion", FAIL, f"order or convention: published (w, x, y, z); {seen}")
    if rotation_angle((-x, -y, -z, w), want) <= INITIAL_ANGLE_TOL_RAD:
        return Result(
            "quaternion",
            FAIL,
            f"order or convention: the inverse rotation (inertial in body); {seen}",
        )
    return Result("quaternion", FAIL, f"not the scenario's initial attitude: {seen}")
