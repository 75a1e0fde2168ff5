"""The recorded states and the steps between them, each with the torque the contract says
the bridge applied over it (lockstep: exactly; real time: the latest torque or zero).

With wheels (``wheels.*``) a state also has the wheel speeds and efforts of its stamp
(:func:`wheel_values`: read by name), the torques are the commanded motor torques and a
step is judged by the hub-and-wheel model (:func:`.physics.reference`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .physics import Reference, matches, reference
from .record import JointSample, Recording, Sample

ZERO = np.zeros(3)
POSITIONAL = "the efforts read by position, not by name"
REALTIME_STALE_TOL_S = 0.1  # real time: ages this close above the stale limit may go either way


@dataclass(frozen=True)
class State:
    """A distinct state: its first attitude message and the rate of the same stamp."""

    index: int
    stamp_ns: int
    quat: tuple[float, ...]
    rate: tuple[float, ...] | None
    wall_s: float
    speeds: tuple[float, ...] | None = None  # with wheels: velocity, scenario's wheel order
    effort: tuple[float, ...] | None = None  # ... and effort (None: no usable wheel state)

    def values(self) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...] | None]:
        """(quaternion, rate, wheel speeds) for :func:`.physics.reference`."""
        assert self.rate is not None
        return self.quat, self.rate, self.speeds


@dataclass
class Step:
    """From ``before`` to ``after``. ``kind``: commanded, held, zero or either (real time,
    near the stale limit). ``accepted``: the torques the contract allows, the expected one
    first. ``matched``: the label of the accepted torque the physics reproduces (None: none).
    ``refs``: the reference physics of each label tried (with wheels, the motor torques
    the contract says the wheels applied). ``t_s``: the scenario time of ``before``."""

    before: State
    after: State
    kind: str
    accepted: list[tuple[str, np.ndarray]]
    matched: str | None = None
    torque: np.ndarray | None = None
    errors: tuple[float, ...] = (float("nan"), float("nan"), float("nan"))
    alternatives: list[tuple[str, np.ndarray]] = field(default_factory=list)
    refs: dict[str, Reference] = field(default_factory=dict)
    t_s: float = 0.0

    @property
    def expected(self) -> Reference | None:
        """The reference of the matched torque, else of the expected one."""
        return self.refs.get(self.matched or self.accepted[0][0])


def wheel_values(
    sample: JointSample, names: Sequence[str]
) -> tuple[tuple[float, ...], tuple[float, ...]] | str:
    """(velocity, effort) of a wheel state in the order of ``names``, read by name, or why
    not: every declared wheel once, no other name, one finite number each."""
    got = list(sample.names)
    dup = sorted({n for n in got if got.count(n) > 1})
    if dup:
        return f"wheel(s) {dup} more than once in name"
    unknown = [n for n in got if n not in names]
    if unknown:
        return f"name {unknown} not among the declared wheels {list(names)}"
    missing = [n for n in names if n not in got]
    if missing:
        return f"wheel(s) {missing} missing from name {got}"
    out = []
    for field_name in ("velocity", "effort"):
        data = getattr(sample, field_name)
        if len(data) != len(got):
            return f"{len(data)} {field_name} values for {len(got)} names"
        by_name = dict(zip(got, data, strict=True))
        ordered = tuple(float(by_name[n]) for n in names)
        if not np.all(np.isfinite(ordered)):
            return f"{field_name} not finite: {list(ordered)}"
        out.append(ordered)
    return out[0], out[1]


def states(rec: Recording) -> list[State]:
    """Distinct attitude stamps in order of first receipt, with their rates."""
    rates: dict[int, tuple[float, ...]] = {}
    for r in rec.rate:
        rates.setdefault(r.stamp_ns, r.values)
    wheels: dict[int, tuple[tuple[float, ...], tuple[float, ...]] | str] = {}
    if rec.setup.wheels is not None:
        for w in rec.wheel_states:
            if w.stamp_ns not in wheels:
                wheels[w.stamp_ns] = wheel_values(w, rec.setup.wheels.names)
    out: list[State] = []
    seen: set[int] = set()
    for a in rec.attitude:
        if a.stamp_ns not in seen:
            seen.add(a.stamp_ns)
            ws = wheels.get(a.stamp_ns)
            speeds, effort = (None, None) if ws is None or isinstance(ws, str) else ws
            rate = rates.get(a.stamp_ns)
            out.append(State(len(out), a.stamp_ns, a.values, rate, a.wall_s, speeds, effort))
    return out


def zero(rec: Recording) -> np.ndarray:
    """No torque: three body axes, or one motor torque per wheel."""
    return ZERO if rec.setup.wheels is None else np.zeros(len(rec.setup.wheels))


def _first_torques(rec: Recording) -> dict[int, Sample]:
    sent: dict[int, Sample] = {}
    for t in rec.torques:
        sent.setdefault(t.stamp_ns, t)
    return sent


def _lockstep(rec: Recording, pairs: list[tuple[State, State]]) -> list[Step]:
    sent = _first_torques(rec)
    none = zero(rec)
    last, held, out = none, 0, []
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
                last = none
                out.append(Step(before, after, "zero", [("zero", none)]))
    return out


def _realtime(rec: Recording, pairs: list[tuple[State, State]]) -> list[Step]:
    stale_s, out, none = rec.setup.limits.torque_stale_s, [], zero(rec)
    for before, after in pairs:
        earlier = [t for t in rec.torques if t.wall_s < after.wall_s]
        if not earlier:
            out.append(Step(before, after, "commanded", [("zero before any torque", none)]))
            continue
        latest = earlier[-1]
        age = after.wall_s - latest.wall_s
        u = np.array(latest.values)
        if age > stale_s + REALTIME_STALE_TOL_S:
            out.append(Step(before, after, "zero", [("zero", none)]))
        elif age > stale_s:
            out.append(Step(before, after, "either", [("held", u), ("zero", none)]))
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
        step.alternatives.append(("zero torque", zero(rec)))
        order = rec.wheel_orders.get(step.before.stamp_ns)
        if order is not None and step.before.stamp_ns in sent:  # the message's arrays as is
            u = np.array(sent[step.before.stamp_ns].values)
            step.alternatives.append((POSITIONAL, u[list(order)]))


def steps(rec: Recording, seq: list[State] | None = None) -> list[Step]:
    """The consecutive pairs of states that both have a rate, judged by the physics."""
    seq = states(rec) if seq is None else seq
    wheels = rec.setup.wheels is not None
    pairs = [
        (a, b)
        for a, b in zip(seq, seq[1:], strict=False)
        if a.rate is not None and b.rate is not None and (a.speeds is not None or not wheels)
    ]
    out = _lockstep(rec, pairs) if rec.setup.lockstep else _realtime(rec, pairs)
    _alternatives(out, rec)
    for k, step in enumerate(out):
        step.t_s = (step.before.stamp_ns - seq[0].stamp_ns) * 1e-9
        if not rec.setup.lockstep and step.kind in ("commanded", "held") and k:
            prev = out[k - 1].torque  # real time: a torque that came in after the tick
            if prev is not None:
                step.accepted.append(("late", prev))
        for n, (label, u) in enumerate(step.accepted):
            ref = step_reference(rec, step, u)
            step.refs[label] = ref
            if n == 0:
                step.errors = ref.errors
            if matches(ref.errors):
                step.matched, step.torque = label, u
                break
    return out


def step_reference(rec: Recording, step: Step, u: np.ndarray) -> Reference:
    """The reference physics of ``step`` with the torque (or motor torques) ``u``."""
    return reference(rec.setup, step.before.values(), step.after.values(), u, step.t_s)
