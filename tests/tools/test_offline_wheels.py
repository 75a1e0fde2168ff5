"""``attitude-offline`` and ``attitude-run`` with a wheel array: the offline run writes
the wheels' columns and figures, read back and checked against the physics; the ROS run
refuses the scenario (for now) before anything is written or started."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from attitude_core.config.scenario_loader import load_scenario

ROOT = Path(__file__).resolve().parents[2]
PYRAMID = ROOT / "scenarios" / "case1_rw_pyramid.yaml"


def test_offline_writes_each_wheel_and_the_system_momentum(tmp_path):
    out = tmp_path / "run"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "attitude_tools.offline",
            str(PYRAMID),
            "--out",
            str(out),
            "--quiet",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    table = pd.read_csv(out / "timeseries.csv")
    array = load_scenario(PYRAMID).wheels
    speeds = table[[f"{w}_speed_rad_s" for w in array.names]].to_numpy()
    applied = table[[f"{w}_applied_nm" for w in array.names]].to_numpy()
    assert summary["reached"] and summary["min_margin_deg"] > 0.0
    # the figures are the table's (to its 10 significant digits)
    np.testing.assert_allclose(
        np.max(np.abs(speeds) / array.max_speed), summary["peak_wheel_speed_frac"], rtol=1e-8
    )
    assert summary["peak_wheel_speed_frac"] < 1.0
    assert np.all(np.abs(applied) <= array.max_torque * (1 + 1e-9))
    # the body torque column is what the wheels applied: -G u
    body = table[[f"torque_b_{i}_nm" for i in (1, 2, 3)]].to_numpy()
    np.testing.assert_allclose(body, -(applied @ array.axes.T), atol=1e-11)
    h = table[[f"h_system_n_{i}_nms" for i in (1, 2, 3)]].to_numpy()
    peak_wheel_h = np.max(np.abs(speeds) * array.spin_inertia)
    assert np.max(np.linalg.norm(h - h[0], axis=1)) < 0.01 * peak_wheel_h
