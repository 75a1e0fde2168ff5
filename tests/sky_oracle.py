"""An independent sky for judging runs on LEO scenarios, without attitude_core's sky: the
Sun and the Moon from astropy's built-in ephemeris (GCRS), the spacecraft by integrating
the two-body equations from the scenario's elements with SciPy, every avoided
(instrument, object) margin from the limb. Imported as ``from sky_oracle import ...``
(``tests/`` is on ``sys.path``, see ``support.py``)."""

from __future__ import annotations

import math
import warnings

import numpy as np
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

__all__ = ["independent_margins_deg"]

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


def independent_margins_deg(sc, t_s: np.ndarray, sigma_bn: np.ndarray) -> np.ndarray:
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
