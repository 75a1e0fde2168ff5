"""The parameter rows and the scenario edits the parameter tests share
(``test_parameters.py``, ``test_parameter_tables.py``, ``test_parameters_keep_in.py``):
every row with the names of ``scenarios/case1.yaml``, the reason ``convert`` refuses a
value with, and values just inside and outside a row's bounds written into a scenario."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest
import yaml

from attitude_core.config.node_parameters import CONTROLLER, PLANNER, RECORDER, SIMULATOR
from attitude_core.config.parameters import Param, ParameterError, convert
from attitude_core.config.scenario import ScenarioError
from attitude_core.config.scenario_flatten import scenario_keys
from attitude_core.config.scenario_loader import loads_scenario
from attitude_core.config.scenario_schema import (
    INSTRUMENT_PARAMETERS,
    KEEP_IN_PARAMETERS,
    OBJECT_PARAMETERS,
    SCENARIO_PARAMETERS,
)

ROOT = Path(__file__).resolve().parents[2]
CASE1 = (ROOT / "scenarios" / "case1.yaml").read_text(encoding="utf-8")
NODE_TABLES = {
    "planner": PLANNER,
    "controller": CONTROLLER,
    "simulator": SIMULATOR,
    "recorder": RECORDER,
}
# Every scenario row under its dotted key, with the names of case1.yaml.
CASE1_ROWS = scenario_keys(("star_tracker",), ("object_1", "object_2", "object_3"))
ALL_ROWS = (
    list(SCENARIO_PARAMETERS)
    + list(INSTRUMENT_PARAMETERS)
    + list(OBJECT_PARAMETERS)
    + list(KEEP_IN_PARAMETERS)
    + [p for table in NODE_TABLES.values() for p in table.own]
)


def row(key: str, rows=CASE1_ROWS) -> Param:
    return next(p for p in rows if p.key == key)


def reason(param: Param, raw, **kw) -> str:
    """The reason ``convert`` refuses ``raw`` with (fails if it accepts it)."""
    with pytest.raises(ParameterError) as info:
        convert(param, raw, "src.yaml", **kw)
    assert info.value.key == param.key and info.value.source == "src.yaml"
    assert str(info.value) == f"src.yaml: {param.key}: {info.value.reason}"
    return info.value.reason


def yaml_number(x: float | int) -> str:
    """``x`` as YAML 1.1 text that reads back as exactly ``x`` with its type."""
    text = repr(x)
    if isinstance(x, float) and "e" in text and "." not in text:
        text = text.replace("e", ".0e")
    assert yaml.safe_load(text) == x and type(yaml.safe_load(text)) is type(x)
    return text


def with_value(text: str, key: str, value: float | int) -> str:
    """case1.yaml with ``key`` set to ``value``: the line of the key replaced, or a dotted
    key added under ``ros__parameters``."""
    leaf = key.rsplit(".", 1)[-1]
    # A line holding the leaf with a value (not the header of a mapping of that name).
    pattern = re.compile(
        rf"^(\s*{re.escape(leaf)}:[ \t]*)[^#\n\s][^#\n]*?(\s*(#.*)?)$", re.MULTILINE
    )
    matches = pattern.findall(text)
    assert len(matches) <= 1, key
    if matches:
        return pattern.sub(lambda m: m.group(1) + yaml_number(value) + m.group(2), text)
    # Absent: added as a dotted key under ros__parameters (the loader flattens both).
    return text + f"    {key}: {yaml_number(value)}\n"


def outside_values(param: Param) -> list[float | int]:
    """The values just outside each bounded side of the row's bounds."""
    b = param.bounds
    out = []
    if param.kind == "int":
        if b.lo is not None:
            out.append(b.lo if b.lo_open else b.lo - 1)
        if b.hi is not None:
            out.append(b.hi if b.hi_open else b.hi + 1)
    else:
        if b.lo is not None:
            out.append(float(b.lo) if b.lo_open else math.nextafter(b.lo, -math.inf))
        if b.hi is not None:
            out.append(float(b.hi) if b.hi_open else math.nextafter(b.hi, math.inf))
    return out


def inside_values(param: Param) -> list[float | int]:
    b = param.bounds
    if param.kind == "int":
        return [
            v
            for v in (
                (b.lo + 1 if b.lo_open else b.lo) if b.lo is not None else None,
                (b.hi - 1 if b.hi_open else b.hi) if b.hi is not None else None,
            )
            if v is not None
        ]
    return [
        v
        for v in (
            (math.nextafter(b.lo, math.inf) if b.lo_open else float(b.lo))
            if b.lo is not None
            else None,
            (math.nextafter(b.hi, -math.inf) if b.hi_open else float(b.hi))
            if b.hi is not None
            else None,
        )
        if v is not None
    ]


def refused_just_outside(text: str, source: str, param) -> None:
    """Every value just outside ``param``'s bound, in the scenario ``text``, is refused
    naming the key and the bound's reason."""
    for value in outside_values(param):
        with pytest.raises(ScenarioError) as info:
            loads_scenario(with_value(text, param.key, value), source)
        assert info.value.key == param.key, (value, str(info.value))
        assert info.value.reason == param.bounds.check(value)
        assert str(info.value) == f"{source}: {param.key}: {param.bounds.check(value)}"
