"""``attitude-campaign``: SPEC validation, deterministic draws, real Dask engines
(LocalCluster, and a ``dask scheduler`` with ``dask worker`` processes), a worker
killed mid-campaign, SIGINT and ``--resume``, outputs and a reproducer rerun."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
import yaml
from scipy.spatial.transform import Rotation
from support import needs_workspace

from attitude_core.config.scenario_loader import load_scenario, loads_scenario
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.record.metrics import dense_min_margin_deg
from attitude_tools.bag.run_record import run_from_bag
from attitude_tools.campaign.draw import _candidate, base_parameters, draw_run, scenario_text
from attitude_tools.campaign.spec import SpecError, load_spec
from attitude_tools.campaign.stats import wilson_interval
from attitude_tools.campaign.task import OUTCOMES, TIMING_COLUMNS, run_task
from attitude_tools.run.cli import ros_environment

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(sys.prefix) / "bin"
CASE1 = ROOT / "scenarios" / "case1.yaml"
pytestmark = pytest.mark.slow


def write_spec(tmp_path: Path, runs: int = 6, name: str = "spec.yaml", **extra) -> Path:
    campaign = {
        "name": "test",
        "runs": runs,
        "seed": 7,
        "base_scenario": os.path.relpath(CASE1, tmp_path),
        "sim_time_s": 60.0,
        "dispersions": {
            "attitudes": "uniform",
            "min_end_margin_deg": 3.0,
            "instruments": {"count": [1, 3], "half_angle_deg": [10.0, 35.0]},
            "bright_objects": {"count": [2, 6]},
            "actuators": {"max_torque_nm": [0.05, 0.2], "max_rate_rad_s": [0.05, 0.2]},
        },
        "planner_variants": ["improved", "paper"],
    }
    campaign.update(extra)
    path = tmp_path / name
    path.write_text(yaml.safe_dump({"campaign": campaign}, sort_keys=False))
    return path


def campaign(*args: str, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(BIN / "attitude-campaign"), *args],
        capture_output=True, text=True, timeout=timeout,
    )  # fmt: skip


def table(out: Path) -> pd.DataFrame:
    """``runs.parquet`` read back with pyarrow, without the timing columns."""
    frame = pq.read_table(out / "runs.parquet").to_pandas()
    return frame.drop(columns=list(TIMING_COLUMNS))


def expected_table(spec_path: Path) -> pd.DataFrame:
    """Every task run in this process, in order: the reference for any engine."""
    spec = load_spec(spec_path)
    rows = [run_task(spec, i, v) for i, v in spec.tasks]
    frame = pd.DataFrame(rows).sort_values(["run", "variant"]).reset_index(drop=True)
    return frame.drop(columns=list(TIMING_COLUMNS))


def assert_same_table(a: pd.DataFrame, b: pd.DataFrame) -> None:
    assert list(a.columns) == list(b.columns)
    pd.testing.assert_frame_equal(a.reset_index(drop=True), b.reset_index(drop=True))


# --- the SPEC ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "change, key, reason",
    [
        ({"runs": 0}, "campaign.runs", "must be >= 1"),
        ({"runs": 2.5}, "campaign.runs", "expected an integer"),
        ({"seed": -1}, "campaign.seed", "must be >= 0"),
        ({"base_scenario": "nowhere.yaml"}, "campaign.base_scenario", "not a valid scenario"),
        ({"sim_time_s": 0.0}, "campaign.sim_time_s", "must be > 0"),
        ({"planner_variants": ["fast"]}, "campaign.planner_variants", "expected distinct"),
        ({"planner_variants": []}, "campaign.planner_variants", "expected distinct"),
        ({"runs_": 3}, "campaign.runs_", "unknown key"),
        ({"dispersions": {"attitudes": "gaussian"}}, "campaign.dispersions.attitudes", "only"),
        (
            {"dispersions": {"instruments": {"count": [3, 1]}}},
            "campaign.dispersions.instruments.count",
            "above max",
        ),
        (
            {"dispersions": {"instruments": {"half_angle_deg": [10.0, 95.0]}}},
            "campaign.dispersions.instruments.half_angle_deg",
            "below 90",
        ),
        (
            {"dispersions": {"bright_objects": {"count": [0, 2]}}},
            "campaign.dispersions.bright_objects.count",
            "must be >= 1",
        ),
        (
            {"dispersions": {"actuators": {"max_torque_nm": [0.1, -0.1]}}},
            "campaign.dispersions.actuators.max_torque_nm",
            "must be > 0",
        ),
        (
            {"dispersions": {"inertia_scale": [1.1]}},
            "campaign.dispersions.inertia_scale",
            "expected [low, high]",
        ),
        ({"dispersions": {"colour": 1}}, "campaign.dispersions.colour", "unknown key"),
        (
            {"dispersions": {"keep_in": {"count": [-1, 2], "max_angle_deg": [60.0, 90.0]}}},
            "campaign.dispersions.keep_in.count",
            "must be >= 0",
        ),
        (
            {"dispersions": {"keep_in": {"count": [2, 1], "max_angle_deg": [60.0, 90.0]}}},
            "campaign.dispersions.keep_in.count",
            "above max",
        ),
        (
            {"dispersions": {"keep_in": {"count": [1, 2], "max_angle_deg": [0.0, 90.0]}}},
            "campaign.dispersions.keep_in.max_angle_deg",
            "must be > 0",
        ),
        (
            {"dispersions": {"keep_in": {"count": [1, 2], "max_angle_deg": [60.0, 180.0]}}},
            "campaign.dispersions.keep_in.max_angle_deg",
            "below 180",
        ),
        (
            {"dispersions": {"keep_in": {"count": [1, 2]}}},
            "campaign.dispersions.keep_in.max_angle_deg",
            "missing",
        ),
        (
            {"dispersions": {"keep_in": {"count": [1, 2], "max_angle_deg": [60.0, 90.0], "n": 1}}},
            "campaign.dispersions.keep_in.n",
            "unknown key",
        ),
        (
            {"dispersions": {"keep_in": [1, 2]}},
            "campaign.dispersions.keep_in",
            "expected a mapping",
        ),
    ],
)
def test_a_bad_spec_names_the_key_exits_2_and_writes_nothing(tmp_path, change, key, reason):
    path = write_spec(tmp_path, **change)
    with pytest.raises(SpecError) as info:
        load_spec(path)
    assert info.value.key == key and reason in info.value.reason
    out = tmp_path / "out"
    result = campaign(str(path), "--out", str(out), "--workers", "1")
    assert result.returncode == 2
    assert key in result.stderr and reason in result.stderr
    assert not out.exists()


def test_spec_that_is_not_yaml_or_lacks_keys(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("campaign: [1, 2\n")
    with pytest.raises(SpecError, match="not valid YAML"):
        load_spec(bad)
    bad.write_text(yaml.safe_dump({"campaign": {"name": "x", "seed": 1}}))
    with pytest.raises(SpecError) as info:
        load_spec(bad)
    assert info.value.key == "campaign.runs" and info.value.reason == "missing"


def test_wilson_interval_matches_the_closed_form():
    lo, hi = wilson_interval(0, 20)
    assert lo == 0.0 and hi == pytest.approx(0.16113, abs=1e-4)
    lo, hi = wilson_interval(10, 20)
    assert (lo, hi) == pytest.approx((0.29930, 0.70070), abs=1e-4)
    lo, hi = wilson_interval(1000, 1000)
    assert hi == 1.0 and lo == pytest.approx(0.99617, abs=1e-4)


# --- draws ------------------------------------------------------------------------------


def test_a_run_depends_only_on_the_seed_and_its_index(tmp_path):
    spec = load_spec(write_spec(tmp_path, runs=50))
    base = base_parameters(spec)
    forward = [draw_run(spec, base, i).flat for i in range(8)]
    backward = [draw_run(spec, base, i).flat for i in reversed(range(8))][::-1]
    assert forward == backward
    other = load_spec(write_spec(tmp_path, runs=50, name="other.yaml", seed=8))
    assert draw_run(other, base_parameters(other), 3).flat != forward[3]
    for i in range(8):
        d = draw_run(spec, base, i)
        sc = d.scenario
        assert 1 <= len(sc.instrument_names) <= 3 and 2 <= len(sc.bright_object_names) <= 6
        exact = sc.cone_geometry()
        assert exact.min_margin_deg_single(sc.initial_mrp) >= 3.0
        assert exact.min_margin_deg_single(sc.desired_mrp) >= 3.0
        assert all(0.05 <= t <= 0.2 for t in sc.actuators.max_torque_nm)
    # Redraws are counted, not dropped: with a tight margin some draws are refused.
    tight = load_spec(
        write_spec(
            tmp_path,
            name="tight.yaml",
            dispersions={
                "min_end_margin_deg": 20.0,
                "instruments": {"count": [3, 3], "half_angle_deg": [30.0, 35.0]},
                "bright_objects": {"count": [6, 6]},
            },
        )
    )
    d = draw_run(tight, base_parameters(tight), 0)
    assert d.refused_by_loader + d.too_close_to_a_cone > 0


# Run 0, 3 and 5 of write_spec's SPEC (seed 7) as drawn before keep-in cones existed:
# (initial_mrp, desired_mrp, max_rate_rad_s, instruments, objects, redraws too close).
DRAWN_BEFORE_KEEP_IN = {
    0: (
        [0.023256595380798297, -0.05433257473016636, 0.7337124685256233],
        [0.36945471318734496, 0.3053887624763629, -0.40055835947765284],
        0.09013989568456782, 3, 5, 0,
    ),
    3: (
        [0.8588610387313792, 0.020000248388649708, 0.29319333874728815],
        [-0.15556863799495102, 0.515580122692136, -0.20761110387148907],
        0.05063681232761468, 1, 5, 2,
    ),
    5: (
        [-0.5943323027610317, 0.21693116797197093, -0.14466954871033158],
        [-0.09196456843284917, 0.7231657342739717, 0.5727125180636679],
        0.11641147606152512, 1, 3, 3,
    ),
}  # fmt: skip


def test_a_spec_without_keep_in_draws_the_runs_it_drew_before(tmp_path):
    spec = load_spec(write_spec(tmp_path, runs=50))
    assert spec.keep_in_count is None
    base = base_parameters(spec)
    for i, (sigma_0, sigma_d, rate, n_inst, n_obj, close) in DRAWN_BEFORE_KEEP_IN.items():
        d = draw_run(spec, base, i)
        assert d.flat["initial_mrp"] == pytest.approx(sigma_0, rel=1e-13, abs=1e-15)
        assert d.flat["desired_mrp"] == pytest.approx(sigma_d, rel=1e-13, abs=1e-15)
        assert d.flat["actuators.max_rate_rad_s"] == pytest.approx(rate, rel=1e-13)
        assert (len(d.scenario.instrument_names), len(d.scenario.bright_object_names)) == (
            n_inst,
            n_obj,
        )
        assert (d.too_close_to_a_cone, d.refused_by_loader) == (close, 0)
        assert d.scenario.keep_in_names == () and not any(k.startswith("keep_in") for k in d.flat)


def test_keep_in_draws_come_after_every_other_draw(tmp_path):
    """A candidate with keep-in cones consumes the stream of one without, then its own:
    every other drawn value is the same."""
    plain = load_spec(write_spec(tmp_path, runs=50))
    with_keep_in = load_spec(
        write_spec(
            tmp_path,
            runs=50,
            name="keep_in.yaml",
            dispersions={
                "instruments": {"count": [1, 3], "half_angle_deg": [10.0, 35.0]},
                "bright_objects": {"count": [2, 6]},
                "actuators": {"max_torque_nm": [0.05, 0.2], "max_rate_rad_s": [0.05, 0.2]},
                "keep_in": {"count": [1, 2], "max_angle_deg": [60.0, 120.0]},
            },
        )
    )
    base = base_parameters(plain)
    for i in range(10):
        a = _candidate(plain, base, i, np.random.default_rng([7, i]))
        b = _candidate(with_keep_in, base, i, np.random.default_rng([7, i]))
        assert {k: v for k, v in b.items() if not k.startswith("keep_in.")} == a
        assert 1 <= len(b["keep_in.names"]) <= 2


def test_keep_in_draws_respect_the_dispersion_and_the_end_margin(tmp_path):
    spec = load_spec(
        write_spec(
            tmp_path,
            runs=50,
            dispersions={
                "min_end_margin_deg": 4.0,
                "instruments": {"count": [1, 2], "half_angle_deg": [10.0, 20.0]},
                "bright_objects": {"count": [2, 3]},
                "keep_in": {"count": [0, 2], "max_angle_deg": [60.0, 120.0]},
            },
        )
    )
    assert spec.keep_in_count == (0, 2) and spec.keep_in_max_angle_deg.lo == 60.0
    base = base_parameters(spec)
    counts = set()
    for i in range(12):
        d = draw_run(spec, base, i)
        assert d.flat == draw_run(spec, base, i).flat  # (seed, i) only
        sc = d.scenario
        counts.add(len(sc.keep_in_names))
        assert len(sc.keep_in_names) <= 2
        assert np.all((sc.keep_in_max_angles_deg >= 60.0) & (sc.keep_in_max_angles_deg <= 120.0))
        np.testing.assert_allclose(np.linalg.norm(sc.keep_in_axes_body, axis=1), 1.0)
        if not sc.keep_in_names:
            assert "keep_in.names" not in d.flat  # no empty list in a ROS 2 parameters file
        # Every keep-in cone holds the start and goal by >= 4 deg (SciPy, independently).
        for sigma in (sc.initial_mrp, sc.desired_mrp):
            axes_n = Rotation.from_mrp(np.array(sigma)).apply(np.array(sc.keep_in_axes_body))
            cos = np.einsum("ki,ki->k", axes_n, sc.keep_in_directions_inertial)
            margins = sc.keep_in_max_angles_deg - np.degrees(np.arccos(np.clip(cos, -1, 1)))
            assert np.all(margins >= 4.0), (i, margins)
            assert sc.cone_geometry().min_margin_deg_single(sigma) >= 4.0
    assert counts == {0, 1, 2}
    # The drawn cones make the end-margin rule redraw: counted, as for keep-out cones.
    assert sum(draw_run(spec, base, i).too_close_to_a_cone for i in range(12)) > 0


def test_the_keep_in_campaign_spec_draws_keep_in_cones():
    spec = load_spec(ROOT / "campaigns" / "random_slews_keep_in.yaml")
    assert spec.keep_in_count == (1, 2) and spec.planner_variants == ("improved",)
    assert (spec.keep_in_max_angle_deg.lo, spec.keep_in_max_angle_deg.hi) == (60.0, 120.0)
    d = draw_run(spec, base_parameters(spec), 0, "improved")
    assert 1 <= len(d.scenario.keep_in_names) <= 2
    reread = loads_scenario(scenario_text(d.flat))  # the reproducer's text
    np.testing.assert_array_equal(reread.keep_in_axes_body, d.scenario.keep_in_axes_body)


def test_a_task_row_counts_the_keep_in_cones(tmp_path):
    spec = load_spec(
        write_spec(
            tmp_path,
            runs=2,
            sim_time_s=5.0,
            dispersions={"keep_in": {"count": [2, 2], "max_angle_deg": [100.0, 120.0]}},
        )
    )
    row = run_task(spec, 0, "improved")
    assert row["n_keep_in"] == 2
    assert (
        run_task(load_spec(write_spec(tmp_path, runs=2, sim_time_s=5.0)), 0, "paper")["n_keep_in"]
        == 0
    )


def test_a_task_row_measures_the_body(tmp_path):
    spec = load_spec(write_spec(tmp_path, runs=2, sim_time_s=200.0))
    row = run_task(spec, 0, "improved")
    assert row["outcome"] in OUTCOMES
    assert row["eigenaxis_deg"] > 0.0
    assert row["rotation_ratio"] == pytest.approx(row["rotation_deg"] / row["eigenaxis_deg"])
    if row["outcome"] == "reached":
        assert row["rotation_ratio"] >= 1.0 - 1e-6  # never shorter than the eigenaxis
        assert row["min_margin_deg"] > 0.0 and row["t_reach_s"] > 0.0


# --- engines ------------------------------------------------------------------------------


def test_local_cluster_campaign_writes_every_output(tmp_path):
    spec_path = write_spec(tmp_path, runs=6)
    out = tmp_path / "out"
    result = campaign(str(spec_path), "--out", str(out), "--workers", "2")
    assert result.returncode == 0, result.stdout + result.stderr
    got = table(out)
    assert len(got) == 12 and set(got["variant"]) == {"improved", "paper"}
    assert_same_table(got, expected_table(spec_path))  # in-process, one by one
    summary = json.loads((out / "summary.json").read_text())
    for variant in ("improved", "paper"):
        v = summary["variants"][variant]
        assert v["runs"] == 6
        assert sum(o["count"] for o in v["outcomes"].values()) == 6
        for o in v["outcomes"].values():
            lo, hi = o["wilson95"]
            assert lo <= o["rate"] <= hi
    html = (out / "report.html").read_text()
    assert html.count("<img") >= 3 and "worst runs" in html
    repro = sorted((out / "reproducers").glob("run_*_*.yaml"))
    assert len(repro) == 12  # the 20 worst of 12 rows: all
    # One worker gives the same table.
    out1 = tmp_path / "out1"
    assert campaign(str(spec_path), "--out", str(out1), "--workers", "1").returncode == 0
    assert_same_table(table(out1), got)


def test_a_reproducer_reruns_to_the_same_outcome(tmp_path):
    spec_path = write_spec(tmp_path, runs=3)
    out = tmp_path / "out"
    assert campaign(str(spec_path), "--out", str(out), "--workers", "2").returncode == 0
    rows = table(out)
    row = rows.sort_values("min_margin_deg").iloc[0]
    path = out / "reproducers" / f"run_{int(row['run'])}_{row['variant']}.yaml"
    rerun = subprocess.run(
        [str(BIN / "attitude-offline"), str(path), "--out", str(tmp_path / "rerun"), "--quiet"],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    summary = json.loads((tmp_path / "rerun" / "summary.json").read_text())
    assert summary["planner_variant"] == row["variant"]
    assert summary["min_margin_deg"] == pytest.approx(row["min_margin_deg"], abs=1e-9)
    assert summary["reached"] == (row["outcome"] == "reached")
    assert rerun.returncode == (0 if row["outcome"] == "reached" else 1)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _wait(condition, what: str, timeout_s: float = 120.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.05)


def test_real_scheduler_with_two_workers_survives_a_killed_worker(tmp_path):
    """``dask scheduler`` and two ``dask worker`` processes on localhost; one worker is
    killed (SIGKILL) mid-campaign: its tasks are retried and the table is complete and
    equal to the one computed in this process."""
    spec_path = write_spec(tmp_path, runs=14)
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    logs = contextlib.ExitStack()
    procs = [
        subprocess.Popen(
            [
                str(BIN / "dask"),
                "scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                str(port),
                "--no-dashboard",
            ],
            stdout=subprocess.DEVNULL,
            stderr=logs.enter_context(open(tmp_path / "scheduler.log", "wb")),  # noqa: SIM115
        )  # fmt: skip
    ]
    try:
        for k in range(2):
            procs.append(
                subprocess.Popen(
                    [
                        str(BIN / "dask"),
                        "worker",
                        address,
                        "--nthreads",
                        "1",
                        "--no-nanny",
                        "--no-dashboard",
                        "--name",
                        f"w{k}",
                    ],
                    stdout=subprocess.DEVNULL,
                    stderr=logs.enter_context(open(tmp_path / f"worker{k}.log", "wb")),  # noqa: SIM115
                )  # fmt: skip
            )
        out = tmp_path / "out"
        run = subprocess.Popen(
            [str(BIN / "attitude-campaign"), str(spec_path), "--out", str(out),
             "--scheduler", address],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )  # fmt: skip
        _wait(lambda: any((out / "parts").glob("part-*.parquet")), "the first results")
        assert run.poll() is None, "the campaign ended before a worker could be killed"
        procs[1].send_signal(signal.SIGKILL)
        procs[1].wait(30)
        stdout, stderr = run.communicate(timeout=600)
        assert run.returncode == 0, stdout + stderr
        assert "scheduler" in stdout
        assert_same_table(table(out), expected_table(spec_path))
    finally:
        for p in procs:
            if p.poll() is None:
                p.terminate()
        for p in procs:
            try:
                p.wait(30)
            except subprocess.TimeoutExpired:
                p.kill()
        logs.close()


def test_sigint_then_resume_gives_the_uninterrupted_table(tmp_path):
    # Enough runs that the SIGINT, sent once the first rows are on disk (rows are
    # written every FLUSH_S = 1 s), falls among the tasks: 320 of them take about 3.5 s
    # on two workers here, and a loaded machine's first flush came with the last of
    # them once (16 runs took less than the first flush); 800 leave a wide window.
    runs = 400
    spec_path = write_spec(tmp_path, runs=runs)
    out = tmp_path / "out"
    run = subprocess.Popen(
        [str(BIN / "attitude-campaign"), str(spec_path), "--out", str(out), "--workers", "2"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    _wait(lambda: any((out / "parts").glob("part-*.parquet")), "the first results")
    run.send_signal(signal.SIGINT)
    stdout, stderr = run.communicate(timeout=120)
    assert run.returncode == 130, stdout + stderr
    assert "--resume" in stdout
    assert not (out / "runs.parquet").exists()
    partial = pd.concat(pq.read_table(p).to_pandas() for p in (out / "parts").glob("*.parquet"))
    assert 0 < len(partial) < 2 * runs
    # Without --resume the directory is refused; with it, only the rest is run.
    refused = campaign(str(spec_path), "--out", str(out), "--workers", "2")
    assert refused.returncode == 2 and "--resume" in refused.stderr
    resumed = campaign(str(spec_path), "--out", str(out), "--workers", "2", "--resume")
    assert resumed.returncode == 0, resumed.stdout + resumed.stderr
    done = set(zip(partial["run"], partial["variant"], strict=True))
    assert f"{len(done)} done" in resumed.stdout
    assert_same_table(table(out), expected_table(spec_path))


def test_a_scheduler_that_does_not_answer_fails_within_10_s(tmp_path):
    spec_path = write_spec(tmp_path, runs=2)
    out = tmp_path / "out"
    t0 = time.monotonic()
    result = campaign(
        str(spec_path), "--out", str(out), "--scheduler", f"tcp://127.0.0.1:{_free_port()}"
    )
    elapsed = time.monotonic() - t0
    assert result.returncode == 2 and "no Dask scheduler answered" in result.stderr
    assert elapsed < 10.0 + 3.0  # the client's 8 s, plus interpreter start on a busy machine
    assert not out.exists()


def test_out_that_is_not_a_campaign_is_refused(tmp_path):
    spec_path = write_spec(tmp_path, runs=2)
    out = tmp_path / "out"
    out.mkdir()
    (out / "precious.txt").write_text("keep me")
    for extra in ([], ["--resume"]):
        result = campaign(str(spec_path), "--out", str(out), "--workers", "1", *extra)
        assert result.returncode == 2 and str(out) in result.stderr
    assert sorted(p.name for p in out.iterdir()) == ["precious.txt"]
    other = write_spec(tmp_path, runs=3, name="other.yaml")
    done = tmp_path / "done"
    assert campaign(str(spec_path), "--out", str(done), "--workers", "1").returncode == 0
    result = campaign(str(other), "--out", str(done), "--workers", "1", "--resume")
    assert result.returncode == 2 and "another SPEC" in result.stderr
    assert np.isfinite(table(done)["min_margin_deg"]).all()


@pytest.mark.ros
@needs_workspace
def test_a_reproducer_runs_as_is_through_the_ros_graph(tmp_path, ros_env):
    """The same reproducer file through ``attitude-run`` (real nodes, lockstep): the
    outcome and the dense body margin of the campaign row."""
    spec_path = write_spec(tmp_path, runs=2)
    out = tmp_path / "out"
    assert campaign(str(spec_path), "--out", str(out), "--workers", "1").returncode == 0
    row = table(out).sort_values("min_margin_deg").iloc[0]
    path = out / "reproducers" / f"run_{int(row['run'])}_{row['variant']}.yaml"
    run = subprocess.run(
        [str(BIN / "attitude-run"), str(path), "--out", str(tmp_path / "ros"), "--quiet"],
        env=ros_env(ros_environment()), capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    summary = json.loads((tmp_path / "ros" / "summary.json").read_text())
    assert summary["reached"] == (row["outcome"] == "reached")
    assert run.returncode == (0 if row["outcome"] == "reached" else 1), run.stderr
    # The graph records until the settle time after arrival, the campaign row covers the
    # whole scenario time: the same trajectory, compared over the recorded span.
    rec = run_from_bag(str(tmp_path / "ros" / "bag")).run
    offline = run_closed_loop(load_scenario(path))
    n = len(rec.t)
    np.testing.assert_allclose(rec.sigma_bn, offline.sigma_bn[:n], rtol=0, atol=1e-9)
    margin, _ = dense_min_margin_deg(
        rec.scenario.cone_geometry(), offline.t[:n], offline.sigma_bn[:n], offline.omega_b[:n]
    )
    assert summary["min_margin_deg"] == pytest.approx(margin, abs=1e-9)
    assert summary["min_margin_deg"] >= row["min_margin_deg"] - 1e-9
