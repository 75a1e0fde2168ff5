"""``attitude-campaign`` flying observation plans: the SPEC's ``plan`` dispersion (random
target sequences), refused with a bad key, and a small campaign whose every target is
judged on the true body."""

from __future__ import annotations

import os

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation
from test_campaign import ROOT, campaign, table

from attitude_core.models.cone_math import margins_deg_from_dcm
from attitude_tools.campaign.draw import base_parameters, draw_run
from attitude_tools.campaign.spec import SpecError, load_spec

SPEC = ROOT / "campaigns" / "plan_random_targets.yaml"


def plan_spec(tmp_path, runs=3, base="case1.yaml", **plan):
    doc = yaml.safe_load(SPEC.read_text())
    c = doc["campaign"]
    c["runs"] = runs
    c["base_scenario"] = os.path.relpath(ROOT / "scenarios" / base, tmp_path)
    c["dispersions"]["plan"].update(plan)
    path = tmp_path / "plan.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def test_drawn_plans_have_their_targets_clear_of_every_cone_and_are_reproducible():
    spec = load_spec(SPEC)
    assert spec.plan_targets == 3 and spec.runs >= 300
    base = base_parameters(spec)
    for i in range(40):
        draw = draw_run(spec, base, i)
        sc = draw.scenario
        assert [t.name for t in sc.plan] == ["target_0", "target_1", "target_2"]
        assert "desired_mrp" not in draw.flat
        assert all(5.0 <= t.dwell_s <= 30.0 for t in sc.plan)
        for t in sc.plan:
            c_bn = Rotation.from_mrp(np.array(t.desired_mrp)).as_matrix().T
            m = margins_deg_from_dcm(
                c_bn[None], sc.boresights_body, sc.half_angles_deg, sc.directions_inertial
            )
            assert float(np.min(m)) >= spec.min_end_margin_deg - 1e-9
        assert draw_run(spec, base, i).flat == draw.flat


def test_bad_plan_dispersions_are_refused_naming_the_key(tmp_path):
    with pytest.raises(SpecError, match="plan.targets'?: must be an integer in \\[1, 20\\]"):
        load_spec(plan_spec(tmp_path, targets=0))
    with pytest.raises(SpecError, match="plan'?: the base scenario .* wheels"):
        load_spec(plan_spec(tmp_path, base="case1_rw_pyramid.yaml"))


def test_a_small_plan_campaign_judges_every_target_on_the_body(tmp_path):
    out = tmp_path / "out"
    run = campaign(str(plan_spec(tmp_path, runs=3)), "--out", str(out), "--workers", "1")
    assert run.returncode == 0, run.stdout + run.stderr
    frame = table(out)
    assert (frame.min_margin_deg > 0.0).all()
    for k in range(3):
        assert (frame[f"target_{k}_min_margin_deg"].dropna() > 0.0).all()
    reached = frame[[f"target_{k}_outcome" for k in range(3)]].eq("reached").sum(axis=1)
    assert (reached == frame.goals_reached).all()
    assert ((frame.outcome == "reached") == (frame.goals_reached == 3)).all()
