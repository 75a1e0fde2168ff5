"""The real sky through the ROS node graph, judged on the bag by an independent sky.

``attitude-run`` flies the LEO scenarios (lockstep, real processes, real DDS); the test
then rebuilds the sky without our ephemeris module: the Sun and the Moon from astropy's
built-in ephemeris (GCRS), the spacecraft by integrating the two-body equations from the
scenario's elements with SciPy, and measures every (instrument, object) margin of the
recorded body attitude, between the samples too (SciPy's Slerp).
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation, Slerp
from support import attitude_run, needs_workspace

from attitude_core.contract.diagnostics import STATUS_NAME
from attitude_core.contract.status import PlannerStatus
from attitude_core.contract.topics import DIAGNOSTICS, PLANNER_STATUS
from attitude_tools.bag import read_bag
from attitude_tools.bag.run_record import run_from_bag, scenario_from_bag

ROOT = Path(__file__).resolve().parents[2]
pytestmark = [pytest.mark.ros, needs_workspace]
MU = 398_600.4418  # km^3/s^2
RADIUS_KM = {"sun": 695_700.0, "moon": 1737.4, "earth": 6378.137}


def _orbit_positions_km(orbit, t_s: np.ndarray) -> np.ndarray:
    """The spacecraft by numerical integration of r'' = -mu r / |r|^3 from the elements."""
    a, e = orbit.semi_major_axis_km, orbit.eccentricity
    i, raan, argp, nu = (
        math.radians(x)
        for x in (
            orbit.inclination_deg,
            orbit.raan_deg,
            orbit.arg_perigee_deg,
            orbit.true_anomaly_deg,
        )
    )
    p = a * (1.0 - e * e)
    r_pf = p / (1.0 + e * math.cos(nu)) * np.array([math.cos(nu), math.sin(nu), 0.0])
    v_pf = math.sqrt(MU / p) * np.array([-math.sin(nu), e + math.cos(nu), 0.0])
    rot = Rotation.from_euler("ZXZ", [raan, i, argp])  # perifocal -> GCRS
    y0 = np.concatenate([rot.apply(r_pf), rot.apply(v_pf)])

    def f(_t, y):
        r = y[:3]
        return np.concatenate([y[3:], -MU * r / np.linalg.norm(r) ** 3])

    sol = solve_ivp(f, (0.0, float(t_s[-1])), y0, t_eval=t_s, rtol=1e-11, atol=1e-6)
    return sol.y[:3].T


def _independent_margins_deg(sc, t_s: np.ndarray, sigma_bn: np.ndarray) -> np.ndarray:
    """Every avoided pair's margin from the limb, ``(n, pairs)``, without attitude_core's sky."""
    from astropy import units as u
    from astropy.coordinates import GCRS, get_body
    from astropy.time import Time
    from astropy.utils import iers

    iers.conf.auto_download = False
    times = Time(sc.epoch_utc.replace("Z", ""), scale="utc") + t_s * u.s
    r_sc = _orbit_positions_km(sc.orbit, t_s)
    where = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for body in ("sun", "moon"):
            gcrs = get_body(body, times, ephemeris="builtin").transform_to(GCRS(obstime=times))
            where[body] = gcrs.cartesian.xyz.to_value(u.km).T - r_sc
    where["earth"] = -r_sc
    bore = Rotation.from_mrp(sigma_bn)  # C_NB: body vectors in inertial axes
    out = []
    for inst in sc.instruments:
        s_n = bore.apply(np.array(inst.boresight_body))
        for obj in sc.bright_objects:
            if obj.name not in inst.avoids:
                continue
            rel = where[obj.ephemeris]
            d = np.linalg.norm(rel, axis=1)
            cos = np.einsum("ij,ij->i", s_n, rel / d[:, None])
            excl = dict(inst.exclusion_deg).get(obj.name, inst.half_angle_deg)
            radius = np.degrees(np.arcsin(RADIUS_KM[obj.ephemeris] / d))
            out.append(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))) - excl - radius)
    return np.array(out).T


def _dense(t: np.ndarray, sigma: np.ndarray, per: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """The recorded attitudes with ``per - 1`` Slerp points between samples."""
    fine = np.linspace(t[0], t[-1], (len(t) - 1) * per + 1)
    return fine, Slerp(t, Rotation.from_mrp(sigma))(fine).as_mrp()


def _planner_diagnostics(bag: Path) -> list[dict[str, str]]:
    return [
        {kv.key: kv.value for kv in st.values}
        for m in read_bag(str(bag), [DIAGNOSTICS])
        for st in m.msg.status
        if st.name == STATUS_NAME
    ]


@pytest.mark.slow
@pytest.mark.parametrize(("name", "exit_code"), [("leo_star_tracker", 0), ("leo_goal_blocked", 1)])
def test_leo_run_judged_on_the_bag_by_an_independent_sky(tmp_path, ros_domain, name, exit_code):
    out = tmp_path / name
    proc = attitude_run(ROOT / "scenarios" / f"{name}.yaml", out, ros_domain, timeout=300)
    assert proc.returncode == exit_code, proc.stdout + proc.stderr
    bag = out / "bag"
    sc = scenario_from_bag(str(bag))
    run = run_from_bag(str(bag)).run
    fine_t, fine_sigma = _dense(run.t, run.sigma_bn)
    margins = _independent_margins_deg(sc, fine_t, fine_sigma)
    summary = json.loads((out / "summary.json").read_text())
    # No violation on the true sky; our dense minimum agrees with the independent one
    # (astropy's positions are apparent: up to about 20 arcsec of aberration).
    assert margins.min() > 0.0
    assert summary["min_margin_deg"] == pytest.approx(margins.min(), abs=0.05)
    diags = _planner_diagnostics(bag)
    statuses = [m.msg.data for m in read_bag(str(bag), [PLANNER_STATUS])]
    if name == "leo_star_tracker":
        assert summary["reached"] and statuses[-1] == PlannerStatus.ARRIVED
        assert float(diags[-1]["goal_safe_until_s"]) == math.inf  # clear to the end
        return
    # The blocked goal: reported from the first state, before the Earth covers it.
    assert statuses == [PlannerStatus.BLOCKED]
    first = diags[0]
    assert first["status"] == "blocked" and first["blocked_by"] == "star_tracker/earth"
    start = float(first["blocked_from_s"])
    assert 55.0 <= start <= 70.0 and float(first["blocked_until_s"]) == math.inf
    assert "star_tracker/earth" in first["reason"]
    assert summary["planner_blocked"] and summary["blocked_by"] == "star_tracker/earth"
    goal = np.tile(sc.desired_mrp, (len(run.t), 1))
    assert _independent_margins_deg(sc, run.t, goal).min() < 0.0  # entering it would fail
