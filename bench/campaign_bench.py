"""Benchmark of ``attitude-campaign``: scenarios per second with 1 and 2 Dask workers
(the scaling ratio) and the per-run cost split into closed loop, metrics and overhead.

Run: .venv/bin/python bench/campaign_bench.py [--runs N]

The same SPEC (``N`` random slews around Case 1, improved variant, 150 s simulated) runs
on a ``LocalCluster`` of 1, then 2 worker processes, each from a fresh start to every
output written. Per run: ``loop_s`` (the offline closed loop), ``metrics_s``
(``summarize``: the dense margin and the rest), overhead (the task's draw and its row,
and the campaign's scheduling, writing and reporting, spread over the runs). The
scaling is printed for the task phase (aim: at least 1.8x from 1 to 2 workers) and end
to end. Not a test: timings depend on the machine.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

import yaml

from attitude_tools.campaign.cli import run_campaign
from attitude_tools.campaign.spec import load_spec

ROOT = Path(__file__).resolve().parents[1]
AIM_SCALING = 1.8


def spec_file(tmp: Path, runs: int) -> Path:
    doc = {
        "campaign": {
            "name": "bench",
            "runs": runs,
            "seed": 3,
            "base_scenario": str(ROOT / "scenarios" / "case1.yaml"),
            "sim_time_s": 150.0,
            "dispersions": {
                "attitudes": "uniform",
                "min_end_margin_deg": 3.0,
                "instruments": {"count": [1, 3], "half_angle_deg": [10.0, 35.0]},
                "bright_objects": {"count": [2, 6]},
            },
            "planner_variants": ["improved"],
        }
    }
    path = tmp / "bench.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def main() -> None:
    # Here, not at the top: a worker process imports this module again (multiprocessing's
    # spawn), and attitude-campaign's workers do not import pyarrow.
    import pyarrow.parquet as pq

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=200)
    args = parser.parse_args()
    print(f"campaign benchmark: {args.runs} runs x 150 s simulated, {os.cpu_count()} cpu(s)")
    rates, task_rates = {}, {}
    with tempfile.TemporaryDirectory() as tmp_dir:
        tmp = Path(tmp_dir)
        spec = load_spec(spec_file(tmp, args.runs))
        for workers in (1, 2):
            out = tmp / f"out{workers}"
            t0 = time.perf_counter()
            code = run_campaign(spec, out, workers=workers, log=lambda msg: None)
            wall = time.perf_counter() - t0
            assert code == 0, code
            rows = pq.read_table(out / "runs.parquet").to_pandas()
            rates[workers] = len(rows) / wall
            info = json.loads((out / "summary.json").read_text())["campaign"]
            task_rates[workers] = len(rows) / info["tasks_wall_s"]
            loop, metrics = rows["loop_s"].mean(), rows["metrics_s"].mean()
            per_run = wall * workers / len(rows)  # worker-seconds per run
            print(
                f"  {workers} worker(s): {wall:6.1f} s wall, {rates[workers]:5.2f} scenarios/s; "
                f"per run {per_run:.3f} worker-s = closed loop {loop:.3f} s "
                f"({100 * loop / per_run:.0f} %) + metrics {metrics:.3f} s "
                f"({100 * metrics / per_run:.0f} %) + overhead {per_run - loop - metrics:.3f} s "
                f"({100 * (per_run - loop - metrics) / per_run:.0f} %)"
            )
    print(
        f"  scaling 1 -> 2 workers, task phase (first submission to last result): "
        f"{task_rates[2] / task_rates[1]:.2f}x (aim >= {AIM_SCALING}x)"
    )
    print(
        f"  scaling 1 -> 2 workers, end to end (cluster start and outputs included): "
        f"{rates[2] / rates[1]:.2f}x"
    )


if __name__ == "__main__":
    main()
