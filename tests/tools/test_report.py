"""attitude-report on real recorded bags: figures, report.html and summary.json.

The module fixture records paper Case 1 twice through the ROS 2 node graph
(``attitude-run``, improved and paper-faithful planners, each on its own reserved
``ROS_DOMAIN_ID`` (conftest.py) with localhost-only discovery, both at once), then the tests run the
``attitude-report`` command on those run directories. The geometry helpers are tested
without ROS; keep-in cones and reaction wheels on bags written from offline runs are in
``test_report_bags.py``.
"""

import base64
import json
import os
import re
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from report_helpers import BIN, ROOT, assert_valid_figure, report, summary_cells

from attitude_core.models.constraints import ConeGeometry
from attitude_tools.report.figures import FIGURES
from attitude_tools.report.geometry import (
    Pair,
    boresight_inertial,
    break_wraps,
    mrp_surface,
    ra_dec_deg,
    small_circle,
)
from attitude_tools.report.html import format_value

HAVE_WORKSPACE = (ROOT / "ros2_ws" / "install" / "setup.bash").exists()
COMPARED_KEYS = (
    "reached",
    "t_reach_s",
    "min_margin_deg",
    "min_margin_deg_per_pair",
    "path_length_mrp",
    "peak_torque_nm",
    "final_rate_rad_s",
    "planner_step_us_median",
)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory, reserve_ros_domain):
    """Run directories of case1 (improved) and case1_paper, recorded through ROS."""
    if not HAVE_WORKSPACE:
        pytest.skip("colcon workspace not built (bash tools/bootstrap builds it)")
    base = tmp_path_factory.mktemp("report_runs")
    procs = {}
    with reserve_ros_domain() as d1, reserve_ros_domain() as d2:
        for name, domain in zip(("case1", "case1_paper"), (d1, d2), strict=True):
            env = domain.env()
            env.pop("AMENT_PREFIX_PATH", None)  # attitude-run finds the workspace itself
            procs[name] = subprocess.Popen(
                [
                    str(BIN / "attitude-run"),
                    str(ROOT / "scenarios" / f"{name}.yaml"),
                    "--out",
                    str(base / name),
                    "--quiet",
                ],
                env=env,
                stdout=subprocess.PIPE,
                stderr=subprocess.STDOUT,
                text=True,
            )
        for name, proc in procs.items():
            out, _ = proc.communicate(timeout=240)
            assert proc.returncode == 0, f"{name}: {out}"
    return {name: base / name for name in procs}


@pytest.fixture(scope="module")
def single(recorded):
    """``attitude-report DIR`` on the improved Case 1 run; (run dir, seconds taken)."""
    t0 = time.monotonic()
    proc = report(recorded["case1"])
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return recorded["case1"], time.monotonic() - t0


@pytest.fixture(scope="module")
def comparison(recorded, tmp_path_factory):
    out = tmp_path_factory.mktemp("report_cmp") / "paper_vs_improved"
    proc = report(recorded["case1_paper"], recorded["case1"], "--out", out)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out


def assert_self_contained(page: str, out: Path) -> None:
    assert "http://" not in page and "https://" not in page
    assert not re.search(r"""(src|href)\s*=\s*(?!["']?data:)""", page)
    assert "<link" not in page and "<script" not in page
    for name in FIGURES:
        data = base64.b64encode((out / name).read_bytes()).decode("ascii")
        assert f'src="data:image/png;base64,{data}"' in page, name


# --- single run -----------------------------------------------------------------------


@pytest.mark.ros
@pytest.mark.slow
def test_single_report_writes_every_figure_as_a_valid_png(single):
    run_dir, seconds = single
    out = run_dir / "report"
    assert sorted(p.name for p in out.glob("*.png")) == sorted(FIGURES)
    for name in FIGURES:
        assert_valid_figure(out / name)
    assert seconds < 60.0  # a few seconds on an idle machine; generous for loaded CI
    assert not list(run_dir.glob(".tmp-report-*"))


@pytest.mark.ros
@pytest.mark.slow
def test_single_report_html_is_self_contained_and_embeds_every_figure(single):
    out = single[0] / "report"
    page = (out / "report.html").read_text(encoding="utf-8")
    assert page.startswith("<!DOCTYPE html>")
    assert_self_contained(page, out)
    assert "case1 (improved)" in page


@pytest.mark.ros
@pytest.mark.slow
def test_single_report_numbers_equal_attitude_run_summary(single):
    run_dir = single[0]
    expected = json.loads((run_dir / "summary.json").read_text())
    doc = json.loads((run_dir / "report" / "summary.json").read_text())
    assert len(doc["runs"]) == 1
    shown = doc["runs"][0]["summary"]
    assert shown["reached"] is True and shown["t_reach_s"] is not None
    for key in COMPARED_KEYS:
        assert shown[key] == expected[key], key
    # Every number the report shows that attitude-run also wrote is the same number.
    for key, value in shown.items():
        if key in expected:
            assert value == expected[key], key
    assert shown["time_mode"] == expected["time_mode"] == "lockstep"
    assert shown["steps_recorded"] == expected["steps_recorded"]
    # ...and the HTML table shows exactly those numbers.
    cells = summary_cells((run_dir / "report" / "report.html").read_text(encoding="utf-8"))
    for key in (
        "reached",
        "t_reach_s",
        "min_margin_deg",
        "path_length_mrp",
        "peak_torque_nm",
        "final_rate_rad_s",
        "planner_step_us_median",
    ):
        assert cells[key] == [(shown[key], format_value(shown[key]))], key
    for pair, value in shown["min_margin_deg_per_pair"].items():
        assert cells[f"min_margin_deg_per_pair/{pair}"] == [(value, format_value(value))]
    assert set(cells) >= {k for k in shown if k != "min_margin_deg_per_pair"}


# --- comparison -------------------------------------------------------------------------


@pytest.mark.ros
@pytest.mark.slow
def test_comparison_overlays_both_runs_in_figures_and_table(recorded, comparison):
    for name in FIGURES:
        assert_valid_figure(comparison / name)
    page = (comparison / "report.html").read_text(encoding="utf-8")
    assert_self_contained(page, comparison)
    table = page[page.index('<table id="summary">') :]
    table = table[: table.index("</table>")]
    assert "<th>case1_paper (paper)</th>" in table and "<th>case1 (improved)</th>" in table
    doc = json.loads((comparison / "summary.json").read_text())
    assert [r["label"] for r in doc["runs"]] == ["case1_paper (paper)", "case1 (improved)"]
    cells = summary_cells(page)
    for k, name in enumerate(("case1_paper", "case1")):
        expected = json.loads((recorded[name] / "summary.json").read_text())
        shown = doc["runs"][k]["summary"]
        for key in COMPARED_KEYS:
            assert shown[key] == expected[key], (name, key)
        assert cells["t_reach_s"][k] == (expected["t_reach_s"], format_value(expected["t_reach_s"]))
    # The improved planner's point: lower peak torque than the paper-faithful FEPF.
    assert doc["runs"][1]["summary"]["peak_torque_nm"] < doc["runs"][0]["summary"]["peak_torque_nm"]


@pytest.mark.ros
@pytest.mark.slow
def test_comparison_labels_option_and_replacing_a_previous_report(recorded, tmp_path):
    out = tmp_path / "cmp"
    out.mkdir()
    (out / "report.html").write_text("previous report")
    (out / "stale.png").write_bytes(b"old")
    proc = report(
        recorded["case1_paper"],
        recorded["case1"],
        "--out",
        out,
        "--labels",
        "paper FEPF",
        "improved FEPF",
        "--dpi",
        "50",
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert not (out / "stale.png").exists()
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "<th>paper FEPF</th>" in page and "<th>improved FEPF</th>" in page
    assert sorted(os.listdir(tmp_path)) == ["cmp"]  # no temporary siblings left


# --- bad input ------------------------------------------------------------------------------


def test_missing_bag_exits_2_and_writes_nothing(tmp_path):
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    (run_dir / "summary.json").write_text("{}")
    proc = report(run_dir)
    assert proc.returncode == 2
    assert str(run_dir / "bag") in proc.stderr
    assert sorted(os.listdir(run_dir)) == ["summary.json"]
    proc = report(tmp_path / "absent", run_dir, "--out", tmp_path / "cmp")
    assert proc.returncode == 2 and str(tmp_path / "absent" / "bag") in proc.stderr
    assert sorted(os.listdir(tmp_path)) == ["run"]


@pytest.mark.ros
@pytest.mark.slow
def test_unreadable_bag_exits_2_and_writes_nothing(recorded, tmp_path):
    bag = tmp_path / "run" / "bag"
    bag.mkdir(parents=True)
    src = recorded["case1"] / "bag"
    (bag / "metadata.yaml").write_bytes((src / "metadata.yaml").read_bytes())
    (bag / "bag_0.mcap").write_bytes((src / "bag_0.mcap").read_bytes()[:4096])  # truncated
    proc = report(tmp_path / "run")
    assert proc.returncode == 2
    assert str(bag) in proc.stderr
    assert sorted(os.listdir(tmp_path / "run")) == ["bag"]


# --- geometry (no ROS) ----------------------------------------------------------------------


def test_small_circle_is_a_true_circle_on_the_sphere():
    c = np.array([0.958, 0.0, 0.287])
    pts = small_circle(c, 20.0)
    angles = np.degrees(np.arccos(np.clip(pts @ (c / np.linalg.norm(c)), -1.0, 1.0)))
    np.testing.assert_allclose(angles, 20.0, atol=1e-9)
    ra, dec = ra_dec_deg(pts)
    assert ra.min() >= 0.0 and ra.max() < 360.0
    ra_b, dec_b = break_wraps(ra, dec)
    assert np.isnan(ra_b).sum() >= 1  # this circle straddles RA = 0
    finite = ra_b[np.isfinite(ra_b)]
    jumps = np.abs(np.diff(ra_b))
    assert np.all(jumps[np.isfinite(jumps)] < 180.0) and len(finite) == len(ra)


def test_boresight_and_mrp_surface_agree_with_the_exact_margins():
    pair = Pair("st", "obj", (1.0, 0.0, 0.0), 20.0, (0.0, -0.981, -0.196))
    geometry = ConeGeometry(
        np.array([pair.boresight_body]), np.array([20.0]), np.array([pair.direction_inertial])
    )
    sigma = np.random.default_rng(1).uniform(-0.6, 0.6, (50, 3))
    b = boresight_inertial(sigma, pair.boresight_body)
    c = np.array(pair.direction_inertial) / np.linalg.norm(pair.direction_inertial)
    margin = np.degrees(np.arccos(np.clip(b @ c, -1.0, 1.0))) - 20.0
    np.testing.assert_allclose(margin, geometry.margins_deg(sigma)[:, 0, 0], atol=1e-9)
    triangles = mrp_surface(pair, n=40)
    assert triangles.shape[1:] == (3, 3) and len(triangles) > 100
    verts = triangles.reshape(-1, 3)
    assert np.all(np.linalg.norm(verts, axis=1) <= 1.0 + 1e-9)
    inner = verts[np.linalg.norm(verts, axis=1) < 0.95]
    # On the zero level set, to the grid's resolution (spacing 2/39 MRP ~ a few degrees).
    assert np.max(np.abs(geometry.margins_deg(inner)[:, 0, 0])) < 4.0


# --- keep-in cones (no ROS: a bag written here, read back as attitude-report reads it) -----
