"""Declare the scenario's ROS 2 parameters on a node and build the validated Scenario.

Every key of :func:`attitude_core.scenario.parameter_specs` is declared up front with a
read-only descriptor (type, description, range). Keys without a value in the
parameters file are left unset so that the one scenario loader supplies its defaults;
the values are then validated by :func:`attitude_core.scenario.parse_scenario`, with
every parameter given to the node that no one declared (a typo) so that the loader
refuses it as it refuses it in a file. Relative data-file paths are resolved against
the node's working directory (``attitude-run`` starts the nodes in the scenario's
directory, so they resolve as :func:`~attitude_core.scenario.load_scenario` resolves them).
"""

from __future__ import annotations

import os

from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor, ParameterType
from rclpy.exceptions import ParameterUninitializedException
from rclpy.parameter import Parameter

from attitude_core.scenario import Scenario, ScenarioError, parameter_specs, parse_scenario

_TYPES = {
    "double": (Parameter.Type.DOUBLE, ParameterType.PARAMETER_DOUBLE),
    "double_array": (Parameter.Type.DOUBLE_ARRAY, ParameterType.PARAMETER_DOUBLE_ARRAY),
    "integer": (Parameter.Type.INTEGER, ParameterType.PARAMETER_INTEGER),
    "string": (Parameter.Type.STRING, ParameterType.PARAMETER_STRING),
    "string_array": (Parameter.Type.STRING_ARRAY, ParameterType.PARAMETER_STRING_ARRAY),
    "bool": (Parameter.Type.BOOL, ParameterType.PARAMETER_BOOL),
}


def descriptor(name: str, ros_type: str, description: str, *, read_only: bool = True,
               value_range: tuple[float, float] | None = None) -> ParameterDescriptor:
    """A parameter descriptor; ``value_range`` gives closed bounds for a double."""
    d = ParameterDescriptor(name=name, type=_TYPES[ros_type][1], description=description,
                            read_only=read_only)
    if value_range is not None and ros_type == "double":
        d.floating_point_range = [FloatingPointRange(
            from_value=float(value_range[0]), to_value=float(value_range[1]), step=0.0)]
    return d


def declare(node, name: str, ros_type: str, description: str, default=None, *,
            read_only: bool = True, value_range=None):
    """Declare one parameter (typed; unset when ``default`` is None) and return its value
    (None when unset)."""
    desc = descriptor(name, ros_type, description, read_only=read_only,
                      value_range=value_range)
    value = _TYPES[ros_type][0] if default is None else default
    node.declare_parameter(name, value, desc)
    try:
        return node.get_parameter(name).value
    except ParameterUninitializedException:
        return None


def _plain(value):
    """rclpy arrays (array.array, numpy) -> lists, as the YAML loader would give them."""
    if isinstance(value, (str, bool, int, float)) or value is None:
        return value
    return list(value)


def declare_scenario(node) -> Scenario:
    """Declare every scenario parameter on ``node`` and return the validated scenario.

    Call it after the node's own parameters are declared. Raises
    :class:`ScenarioError` (naming the key) on a missing, unknown or invalid value;
    rclpy's own exceptions on a value of the wrong type are turned into one too.
    """
    source = f"node '{node.get_fully_qualified_name()}' parameters"
    flat: dict[str, object] = {}

    def declare_spec(spec):
        try:
            value = declare(node, spec.name, spec.ros_type, spec.description,
                            value_range=spec.value_range)
        except Exception as exc:  # rclpy: InvalidParameterType/ValueException
            raise ScenarioError(source, spec.name, f"{type(exc).__name__}: {exc}") from exc
        if value is not None:
            flat[spec.name] = _plain(value)

    first = parameter_specs()
    name_specs = [s for s in first if s.name.endswith(".names")]
    for spec in name_specs:
        declare_spec(spec)
    # Each distinct name once: a duplicate is the loader's to report, on the names list.
    instruments = tuple(dict.fromkeys(flat.get("instruments.names") or ()))
    objects = tuple(dict.fromkeys(flat.get("bright_objects.names") or ()))
    for spec in parameter_specs(instruments, objects):
        if spec.name not in (s.name for s in name_specs):
            declare_spec(spec)
    # Parameters given to this node (file or -p) that nothing declared: typos.
    overrides = getattr(node, "_parameter_overrides", {})  # rclpy keeps no public getter
    for name, parameter in overrides.items():
        if not node.has_parameter(name):
            flat[name] = _plain(parameter.value)
    return parse_scenario(flat, source, base_dir=os.getcwd())
