"""The planner's step-time figures of a run summary are taken over the steps that have
a step time: a recorded step can lack the planner's report (the last states of a run
whose planner stopped first), which is no reason for the figures to be NaN."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.record.summary import summarize

CASE1 = Path(__file__).resolve().parents[2] / "scenarios" / "case1.yaml"


def test_a_step_without_the_planners_report_leaves_the_step_time_figures_finite():
    run = run_closed_loop(load_scenario(CASE1))
    tracking = run.planner_status == PlannerStatus.TRACKING.code
    whole = summarize(run)
    k = int(np.flatnonzero(tracking)[-1])
    run.planner_step_s[k] = np.nan  # as a bag rebuild has it where the report is missing
    gap = summarize(run)
    finite = run.planner_step_s[tracking & np.isfinite(run.planner_step_s)]
    assert np.isfinite(gap.planner_step_us_median) and np.isfinite(gap.planner_step_us_p99)
    assert gap.planner_step_us_median == float(np.median(finite)) * 1e6
    assert gap.planner_step_us_p99 == float(np.percentile(finite, 99)) * 1e6
    assert np.isfinite(whole.planner_step_us_median)
    run.planner_step_s[:] = np.nan  # no report at all: unknown
    assert np.isnan(summarize(run).planner_step_us_median)
