"""``attitude-campaign`` on a wheel array: the SPEC's ``wheels`` dispersions (biases,
one wheel failing in a share of runs), refused on a base without wheels or beyond a
wheel's speed limit, and a small campaign with a failed wheel in every run, judged on
the true body and wheels."""

from __future__ import annotations

import os

import numpy as np
import pytest
import yaml
from test_campaign import ROOT, campaign, table

from attitude_core.models.wheel_array import RPM
from attitude_tools.campaign.draw import base_parameters, draw_run
from attitude_tools.campaign.spec import SpecError, load_spec

SPEC = ROOT / "campaigns" / "rw_random_slews.yaml"


def wheels_spec(tmp_path, runs=4, base="case1_rw_pyramid.yaml", **wheels):
    doc = yaml.safe_load(SPEC.read_text())
    c = doc["campaign"]
    c["runs"] = runs
    c["base_scenario"] = os.path.relpath(ROOT / "scenarios" / base, tmp_path)
    c["dispersions"]["wheels"].update(wheels)
    path = tmp_path / "rw.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def test_the_drawn_biases_and_failures_are_within_their_ranges_and_reproducible():
    spec = load_spec(SPEC)
    assert spec.wheels and spec.runs >= 300
    base = base_parameters(spec)
    failed = 0
    for i in range(120):
        sc = draw_run(spec, base, i).scenario
        speeds = np.array([w.initial_speed_rad_s for w in sc.wheels.wheels]) / RPM
        assert np.all(np.abs(speeds) <= 2000.0 + 1e-9) and len(set(speeds)) == 4
        times = [w.fails_at_s for w in sc.wheels.wheels if w.fails_at_s is not None]
        assert len(times) <= 1 and all(0.0 <= t <= 60.0 for t in times)
        failed += len(times)
        assert draw_run(spec, base, i).flat == draw_run(spec, base, i).flat
    assert 15 <= failed <= 45  # a quarter of 120, loosely


def test_bad_wheel_dispersions_are_refused_naming_the_key(tmp_path):
    with pytest.raises(SpecError, match="wheels'?: the base scenario .* declares no wheels"):
        load_spec(wheels_spec(tmp_path, base="case1.yaml"))
    with pytest.raises(SpecError, match="initial_speed_rpm'?: must stay within"):
        load_spec(wheels_spec(tmp_path, initial_speed_rpm=[-7000.0, 0.0]))
    with pytest.raises(SpecError, match="failure.share'?: must be <= 1"):
        load_spec(wheels_spec(tmp_path, failure={"share": 1.5, "fails_at_s": [0.0, 1.0]}))


def test_a_small_campaign_with_a_failed_wheel_in_every_run_stays_safe(tmp_path):
    """Safe in every run; the three wheels left may be too slow to arrive within the
    run (the guidance re-budgets the slew on them, about every axis)."""
    out = tmp_path / "out"
    spec = wheels_spec(tmp_path, runs=4, failure={"share": 1.0, "fails_at_s": [5.0, 40.0]})
    run = campaign(str(spec), "--out", str(out), "--workers", "1")
    assert run.returncode == 0, run.stdout + run.stderr
    frame = table(out)
    assert (frame.failed_wheel != "").all()
    assert (frame.min_margin_deg > 0.0).all()
    assert (
        frame.outcome.isin(["reached", "not_reached"]).all() and (frame.outcome == "reached").any()
    )
    assert (frame.peak_wheel_speed_frac < 1.0).all()
    assert (frame.peak_wheel_torque_frac <= 1.0 + 1e-12).all()
