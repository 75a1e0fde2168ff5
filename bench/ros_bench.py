"""Benchmark of a scenario (default Case 1) through the ROS 2 node graph, against offline.

Run: .venv/bin/python bench/ros_bench.py [--repeats N] [--scenario PATH] [--mode lockstep|realtime]

Each repeat runs `attitude-run SCENARIO --out <fresh temp dir> --quiet` as a subprocess
(the ROS 2 processes over real DDS), times it from process start to exit (start-up
and bag close included) and reads its summary.json. By default without ROS_DOMAIN_ID, as
a user runs it: attitude-run reserves a domain and does not probe it; `--domain caller`
sets a reserved ID in the environment, so attitude-run probes it first (a caller's
domain). Prints median (min, max) of:
  * end-to-end wall time, aim <= 10 s (lockstep);
  * the fixed overhead: wall minus the stepping (steps_recorded / steps_per_s), aim <= 2.5 s;
  * lockstep steps per second (summary steps_per_s, from the recorder's receive times),
    aim >= 300; in realtime mode the aims do not apply and steps/s is shown against 1/dt;
  * simulated time covered (steps_recorded * dt) and sim-time / wall-time speed-up;
and the offline runner on the same scenario: warm in-process run_closed_loop (after one
warm-up call; it simulates the whole sim_time_s, so its wall is also scaled to the
recorded span, and offline steps/s = (n_steps + 1) / wall) and the cold
`attitude-offline` command; the bare rclpy ring (bench/ros_ring.py: the same
messages between three processes, no work), one ring run right after each ROS run, so
that each ratio is taken under the same machine load; then ROS steps/s / ring steps/s
(aim >= 0.6; of the medians, and the median of the run-by-run ratios); beside it, like
for like, the ring with a fourth process that reads every topic raw and keeps nothing
(``ros_ring.py --recorder``: our run has its recorder, the bare ring has none),
ROS steps/s / offline steps/s and ROS wall / cold offline wall. Every ROS run must have
reached (reached, min_margin_deg > 0, no failure),
else it is printed and the script exits 1: a broken run gives no figure.
Not a test: nothing timed is asserted; timings depend on the machine.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

from attitude_core.config.scenario_loader import load_scenario
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_tools.run.domain import reserve_domain

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ros_ring import ring  # beside this file

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.dirname(sys.executable)
AIM_WALL_S = 10.0
AIM_STEPS_PER_S = 300.0
AIM_OVERHEAD_S = 2.5
AIM_RING_RATIO = 0.6


def ros_run(scenario_path, mode, caller_domain):
    """One `attitude-run` subprocess; return (wall s, exit code, summary or None, stderr)."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    env.pop("ROS_DOMAIN_ID", None)
    if caller_domain:
        with reserve_domain() as domain:  # held by us, named to attitude-run: it probes
            return _timed_run(scenario_path, mode, domain.env(env))
    return _timed_run(scenario_path, mode, env)


def _timed_run(scenario_path, mode, env):
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        proc = subprocess.run(
            [
                f"{BIN}/attitude-run",
                scenario_path,
                "--out",
                f"{tmp}/run",
                "--mode",
                mode,
                "--quiet",
            ],
            env=env,
            capture_output=True,
            text=True,
        )
        wall = time.perf_counter() - t0
        try:
            with open(f"{tmp}/run/summary.json") as f:
                summary = json.load(f)
        except OSError:
            summary = None
    return wall, proc.returncode, summary, proc.stderr


def stats(xs):
    return statistics.median(xs), min(xs), max(xs)


def row(name, xs, unit, fmt, aim=None, higher_is_better=False):
    med, lo, hi = stats(xs)
    line = f"  {name:34s} {med:{fmt}} {unit:5s} ({lo:{fmt}} .. {hi:{fmt}})"
    if aim is not None:
        line += f"  aim {'>=' if higher_is_better else '<='} {aim:g}  ratio {med / aim:.2f}"
    print(line)
    return med


def main():
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--scenario", default=f"{ROOT}/scenarios/case1.yaml")
    parser.add_argument("--mode", choices=("lockstep", "realtime"), default="lockstep")
    parser.add_argument("--domain", choices=("reserved", "caller"), default="reserved")
    parser.add_argument("--ring-steps", type=int, default=2000)
    args = parser.parse_args()
    scen = load_scenario(args.scenario)
    lockstep = args.mode == "lockstep"
    print(
        f"ROS benchmark: {scen.name} ({args.scenario}), {args.mode}, {args.repeats} repeat(s), "
        f"{args.domain} domain, {os.cpu_count()} cpu(s)"
    )

    walls, rates, spans, overheads, ok = [], [], [], [], True
    ring_rates = []  # one ring beside each ROS run: each ratio under the same machine load
    reader_rates = []  # and one with a fourth process reading everything (like for like)
    for i in range(1, args.repeats + 1):
        wall, code, s, err = ros_run(args.scenario, args.mode, args.domain == "caller")
        if s is None:
            print(f"  run {i}: exit {code}, no summary.json\n{err.strip()}")
            ok = False
            continue
        good = code == 0 and s["reached"] and s["min_margin_deg"] > 0.0 and s["failure"] is None
        print(
            f"  run {i} (domain {s['ros_domain_id']:3d}): exit {code}  reached {s['reached']}  "
            f"t_reach {s['t_reach_s']} s  min margin {s['min_margin_deg']:.2f} deg  "
            f"failure {s['failure']}  end '{s['end_reason']}'  steps {s['steps_recorded']}  "
            f"wall {wall:.2f} s (summary {s['wall_time_s']:.2f} s)  -> {'ok' if good else 'BAD'}"
        )
        if not good:
            print(f"    exit codes {s['exit_codes']}\n{err.strip()}")
            ok = False
        walls.append(wall)
        rates.append(s["steps_per_s"])
        if lockstep:
            ring_rates += ring(args.ring_steps, 1)
            reader_rates += ring(args.ring_steps, 1, with_recorder=True)
        overheads.append(wall - s["steps_recorded"] / s["steps_per_s"])
        spans.append(s["steps_recorded"] * scen.dt_s)
    if not ok:
        print("a ROS run did not reach without violation: no benchmark figure")
        return 1

    run_closed_loop(scen)  # warm-up: imports, FIS lookup tables
    off_walls, cold_walls = [], []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        run_closed_loop(scen)
        off_walls.append(time.perf_counter() - t0)
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            subprocess.run(
                [f"{BIN}/attitude-offline", args.scenario, "--out", f"{tmp}/run", "--quiet"],
                check=True,
            )
            cold_walls.append(time.perf_counter() - t0)
    if not ring_rates:
        ring_rates = ring(args.ring_steps, args.repeats)
    n_samples = scen.n_steps + 1
    recorded = statistics.median(spans) / scen.dt_s

    print("\nfigure                              median unit  (min .. max)")
    print("ROS 2 node graph (attitude-run subprocess)")
    wall = row(
        "end-to-end wall, start to exit", walls, "s", "8.2f", AIM_WALL_S if lockstep else None
    )
    if lockstep:
        rate = row("lockstep steps/s", rates, "1/s", "8.1f", AIM_STEPS_PER_S, True)
    else:
        rate = row("steps/s", rates, "1/s", "8.1f")
        print(f"  {'':34s} vs real time 1/dt = {1 / scen.dt_s:g} /s: ratio {rate * scen.dt_s:.3f}")
    row("fixed overhead (wall - stepping)", overheads, "s", "8.2f", AIM_OVERHEAD_S)
    span = row("simulated time covered", spans, "s", "8.1f")
    row("speed-up sim time / wall", [a / b for a, b in zip(spans, walls, strict=True)], "x", "8.1f")
    print(f"offline runner ({scen.n_steps} steps, {scen.sim_time_s:g} s simulated)")
    off = row("warm run_closed_loop wall", off_walls, "s", "8.3f")
    row(
        f"  scaled to recorded {span:g} s",
        [w * recorded / n_samples for w in off_walls],
        "s",
        "8.3f",
    )
    off_rate = row("offline steps/s", [n_samples / w for w in off_walls], "1/s", "8.0f")
    cold = row("cold attitude-offline wall", cold_walls, "s", "8.2f")
    print(f"bare rclpy ring (bench/ros_ring.py, {args.ring_steps} steps, three processes)")
    ring_rate = row("ring steps/s", ring_rates, "1/s", "8.0f")
    reader_rate = row("ring + raw reader of every topic", reader_rates, "1/s", "8.0f")
    print("ratios (medians)")
    if lockstep:
        paired = statistics.median(r / g for r, g in zip(rates, ring_rates, strict=True))
        print(
            f"  ROS steps/s / ring steps/s          {rate / ring_rate:8.3f}  aim >= "
            f"{AIM_RING_RATIO:g}  ratio {rate / ring_rate / AIM_RING_RATIO:.2f}"
        )
        print(
            f"  the same, run by run (median)       {paired:8.3f}  aim >= "
            f"{AIM_RING_RATIO:g}  ratio {paired / AIM_RING_RATIO:.2f}"
        )
        like = statistics.median(r / g for r, g in zip(rates, reader_rates, strict=True))
        print(
            f"  ROS / ring with the reader, like for like (run by run) "
            f"{rate / reader_rate:.3f} ({like:.3f})"
        )
    print(f"  ROS steps/s / offline steps/s       {rate / off_rate:8.3f}")
    print(f"  ROS wall / cold offline wall        {wall / cold:8.2f}")
    print(f"  ROS wall / warm offline (scaled)    {wall / (off * recorded / n_samples):8.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
