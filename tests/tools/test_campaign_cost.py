"""The shortcuts a campaign run takes give what the long way gave: a draw is loaded from
the values its reproducer file holds, without writing and reading that file; short runs
share a Dask task, with the rows of one run per task; LocalCluster workers keep glibc's
malloc defaults."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
import yaml

from attitude_core.config.scenario_flatten import flatten_parameters
from attitude_core.config.scenario_loader import loads_scenario
from attitude_core.yamlio import load_strict
from attitude_tools.campaign import cli
from attitude_tools.campaign.cli import run_campaign
from attitude_tools.campaign.draw import as_read_back, base_parameters, draw_run, scenario_text
from attitude_tools.campaign.spec import load_spec
from attitude_tools.campaign.task import TIMING_COLUMNS, batches, run_task

ROOT = Path(__file__).resolve().parents[2]
SPECS = sorted((ROOT / "campaigns").glob("*.yaml"))


def _typed(value: Any) -> Any:
    """``value`` with the type of every part (1 and 1.0 and True differ)."""
    if isinstance(value, dict):
        return {k: _typed(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return (type(value).__name__, [_typed(v) for v in value])
    return (type(value).__name__, value)


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return bool(np.array_equal(a, b)) and np.asarray(a).dtype == np.asarray(b).dtype
    if isinstance(a, tuple | list) and isinstance(b, tuple | list):
        return type(a) is type(b) and len(a) == len(b) and all(map(_same, a, b))
    if hasattr(a, "__dataclass_fields__") and type(a) is type(b):
        return all(_same(getattr(a, f), getattr(b, f)) for f in a.__dataclass_fields__)
    return bool(type(a) is type(b) and a == b)


@pytest.mark.parametrize("spec_path", SPECS, ids=[p.stem for p in SPECS])
def test_a_draw_is_loaded_from_the_values_its_reproducer_holds(spec_path):
    spec = load_spec(spec_path)
    base = base_parameters(spec)
    for i in range(3):
        draw = draw_run(spec, base, i, spec.planner_variants[-1])
        text = scenario_text(draw.flat)
        read = flatten_parameters(load_strict(text)["/**"]["ros__parameters"])
        assert _typed(read) == _typed(as_read_back(draw.flat))
        assert _same(loads_scenario(text, draw.scenario.source), draw.scenario)


def _spec(tmp_path: Path, runs: int, sim_time_s: float) -> Path:
    campaign = {
        "name": "cost",
        "runs": runs,
        "seed": 5,
        "base_scenario": str(ROOT / "scenarios" / "case1.yaml"),
        "sim_time_s": sim_time_s,
        "dispersions": {
            "attitudes": "uniform",
            "instruments": {"count": [1, 2], "half_angle_deg": [10.0, 30.0]},
            "bright_objects": {"count": [2, 4]},
        },
        "planner_variants": ["improved", "paper"],
    }
    path = tmp_path / f"cost_{runs}_{sim_time_s:g}.yaml"
    path.write_text(yaml.safe_dump({"campaign": campaign}, sort_keys=False))
    return path


def test_short_runs_share_a_dask_task_and_long_ones_do_not(tmp_path):
    for runs, sim_time_s, workers, size in [
        (100, 150.0, 1, 5),  # 1500 steps: five to a task
        (100, 150.0, 2, 5),
        (20, 150.0, 2, 2),  # 40 tasks, 16 groups at least
        (6, 150.0, 2, 1),
        (50, 400.0, 1, 2),
        (50, 600.0, 1, 1),
    ]:
        spec = load_spec(_spec(tmp_path, runs, sim_time_s))
        groups = batches(spec, spec.tasks, workers)
        assert [t for g in groups for t in g] == list(spec.tasks)
        assert max(len(g) for g in groups) == size
        assert all(len(g) == size for g in groups[:-1])


@pytest.mark.slow
def test_a_campaign_of_batched_runs_gives_the_rows_of_single_ones(tmp_path):
    spec = load_spec(_spec(tmp_path, 12, 5.0))
    assert len(batches(spec, spec.tasks, 1)[0]) == 3  # 24 tasks: 8 groups of 3
    out = tmp_path / "out"
    assert run_campaign(spec, out, workers=1, log=lambda msg: None) == 0
    got = pq.read_table(out / "runs.parquet").to_pandas().drop(columns=list(TIMING_COLUMNS))
    rows = [run_task(spec, i, v) for i, v in spec.tasks]
    expected = pd.DataFrame(rows).sort_values(["run", "variant"]).reset_index(drop=True)
    pd.testing.assert_frame_equal(got, expected.drop(columns=list(TIMING_COLUMNS)))


@pytest.mark.slow
def test_local_cluster_workers_keep_the_malloc_defaults(monkeypatch):
    """Not Dask's MALLOC_TRIM_THRESHOLD_ (it makes NumPy's temporaries page-fault anew)."""
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
    client, _ = cli._connect(1, None)
    try:
        env = client.submit(lambda: dict(os.environ), pure=False).result()
    finally:
        cli._close(client)
    assert "MALLOC_TRIM_THRESHOLD_" not in env
    assert env["OMP_NUM_THREADS"] == "1"  # the rest of Dask's worker environment
