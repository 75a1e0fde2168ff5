"""Star tracker gaps (``sensors.star_tracker.max_rate_deg_s``, ``.outages``,
``.instrument``): no solution above the rate limit, in an outage or while blinded; the
MEKF flies the gyro through them; the guidance keeps the rate under the limit and the
buffer covers the 3-sigma at the end of the longest outage; judged on the true body."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from attitude_core.config.scenario import TRACKER_RATE_USE, ScenarioError
from attitude_core.config.scenario_loader import load_scenario, loads_scenario
from attitude_core.contract.faults import FaultKind
from attitude_core.fsw.fdir.tracker_watch import tracker_outages
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.sensor_spec import SensorSpec
from attitude_core.record.summary import summarize
from attitude_core.world.sensors import SensorSuite

ROOT = Path(__file__).resolve().parents[2]
GAPS = ROOT / "scenarios" / "case1_tracker_gaps.yaml"


def _spec(**kw) -> SensorSpec:
    base = dict(
        seed=1,
        star_tracker_noise_rad=(1e-5, 1e-5, 1e-5),
        star_tracker_rate_hz=10.0,
        gyro_noise_rad_s=1e-5,
        gyro_bias_rad_s=(0.0, 0.0, 0.0),
    )
    return SensorSpec(**{**base, **kw})


def test_no_solution_above_the_rate_limit_nor_while_blinded():
    suite = SensorSuite(_spec(star_tracker_max_rate_rad_s=0.01), 0.1)
    sigma = np.zeros(3)
    slow, fast = np.array([0.0, 0.009, 0.0]), np.array([0.0, 0.0, 0.011])
    assert suite.measure(0.0, sigma, slow).star_tracker_quat is not None
    assert suite.measure(0.1, sigma, fast).star_tracker_quat is None
    assert suite.measure(0.2, sigma, slow, blinded=True).star_tracker_quat is None
    assert suite.measure(0.3, sigma, slow).star_tracker_quat is not None


def test_gaps_become_star_tracker_outage_faults():
    times = [0.0, 0.25, 0.5, 3.0, 3.25]  # 4 Hz, then nothing from 0.75 s to 3.0 s
    (fault,) = tracker_outages(times, 4.0, 3.5)
    assert fault.kind is FaultKind.STAR_TRACKER_OUTAGE
    assert (fault.t_start_s, fault.t_end_s) == (0.75, 3.0)
    assert tracker_outages([0.0, 0.25], 4.0, 2.0)[0].t_end_s is None  # to the end


def test_the_keys_reach_the_spec_the_buffer_and_the_rate_cap():
    sc = load_scenario(GAPS)
    assert sc.sensors is not None
    assert sc.sensors.star_tracker_outages_s == ((60.0, 105.0),)
    assert sc.sensors.star_tracker_max_rate_rad_s == pytest.approx(np.radians(0.6))
    k = sc.knowledge
    assert (
        k.outage_3sigma_deg > k.attitude_3sigma_deg and k.buffer_3sigma_deg == k.outage_3sigma_deg
    )
    cap = TRACKER_RATE_USE * np.radians(0.6)
    assert sc.guidance_max_rate_rad_s == pytest.approx(min(cap, sc.actuators.max_rate_rad_s))


def test_a_tracker_named_that_is_no_instrument_is_refused():
    doc = yaml.safe_load(GAPS.read_text())
    doc["/**"]["ros__parameters"]["sensors"]["star_tracker"]["instrument"] = "camera"
    with pytest.raises(ScenarioError, match="sensors.star_tracker.instrument"):
        loads_scenario(yaml.safe_dump(doc), "gaps")


def test_slews_through_a_45_s_outage_at_a_0p6_deg_s_tracker_limit_are_safe_on_the_truth():
    """Two starts of the outage (before and during the slew): reached, the true body out
    of every cone, the body under the tracker's limit, the outage on the record."""
    doc = yaml.safe_load(GAPS.read_text())
    for start in (20.0, 150.0):
        doc["/**"]["ros__parameters"]["sensors"]["star_tracker"]["outages"] = [start, 45.0]
        sc = loads_scenario(yaml.safe_dump(doc), f"gaps at {start}")
        run = run_closed_loop(sc)
        s = summarize(run)
        assert s.reached and s.min_margin_deg > 0.0
        assert np.degrees(s.peak_rate_rad_s) < 0.6
        starts = [f.t_start_s for f in run.faults if f.kind is FaultKind.STAR_TRACKER_OUTAGE]
        assert any(abs(t - start) <= 0.26 for t in starts), starts
