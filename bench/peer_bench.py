"""Benchmark against a peer: the Case 1 closed loop built from Basilisk's compiled modules
and ours, side by side in one run, per run and per step, and a campaign run of ours
end to end.

Run: .venv/bin/python bench/peer_bench.py [--runs N] [--repeats N] [--grids 8,12]

Basilisk (``bsk``, pinned in ``bench/requirements-bsk.txt``) lives in an environment of
its own, ``.bench-venv/bsk/``, made here with ``python3.11 -m venv`` on the first run and
reused while it imports and its stamp matches the requirements file's hash; it is never
in the project's lock. ``bench/peer_bsk_case1.py`` runs there in a subprocess: the
spacecraft, simple navigation, Basilisk's constrained attitude maneuver planner (CAM,
A* on an MRP grid with the three Case 1 cones), attitude tracking error, MRP feedback
with our gains; per run the build, the CAM's plan and the 1500-step stepping, timed in
one process after a warm-up; once per CAM grid fineness of ``--grids`` (8, its example's
value, and 12, the fineness of the issue's reference figure of 65-69 ms).

Ours, in this process: the offline Case 1 closed loop (``run_closed_loop``) per run
after a warm-up (the guidance's set-up, its global route included, timed alone too so
that the stepping's share per step can be given), and a campaign run: ``N`` random
slews (``bench/campaign_bench.py``'s spec) through ``attitude-campaign``'s run on a
1-worker Dask ``LocalCluster``, from the start to every output written, over ``N``.
Both flights are judged by ``attitude_core``'s margins and Case 1's arrival tolerances:
a speed comparison means something only when both fly the same problem. The plant, the
PD law and gains, the cones, the start and the goal are the same; the planners are not:
the CAM plans the whole path before the first step (A* on its MRP grid, the cones held
at the grid's nodes, a B-spline through them lasting 4 x its MRP length / its mean
rate), ours steps the FEPF (after its global route) every step. The aim: a campaign run
costs at most half of Basilisk's Case 1 run. Not a test: timings depend on the machine.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from campaign_bench import spec_file

from attitude_core.assembly.guidance import guidance_from_scenario
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.record.metrics import arrival_time
from attitude_core.record.summary import constraint_margins_deg, summarize
from attitude_tools.campaign.cli import run_campaign
from attitude_tools.campaign.spec import load_spec

ROOT = Path(__file__).resolve().parents[1]
BSK_ENV = ROOT / ".bench-venv" / "bsk"
BSK_REQUIREMENTS = ROOT / "bench" / "requirements-bsk.txt"
BSK_SCRIPT = ROOT / "bench" / "peer_bsk_case1.py"
STAMP = ".requirements-sha256"
AIM_CAMPAIGN_OVER_BSK = 0.5


def ensure_bsk_env(python: str) -> tuple[Path, str]:
    """The Basilisk environment's interpreter, made or remade when its stamp (the
    requirements file's hash) differs or Basilisk does not import."""
    digest = hashlib.sha256(BSK_REQUIREMENTS.read_bytes()).hexdigest()
    exe = BSK_ENV / "bin" / "python"
    stamp = BSK_ENV / STAMP
    if stamp.is_file() and stamp.read_text().strip() == digest:
        probe = subprocess.run([exe, "-c", "import Basilisk"], capture_output=True)
        if probe.returncode == 0:
            return exe, "reused"
    base = shutil.which(python)
    if base is None:
        sys.exit(f"peer bench: {python} not found (it makes the Basilisk environment)")
    t0 = time.perf_counter()
    BSK_ENV.parent.mkdir(exist_ok=True)
    steps = (
        [base, "-m", "venv", "--clear", BSK_ENV],
        [exe, "-m", "pip", "install", "--quiet", "-r", BSK_REQUIREMENTS],
        [exe, "-c", "import Basilisk"],
    )
    for cmd in steps:
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode != 0:
            sys.exit(f"peer bench: {' '.join(map(str, cmd))} failed:\n{done.stderr[-3000:]}")
    stamp.write_text(digest + "\n")
    return exe, f"made in {time.perf_counter() - t0:.0f} s"


def basilisk_case1(exe: Path, repeats: int, trajectory: Path, grid: int) -> dict:
    """``peer_bsk_case1.py``'s JSON line, the CAM on a grid of fineness ``grid``."""
    done = subprocess.run(
        [
            exe,
            BSK_SCRIPT,
            "--repeats",
            str(repeats),
            "--trajectory",
            trajectory,
            "--grid",
            str(grid),
        ],
        capture_output=True,
        text=True,
    )
    if done.returncode != 0:
        sys.exit(f"peer bench: {BSK_SCRIPT.name} failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def judged(scenario, t, sigma, omega) -> tuple[np.ndarray, float | None]:
    """A flight by our measures: the minimum margin per constraint at the samples
    (deg) and the arrival time (Case 1's tolerances; None: not arrived)."""
    margins = constraint_margins_deg(scenario, t, sigma).min(axis=0)
    tol = scenario.true_arrival
    _, t_reach, _ = arrival_time(
        t, sigma, omega, np.asarray(scenario.desired_mrp), tol.attitude_tol_deg, tol.rate_tol_rad_s
    )
    return margins, t_reach


def ours_case1(scenario, repeats: int) -> dict:
    """Our offline Case 1 in this (warm) process: per run, the guidance's set-up alone."""
    run = run_closed_loop(scenario)  # warm-up (FIS tables, kernels, caches)
    walls, setups = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        run = run_closed_loop(scenario)
        walls.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        guidance_from_scenario(scenario)
        setups.append(time.perf_counter() - t0)
    margins, t_reach = judged(scenario, run.t, run.sigma_bn, run.omega_b)
    summary = summarize(run)
    return {
        "run_s": statistics.median(walls),
        "run_s_min": min(walls),
        "setup_s": statistics.median(setups),
        "margins": margins,
        "arrival_s": t_reach,
        "rotation_deg": summary.rotation_deg,
        "dense_margin_deg": summary.min_margin_deg,
    }


def ours_campaign(runs: int) -> dict:
    """``runs`` random slews on a 1-worker LocalCluster, start to every output written."""
    # Here, not at the top: the worker process imports this module again (spawn), and
    # attitude-campaign's workers do not import pyarrow.
    import pyarrow.parquet as pq

    with tempfile.TemporaryDirectory() as tmp_dir:
        tmp = Path(tmp_dir)
        spec = load_spec(spec_file(tmp, runs))
        t0 = time.perf_counter()
        code = run_campaign(spec, tmp / "out", workers=1, log=lambda msg: None)
        wall = time.perf_counter() - t0
        if code != 0:
            sys.exit(f"peer bench: the campaign exited {code}")
        rows = pq.read_table(tmp / "out" / "runs.parquet").to_pandas()
    return {
        "wall_s": wall,
        "runs": len(rows),
        "run_s": wall / len(rows),
        "loop_s": float(rows["loop_s"].mean()),
        "metrics_s": float(rows["metrics_s"].mean()),
    }


def _margins(values) -> str:
    return " / ".join(f"{m:.1f}" for m in values)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=200, help="campaign size (random slews)")
    parser.add_argument("--repeats", type=int, default=5, help="timed Case 1 runs on each side")
    parser.add_argument("--python", default="python3.11", help="makes the Basilisk environment")
    parser.add_argument(
        "--grids",
        default="8,12",
        help="the CAM's grid fineness N, each a Basilisk run (8: its example; 12: the issue's)",
    )
    args = parser.parse_args()
    grids = [int(n) for n in args.grids.split(",")]
    scenario = load_scenario(ROOT / "scenarios" / "case1.yaml")
    steps = scenario.n_steps
    print(f"peer benchmark: Case 1 ({steps} steps, {scenario.sim_time_s:.0f} s simulated)")
    print(f"  {os.cpu_count()} cpu(s); Case 1 runs: warm process, warm-up + {args.repeats} timed")

    exe, how = ensure_bsk_env(args.python)
    peers = []  # (Basilisk's figures, margins, arrival) per grid
    with tempfile.TemporaryDirectory() as tmp:
        for grid in grids:
            trajectory = Path(tmp) / f"bsk_case1_{grid}.npz"
            found = basilisk_case1(exe, args.repeats, trajectory, grid)
            flown = np.load(trajectory)
            peers.append(
                (found, *judged(scenario, flown["t"], flown["sigma_bn"], flown["omega_b"]))
            )
    ours = ours_case1(scenario, args.repeats)
    camp = ours_campaign(args.runs)

    print(
        "the problem flown: the same plant, gains, cones, start and goal; the planners differ "
        "(margins at the samples, deg, objects 1 / 2 / 3; aim > 0)"
    )
    for bsk, bsk_margins, bsk_arrival in peers:
        fl = bsk["flight"]
        print(
            f"  Basilisk {bsk['basilisk']} ({BSK_ENV.relative_to(ROOT)}, {how}): CAM grid N = "
            f"{bsk['grid_n']}, distance A*, B-spline at {bsk['avg_omega_rad_s']} rad/s mean: "
            f"margins {_margins(bsk_margins)}, arrival "
            f"{bsk_arrival if bsk_arrival is not None else 'none'} s, rotation "
            f"{fl['rotation_deg']:.0f} deg ({fl['plan_waypoints']} CAM waypoints; its own "
            f"check: min margin {fl['min_margin_deg']:.2f} deg, outside the cones: "
            f"{fl['outside_cones']})"
        )
    print(
        f"  ours:     margins {_margins(ours['margins'])}, arrival {ours['arrival_s']} s, "
        f"rotation {ours['rotation_deg']:.0f} deg (FEPF, improved variant; dense margin "
        f"{ours['dense_margin_deg']:.2f} deg)"
    )

    our_run = 1e3 * ours["run_s"]
    our_setup = 1e3 * ours["setup_s"]
    our_step = 1e3 * (our_run - our_setup) / steps
    camp_run = 1e3 * camp["run_s"]
    camp_step = 1e6 * camp["loop_s"] / steps
    print(f"{'':44s}{'per run, ms':>14s}{'per step, us':>14s}")
    rows = [
        (
            f"Basilisk Case 1, N = {b['grid_n']} (build + plan + steps)",
            1e3 * b["run_s"],
            b["step_us"],
        )
        for b, _, _ in peers
    ]
    rows += [
        ("ours, offline Case 1 (warm process)", our_run, our_step),
        (f"ours, campaign run (1 worker, {camp['runs']} slews)", camp_run, camp_step),
    ]
    for name, run_ms, step_us in rows:
        print(f"  {name:42s}{run_ms:14.1f}{step_us:14.1f}")
    for bsk, _, _ in peers:
        print(
            f"  Basilisk N = {bsk['grid_n']}: run min {1e3 * bsk['run_s_min']:.1f} ms; build "
            f"{1e3 * bsk['build_s']:.1f} ms, CAM plan (init) {1e3 * bsk['plan_s']:.1f} ms, "
            f"steps {1e3 * bsk['loop_s']:.1f} ms (per step: the steps / {steps}; min "
            f"{bsk['step_us_min']:.1f} us)"
        )
    print(
        f"  ours: run min {1e3 * ours['run_s_min']:.1f} ms; guidance set-up (route, timed "
        f"alone) {our_setup:.1f} ms (per step: (run - set-up) / {steps})"
    )
    print(
        f"  campaign: {camp['wall_s']:.1f} s wall for {camp['runs']} runs; per run closed loop "
        f"{1e3 * camp['loop_s']:.1f} ms + metrics {1e3 * camp['metrics_s']:.1f} ms + overhead "
        f"{camp_run - 1e3 * (camp['loop_s'] + camp['metrics_s']):.1f} ms (per step: its closed "
        f"loop / {steps}, set-up included)"
    )
    for bsk, _, _ in peers:
        bsk_run, bsk_step = 1e3 * bsk["run_s"], bsk["step_us"]
        print(f"ratios ours / Basilisk N = {bsk['grid_n']}")
        print(
            f"  offline Case 1: per run {our_run / bsk_run:.2f}, per step {our_step / bsk_step:.2f}"
        )
        print(
            f"  campaign run: per run {camp_run / bsk_run:.2f}, per step {camp_step / bsk_step:.2f}"
        )
        ratio = camp_run / bsk_run
        verdict = "met" if ratio <= AIM_CAMPAIGN_OVER_BSK else "not met"
        print(
            f"  aim: a campaign run (1 worker, {camp['runs']} slews) at most "
            f"{AIM_CAMPAIGN_OVER_BSK} of Basilisk's Case 1 run: {ratio:.2f} ({verdict}; "
            f"{camp_run:.1f} ms against {AIM_CAMPAIGN_OVER_BSK * bsk_run:.1f} ms)"
        )


if __name__ == "__main__":
    main()
