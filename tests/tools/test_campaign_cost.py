"""The shortcuts a campaign run takes give what the long way gave: a draw is loaded from
the values its reproducer file holds, without writing and reading that file."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from attitude_core.config.scenario import flatten_parameters, loads_scenario
from attitude_core.yamlio import load_strict
from attitude_tools.campaign.draw import as_read_back, base_parameters, draw_run, scenario_text
from attitude_tools.campaign.spec import load_spec

ROOT = Path(__file__).resolve().parents[2]
SPECS = sorted((ROOT / "campaigns").glob("*.yaml"))


def _typed(value: Any) -> Any:
    """``value`` with the type of every part (1 and 1.0 and True differ)."""
    if isinstance(value, dict):
        return {k: _typed(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return (type(value).__name__, [_typed(v) for v in value])
    return (type(value).__name__, value)


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return bool(np.array_equal(a, b)) and np.asarray(a).dtype == np.asarray(b).dtype
    if isinstance(a, tuple | list) and isinstance(b, tuple | list):
        return type(a) is type(b) and len(a) == len(b) and all(map(_same, a, b))
    if hasattr(a, "__dataclass_fields__") and type(a) is type(b):
        return all(_same(getattr(a, f), getattr(b, f)) for f in a.__dataclass_fields__)
    return bool(type(a) is type(b) and a == b)


@pytest.mark.parametrize("spec_path", SPECS, ids=[p.stem for p in SPECS])
def test_a_draw_is_loaded_from_the_values_its_reproducer_holds(spec_path):
    spec = load_spec(spec_path)
    base = base_parameters(spec)
    for i in range(3):
        draw = draw_run(spec, base, i, spec.planner_variants[-1])
        text = scenario_text(draw.flat)
        read = flatten_parameters(load_strict(text)["/**"]["ros__parameters"])
        assert _typed(read) == _typed(as_read_back(draw.flat))
        assert _same(loads_scenario(text, draw.scenario.source), draw.scenario)
