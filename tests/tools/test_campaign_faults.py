"""``attitude-campaign`` behind a rehearsal link: the SPEC's ``link`` dispersions (a
seed per run, latency, jitter, losses, outages), refused when the slowest state would
always be stale, and a small campaign judged on the true body with its fault columns."""

from __future__ import annotations

import os

import pytest
import yaml
from test_campaign import ROOT, campaign, table

from attitude_tools.campaign.draw import base_parameters, draw_run
from attitude_tools.campaign.spec import SpecError, load_spec

SPEC = ROOT / "campaigns" / "faults.yaml"


def faults_spec(tmp_path, runs=4, **link):
    doc = yaml.safe_load(SPEC.read_text())
    c = doc["campaign"]
    c["runs"] = runs
    c["base_scenario"] = os.path.relpath(ROOT / "scenarios" / "case1.yaml", tmp_path)
    c["dispersions"]["link"].update(link)
    path = tmp_path / "faults.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def test_the_drawn_links_are_within_their_ranges_and_reproducible():
    spec = load_spec(SPEC)
    assert spec.link and spec.runs >= 500
    base = base_parameters(spec)
    seeds = set()
    for i in range(30):
        flat = draw_run(spec, base, i).flat
        seeds.add(flat["link.seed"])
        assert 0.0 <= flat["link.state_latency_s"] <= 0.15
        assert 0.0 <= flat["link.jitter_s"] <= 0.05
        assert 0.0 <= flat["link.drop_rate"] <= 0.1
        outages = flat["link.outages"]
        assert len(outages) in (2, 4)
        for start, duration in zip(outages[0::2], outages[1::2], strict=True):
            assert 0.0 <= start <= 90.0 and 0.0 < duration <= 3.0
        assert draw_run(spec, base, i).flat == flat
    assert len(seeds) == 30


def test_a_link_slower_than_the_watchdog_is_refused(tmp_path):
    with pytest.raises(SpecError, match="link.state_latency_s.*fdir.state_timeout_s"):
        load_spec(faults_spec(tmp_path, state_latency_s=[0.0, 0.25], jitter_s=[0.0, 0.1]))


def test_a_small_faults_campaign_reaches_every_goal_safely(tmp_path):
    out = tmp_path / "out"
    run = campaign(str(faults_spec(tmp_path, runs=6)), "--out", str(out), "--workers", "1")
    assert run.returncode == 0, run.stdout + run.stderr
    frame = table(out)
    assert (frame.outcome == "reached").all() and (frame.min_margin_deg > 0.0).all()
    assert (frame.n_faults >= 1).any() and (frame.stale_s > 0.0).any()  # outages flown
    assert not frame.safe_mode.any()
