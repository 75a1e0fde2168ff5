"""``attitude-run --param NODE:NAME:=VALUE``: checked against each node's parameter table
before anything is written or started (:mod:`attitude_core.config.param_overrides`)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from attitude_core.config.node_graph import NodeSpec
from attitude_core.config.param_overrides import check_overrides, parse_assignment
from attitude_core.config.parameters import NodeParameterError
from attitude_core.yamlio import load_strict

__all__ = ["check_node_params"]


def check_node_params(
    scenario_path: str | Path,
    node_params: Mapping[str, Iterable[str]],
    specs: Iterable[NodeSpec[Any]],
) -> None:
    """Check each node's ``NAME:=VALUE`` items (by role) as that node would, with the
    scenario file (already validated) as its other parameters. Raises
    ``NodeParameterError`` or ``ScenarioError`` whose source is ``--param ROLE``."""
    path = Path(scenario_path).resolve()
    file_params = load_strict(path.read_text(encoding="utf-8"))["/**"]["ros__parameters"]
    for spec in specs:
        items = list(node_params.get(spec.role, ()))
        if not items:
            continue
        source = f"--param {spec.role}"
        overrides = dict(parse_assignment(item, source) for item in items)
        check_overrides(spec.parameters, overrides, file_params, source, base_dir=path.parent)
        own = {row.key for row in spec.parameters.own}
        for name in overrides:
            if name not in own and spec.parameters.scenario is not None:
                raise NodeParameterError(
                    source,
                    name,
                    "a scenario key: set it in the scenario file, which every node of the "
                    "run reads (nodes with other scenario values fail the run's fingerprint "
                    "check)",
                )
