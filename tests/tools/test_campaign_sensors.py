"""``attitude-campaign`` on estimates: the SPEC's ``sensors`` dispersions (a seed per run,
the star tracker's noise factor and rate, the gyro's noise and bias), refused without a
base that declares sensors, and a small campaign judged on the true body."""

from __future__ import annotations

import os

import numpy as np
import pytest
import yaml
from test_campaign import ROOT, campaign, table

from attitude_tools.campaign.draw import base_parameters, draw_run
from attitude_tools.campaign.spec import SpecError, load_spec

SPEC = ROOT / "campaigns" / "noisy_sensors.yaml"
BASE = ROOT / "scenarios" / "case1_wheels_sensors.yaml"


def noisy_spec(tmp_path, runs=4, base=BASE, **sensors):
    """The shipped SPEC, copied with ``runs``, the base and ``dispersions.sensors`` keys."""
    doc = yaml.safe_load(SPEC.read_text())
    c = doc["campaign"]
    c["runs"], c["base_scenario"] = runs, os.path.relpath(base, tmp_path)
    c["dispersions"]["sensors"].update(sensors)
    path = tmp_path / "noisy.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def test_the_shipped_spec_parses():
    spec = load_spec(SPEC)
    assert spec.sensors and spec.runs == 1000
    assert (spec.star_tracker_noise_scale.lo, spec.star_tracker_noise_scale.hi) == (0.5, 8.0)
    assert (spec.star_tracker_rate_hz.lo, spec.star_tracker_rate_hz.hi) == (1.0, 10.0)
    assert (spec.gyro_bias_rad_s.lo, spec.gyro_bias_rad_s.hi) == (0.0, 2.0e-3)


def test_the_drawn_sensors_are_within_their_ranges_and_differ_per_run():
    spec = load_spec(SPEC)
    base = base_parameters(spec)
    shape = np.array(base["sensors.star_tracker.noise_arcsec"])
    seeds = set()
    for i in range(25):
        flat = draw_run(spec, base, i).flat
        seeds.add(flat["sensors.seed"])
        noise = np.array(flat["sensors.star_tracker.noise_arcsec"])
        factor = noise / shape
        assert np.allclose(factor, factor[0])  # the base's shape, one factor
        assert 0.5 <= factor[0] <= 8.0
        assert 1.0 <= flat["sensors.star_tracker.rate_hz"] <= 10.0
        assert 1e-5 <= flat["sensors.gyro.noise_rad_s"] <= 5e-4
        assert all(abs(b) <= 2e-3 for b in flat["sensors.gyro.bias_rad_s"])
        # the rest of the declaration is the base's
        assert flat["sensors.gyro.bias_walk_rad_s2"] == base["sensors.gyro.bias_walk_rad_s2"]
        assert draw_run(spec, base, i).flat == flat  # reproducible
    assert len(seeds) == 25
    signs = np.sign([draw_run(spec, base, i).flat["sensors.gyro.bias_rad_s"] for i in range(25)])
    assert (signs > 0).any() and (signs < 0).any()


def test_sensors_need_a_base_that_declares_them(tmp_path):
    path = noisy_spec(tmp_path, base=ROOT / "scenarios" / "case1_wheels.yaml")
    with pytest.raises(SpecError, match="declares no sensors") as err:
        load_spec(path)
    assert err.value.key == "campaign.dispersions.sensors"


@pytest.mark.parametrize(
    "key, value, reason",
    [
        ("star_tracker_rate_hz", [0.0, 4.0], "must be > 0"),
        ("gyro_noise_rad_s", [2e-4, 1e-4], "above high"),
        ("gyro_bias_rad_s", 1e-3, "expected \\[low, high\\]"),
        ("bias_walk", [0.0, 1.0], "unknown"),
    ],
)
def test_a_bad_sensors_key_is_named(tmp_path, key, value, reason):
    path = noisy_spec(tmp_path, **{key: value})
    with pytest.raises(SpecError, match=reason) as err:
        load_spec(path)
    assert "campaign.dispersions.sensors" in (err.value.key or "")


@pytest.mark.slow
def test_a_small_noisy_campaign_reaches_on_the_truth(tmp_path):
    out = tmp_path / "camp"
    done = campaign(str(noisy_spec(tmp_path, runs=4)), "--out", str(out), "--workers", "1",
                    "--quiet")  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    rows = table(out)
    assert list(rows["outcome"]) == ["reached"] * 4
    assert (rows["min_margin_deg"] > 0.0).all()
    assert np.isfinite(rows["knowledge_3sigma_deg"]).all()
    assert (rows["estimation_error_deg_max"] > 0.0).all()
    assert (rows["final_attitude_error_deg"] < 0.5 + rows["knowledge_3sigma_deg"] * 2).all()
