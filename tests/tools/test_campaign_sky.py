"""``attitude-campaign`` on a real sky: the SPEC's ``sky`` dispersions (epoch, RAAN, true
anomaly), the base scenario's instruments and ephemeris objects kept, the end-margin rule
on a moving sky, the ``blocked`` outcome, the draws of the older SPECs unchanged (against
the drawing code before the sky dispersions), and a small LEO campaign judged against the
sky of each instant. The draws of older SPECs are compared with the drawing code of the
commit before the sensors dispersions (the last optional dispersion added)."""

from __future__ import annotations

import importlib
import json
import os
import re
import subprocess
from datetime import UTC, datetime

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation
from test_campaign import ROOT, campaign, table, write_spec

from attitude_core.config.scenario_loader import load_scenario, loads_scenario
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.record.metrics import dense_min_margin_deg
from attitude_core.record.summary import summarize
from attitude_tools.campaign.draw import (
    _base_parameters,
    _end_margin_deg,
    base_parameters,
    draw_run,
)
from attitude_tools.campaign.spec import SpecError, load_spec
from attitude_tools.campaign.task import FAILURES, OUTCOMES, outcome_of

pytestmark = pytest.mark.slow
LEO_SPEC = ROOT / "campaigns" / "leo_star_tracker.yaml"
LEO = ROOT / "scenarios" / "leo_star_tracker.yaml"
BLOCKED = ROOT / "scenarios" / "leo_goal_blocked.yaml"
# draw.py and spec.py before the sensors dispersions (the sky dispersions in; the history
# before them is not importable with this package layout)
BEFORE_SENSORS = "2e11272b4b398a1fc08e2aedda1ee91cd622a3a6"
EXCLUSION_DEG = {"sun": 40.0, "earth": 25.0, "moon": 15.0}  # leo_star_tracker's
ISO_Z = re.compile(r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ$")


def posix(text: str) -> float:
    return datetime.fromisoformat(text.replace("Z", "+00:00")).astimezone(UTC).timestamp()


def leo_spec(tmp_path, runs: int = 4, name: str = "leo.yaml", sky=None, **dispersions):
    """The shipped LEO SPEC, copied with ``runs``, ``dispersions.sky`` and others changed."""
    doc = yaml.safe_load(LEO_SPEC.read_text())
    c = doc["campaign"]
    c["runs"] = runs
    c["base_scenario"] = os.path.relpath(LEO, tmp_path)
    if sky is not None:
        c["dispersions"]["sky"] = sky
    c["dispersions"].update(dispersions)
    path = tmp_path / name
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


# --- the SPEC ---------------------------------------------------------------------------


def test_the_leo_spec_parses_and_a_yaml_timestamp_is_an_epoch(tmp_path):
    spec = load_spec(LEO_SPEC)
    assert (spec.runs, spec.seed, spec.sim_time_s, spec.planner_variants) == (
        1000, 11, 600.0, ("improved",),
    )  # fmt: skip
    assert spec.sky_epoch_s == (posix("2026-01-01T00:00:00Z"), posix("2027-01-01T00:00:00Z"))
    assert (spec.sky_raan_deg.lo, spec.sky_raan_deg.hi) == (0.0, 360.0)
    assert (spec.sky_true_anomaly_deg.lo, spec.sky_true_anomaly_deg.hi) == (0.0, 360.0)
    assert spec.drawn_groups == ()  # instruments and objects: the base's
    # Unquoted, YAML reads the ends as timestamps: the same range. Fractional ends: the
    # whole seconds within.
    path = leo_spec(tmp_path)
    quoted = path.read_text()
    assert "'2026-01-01T00:00:00Z'" in quoted
    path.write_text(quoted.replace("'2026-01-01T00:00:00Z'", "2026-01-01T00:00:00Z"))
    assert load_spec(path).sky_epoch_s == spec.sky_epoch_s
    frac = load_spec(leo_spec(tmp_path, sky={"epoch_utc": ["2026-01-01T00:00:00.5Z",
                                                          "2026-01-01T00:00:09.5Z"]}))  # fmt: skip
    lo = posix("2026-01-01T00:00:00Z")
    assert frac.sky_epoch_s == (lo + 1, lo + 9)


@pytest.mark.parametrize(
    "sky, extra, key, reason",
    [
        ({"epoch_utc": ["2027-01-01T00:00:00Z", "2026-01-01T00:00:00Z"]}, {}, "sky.epoch_utc",
         "is after"),
        ({"epoch_utc": ["2026-13-01T00:00:00Z", "2027-01-01T00:00:00Z"]}, {}, "sky.epoch_utc",
         "month must be in 1..12"),
        ({"epoch_utc": ["2026-01-01T00:00:00Z", "2200-01-01T00:00:00Z"]}, {}, "sky.epoch_utc",
         "out of range"),
        ({"epoch_utc": ["2026-01-01T00:00:00.2Z", "2026-01-01T00:00:00.7Z"]}, {},
         "sky.epoch_utc", "no whole second"),
        ({"epoch_utc": "2026-01-01T00:00:00Z"}, {}, "sky.epoch_utc", "expected [from, to]"),
        ({"raan_deg": [360.0, 0.0]}, {}, "sky.raan_deg", "above high"),
        ({"true_anomaly_deg": [0.0, "x"]}, {}, "sky.true_anomaly_deg", "expected a number"),
        ({"arg_perigee_deg": [0.0, 1.0]}, {}, "sky.arg_perigee_deg", "unknown key"),
        ({}, {}, "sky", "at least one"),
        # Drawn objects with the base's star tracker, which names the Sun, Earth and Moon.
        (None, {"bright_objects": {"count": [2, 3]}}, "bright_objects", "exclusion_deg"),
    ],
)  # fmt: skip
def test_a_bad_sky_dispersion_names_its_key(tmp_path, sky, extra, key, reason):
    with pytest.raises(SpecError) as info:
        load_spec(leo_spec(tmp_path, sky=sky, **extra))
    assert info.value.key == f"campaign.dispersions.{key}" and reason in info.value.reason


def test_a_sky_dispersion_needs_a_base_with_an_orbit_exit_2(tmp_path):
    path = write_spec(tmp_path, dispersions={"sky": {"raan_deg": [0.0, 360.0]}})
    with pytest.raises(SpecError) as info:
        load_spec(path)
    assert info.value.key == "campaign.dispersions.sky" and "no orbit" in info.value.reason
    out = tmp_path / "out"
    result = campaign(str(path), "--out", str(out), "--workers", "1")
    assert result.returncode == 2 and "campaign.dispersions.sky" in result.stderr
    assert "no orbit" in result.stderr and not out.exists()


# --- draws ------------------------------------------------------------------------------


def test_sky_draws_depend_on_the_run_stay_in_range_and_keep_the_base_groups():
    spec = load_spec(LEO_SPEC)
    base = base_parameters(spec)
    lo, hi = spec.sky_epoch_s
    groups = ("instruments", "bright_objects")
    kept = {k: v for k, v in base.items() if k.split(".")[0] in groups}
    draws = [draw_run(spec, base, i) for i in range(8)]
    for i, d in enumerate(draws):
        assert d.flat == draw_run(spec, base, i).flat  # (seed, i) only
        assert ISO_Z.match(d.flat["epoch_utc"]) and lo <= posix(d.flat["epoch_utc"]) <= hi
        assert 0.0 <= d.flat["orbit.raan_deg"] < 360.0
        assert 0.0 <= d.flat["orbit.true_anomaly_deg"] < 360.0
        for k in ("semi_major_axis_km", "eccentricity", "inclination_deg", "arg_perigee_deg"):
            assert d.flat[f"orbit.{k}"] == base[f"orbit.{k}"]
        # The star tracker and the Sun, Earth and Moon of the base, as they are.
        assert {k: v for k, v in d.flat.items() if k.split(".")[0] in groups} == kept
        sc = d.scenario
        assert sc.constraint_names == tuple(f"star_tracker/{o}" for o in EXCLUSION_DEG)
        np.testing.assert_array_equal(sc.sky.pair_exclusion_deg, list(EXCLUSION_DEG.values()))
        # The start clears every exclusion by 3 deg at t = 0; the goal all run long (checked
        # every 5 s; here every 1 s, the Earth turning at about 0.063 deg/s).
        t = np.arange(0.0, spec.sim_time_s + 0.5, 1.0)
        assert sc.sky.constraint_margins_deg(0.0, sc.initial_mrp).min() >= 3.0
        goal = np.broadcast_to(sc.desired_mrp, (len(t), 3))
        assert sc.sky.constraint_margins_deg(t, goal).min() >= 3.0 - 0.2
    for key in ("epoch_utc", "orbit.raan_deg", "orbit.true_anomaly_deg", "desired_mrp"):
        assert len({str(d.flat[key]) for d in draws}) == len(draws), key
    # Another epoch: the Sun is elsewhere at t = 0 (a year's draws span its whole circle).
    suns = np.array([d.scenario.sky.object_directions(0.0)[0][0] for d in draws])
    assert np.degrees(np.arccos(np.clip(suns @ suns.T, -1, 1))).max() > 90.0


def test_a_goal_the_sky_covers_during_the_run_is_too_close():
    """leo_goal_blocked's goal clears the Earth by 6 deg at t = 0, and the Earth covers
    it about 62 s later: the end-margin rule measures it over the run."""
    sc = load_scenario(BLOCKED)
    assert sc.sky.constraint_margins_deg(0.0, sc.desired_mrp).min() > 5.0
    flat = _base_parameters(str(BLOCKED))
    assert _end_margin_deg(flat, sc) < 0.0
    with pytest.raises(ValueError, match="loaded scenario"):
        _end_margin_deg(flat)  # a moving sky cannot be measured on the drawn values alone


# Where the core's names that commit imports live now (the core has been reorganised
# since): each name is imported from the first of these modules that defines it.
_TODAY = (
    "attitude_core.config.scenario",
    "attitude_core.config.scenario_loader",
    "attitude_core.config.scenario_flatten",
    "attitude_core.config.scenario_schema",
    "attitude_core.models.ephemeris",
    "attitude_core.models.constraints",
    "attitude_core.yamlio",
)


def _today_imports(source: str) -> str:
    """``source`` with each ``from attitude_core... import names`` (one name a line or
    all on one) pointed at the module that defines each name today."""

    def home(name: str) -> str:
        for module in _TODAY:
            if hasattr(importlib.import_module(module), name):
                return module
        raise AssertionError(f"{name}: in none of {_TODAY}")

    def rewrite(match: re.Match[str]) -> str:
        names = [n.strip() for n in match.group(1).strip("()").split(",") if n.strip()]
        return "\n".join(f"from {home(n.split(' as ')[0])} import {n}" for n in names)

    return re.sub(
        r"^from attitude_core\.[\w.]+ import (\([^)]*\)|[^\n]+)", rewrite, source, flags=re.M
    )


def test_older_specs_draw_what_they_drew_before_the_sensors_dispersions(tmp_path, monkeypatch):
    """Early runs of the SPECs shipped before the sensors dispersions, drawn by this code
    and by draw.py and spec.py of that commit: the same parameters and redraw counts."""
    pkg = tmp_path / "campaign_before_sensors"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    for name in ("spec", "draw"):
        where = f"{BEFORE_SENSORS}:src/attitude_tools/attitude_tools/campaign/{name}.py"
        shown = subprocess.run(["git", "-C", str(ROOT), "show", where], capture_output=True,
                               text=True)  # fmt: skip
        if shown.returncode != 0:
            pytest.skip(f"no git history to compare with ({shown.stderr.strip()})")
        (pkg / f"{name}.py").write_text(_today_imports(shown.stdout))
    monkeypatch.syspath_prepend(str(tmp_path))
    old_draw = importlib.import_module("campaign_before_sensors.draw")
    old_spec = importlib.import_module("campaign_before_sensors.spec")
    for spec_file in (
        "random_slews.yaml",
        "random_slews_keep_in.yaml",
        "leo_star_tracker.yaml",
        "leo_two_instruments.yaml",
    ):
        new, old = (
            load_spec(ROOT / "campaigns" / spec_file),
            old_spec.load_spec(ROOT / "campaigns" / spec_file),
        )
        new_base, old_base = base_parameters(new), old_draw.base_parameters(old)
        for i in range(21 if "leo" not in spec_file else 6):  # a moving sky draws slowly
            a, b = draw_run(new, new_base, i, "paper"), old_draw.draw_run(old, old_base, i, "paper")
            assert a.flat == b.flat, (spec_file, i)
            assert (a.refused_by_loader, a.too_close_to_a_cone) == (
                b.refused_by_loader, b.too_close_to_a_cone,
            )  # fmt: skip


# --- outcomes ---------------------------------------------------------------------------


def test_a_blocked_run_is_its_own_outcome():
    run = run_closed_loop(load_scenario(BLOCKED))
    summary = summarize(run).to_json()
    assert summary["planner_blocked"] and not summary["reached"]
    assert summary["min_margin_deg"] > 0.0  # kept clear of the Earth that covers the goal
    assert outcome_of(summary) == "blocked"
    assert "blocked" in OUTCOMES and "blocked" in FAILURES


# --- a campaign -------------------------------------------------------------------------


def test_a_small_leo_campaign_never_violates_the_moving_sky(tmp_path):
    spec_path = leo_spec(tmp_path, runs=4)
    out = tmp_path / "out"
    result = campaign(str(spec_path), "--out", str(out), "--workers", "1")
    assert result.returncode == 0, result.stdout + result.stderr
    rows = table(out)
    assert len(rows) == 4 and set(rows["outcome"]) <= set(OUTCOMES)
    summary = json.loads((out / "summary.json").read_text())["variants"]["improved"]
    assert summary["outcomes"]["violated"]["count"] == 0
    assert sum(o["count"] for o in summary["outcomes"].values()) == 4
    spec = load_spec(spec_path)
    base = base_parameters(spec)
    for _, row in rows.iterrows():
        # Judged here on the drawn scenario flown again, against the sky of each instant.
        sc = draw_run(spec, base, int(row["run"]), "improved").scenario
        assert not sc.sky.static and sc.sim_time_s == 600.0
        run = run_closed_loop(sc)
        dense, _ = dense_min_margin_deg(sc.sky, run.t, run.sigma_bn, run.omega_b)
        assert dense > 0.0 and dense == pytest.approx(row["min_margin_deg"], abs=1e-9)
        # At the samples, from the boresight and the bodies' directions and radii.
        boresight = Rotation.from_mrp(run.sigma_bn).apply([1.0, 0.0, 0.0])  # C_NB s
        dirs, radii = sc.sky.object_directions(run.t)
        angle = np.degrees(np.arccos(np.clip(np.einsum("ti,tji->tj", boresight, dirs), -1, 1)))
        sampled = angle - np.array(list(EXCLUSION_DEG.values())) - radii
        assert sampled.min() >= dense - 1e-9
        # The sky moved under the slew: the Earth by tens of degrees over the run.
        earth = dirs[:, 1]
        assert np.degrees(np.arccos(np.clip(earth[0] @ earth[-1], -1, 1))) > 10.0
        # Its reproducer is the same scenario: the drawn epoch and orbit, as text.
        repro = out / "reproducers" / f"run_{int(row['run'])}_improved.yaml"
        again = loads_scenario(repro.read_text())
        assert again.epoch_utc == sc.epoch_utc and again.orbit == sc.orbit
