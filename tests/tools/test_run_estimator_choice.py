"""Which nodes ``attitude-run`` starts for a scenario with sensors (no ROS: the checked
inputs, before anything is started): the estimator between the plant's measurements and
the loop, with our simulator or an external plant that feeds raw sensors; no estimator
for an external plant that feeds its own estimate (``--external-estimate``); the
simulator's expected listeners follow the graph."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from attitude_core.config import node_graph as graph
from attitude_core.config.scenario import ScenarioError
from attitude_tools.run.orchestrate import (
    PLANT_EXTERNAL,
    PLANT_SIM,
    RunRequest,
    _own_args,
    check_inputs,
)

ROOT = Path(__file__).resolve().parents[2]
SENSING = ROOT / "scenarios" / "case1_wheels_sensors.yaml"
PLAIN = ROOT / "scenarios" / "case1_wheels.yaml"


def _request(tmp_path, scenario, plant=PLANT_SIM, external_estimate=False) -> RunRequest:
    return RunRequest(
        scenario_path=str(scenario),
        out_dir=str(tmp_path / "run"),
        time_mode="lockstep",
        timeout_s=None,
        settle_s=1.0,
        log=lambda _: None,
        node_params={},
        plant=plant,
        plant_timeout_s=10.0,
        namespace=None,
        external_estimate=external_estimate,
    )


def _roles(inputs) -> list[str]:
    return [n.role for n in inputs.started]


def test_sensors_with_our_simulator_start_the_estimator(tmp_path):
    inputs = check_inputs(_request(tmp_path, SENSING))
    assert _roles(inputs) == [n.role for n in graph.SENSING_NODES]
    args = _own_args(_request(tmp_path, SENSING), tmp_path, inputs.nodes, inputs.scenario)
    assert "lockstep.expected_subscribers:=2" in args[graph.SIMULATOR.role]


def test_no_sensors_no_estimator(tmp_path):
    inputs = check_inputs(_request(tmp_path, PLAIN))
    assert _roles(inputs) == [n.role for n in graph.NODES]
    args = _own_args(_request(tmp_path, PLAIN), tmp_path, inputs.nodes, inputs.scenario)
    assert "lockstep.expected_subscribers:=3" in args[graph.SIMULATOR.role]


def test_an_external_plant_with_raw_sensors_gets_the_estimator(tmp_path):
    inputs = check_inputs(_request(tmp_path, SENSING, PLANT_EXTERNAL))
    assert _roles(inputs) == ["recorder", "estimator", "planner", "controller"]


def test_an_external_plant_with_its_own_estimate_gets_none(tmp_path):
    inputs = check_inputs(_request(tmp_path, SENSING, PLANT_EXTERNAL, external_estimate=True))
    assert _roles(inputs) == ["recorder", "planner", "controller"]
    assert not inputs.nodes.sensing


def test_an_external_estimate_needs_the_sensors_it_comes_from(tmp_path):
    with pytest.raises(ScenarioError, match="sensors") as err:
        check_inputs(_request(tmp_path, PLAIN, PLANT_EXTERNAL, external_estimate=True))
    assert err.value.key == "sensors"


def test_the_cli_refuses_an_external_estimate_with_our_simulator(tmp_path):
    run = subprocess.run(
        [str(Path(sys.prefix) / "bin" / "attitude-run"), str(SENSING), "--out",
         str(tmp_path / "run"), "--external-estimate"],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert run.returncode == 2
    assert "--external-estimate" in run.stderr and "--plant external" in run.stderr
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize(
    "scenario, until_stopped, stops",
    [
        ("case1.yaml", False, "[arrived,stuck,infeasible,safe_mode,complete]"),
        ("case1_plan.yaml", False, "[complete,safe_mode]"),  # not on a target's arrival
        ("case1_operator.yaml", True, "['']"),  # the operator ends it
    ],
)
def test_the_recorder_stops_on_the_end_of_the_slew_of_the_plan_or_never(
    tmp_path, scenario, until_stopped, stops
):
    req = _request(tmp_path, ROOT / "scenarios" / scenario)
    req = RunRequest(**{**req.__dict__, "until_stopped": until_stopped})
    inputs = check_inputs(req)
    args = _own_args(req, tmp_path, inputs.nodes, inputs.scenario)
    assert f"stop_on_planner_status:={stops}" in args[graph.RECORDER.role]
