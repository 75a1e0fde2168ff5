"""ROS 2 message definitions as rosbag2 stores them in MCAP schemas (``ros2msg``).

rosbag2 (Jazzy, ``rosbag2_cpp::LocalMessageDefinitionSource``) builds the schema text
of a type from the installed ``.msg`` files: the type's own file text, then, depth
first, for every nested type not yet written::

    <empty line produced by the "\\n" joiner>
    ================================================================================
    MSG: <pkg>/<Type>
    <that type's .msg text, followed by its own nested types>

The nested types of one file are visited in sorted (byte) order of their
``<pkg>/<Type>`` names. This module does the same without ROS: the files are found
under ``<prefix>/share/<pkg>/msg/<Type>.msg`` for every prefix of
``AMENT_PREFIX_PATH`` and then ``sys.prefix`` (a virtualenv holding the ROS 2
PyPI wheels).

Two deliberate differences from rosbag2, both for files rosbag2 cannot resolve
as ``.msg`` at all (it then falls back to an IDL schema): ``wstring`` is a
primitive here, and a bare ``Header`` means ``std_msgs/Header``.

``type_description_hash`` returns the RIHS01 type hash that rosidl generated next
to the ``.msg`` file (``<Type>.json``); rosbag2 records that hash per topic.
"""

from __future__ import annotations

import json
import os
import re
import sys
from functools import cache

__all__ = [
    "SEPARATOR",
    "message_definition",
    "message_dependencies",
    "normalize_type_name",
    "search_prefixes",
    "type_description_hash",
]

SEPARATOR = "=" * 80
"""Line between the sections of a ``ros2msg`` schema."""

PRIMITIVE_TYPES = frozenset(
    {
        "bool",
        "byte",
        "char",
        "float32",
        "float64",
        "int8",
        "uint8",
        "int16",
        "uint16",
        "int32",
        "uint32",
        "int64",
        "uint64",
        "string",
        "wstring",
    }
)

MAX_DEPTH = 50
"""Nesting limit, as rosbag2's (a deeper chain means a cycle or a broken install)."""

_NAME = re.compile(r"^([A-Za-z0-9_]+)/(?:msg/)?([A-Za-z0-9_]+)$")


def normalize_type_name(type_name: str) -> tuple[str, str]:
    """``'pkg/msg/Type'`` or ``'pkg/Type'`` -> ``('pkg', 'Type')``; ValueError otherwise."""
    match = _NAME.match(type_name) if isinstance(type_name, str) else None
    if match is None:
        raise ValueError(
            f"not a ROS 2 message type name: {type_name!r} (expected 'pkg/msg/Type' or 'pkg/Type')"
        )
    return match.group(1), match.group(2)


def search_prefixes() -> tuple[str, ...]:
    """Install prefixes searched, in order: ``AMENT_PREFIX_PATH`` then ``sys.prefix``."""
    prefixes = [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    if sys.prefix not in prefixes:
        prefixes.append(sys.prefix)
    return tuple(prefixes)


def _find_file(pkg: str, name: str, suffix: str, prefixes: tuple[str, ...]) -> str | None:
    for prefix in prefixes:
        path = os.path.join(prefix, "share", pkg, "msg", name + suffix)
        if os.path.isfile(path):
            return path
    return None


@cache
def _msg_text(pkg: str, name: str, prefixes: tuple[str, ...]) -> str:
    path = _find_file(pkg, name, ".msg", prefixes)
    if path is None:
        searched = ", ".join(os.path.join(p, "share", pkg, "msg") for p in prefixes)
        raise LookupError(
            f"no message definition for {pkg}/msg/{name}: {name}.msg not found in {searched}"
        )
    # newline="" keeps the file's bytes as they are (rosbag2 copies the file verbatim).
    with open(path, encoding="utf-8", newline="") as f:
        return f.read()


def _field_type(line: str) -> str | None:
    """Base type of a field or constant line (``'pkg/Type[<=3] x'`` -> ``'pkg/Type'``)."""
    words = line.split()
    if len(words) < 2 or words[0].startswith("#"):
        return None
    base = words[0].split("[", 1)[0].split("<=", 1)[0]
    return base or None


def message_dependencies(text: str, package: str) -> list[str]:
    """Sorted ``pkg/Type`` names of the non-primitive field types of one ``.msg`` text."""
    deps = set()
    for line in text.splitlines():
        base = _field_type(line)
        if base is None or base in PRIMITIVE_TYPES:
            continue
        if "/" in base:
            pkg, name = normalize_type_name(base)
        elif base == "Header":
            pkg, name = "std_msgs", "Header"
        else:
            pkg, name = package, base
        deps.add(f"{pkg}/{name}")
    return sorted(deps)


@cache
def _definition(pkg: str, name: str, prefixes: tuple[str, ...]) -> str:
    seen: set[str] = set()

    def append(pkg_: str, name_: str, depth: int) -> str:
        if depth <= 0:
            raise ValueError(f"message nesting deeper than {MAX_DEPTH} below {pkg}/msg/{name}")
        text = _msg_text(pkg_, name_, prefixes)
        parts = [text]
        for dep in message_dependencies(text, pkg_):
            if dep in seen:
                continue
            seen.add(dep)
            dep_pkg, dep_name = dep.split("/")
            parts.append(f"\n{SEPARATOR}\nMSG: {dep}\n")
            parts.append(append(dep_pkg, dep_name, depth - 1))
        return "".join(parts)

    return append(pkg, name, MAX_DEPTH)


def message_definition(type_name: str) -> str:
    """The ``ros2msg`` schema text of ``type_name`` (``'pkg/msg/Type'`` or ``'pkg/Type'``).

    Raises LookupError naming the type and the searched directories when a ``.msg``
    file (of the type or of a nested type) is not installed. Cached per process and
    search path.
    """
    pkg, name = normalize_type_name(type_name)
    try:
        return _definition(pkg, name, search_prefixes())
    except LookupError as err:
        if f"{pkg}/msg/{name}:" in str(err):
            raise
        raise LookupError(f"definition of {pkg}/msg/{name} incomplete: {err}") from None


def type_description_hash(type_name: str) -> str:
    """The ``RIHS01_<sha256>`` hash of ``type_name``, or ``''`` if rosidl left none."""
    pkg, name = normalize_type_name(type_name)
    return _type_hash(pkg, name, search_prefixes())


@cache
def _type_hash(pkg: str, name: str, prefixes: tuple[str, ...]) -> str:
    path = _find_file(pkg, name, ".json", prefixes)
    if path is None:
        return ""
    with open(path, encoding="utf-8") as f:
        hashes = json.load(f).get("type_hashes", [])
    full_name = f"{pkg}/msg/{name}"
    return next((h["hash_string"] for h in hashes if h.get("type_name") == full_name), "")
