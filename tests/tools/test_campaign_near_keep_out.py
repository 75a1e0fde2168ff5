"""``attitude-campaign`` with goals just outside a keep-out on the moving sky: the SPEC's
``goal_near_keep_out`` dispersion (the goal turned onto a drawn keep-out pair at a drawn
offset), refused with a bad key, and a small campaign in which no goal the sky leaves
clear is declared blocked, judged on the goal's own margin history."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
import yaml
from test_campaign import ROOT, campaign, table

from attitude_tools.campaign.draw import base_parameters, draw_run
from attitude_tools.campaign.spec import SpecError, load_spec

pytestmark = pytest.mark.slow
SPEC = ROOT / "campaigns" / "leo_near_keep_out.yaml"


def near_spec(tmp_path, runs=4, **dispersions):
    doc = yaml.safe_load(SPEC.read_text())
    c = doc["campaign"]
    c["runs"] = runs
    c["base_scenario"] = os.path.relpath(ROOT / "scenarios" / "leo_two_instruments.yaml", tmp_path)
    c["dispersions"].update(dispersions)
    path = tmp_path / "near.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def test_drawn_goals_sit_at_their_offset_outside_one_keep_out_and_are_reproducible():
    spec = load_spec(SPEC)
    assert spec.goal_near_keep_out_deg is not None and spec.runs >= 300
    lo, hi = spec.goal_near_keep_out_deg.lo, spec.goal_near_keep_out_deg.hi
    assert (lo, hi) == (0.3, 2.0)
    base = base_parameters(spec)
    nearest = set()
    for i in range(30):
        draw = draw_run(spec, base, i)
        sc = draw.scenario
        goal = sc.sky.constraint_margins_deg(0.0, np.asarray(sc.desired_mrp))
        k = int(np.argmin(goal))
        assert lo - 1e-6 <= goal[k] <= hi + 1e-6  # the offset, on the nearest pair
        nearest.add(sc.constraint_names[k])
        start = sc.sky.constraint_margins_deg(0.0, np.asarray(sc.initial_mrp))
        assert start.min() >= spec.min_end_margin_deg - 1e-9
        assert draw_run(spec, base, i).flat == draw.flat
    assert len(nearest) >= 3  # the pair is drawn, not always the same


@pytest.mark.parametrize(
    "extra, key, words",
    [
        ({"goal_near_keep_out": {}}, "goal_near_keep_out.offset_deg", "missing"),
        ({"goal_near_keep_out": {"offset_deg": [2.0, 1.0]}}, "offset_deg", "above high"),
        ({"goal_near_keep_out": {"offset_deg": [0.0, 1.0]}}, "offset_deg", ""),
        ({"plan": {"targets": 2, "dwell_s": [1.0, 2.0]}}, "goal_near_keep_out", "not with plan"),
    ],
)
def test_bad_near_keep_out_dispersions_are_refused_naming_the_key(tmp_path, extra, key, words):
    with pytest.raises(SpecError) as err:
        load_spec(near_spec(tmp_path, **extra))
    assert key in str(err.value.key) and words in str(err.value)


def test_a_small_campaign_blocks_only_goals_the_sky_covers(tmp_path):
    out = tmp_path / "out"
    path = near_spec(tmp_path, runs=6)
    result = campaign(str(path), "--out", str(out), "--workers", "1")
    assert result.returncode == 0, result.stdout + result.stderr
    rows = table(out)
    assert len(rows) == 6 and not (rows["outcome"] == "violated").any()
    assert (rows["min_margin_deg"] > 0.0).all()
    spec, summary = load_spec(path), json.loads((out / "summary.json").read_text())
    base = base_parameters(spec)
    for _, row in rows.iterrows():
        sc = draw_run(spec, base, int(row["run"])).scenario
        t = np.arange(0.0, sc.sim_time_s + 0.05, 0.1)
        history = sc.sky.constraint_margins_deg(t, np.broadcast_to(sc.desired_mrp, (len(t), 3)))
        least = float(history.min())
        assert row["goal_min_margin_deg"] == pytest.approx(least, abs=1e-9)
        if least > 0.0:  # never covered: flown
            assert row["outcome"] == "reached", row.to_dict()
        if row["outcome"] == "blocked":
            assert np.isfinite(row["t_goal_covered_s"]) and least <= 0.0
    blocked = summary["variants"]["improved"]["blocked_goal"]
    assert blocked["never_covered"] == 0
    assert blocked["covered"] == int((rows["outcome"] == "blocked").sum())
