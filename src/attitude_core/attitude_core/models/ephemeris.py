"""Sun, Moon and Earth as seen from the spacecraft: IAU SOFA ephemerides (pyerfa) and a
two-body orbit.

Inputs: the epoch (UTC, :func:`parse_epoch_utc`), the orbit's Keplerian elements at the
epoch (:class:`Orbit`), times in seconds after the epoch. Outputs, in the GCRS (ICRF
axes, Earth-centred): the spacecraft's position and velocity, the Sun's and the Moon's
geocentric positions, and each body's unit direction from the spacecraft and angular
radius ``asin(R / d)``.

* Time: UTC to TAI to TT with SOFA's leap-second table (``erfa.utctai``, ``erfa.taitt``).
  Past the table's end plus five years (SOFA's "dubious year", from 2029 with this
  pyerfa) UTC - TAI is held at its last value, silently: a leap second not yet announced
  shifts the Sun and the Moon by one second of their motion (under 0.001 deg), and the
  orbit not at all (it is propagated from the epoch).
* Sun: minus the Earth's heliocentric position of ``erfa.epv00`` (VSOP2000 fit, a few
  km over 1900-2100). Moon: ``erfa.moon98`` (Meeus' ELP2000-82 truncation, about 10
  arcsec). Both geometric: no light time, no aberration (about 20 arcsec for the Sun).
* Orbit: two-body Keplerian motion about the Earth (``MU_EARTH_KM3_S2``), no J2, drag or
  third body: over one slew (minutes) J2 moves a LEO node by a few millidegrees.
* ``earth`` is nadir, ``-r``; the Sun and the Moon are seen from the spacecraft (the
  Moon's parallax, up to about 1 deg in LEO, included), or from the Earth's centre
  without an orbit.
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import UTC, datetime

import erfa
import numpy as np
import numpy.typing as npt

__all__ = [
    "EARTH_RADIUS_KM",
    "SUN_RADIUS_KM",
    "MOON_RADIUS_KM",
    "MU_EARTH_KM3_S2",
    "BODIES",
    "Orbit",
    "parse_epoch_utc",
    "sun_moon_geocentric_km",
    "body_directions",
]

_Floats = npt.NDArray[np.float64]

EARTH_RADIUS_KM = 6378.137  # WGS 84 equatorial
SUN_RADIUS_KM = 695_700.0  # IAU 2015 nominal
MOON_RADIUS_KM = 1737.4
MU_EARTH_KM3_S2 = 398_600.4418
BODIES = ("sun", "moon", "earth")
_RADIUS_KM = {"sun": SUN_RADIUS_KM, "moon": MOON_RADIUS_KM, "earth": EARTH_RADIUS_KM}
_AU_KM = erfa.DAU / 1000.0
_DAY_S = 86_400.0
_ISO = re.compile(r"\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}:\d{2}(\.\d+)?(Z|[+-]\d{2}:\d{2})?\Z")


@contextmanager
def _future_utc() -> Iterator[None]:
    """SOFA's "dubious year" warning silenced (the module docstring says why)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*dubious year", category=erfa.ErfaWarning)
        yield


def parse_epoch_utc(text: str) -> tuple[float, float]:
    """Two-part UTC Julian date of an ISO 8601 date-time (``2026-03-20T14:46:00Z``; no
    zone is UTC, an offset is converted; a leap second ``23:59:60`` is accepted).
    Raises ``ValueError`` with the reason."""
    if not isinstance(text, str) or not _ISO.match(text.strip()):
        raise ValueError(f"not an ISO 8601 date-time (YYYY-MM-DDThh:mm:ss[.f][Z]): {text!r}")
    s = text.strip()
    leap = s[17:19] == "60"  # a leap second: parsed as :59, the second added back below
    try:
        when = datetime.fromisoformat(s[:17] + "59" + s[19:] if leap else s)
    except ValueError as exc:
        raise ValueError(f"not a valid date-time: {text!r} ({exc})") from None
    _check_year(when.year)  # before astimezone, which overflows near years 1 and 9999
    if when.tzinfo is not None:
        when = when.astimezone(UTC)
        _check_year(when.year)
    sec = when.second + when.microsecond * 1e-6 + (1.0 if leap else 0.0)
    try:
        with _future_utc():
            jd1, jd2 = erfa.dtf2d("UTC", when.year, when.month, when.day, when.hour,
                                  when.minute, sec)  # fmt: skip
    except (erfa.ErfaError, ValueError) as exc:
        raise ValueError(f"not a valid UTC time: {text!r} ({exc})") from None
    with _future_utc():
        second = int(erfa.d2dtf("UTC", 6, jd1, jd2)[3]["s"])
    if leap and second != 60:
        raise ValueError(f"not a valid UTC time: {text!r} (no leap second at that minute)")
    return float(jd1), float(jd2)


def _check_year(year: int) -> None:
    if not 1900 <= year <= 2100:
        raise ValueError(f"year {year} out of range 1900..2100 (the ephemerides' span)")


@dataclass(frozen=True)
class Orbit:
    """Two-body Keplerian elements at the epoch, GCRS (ICRF axes, Earth-centred)."""

    semi_major_axis_km: float
    eccentricity: float
    inclination_deg: float
    raan_deg: float
    arg_perigee_deg: float
    true_anomaly_deg: float

    def problem(self) -> str | None:
        """None for an orbit this model flies, else the reason."""
        a, e = self.semi_major_axis_km, self.eccentricity
        if not a > 0.0:
            return f"semi_major_axis_km must be > 0, got {a!r}"
        if not 0.0 <= e < 1.0:
            return f"eccentricity must be in [0, 1) (elliptic), got {e!r}"
        perigee = a * (1.0 - e) - EARTH_RADIUS_KM
        if perigee <= 0.0:
            return f"perigee altitude {perigee:.1f} km is below the Earth's surface"
        return None

    @property
    def period_s(self) -> float:
        return 2.0 * math.pi * math.sqrt(self.semi_major_axis_km**3 / MU_EARTH_KM3_S2)

    @property
    def specific_energy_km2_s2(self) -> float:
        return -MU_EARTH_KM3_S2 / (2.0 * self.semi_major_axis_km)

    def state_km(self, t_s: npt.ArrayLike) -> tuple[_Floats, _Floats]:
        """Position (km) and velocity (km/s), GCRS, ``t_s`` seconds after the epoch:
        ``(3,)`` each for a scalar time, ``(n, 3)`` for ``n`` times."""
        t = np.asarray(t_s, dtype=float)
        a, e = self.semi_major_axis_km, self.eccentricity
        n = math.sqrt(MU_EARTH_KM3_S2 / a**3)
        nu0 = math.radians(self.true_anomaly_deg)
        e_anom0 = 2.0 * math.atan2(math.sqrt(1.0 - e) * math.sin(nu0 / 2.0),
                                   math.sqrt(1.0 + e) * math.cos(nu0 / 2.0))  # fmt: skip
        m = np.remainder(e_anom0 - e * math.sin(e_anom0) + n * t, 2.0 * math.pi)
        ecc = m.copy() if e < 0.8 else np.full_like(m, math.pi)
        for _ in range(50):  # Newton on Kepler's equation E - e sin E = M
            delta = (ecc - e * np.sin(ecc) - m) / (1.0 - e * np.cos(ecc))
            ecc = ecc - delta
            if float(np.max(np.abs(delta), initial=0.0)) < 1e-14:
                break
        cos_e, sin_e = np.cos(ecc), np.sin(ecc)
        b = a * math.sqrt(1.0 - e * e)
        r = a * (1.0 - e * cos_e)
        p = np.stack([a * (cos_e - e), b * sin_e, np.zeros_like(ecc)], axis=-1)  # perifocal
        v = np.stack([-a * sin_e, b * cos_e, np.zeros_like(ecc)], axis=-1) * (n * a / r)[..., None]
        rot = self._perifocal_to_gcrs()
        return p @ rot.T, v @ rot.T

    def _perifocal_to_gcrs(self) -> _Floats:
        """``R3(-raan) R1(-i) R3(-argp)``: perifocal (perigee, in-plane, normal) to GCRS."""
        o, i, w = (math.radians(x) for x in (self.raan_deg, self.inclination_deg,
                                             self.arg_perigee_deg))  # fmt: skip
        co, so, ci, si, cw, sw = (math.cos(o), math.sin(o), math.cos(i), math.sin(i),
                                  math.cos(w), math.sin(w))  # fmt: skip
        return np.array(
            [
                [co * cw - so * sw * ci, -co * sw - so * cw * ci, so * si],
                [so * cw + co * sw * ci, -so * sw + co * cw * ci, -co * si],
                [sw * si, cw * si, ci],
            ]
        )


def _tt(epoch_utc: tuple[float, float], t_s: _Floats) -> tuple[_Floats, _Floats]:
    """TT two-part Julian dates of UTC ``epoch + t_s``."""
    utc1 = np.full(t_s.shape, epoch_utc[0])
    utc2 = epoch_utc[1] + t_s / _DAY_S
    with _future_utc():
        tai1, tai2 = erfa.utctai(utc1, utc2)
    tt1, tt2 = erfa.taitt(tai1, tai2)
    return np.asarray(tt1, dtype=float), np.asarray(tt2, dtype=float)


def sun_moon_geocentric_km(
    epoch_utc: tuple[float, float], t_s: npt.ArrayLike
) -> tuple[_Floats, _Floats]:
    """Geocentric positions (km, GCRS axes) of the Sun and the Moon at UTC ``epoch + t_s``:
    ``(3,)`` each for a scalar time, ``(n, 3)`` for ``n`` times. Geometric: no light time,
    no aberration."""
    t = np.asarray(t_s, dtype=float)
    tt1, tt2 = _tt(epoch_utc, t)
    pvh, _ = erfa.epv00(tt1, tt2)
    moon = erfa.moon98(tt1, tt2)
    sun = -np.asarray(pvh["p"], dtype=float) * _AU_KM
    return sun, np.asarray(moon["p"], dtype=float) * _AU_KM


def body_directions(
    body: str,
    epoch_utc: tuple[float, float] | None,
    orbit: Orbit | None,
    t_s: npt.ArrayLike,
) -> tuple[_Floats, _Floats]:
    """Unit direction from the spacecraft to ``body`` (GCRS axes) and its angular
    radius (rad), ``t_s`` seconds after the epoch: ``(3,)`` and a 0-d array for a scalar
    time, ``(n, 3)`` and ``(n,)`` for ``n`` times."""
    if body not in BODIES:
        raise ValueError(f"unknown body {body!r}: one of {', '.join(BODIES)}")
    t = np.asarray(t_s, dtype=float)
    r_sc = np.zeros(t.shape + (3,)) if orbit is None else orbit.state_km(t)[0]
    if body == "earth":
        if orbit is None:
            raise ValueError("body 'earth' needs an orbit")
        rel = -r_sc
    else:
        if epoch_utc is None:
            raise ValueError(f"body {body!r} needs an epoch (epoch_utc)")
        sun, moon = sun_moon_geocentric_km(epoch_utc, t)
        rel = (sun if body == "sun" else moon) - r_sc
    d = np.linalg.norm(rel, axis=-1)
    radius = np.arcsin(np.minimum(_RADIUS_KM[body] / d, 1.0))
    return rel / d[..., None], radius
