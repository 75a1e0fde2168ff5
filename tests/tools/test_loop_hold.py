"""The offline loop's hold on the goal (``closed_loop``, ``Guidance.hold_band``,
``LoopPlant.hold``): the record of every run is the same, to the bit, as the loop that
asks the guidance for a target at every step, on the paper's cases, every scenario file
and random campaign slews of both planner variants, the body leaving the band included."""

from __future__ import annotations

import glob
import os

import numpy as np
import pytest
import yaml

import attitude_core.loop.closed_loop as closed_loop
from attitude_core.assembly.guidance import guidance_from_scenario
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.fsw.guidance.guidance import Guidance
from attitude_tools.campaign.draw import base_parameters, draw_run
from attitude_tools.campaign.spec import load_spec

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
RECORD = ("sigma_bn", "omega_b", "torque_b", "sigma_t", "omega_t")
RECORD_1D = ("obstacle_distance_mrp", "planner_status")


class _CountingPlant:
    """The loop's plant, counting its holds and those the body ended early."""

    def __init__(self, plant, counts):
        self.plant, self.counts = plant, counts

    def step(self, *args):
        self.plant.step(*args)

    def hold(self, k, stop, *args):
        taken = self.plant.hold(k, stop, *args)
        self.counts["holds"] += 1
        self.counts["steps"] += taken - k
        self.counts["left"] += taken < stop
        return taken


UNLIMITED = {  # random slews without actuator limits: the body overshoots the goal
    "campaign": {
        "name": "unlimited",
        "runs": 30,
        "seed": 3,
        "base_scenario": f"{ROOT}/scenarios/case1.yaml",
        "sim_time_s": 150.0,
        "dispersions": {
            "attitudes": "uniform",
            "min_end_margin_deg": 3.0,
            "instruments": {"count": [1, 3], "half_angle_deg": [10.0, 35.0]},
            "bright_objects": {"count": [2, 6]},
        },
        "planner_variants": ["improved", "paper"],
    }
}


def _scenarios(tmp_path):
    paths = sorted(glob.glob(f"{ROOT}/scenarios/*.yaml"))
    out = [(os.path.basename(p)[:-5], load_scenario(p)) for p in paths]
    unlimited = tmp_path / "unlimited.yaml"
    unlimited.write_text(yaml.safe_dump(UNLIMITED))
    for spec, n in (
        (load_spec(f"{ROOT}/campaigns/random_slews.yaml"), 10),
        (load_spec(unlimited), 30),
    ):
        base = base_parameters(spec)
        for variant in ("improved", "paper"):
            out += [
                (f"{spec.name}_{variant}_{i}", draw_run(spec, base, i, variant).scenario)
                for i in range(n)
            ]
    return out


def test_the_hold_leaves_the_record_as_single_steps(monkeypatch, tmp_path):
    counts = {"holds": 0, "steps": 0, "left": 0}
    made = closed_loop.loop_plant
    monkeypatch.setattr(closed_loop, "loop_plant", lambda *a: _CountingPlant(made(*a), counts))
    runs = _scenarios(tmp_path)
    held = {name: closed_loop.run_closed_loop(sc) for name, sc in runs}
    monkeypatch.setattr(Guidance, "hold_band", lambda self: None)  # a target every step
    before = dict(counts)
    for name, sc in runs:
        single = closed_loop.run_closed_loop(sc)
        for field in RECORD + RECORD_1D:
            a, b = getattr(held[name], field), getattr(single, field)
            assert a.tobytes() == b.tobytes(), (name, field)
    assert counts == before  # no hold without the band
    # The hold took most steps of these runs, and the body left the band in some.
    total = sum(sc.n_steps + 1 for _, sc in runs)
    assert counts["steps"] > 0.3 * total, counts
    assert counts["left"] >= 5, counts


def test_the_hold_band_is_offered_only_on_arrival_and_time_runs_on():
    """No band while the target moves; on the goal, twice the arrival tolerances; a held
    state's time is the guidance's previous time (a state before it is refused)."""
    sc = load_scenario(f"{ROOT}/scenarios/case1.yaml")
    guidance = guidance_from_scenario(sc)
    target = guidance.update(0.0, sc.initial_mrp, np.zeros(3)).target
    assert target.status.name == "TRACKING" and guidance.hold_band() is None
    goal = sc.desired_mrp
    t = 0.0
    while target.status.name == "TRACKING":  # a body on the target, at its rate
        assert guidance.hold_band() is None
        t += sc.dt_s
        target = guidance.update(t, target.sigma_t, target.omega_t).target
    assert guidance.hold_band() == (2.0 * guidance.attitude_tol_deg, 2.0 * guidance.rate_tol_rad_s)
    guidance.held_to(t + 10.0)
    with pytest.raises(ValueError, match="before the previous"):
        guidance.update(t + 5.0, goal, np.zeros(3))
    with pytest.raises(ValueError, match="before the previous"):
        guidance.held_to(t)
    out = guidance.update(t + 10.1, goal, np.zeros(3))
    assert out.target.status.name == "ARRIVED" and out.goal_error_deg == 0.0
