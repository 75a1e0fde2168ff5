"""Campaign statistics: outcome rates with Wilson intervals, percentiles, worst runs."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

from .task import FAILURES, OUTCOMES

__all__ = ["wilson_interval", "summarize_campaign", "worst_runs", "PERCENTILES"]

PERCENTILES = (5, 50, 90, 95, 99)
Z95 = 1.959963984540054  # two-sided 95 % normal quantile


def wilson_interval(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion ``k / n`` (0-1)."""
    if n == 0:
        return (0.0, 1.0)
    p = k / n
    denom = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    lo = 0.0 if k == 0 else max(0.0, centre - half)  # exact ends, not rounding residue
    hi = 1.0 if k == n else min(1.0, centre + half)
    return (lo, hi)


def _percentiles(values: pd.Series) -> dict[str, float | int | None]:
    v = values.to_numpy(dtype=float)
    v = v[np.isfinite(v)]
    out: dict[str, float | int | None] = {"n": len(v)}
    for p in PERCENTILES:
        out[f"p{p}"] = float(np.percentile(v, p)) if len(v) else None
    out["min"] = float(v.min()) if len(v) else None
    out["max"] = float(v.max()) if len(v) else None
    return out


def summarize_campaign(frame: pd.DataFrame) -> dict[str, Any]:
    """Per variant: outcome counts and rates with 95 % Wilson intervals; percentiles of
    ``t_reach_s``, ``rotation_ratio``, ``rotation_to_route`` and
    ``t_reach_x_peak_rate_rad`` (reached runs) and ``min_margin_deg`` (all); the
    ``blocked`` runs whose goal the sky covered during the run and those whose goal it
    never covered (``blocked_goal``; a blocked goal should be a covered one)."""
    variants: dict[str, Any] = {}
    for variant, group in frame.groupby("variant", sort=False):
        n = len(group)
        counts = group["outcome"].value_counts()
        outcomes = {}
        for name in OUTCOMES:
            k = int(counts.get(name, 0))
            lo, hi = wilson_interval(k, n)
            outcomes[name] = {"count": k, "rate": k / n, "wilson95": [lo, hi]}
        reached = group[group["outcome"] == "reached"]
        variants[str(variant)] = {
            "runs": n,
            "outcomes": outcomes,
            "t_reach_s": _percentiles(reached["t_reach_s"]),
            "rotation_ratio": _percentiles(reached["rotation_ratio"]),
            "rotation_to_route": _percentiles(reached["rotation_to_route"]),
            "t_reach_x_peak_rate_rad": _percentiles(reached["t_reach_x_peak_rate_rad"]),
            "min_margin_deg": _percentiles(group["min_margin_deg"]),
        }
        if "t_goal_covered_s" in group:  # tables written before the column: none
            blocked = group[group["outcome"] == "blocked"]
            never = int(blocked["t_goal_covered_s"].isna().sum())
            variants[str(variant)]["blocked_goal"] = {
                "covered": len(blocked) - never,
                "never_covered": never,
            }
    return {"variants": variants}


def worst_runs(frame: pd.DataFrame, n: int = 20) -> pd.DataFrame:
    """Failures first (in the order of :data:`FAILURES`), then the lowest margin, then the
    highest rotation ratio."""
    rank = {name: k for k, name in enumerate(FAILURES)}
    key = frame.assign(
        _fail=frame["outcome"].map(lambda o: rank.get(o, len(FAILURES))),
        _ratio=-frame["rotation_ratio"].fillna(0.0),
    )
    key = key.sort_values(["_fail", "min_margin_deg", "_ratio", "run", "variant"], kind="stable")
    return key.drop(columns=["_fail", "_ratio"]).head(n).reset_index(drop=True)
