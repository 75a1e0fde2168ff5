"""Strict YAML reading for the core's data files (scenarios, FIS definitions).

PyYAML's safe loader keeps the last of two equal mapping keys without a word; a
duplicated parameter or membership term would then silently change the run. The loader
here refuses them instead.
"""

from __future__ import annotations

from collections.abc import Hashable
from typing import IO, Any

import yaml

__all__ = ["StrictLoader", "dump_safe", "load_strict", "load_safe"]

_SAFE_LOADER: Any = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
"""PyYAML's safe loader on libyaml's parser when PyYAML was built with it (the wheels
are): the same documents, about ten times faster than the pure-Python parser."""

_SAFE_DUMPER: Any = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
"""PyYAML's safe dumper on libyaml's emitter when available, about five times faster:
the same documents as ``yaml.safe_dump`` (read back equal), and the same text for a
bag's metadata; long strings that need escapes are folded at other places."""


class StrictLoader(yaml.SafeLoader):
    """SafeLoader that refuses duplicate mapping keys (PyYAML silently keeps the last).

    A duplicate raises :class:`yaml.constructor.ConstructorError` ``duplicate key 'x'``
    with the mark (line, column) of the second occurrence. Merge keys (``<<``) are
    flattened first, so a key that overrides a merged one is a duplicate too.
    """


def _construct_mapping(
    loader: StrictLoader, node: yaml.MappingNode, deep: bool = False
) -> dict[Any, Any]:
    loader.flatten_mapping(node)
    seen: set[Any] = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if not isinstance(key, Hashable):
            continue  # SafeLoader's construct_mapping refuses it: "found unhashable key"
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r}", key_node.start_mark
            )
        seen.add(key)
    return loader.construct_mapping(node, deep=deep)


StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


def load_strict(text_or_stream: str | bytes | IO[str] | IO[bytes]) -> Any:
    """The YAML document in ``text_or_stream`` (``None`` if empty), read with :class:`StrictLoader`.

    Raises :class:`yaml.YAMLError` (a duplicate key: its subclass ``ConstructorError``).
    """
    return yaml.load(text_or_stream, Loader=StrictLoader)


def load_safe(text_or_stream: str | bytes | IO[str] | IO[bytes]) -> Any:
    """``yaml.safe_load`` on libyaml's parser when available: for machine-written YAML
    (a bag's metadata.yaml, QoS profile strings), where the parse is on a run's hot
    path (a run's bring-down reads its bag's metadata).

    Raises :class:`yaml.YAMLError`.
    """
    return yaml.load(text_or_stream, Loader=_SAFE_LOADER)


def dump_safe(data: Any, *, sort_keys: bool = False) -> str:
    """``yaml.safe_dump(data, sort_keys=sort_keys, default_flow_style=False)`` on
    libyaml's emitter when available: for machine-written YAML on a hot path (a bag's
    metadata.yaml, rewritten at every flush of a recording)."""
    text: str = yaml.dump(data, Dumper=_SAFE_DUMPER, sort_keys=sort_keys, default_flow_style=False)
    return text
