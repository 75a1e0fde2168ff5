"""Scenario files: strict loading and validation of a ROS 2 parameters file.

A scenario file is usable as-is with ``--ros-args --params-file`` for every node::

    /**:
      ros__parameters:
        scenario_name: case1
        sim_time_s: 150.0
        ...
        instruments:
          names: [star_tracker]
          star_tracker: {boresight_body: [1.0, 0.0, 0.0], half_angle_deg: 20.0}

Nested mappings under ``ros__parameters`` are ROS dotted parameter names
(``instruments.star_tracker.half_angle_deg``). All quantities are SI and frame names
are part of the key. The validation is driven by the declarative tables ``_FIELDS``,
``_INSTRUMENT_FIELDS``, ``_OBJECT_FIELDS`` and ``_PLANNER_DEFAULTS`` below.

Decisions:

* Types are strict because ROS 2 parameters are strongly typed and the rcl YAML
  parser rejects arrays mixing ints and floats: a float field must be written as a
  YAML float (``10.0``, not ``10``); integers, strings and booleans likewise.
  NaN and infinity are refused.
* Unknown keys are refused, with a "did you mean ...?" suggestion: a typo in a flight
  scenario must not silently fall back to a default. The only exceptions are the
  parameters every rclpy node declares by itself (``use_sim_time``,
  ``start_type_description_service``, ``qos_overrides.*``), which are ignored so that
  a node can pass all of its parameters to :func:`parse_scenario`.
* An MRP with ``|sigma| > 1`` is accepted and replaced by its shadow set (the same
  attitude, :func:`attitude_core.mrp.to_principal`), so ``Scenario.initial_mrp`` and
  ``Scenario.desired_mrp`` always satisfy ``|sigma| <= 1``.
* Boresights and bright-object directions are normalised; a norm more than 5 % away
  from 1 is refused as an almost certain typo (the paper's ``c1 = [0, -0.981, -0.196]``
  has norm 1.0004 and loads).
* A start or goal attitude inside a keep-out cone (exact margin <= 0, eq. 5) is
  refused.
* ``planner.variant`` ("improved" or "paper") selects the defaults of the other
  ``planner.*`` keys; a key given explicitly overrides the variant's default.
"""

from __future__ import annotations

import difflib
import math
import re
from dataclasses import dataclass
from pathlib import Path
from collections.abc import Hashable
from typing import Any, Callable, NamedTuple

import numpy as np
import yaml

from .constraints import KeepOutGeometry
from .mrp import to_principal

__all__ = [
    "ScenarioError",
    "PlannerConfig",
    "ArrivalConfig",
    "Scenario",
    "load_scenario",
    "loads_scenario",
    "parse_scenario",
    "flatten_parameters",
    "ParameterSpec",
    "parameter_specs",
]

_NAME_RE = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")
_UNIT_TOLERANCE = 0.05
MAX_STEPS = 10_000_000  # about 1 GB of trajectory arrays
_ROS_BUILTIN_BOOLS = ("use_sim_time", "start_type_description_service")


class ScenarioError(ValueError):
    """Invalid scenario; ``key`` is the dotted parameter name (None for file-level errors)."""

    def __init__(self, source: str, key: str | None, reason: str) -> None:
        self.source, self.key, self.reason = str(source), key, reason
        where = f"{self.source}: {key}: " if key is not None else f"{self.source}: "
        super().__init__(where + reason)


@dataclass(frozen=True)
class PlannerConfig:
    variant: str
    direction_axis: str
    gamma_deg: float
    fis_attractive: str
    fis_repulsive: str
    max_attractive_rate_mrp_s: float
    max_repulsive_rate_mrp_s: float
    influence_distance_mrp: float
    safety_margin_deg: float
    max_accel_mrp_s2: float
    terminal_time_constant_s: float
    goal_tolerance_mrp: float
    stuck_timeout_s: float
    obstacle_samples: int


@dataclass(frozen=True)
class ArrivalConfig:
    attitude_tol_deg: float
    rate_tol_rad_s: float


@dataclass(frozen=True, eq=False)  # eq=False: ndarray fields have no truth value
class Scenario:
    name: str
    source: str
    sim_time_s: float
    dt_s: float
    inertia_kgm2: np.ndarray
    initial_mrp: np.ndarray
    desired_mrp: np.ndarray
    initial_rate_rad_s: np.ndarray
    instrument_names: tuple[str, ...]
    boresights_body: np.ndarray
    half_angles_deg: np.ndarray
    bright_object_names: tuple[str, ...]
    directions_inertial: np.ndarray
    kp_over_j: float
    kd_over_j: float
    planner: PlannerConfig
    arrival: ArrivalConfig

    @property
    def n_steps(self) -> int:
        return int(round(self.sim_time_s / self.dt_s))

    @property
    def kp(self) -> np.ndarray:
        """Proportional gain matrix ``Kp = kp_over_j * J`` (paper Table 1)."""
        return _frozen(self.kp_over_j * self.inertia_kgm2)

    @property
    def kd(self) -> np.ndarray:
        """Derivative gain matrix ``Kd = kd_over_j * J`` (paper Table 1)."""
        return _frozen(self.kd_over_j * self.inertia_kgm2)

    def keep_out(self, inflation_deg: float = 0.0, samples: int | None = None) -> KeepOutGeometry:
        """Keep-out geometry of this scenario (``samples`` defaults to planner.obstacle_samples)."""
        return KeepOutGeometry(
            self.boresights_body, self.half_angles_deg, self.directions_inertial,
            inflation_deg=inflation_deg,
            samples=self.planner.obstacle_samples if samples is None else samples,
        )


# --- checks: each returns None when the (converted) value is fine, else a reason -------

Check = Callable[[Any], "str | None"]


def _between(lo: float, hi: float, lo_open: bool, hi_open: bool = True) -> Check:
    text = f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"

    def check(x):
        ok_lo = x > lo if lo_open else x >= lo
        ok_hi = x < hi if hi_open else x <= hi
        return None if ok_lo and ok_hi else f"must be in {text}, got {x!r}"
    return check


def _gt(lo: float) -> Check:
    return lambda x: None if x > lo else f"must be > {lo:g}, got {x!r}"


def _ge(lo: float) -> Check:
    return lambda x: None if x >= lo else f"must be >= {lo:g}, got {x!r}"


def _one_of(*options: str) -> Check:
    return lambda x: None if x in options else f"must be one of {list(options)}, got {x!r}"


def _rigid_body(j: np.ndarray) -> str | None:
    scale = float(np.abs(j).max())
    if float(np.abs(j - j.T).max()) > 1e-9 * scale:
        return f"must be symmetric, got {j.tolist()}"
    moments = np.linalg.eigvalsh(0.5 * (j + j.T))
    if moments[0] <= 0.0:
        return f"must be positive definite, principal moments {moments.tolist()}"
    if moments[2] > moments[0] + moments[1] + 1e-9 * moments[2]:
        return (f"principal moments {moments.tolist()} violate the triangle inequality "
                "(J3 <= J1 + J2); not a physical rigid body")
    return None


# --- the declarative table -------------------------------------------------------------

class _ByVariant(NamedTuple):
    improved: Any
    paper: Any


class _Field(NamedTuple):
    key: str
    kind: str             # a key of _CONVERTERS
    check: Check | None = None
    default: Any = None   # None: required; _ByVariant: depends on planner.variant


_FIELDS = (
    _Field("scenario_name", "name"),
    _Field("sim_time_s", "float", _gt(0.0)),
    _Field("dt_s", "float", _gt(0.0)),
    _Field("inertia_kgm2", "matrix3", _rigid_body),
    _Field("initial_mrp", "mrp"),
    _Field("desired_mrp", "mrp"),
    _Field("initial_rate_rad_s", "vec3"),
    _Field("controller.kp_over_j", "float", _gt(0.0), 5.5),
    _Field("controller.kd_over_j", "float", _gt(0.0), 3.1),
    _Field("planner.variant", "str", _one_of("improved", "paper"), "improved"),
    _Field("planner.direction_axis", "str", _one_of("goal_plane", "paper"),
           _ByVariant("goal_plane", "paper")),
    _Field("planner.gamma_deg", "float", _between(0.0, 180.0, False), _ByVariant(60.0, 10.0)),
    _Field("planner.fis_attractive", "data_file", None,
           _ByVariant("fis_attractive.yaml", "fis_attractive_paper.yaml")),
    _Field("planner.fis_repulsive", "data_file", None,
           _ByVariant("fis_repulsive.yaml", "fis_repulsive_paper.yaml")),
    _Field("planner.max_attractive_rate_mrp_s", "float", _gt(0.0), _ByVariant(0.03, 0.03)),
    _Field("planner.max_repulsive_rate_mrp_s", "float", _ge(0.0), _ByVariant(0.03, 0.03)),
    _Field("planner.influence_distance_mrp", "float", _gt(0.0), _ByVariant(0.3, 0.3)),
    _Field("planner.safety_margin_deg", "float", _between(0.0, 45.0, False),
           _ByVariant(2.0, 2.0)),
    _Field("planner.max_accel_mrp_s2", "float", _ge(0.0), _ByVariant(0.01, 0.0)),
    _Field("planner.terminal_time_constant_s", "float", _ge(0.0), _ByVariant(2.0, 0.0)),
    _Field("planner.goal_tolerance_mrp", "float", _gt(0.0), _ByVariant(1.0e-4, 1.0e-4)),
    _Field("planner.stuck_timeout_s", "float", _gt(0.0), _ByVariant(10.0, 10.0)),
    _Field("planner.obstacle_samples", "int", _between(16, 100_000, False, False),
           _ByVariant(180, 180)),
    _Field("arrival.attitude_tol_deg", "float", _gt(0.0), 0.5),
    _Field("arrival.rate_tol_rad_s", "float", _gt(0.0), 1.0e-3),
)
# Per listed name, under instruments.<name>. and bright_objects.<name>.
_INSTRUMENT_FIELDS = (
    _Field("boresight_body", "unit3"),
    _Field("half_angle_deg", "float", _between(0.0, 90.0, True)),
)
_OBJECT_FIELDS = (_Field("direction_inertial", "unit3"),)
_GROUPS = (("instruments", _INSTRUMENT_FIELDS), ("bright_objects", _OBJECT_FIELDS))


# --- the same table as ROS 2 parameter declarations ---------------------------------------

class ParameterSpec(NamedTuple):
    """One scenario key as a ROS 2 parameter: what a node declares up front."""

    name: str                       # dotted parameter name
    ros_type: str                   # double, double_array, integer, string, string_array
    required: bool                  # False: the loader supplies a default
    description: str
    value_range: tuple[float, float] | None  # closed bounds for scalars (exact rule in text)


_ROS_TYPES = {"str": "string", "name": "string", "names": "string_array", "int": "integer",
              "float": "double", "vec3": "double_array", "unit3": "double_array",
              "mrp": "double_array", "matrix3": "double_array", "data_file": "string"}

_DESCRIPTIONS = {
    "scenario_name": "name used in outputs ([A-Za-z][A-Za-z0-9_]*)",
    "sim_time_s": "simulated time, s (> 0, >= dt_s)",
    "dt_s": "guidance, control and integration step, s (> 0)",
    "inertia_kgm2": "inertia J about the body axes, kg m^2, row-major 3x3, SPD (eq. 4)",
    "initial_mrp": "initial attitude sigma_BN(0), MRP (|sigma| > 1 taken as its shadow set)",
    "desired_mrp": "desired attitude sigma_d = sigma_DN, MRP",
    "initial_rate_rad_s": "initial body rate omega_BN(0), body axes, rad/s",
    "controller.kp_over_j": "proportional gain Kp = kp_over_j J, 1/s^2 (> 0; paper 5.5)",
    "controller.kd_over_j": "derivative gain Kd = kd_over_j J, 1/s (> 0; paper 3.1)",
    "planner.variant": "FEPF variant whose defaults apply: improved or paper",
    "planner.direction_axis": "repulsive rotation axis: goal_plane or paper (eq. 9)",
    "planner.gamma_deg": "repulsive rotation angle gamma, deg ([0, 180))",
    "planner.fis_attractive": "attractive FIS data (packaged name or path)",
    "planner.fis_repulsive": "repulsive FIS data (packaged name or path)",
    "planner.max_attractive_rate_mrp_s": "attractive speed scale, MRP/s (> 0)",
    "planner.max_repulsive_rate_mrp_s": "repulsive speed scale, MRP/s (>= 0)",
    "planner.influence_distance_mrp": "obstacle influence distance, MRP (> 0)",
    "planner.safety_margin_deg": "buffer added to every cone for planning, deg ([0, 45))",
    "planner.max_accel_mrp_s2": "target acceleration bound, MRP/s^2 (>= 0; 0: none)",
    "planner.terminal_time_constant_s": "terminal rate time constant, s (>= 0; 0: none)",
    "planner.goal_tolerance_mrp": "goal capture distance, MRP (> 0)",
    "planner.stuck_timeout_s": "no-progress time before status stuck, s (> 0)",
    "planner.obstacle_samples": "rim samples per keep-out cone ([16, 100000])",
    "arrival.attitude_tol_deg": "arrival: attitude error bound, deg (> 0)",
    "arrival.rate_tol_rad_s": "arrival: body rate bound, rad/s (> 0)",
    "boresight_body": "instrument boresight s_i, body axes, unit vector",
    "half_angle_deg": "keep-out half-angle beta_i, deg ((0, 90))",
    "direction_inertial": "bright-object direction c_j, inertial axes, unit vector",
}
_RANGES = {"planner.gamma_deg": (0.0, 180.0), "planner.safety_margin_deg": (0.0, 45.0),
           "half_angle_deg": (0.0, 90.0)}


def parameter_specs(instrument_names=(), bright_object_names=()) -> list[ParameterSpec]:
    """Every scenario key as a :class:`ParameterSpec`, per-name keys for the given names.

    The name lists themselves (``instruments.names``, ``bright_objects.names``) come
    first; a node declares them, reads them, then declares the rest.
    """
    def spec(field: _Field, name: str, short: str) -> ParameterSpec:
        return ParameterSpec(name, _ROS_TYPES[field.kind], field.default is None,
                             _DESCRIPTIONS[short], _RANGES.get(short))

    specs = [ParameterSpec(f"{g}.names", "string_array", True, f"names of the {g}", None)
             for g, _ in _GROUPS]
    specs += [spec(f, f.key, f.key) for f in _FIELDS]
    for (group, fields), names in zip(_GROUPS, (instrument_names, bright_object_names)):
        specs += [spec(f, f"{group}.{n}.{f.key}", f.key) for n in names for f in fields]
    return specs


# --- converters: YAML value -> typed value, raising _Bad(reason) -------------------------

class _Bad(Exception):
    pass


def _type_name(v: Any) -> str:
    names = {bool: "boolean", int: "integer", float: "float", str: "string",
             list: "list", dict: "mapping", type(None): "null"}
    return names.get(type(v), type(v).__name__)


def _float(v: Any, what: str = "") -> float:
    if type(v) is not float:
        hint = ""
        if type(v) is int:
            try:
                hint = (f"; write it as a YAML float, e.g. {float(v)!r} "
                        "(ROS 2 parameters are strongly typed)")
            except OverflowError:  # beyond the range of a double: no float to suggest
                pass
        elif isinstance(v, str):
            try:
                hint = f"; write it as a YAML float, e.g. {float(v)!r}"
            except ValueError:
                pass
        raise _Bad(f"{what}expected float, got {_type_name(v)} {v!r}{hint}")
    if not math.isfinite(v):
        raise _Bad(f"{what}must be finite, got {v!r}")
    return v


def _str(v: Any) -> str:
    if not isinstance(v, str):
        raise _Bad(f"expected string, got {_type_name(v)} {v!r}")
    return v


def _name(v: Any) -> str:
    if not _NAME_RE.match(_str(v)):
        raise _Bad(f"invalid name {v!r}: must match [A-Za-z][A-Za-z0-9_]*")
    return v


def _int(v: Any) -> int:
    if type(v) is not int:
        raise _Bad(f"expected integer, got {_type_name(v)} {v!r}")
    return v


def _floats(v: Any, n: int) -> np.ndarray:
    if not isinstance(v, list):
        raise _Bad(f"expected a list of {n} floats, got {_type_name(v)} {v!r}")
    if len(v) != n:
        raise _Bad(f"expected a list of {n} floats, got {len(v)} elements")
    return np.array([_float(x, f"element {k}: ") for k, x in enumerate(v)])


def _unit3(v: Any) -> np.ndarray:
    u = _floats(v, 3)
    norm = float(np.linalg.norm(u))
    if norm == 0.0:
        raise _Bad("must be a non-zero vector")
    if abs(norm - 1.0) > _UNIT_TOLERANCE:
        raise _Bad(f"must be a unit vector (norm within {_UNIT_TOLERANCE:.0%} of 1), "
                   f"got norm {norm:.4g}")
    return u / norm


def _names(v: Any) -> tuple[str, ...]:
    if not isinstance(v, list) or not v:
        raise _Bad(f"expected a non-empty list of names, got {_type_name(v)} {v!r}")
    names = tuple(_name(x) for x in v)
    dup = sorted({x for x in names if names.count(x) > 1})
    if dup:
        raise _Bad(f"duplicate names {dup}")
    return names


def _data_file(v: Any, base_dir: Path) -> str:
    """Packaged data name, or a path (contains '/') relative to the scenario's directory."""
    if not _str(v):
        raise _Bad("must be a non-empty string")
    if "/" not in v:
        from .fuzzy import packaged_fis_files
        packaged = packaged_fis_files()
        if v not in packaged:
            raise _Bad(f"{v!r} is not a packaged FIS file {packaged}; give your own file as a "
                       "path containing '/' (relative to the scenario)")
        return v
    path = base_dir / v
    if not path.is_file():
        raise _Bad(f"file {str(path)!r} does not exist")
    return str(path.resolve())


_CONVERTERS: dict[str, Callable[[Any, Path], Any]] = {
    "str": lambda v, _: _str(v),
    "name": lambda v, _: _name(v),
    "names": lambda v, _: _names(v),
    "int": lambda v, _: _int(v),
    "float": lambda v, _: _float(v),
    "vec3": lambda v, _: _floats(v, 3),
    "unit3": lambda v, _: _unit3(v),
    "mrp": lambda v, _: to_principal(_floats(v, 3)),
    "matrix3": lambda v, _: _floats(v, 9).reshape(3, 3),
    "data_file": _data_file,
}


# --- parsing -----------------------------------------------------------------------------

def flatten_parameters(params: dict, source: str = "<dict>") -> dict[str, object]:
    """Nested parameter mapping -> ROS dotted names (``{"a": {"b": 1}} -> {"a.b": 1}``)."""
    flat: dict[str, object] = {}

    def walk(node: dict, prefix: str) -> None:
        for k, v in node.items():
            if not isinstance(k, str) or not k:
                raise ScenarioError(source, prefix.rstrip(".") or None,
                                    f"parameter names must be non-empty strings, got {k!r}")
            key = prefix + k
            if isinstance(v, dict):
                walk(v, key + ".")
            elif key in flat:
                raise ScenarioError(source, key, "given twice")
            else:
                flat[key] = v

    walk(params, "")
    return flat


def _is_ros_builtin(key: str) -> bool:
    return key in _ROS_BUILTIN_BOOLS or key.startswith("qos_overrides.")


def parse_scenario(params: dict, source: str = "<dict>", base_dir=None) -> Scenario:
    """Validate a ``ros__parameters`` mapping (nested or dotted) and build a :class:`Scenario`.

    Relative data-file paths are resolved against ``base_dir`` (default: the directory
    of ``source``).
    """
    if not isinstance(params, dict):
        raise ScenarioError(source, None,
                            f"ros__parameters must be a mapping, got {_type_name(params)}")
    flat = flatten_parameters(params, source)
    base_dir = Path(source).parent if base_dir is None else Path(base_dir)
    values: dict[str, Any] = {}

    def convert(field: _Field, key: str, default: Any = None) -> Any:
        if key not in flat:
            if default is None:
                raise ScenarioError(source, key, "missing required key")
            return default
        try:
            value = _CONVERTERS[field.kind](flat[key], base_dir)
            reason = field.check(value) if field.check else None
        except _Bad as exc:
            reason = str(exc)
        if reason:
            raise ScenarioError(source, key, reason)
        return value

    # 1. The name lists define the set of known keys; refuse unknown keys next.
    groups = {g: convert(_Field(f"{g}.names", "names"), f"{g}.names") for g, _ in _GROUPS}
    known = {f.key for f in _FIELDS} | {f"{g}.names" for g in groups}
    known |= {f"{g}.{n}.{f.key}" for g, fields in _GROUPS for n in groups[g] for f in fields}
    for key in flat:
        if key in known:
            continue
        if _is_ros_builtin(key):
            if key in _ROS_BUILTIN_BOOLS and not isinstance(flat[key], bool):
                raise ScenarioError(source, key, f"expected boolean, got {_type_name(flat[key])}")
            continue
        group, _, rest = key.partition(".")
        if group in groups and "." in rest and rest.split(".")[0] not in groups[group]:
            hint = f"; {rest.split('.')[0]!r} is not listed in {group}.names"
        else:
            close = difflib.get_close_matches(key, sorted(known), n=1, cutoff=0.6)
            hint = f"; did you mean {close[0]!r}?" if close else ""
        raise ScenarioError(source, key, "unknown key" + hint)

    # 2. Top-level and planner fields, in table order (planner.variant precedes its defaults).
    for field in _FIELDS:
        default = field.default
        if isinstance(default, _ByVariant):
            default = getattr(default, values["planner.variant"])
        values[field.key] = convert(field, field.key, default)
    if values["sim_time_s"] < values["dt_s"]:
        raise ScenarioError(source, "sim_time_s",
                            f"must be >= dt_s ({values['dt_s']!r}), got {values['sim_time_s']!r}")
    steps = values["sim_time_s"] / values["dt_s"]
    if steps > MAX_STEPS:
        raise ScenarioError(source, "sim_time_s", (
            f"too many steps: sim_time_s / dt_s = {steps:.3g}, at most {MAX_STEPS:,} "
            "(a run keeps every step in memory)"))

    # 3. Per-instrument and per-object fields.
    per_name = {g: [{f.key: convert(f, f"{g}.{n}.{f.key}") for f in fields} for n in groups[g]]
                for g, fields in _GROUPS}
    planner = PlannerConfig(**{k.split(".", 1)[1]: v for k, v in values.items()
                               if k.startswith("planner.")})
    scenario = Scenario(
        name=values["scenario_name"],
        source=str(source),
        sim_time_s=values["sim_time_s"],
        dt_s=values["dt_s"],
        inertia_kgm2=_frozen(values["inertia_kgm2"]),
        initial_mrp=_frozen(values["initial_mrp"]),
        desired_mrp=_frozen(values["desired_mrp"]),
        initial_rate_rad_s=_frozen(values["initial_rate_rad_s"]),
        instrument_names=groups["instruments"],
        boresights_body=_frozen(np.array([d["boresight_body"] for d in per_name["instruments"]])),
        half_angles_deg=_frozen(np.array([d["half_angle_deg"] for d in per_name["instruments"]])),
        bright_object_names=groups["bright_objects"],
        directions_inertial=_frozen(
            np.array([d["direction_inertial"] for d in per_name["bright_objects"]])),
        kp_over_j=values["controller.kp_over_j"],
        kd_over_j=values["controller.kd_over_j"],
        planner=planner,
        arrival=ArrivalConfig(values["arrival.attitude_tol_deg"], values["arrival.rate_tol_rad_s"]),
    )

    # 4. Start and goal must satisfy the keep-out constraints (eq. 5).
    geometry = scenario.keep_out(samples=16)  # exact margins do not depend on samples
    for key in ("initial_mrp", "desired_mrp"):
        margins = geometry.margins_deg(getattr(scenario, key))
        i, j = np.unravel_index(int(np.argmin(margins)), margins.shape)
        if margins[i, j] <= 0.0:
            raise ScenarioError(source, key, (
                f"attitude is inside the keep-out cone of instrument "
                f"{scenario.instrument_names[i]!r} and bright object "
                f"{scenario.bright_object_names[j]!r} (margin {margins[i, j]:.1f} deg)"))
    return scenario


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file (a ROS 2 parameters file, see module docstring)."""
    source = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(source, None, f"cannot read file: {exc}") from exc
    return loads_scenario(text, source)


def loads_scenario(text: str, source: str = "<text>") -> Scenario:
    """Validate the text of a scenario file (e.g. the copy stored in a bag)."""
    try:
        doc = yaml.load(text, Loader=_StrictLoader)  # noqa: S506 - SafeLoader subclass
    except yaml.YAMLError as exc:
        duplicate = isinstance(exc, yaml.constructor.ConstructorError)
        kind = "invalid YAML" if duplicate else "YAML syntax error"
        message = str(exc).replace('in "<unicode string>", ', "")
        raise ScenarioError(source, None, f"{kind}: {message}") from exc
    except (ValueError, TypeError, KeyError, AttributeError, RecursionError) as exc:
        # PyYAML's constructors of explicit tags (``!!float abc``, ``!!bool maybe``) and
        # its recursive composer (very deep nesting) raise these, not a YAMLError.
        raise ScenarioError(source, None, f"invalid YAML: {type(exc).__name__}: {exc}") from exc
    if doc is None:
        raise ScenarioError(source, None, "file is empty")
    if (not isinstance(doc, dict) or list(doc) != ["/**"] or not isinstance(doc["/**"], dict)
            or list(doc["/**"]) != ["ros__parameters"]):
        raise ScenarioError(source, None, "top level must be exactly {'/**': "
                            "{'ros__parameters': {...}}} (a ROS 2 parameters file for all nodes)")
    return parse_scenario(doc["/**"]["ros__parameters"], source)


class _StrictLoader(yaml.SafeLoader):
    """SafeLoader that refuses duplicate mapping keys (PyYAML silently keeps the last one)."""

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if isinstance(key, Hashable) and key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"duplicate key {key!r}", key_node.start_mark)
            if isinstance(key, Hashable):
                seen.add(key)
        return super().construct_mapping(node, deep=deep)


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a
