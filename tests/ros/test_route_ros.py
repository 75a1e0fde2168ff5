"""Global routes through the ROS 2 node graph: an infeasible slew reported up front and a
routed slew flown by the real nodes as offline (real processes, DDS, bags)."""

import json
from pathlib import Path

import numpy as np
import pytest
from support import attitude_run, needs_workspace

from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract import diagnostics
from attitude_core.contract.status import PlannerStatus
from attitude_core.contract.topics import DIAGNOSTICS
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_tools.bag import read_bag
from attitude_tools.bag.run_record import run_from_bag

ROOT = Path(__file__).resolve().parents[2]
pytestmark = [pytest.mark.ros, needs_workspace]


@pytest.mark.slow
def test_infeasible_slew_is_reported_at_the_first_state_with_its_reason(tmp_path, ros_domain):
    sc = load_scenario(ROOT / "scenarios" / "enclosed_goal.yaml")
    out = tmp_path / "enclosed"
    proc = attitude_run(ROOT / "scenarios" / "enclosed_goal.yaml", out, ros_domain)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "attitude-run: infeasible:" in proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["planner_infeasible"] and summary["failure"] is None
    assert summary["end_reason"] == "planner finished"
    for k in range(1, 5):
        assert f"star_tracker/object_{k}" in summary["infeasible_reason"]
    # The planner node said so in /diagnostics from the first stamp on, with the reason.
    first = None
    for m in read_bag(str(out / "bag"), [DIAGNOSTICS]):
        if m.msg.status[0].name != diagnostics.STATUS_NAME:
            continue  # a node's run identity
        values = {kv.key: kv.value for kv in m.msg.status[0].values}
        report = diagnostics.PlannerDiagnostics.from_values(values)
        first = first or report
        assert report.status == PlannerStatus.INFEASIBLE
        assert report.reason == summary["infeasible_reason"]
    assert first is not None
    # The target held the start; no torque was asked for.
    run = run_from_bag(str(out / "bag")).run
    np.testing.assert_allclose(run.sigma_t, np.broadcast_to(sc.initial_mrp, run.sigma_t.shape))
    assert np.abs(run.torque_b).max() == 0.0


@pytest.mark.slow
def test_routed_slew_through_ros_is_the_offline_one(tmp_path, ros_domain):
    """fepf_stall: the FEPF alone stalls there; the planner node flies the global route
    it prepared before the first state, in lockstep exactly as the offline loop."""
    path = ROOT / "scenarios" / "fepf_stall.yaml"
    out = tmp_path / "stall"
    proc = attitude_run(path, out, ros_domain, timeout=400)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    offline = run_closed_loop(load_scenario(path))
    assert summary["reached"] and summary["min_margin_deg"] > 0.0
    assert summary["route_rotation_deg"] == pytest.approx(offline.route_rotation_deg, abs=1e-9)
    run = run_from_bag(str(out / "bag")).run
    n = len(run.t)
    np.testing.assert_allclose(run.sigma_bn, offline.sigma_bn[:n], atol=1e-6, rtol=0)
    np.testing.assert_allclose(run.sigma_t, offline.sigma_t[:n], atol=1e-6, rtol=0)
    np.testing.assert_array_equal(run.planner_status, offline.planner_status[:n])
