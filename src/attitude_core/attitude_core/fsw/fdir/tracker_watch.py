"""Star tracker gaps as faults: where the tracker gave no solution.

Input: the times of the star tracker samples the estimator got (s, increasing), the
tracker's rate (Hz) and the run's end (s). Output: a ``star_tracker_outage`` fault
(:class:`attitude_core.contract.faults.Fault`) for each gap longer than
:data:`MISSED_PERIODS` periods, from the first sample that did not come to the next one
(to the run's end when none came): a scheduled outage, the body above the tracker's
rate limit, or a bright object in its exclusion. The MEKF flies the gyro alone
meanwhile.
"""

from __future__ import annotations

from collections.abc import Sequence

from attitude_core.contract.faults import Fault, FaultKind

__all__ = ["MISSED_PERIODS", "tracker_outages"]

MISSED_PERIODS = 1.5
"""A gap between two samples longer than this many tracker periods is an outage."""


def tracker_outages(times_s: Sequence[float], rate_hz: float, end_s: float) -> list[Fault]:
    """The outages of a run whose tracker samples came at ``times_s`` (module docstring)."""
    period = 1.0 / rate_hz
    faults: list[Fault] = []
    marks = [*times_s, None]
    for prev, nxt in zip(marks[:-1], marks[1:], strict=True):
        assert prev is not None
        until = end_s if nxt is None else nxt
        if until - prev > MISSED_PERIODS * period + 1e-9:
            start = prev + period
            faults.append(
                Fault(
                    FaultKind.STAR_TRACKER_OUTAGE,
                    round(start, 9),
                    None if nxt is None else round(nxt, 9),
                    f"no star tracker solution from {start:.3f} s"
                    + ("" if nxt is None else f" to {nxt:.3f} s")
                    + ": the estimate ran on the gyro",
                )
            )
    return faults
