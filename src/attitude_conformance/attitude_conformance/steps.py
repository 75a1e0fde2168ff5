"""The recorded states and the steps between them, each with the torque the contract says
the bridge applied over it (lockstep: exactly; real time: the latest torque or zero)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .physics import matches, step_errors
from .record import Recording, Sample

ZERO = np.zeros(3)
REALTIME_STALE_TOL_S = 0.1  # real time: ages this close above the stale limit may go either way


@dataclass(frozen=True)
class State:
    """A distinct state: its first attitude message and the rate of the same stamp."""

    index: int
    stamp_ns: int
    quat: tuple[float, ...]
    rate: tuple[float, ...] | None
    wall_s: float


@dataclass
class Step:
    """From ``before`` to ``after``. ``kind``: commanded, held, zero or either (real time,
    near the stale limit). ``accepted``: the torques the contract allows, the expected one
    first. ``matched``: the label of the accepted torque the physics reproduces (None: none)."""

    before: State
    after: State
    kind: str
    accepted: list[tuple[str, np.ndarray]]
    matched: str | None = None
    torque: np.ndarray | None = None
    errors: tuple[float, float] = (float("nan"), float("nan"))
    alternatives: list[tuple[str, np.ndarray]] = field(default_factory=list)


def states(rec: Recording) -> list[State]:
    """Distinct attitude stamps in order of first receipt, with their rates."""
    rates: dict[int, tuple[float, ...]] = {}
    for r in rec.rate:
        rates.setdefault(r.stamp_ns, r.values)
    out: list[State] = []
    seen: set[int] = set()
    for a in rec.attitude:
        if a.stamp_ns not in seen:
            seen.add(a.stamp_ns)
            out.append(State(len(out), a.stamp_ns, a.values, rates.get(a.stamp_ns), a.wall_s))
    return out


def _first_torques(rec: Recording) -> dict[int, Sample]:
    sent: dict[int, Sample] = {}
    for t in rec.torques:
        sent.setdefault(t.stamp_ns, t)
    return sent


def _lockstep(rec: Recording, pairs: list[tuple[State, State]]) -> list[Step]:
    sent = _first_torques(rec)
    last, held, out = ZERO, 0, []
    for before, after in pairs:
        t = sent.get(before.stamp_ns)
        if t is not None:
            last, held = np.array(t.values), 0
            out.append(Step(before, after, "commanded", [("commanded", last)]))
        else:
            held += 1
            if held <= rec.setup.limits.max_held_steps:
                out.append(Step(before, after, "held", [("held", last)]))
            else:
                last = ZERO
                out.append(Step(before, after, "zero", [("zero", ZERO)]))
    return out


def _realtime(rec: Recording, pairs: list[tuple[State, State]]) -> list[Step]:
    stale_s, out = rec.setup.limits.torque_stale_s, []
    for before, after in pairs:
        earlier = [t for t in rec.torques if t.wall_s < after.wall_s]
        if not earlier:
            out.append(Step(before, after, "commanded", [("zero before any torque", ZERO)]))
            continue
        latest = earlier[-1]
        age = after.wall_s - latest.wall_s
        u = np.array(latest.values)
        if age > stale_s + REALTIME_STALE_TOL_S:
            out.append(Step(before, after, "zero", [("zero", ZERO)]))
        elif age > stale_s:
            out.append(Step(before, after, "either", [("held", u), ("zero", ZERO)]))
        else:
            kind = "commanded" if latest.stamp_ns == before.stamp_ns else "held"
            out.append(
                Step(before, after, kind, [("latest" if kind == "commanded" else "held", u)])
            )
    return out


def _alternatives(steps: list[Step], rec: Recording) -> None:
    """Torques a faulty bridge may have applied instead, to name in a failure."""
    sent = _first_torques(rec)
    for k, step in enumerate(steps):
        prev = steps[k - 1].before.stamp_ns if k else None
        nxt = step.after.stamp_ns
        for label, stamp in (
            ("the torque of the previous step", prev),
            ("the torque of the next step", nxt),
        ):
            if stamp in sent:
                step.alternatives.append((label, np.array(sent[stamp].values)))
        step.alternatives.append(("zero torque", ZERO))


def steps(rec: Recording, seq: list[State] | None = None) -> list[Step]:
    """The consecutive pairs of states that both have a rate, judged by the physics."""
    seq = states(rec) if seq is None else seq
    pairs = [
        (a, b)
        for a, b in zip(seq, seq[1:], strict=False)
        if a.rate is not None and b.rate is not None
    ]
    out = _lockstep(rec, pairs) if rec.setup.lockstep else _realtime(rec, pairs)
    _alternatives(out, rec)
    dt, inertia = rec.setup.dt_s, rec.setup.inertia
    for k, step in enumerate(out):
        if not rec.setup.lockstep and step.kind in ("commanded", "held") and k:
            prev = out[k - 1].torque  # real time: a torque that came in after the tick
            if prev is not None:
                step.accepted.append(("late", prev))
        before = (step.before.quat, step.before.rate)
        after = (step.after.quat, step.after.rate)
        for n, (label, u) in enumerate(step.accepted):
            errors = step_errors(inertia, before, after, u, dt)
            if n == 0:
                step.errors = errors
            if matches(errors):
                step.matched, step.torque = label, u
                break
    return out
