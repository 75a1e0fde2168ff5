"""The ``link`` point: the bridge's state link against the stack's watchdog (``fdir.*``).

Measured on the states received: in real time the latency (receipt on this host's clock
less the stamp: the hosts' clocks must agree, as ROS 2 stamps assume), its jitter (half
the 1st-99th percentile spread), the share of states lost (against one per ``dt``) and
the longest wait between two states; in lockstep the states lost (the stamps are
simulated time). FAIL when the states would reach the stack stale (p99 latency beyond
``fdir.state_timeout_s``) or a wait would make it brake (beyond ``fdir.predict_s``) or go
into safe mode; PASS otherwise, saying when the stack would fly on its prediction (a
wait beyond the timeout: a lost state or two, a loaded host).
"""

from __future__ import annotations

import numpy as np

from .record import FAIL, PASS, SKIP, Recording, Result
from .steps import State

__all__ = ["check_link"]


def check_link(rec: Recording, seq: list[State]) -> Result:
    """The module docstring's point."""
    if len(seq) < 2:
        return Result("link", SKIP, "fewer than two states received")
    fdir = rec.setup.watchdog
    timeout = fdir.state_timeout_s
    dt_ns = rec.setup.dt_ns
    if rec.setup.lockstep:
        lost = int(seq[-1].stamp_ns // dt_ns + 1 - len(seq))
        longest = max(b.stamp_ns - a.stamp_ns for a, b in zip(seq[:-1], seq[1:], strict=True))
        figures = f"{len(seq)} states, {lost} lost, longest gap {longest * 1e-9:.3g} s of sim time"
        if longest * 1e-9 > timeout + 1e-9:
            return Result("link", FAIL, f"{figures}: more than fdir.state_timeout_s {timeout:g} s")
        return Result("link", PASS, f"{figures} (latency and jitter: simulated time)")
    stamps = np.array([s.stamp_ns for s in seq], dtype=np.int64)
    walls = np.array([s.wall_s for s in seq])
    expected = max(1, round(int(stamps[-1] - stamps[0]) / dt_ns) + 1)
    share = max(0.0, 1.0 - len(seq) / expected)
    gap = float(np.max(np.diff(walls)))
    figures = f"{share:.1%} of states lost, longest wait {gap:.3f} s"
    stale_on_arrival = False
    if rec.system_offset_s is not None:
        delay = walls + rec.system_offset_s - stamps * 1e-9
        p1, p50, p99 = (float(np.percentile(delay, q)) for q in (1, 50, 99))
        figures = (
            f"latency {p50 * 1e3:.1f} ms (p99 {p99 * 1e3:.1f} ms), jitter "
            f"{(p99 - p1) * 0.5e3:.1f} ms, " + figures
        )
        stale_on_arrival = p99 > timeout
    limit = f"fdir.state_timeout_s {timeout:g} s"
    if stale_on_arrival:
        return Result("link", FAIL, f"{figures}: states arrive older than {limit}")
    if gap > fdir.predict_s:
        way = "into safe mode" if gap > fdir.safe_after_s else "braking"
        return Result(
            "link",
            FAIL,
            f"{figures}: beyond fdir.predict_s {fdir.predict_s:g} s, the stack would fly {way}",
        )
    if gap > timeout:
        return Result("link", PASS, f"{figures}: the stack flies on its prediction then ({limit})")
    return Result("link", PASS, f"{figures}; within {limit}")
