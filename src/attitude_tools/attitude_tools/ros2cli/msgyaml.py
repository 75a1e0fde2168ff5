"""A ROS message as the YAML ``ros2 topic echo`` prints.

``rosidl_runtime_py.message_to_yaml`` when it is importable (it is not on PyPI); otherwise
our conversion with its rules: fields in declaration order, bytes and strings and arrays
truncated to ``truncate_length`` items with ``'...'``, numpy values as Python numbers,
nested messages as mappings, dumped block style with unbounded width.
"""

from __future__ import annotations

import array
import importlib
import sys
from typing import Any

import numpy as np
import yaml


def _upstream() -> Any:
    try:
        return importlib.import_module("rosidl_runtime_py").message_to_yaml
    except (ImportError, AttributeError):
        return None


def message_to_yaml(msg: Any, truncate_length: int | None = 128, flow_style: bool = False) -> str:
    """YAML text of ``msg`` (ends with a newline); ``truncate_length`` None: no truncation."""
    upstream = _upstream()
    if upstream is not None:
        text: str = upstream(msg, truncate_length=truncate_length, flow_style=flow_style)
        return text
    return yaml.dump(
        message_to_dict(msg, truncate_length),
        allow_unicode=True,
        width=sys.maxsize,
        default_flow_style=flow_style,
        sort_keys=False,
    )


def message_to_dict(msg: Any, truncate_length: int | None = None) -> dict[str, Any]:
    """Field name -> converted value, in the message's field order."""
    return {
        name: _convert(getattr(msg, name, None), truncate_length)
        for name in msg.get_fields_and_field_types()
    }


def _convert(value: Any, limit: int | None) -> Any:
    if isinstance(value, bytes):
        cut = limit is not None and len(value) > limit
        text = "".join(chr(c) for c in (value[:limit] if cut else value))
        return text + "..." if cut else text
    if isinstance(value, str):
        return value[:limit] + "..." if limit is not None and len(value) > limit else value
    if isinstance(value, (list, tuple, array.array, np.ndarray)):
        cut = limit is not None and len(value) > limit
        items = [_convert(v, limit) for v in (value[:limit] if cut else value)]
        items += ["..."] if cut else []
        return tuple(items) if isinstance(value, tuple) else items
    if isinstance(value, np.generic):
        return value.item()
    if value is None or isinstance(value, (bool, int, float)):
        return value
    return message_to_dict(value, limit)
