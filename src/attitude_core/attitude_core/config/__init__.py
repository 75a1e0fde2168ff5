"""Configuration: parameters as data, the scenario and each node's parameter table.

* ``parameters``: a row (key, kind, default, bounds) and a raw value in; the typed,
  checked value, or a ``ParameterError`` naming the key, out.
* ``scenario_schema``: the scenario's rows. ``scenario``: a ROS 2 parameters file
  (``/**: ros__parameters``) in; a ``Scenario`` or a ``ScenarioError`` out.
* ``node_parameters``: each node's own rows and the scenario keys it reads.
* ``param_overrides``: ``NAME:=VALUE`` assignments in; checked against a node's table
  before the node starts.
"""
