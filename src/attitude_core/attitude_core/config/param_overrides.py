"""Node parameters given on a command line (``NAME:=VALUE``), checked against a node's
table before the node is started.

Values are parsed as ``ros2 run ... -p NAME:=VALUE`` parses them (a YAML scalar or flow
sequence: ``1`` is an integer, ``1.0`` a float, ``true`` a boolean, ``[a, b]`` a list,
anything else a string). A node's own rows are checked with
:func:`attitude_core.config.parameters.convert`; any other key must be a scenario key (checked
with the scenario by :func:`attitude_core.config.scenario_loader.parse_scenario`) or one rclpy
declares itself; an unknown key is refused with a "did you mean" hint. The nodes run
the same checks (``attitude_ros.params``), so a value refused here would be refused
there.
"""

from __future__ import annotations

import contextlib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from attitude_core.config.node_parameters import NodeParameters
from attitude_core.config.parameters import NodeParameterError, convert
from attitude_core.config.scenario_flatten import flatten_parameters
from attitude_core.config.scenario_loader import parse_scenario

__all__ = ["parse_assignment", "check_overrides"]


def parse_assignment(text: str, source: str) -> tuple[str, Any]:
    """``NAME:=VALUE`` -> (NAME, VALUE parsed as ROS 2 parses a ``-p`` value)."""
    name, sep, raw = text.partition(":=")
    if not sep or not name:
        raise NodeParameterError(source, None, f"expected NAME:=VALUE, got {text!r}")
    try:
        value = yaml.safe_load(raw) if raw.strip() else raw
    except yaml.YAMLError as exc:
        raise NodeParameterError(source, name, f"cannot parse value {raw!r}: {exc}") from None
    if isinstance(value, str) and raw.strip() == value:  # unquoted: rcl reads 1e3 as a float
        with contextlib.suppress(ValueError):
            value = float(value) if any(c.isdigit() for c in value) else value
    if value is None or isinstance(value, dict):
        raise NodeParameterError(source, name, f"value {raw!r} is not a ROS 2 parameter value")
    return name, value


def check_overrides(
    table: NodeParameters[Any],
    overrides: Mapping[str, Any],
    scenario_params: Mapping[str, Any],
    source: str,
    base_dir: str | Path,
) -> None:
    """Check ``overrides`` (name -> parsed value) for a node with ``table`` whose
    scenario parameters are ``scenario_params`` (the file's ``ros__parameters``).
    Raises :class:`NodeParameterError` or ``ScenarioError`` naming the key."""
    own = {row.key: row for row in table.own}
    rest = {}
    for name, value in overrides.items():
        if name in own:
            convert(own[name], value, source, Path(base_dir), error=NodeParameterError)
        else:
            rest[name] = value
    if table.scenario is None:
        table.refuse_unknown(rest, source)
        return
    if rest:  # the scenario as the node sees it: the file, then the command line
        flat = dict(flatten_parameters(dict(scenario_params), source))
        flat.update(rest)
        parse_scenario(flat, source, base_dir=base_dir, also_known=tuple(own))
