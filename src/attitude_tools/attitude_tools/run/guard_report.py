"""What the nodes' run guards reported, read back from their logs (see
:mod:`attitude_ros.run_guard`): the named failure of a node that stopped, and every
foreign publisher any node saw."""

from __future__ import annotations

import re
from pathlib import Path

from attitude_core.runtime.run_identity import EXIT_FINGERPRINT_MISMATCH, EXIT_FOREIGN_PUBLISHER

__all__ = ["guard_failure", "foreign_publishers_logged"]

_STOPPING = re.compile(r"stopping: (.*)$")
_FOREIGN = re.compile(r"foreign publisher (\S+) \(([^)]*)\) on (\S+),")


def _lines(log: Path) -> list[str]:
    try:
        return log.read_text(errors="replace").splitlines()
    except OSError:
        return []


def guard_failure(code: int | None, log: Path) -> str | None:
    """The named failure of a node that exited with a run guard's code, else None."""
    if code not in (EXIT_FOREIGN_PUBLISHER, EXIT_FINGERPRINT_MISMATCH):
        return None
    for line in reversed(_lines(log)):
        found = _STOPPING.search(line)
        if found:
            return found.group(1)
    kind = "foreign publisher" if code == EXIT_FOREIGN_PUBLISHER else "scenario mismatch"
    return f"{kind} ({log.stem} exited with code {code})"


def foreign_publishers_logged(log_dir: Path) -> list[str]:
    """``"<topic> <- <node> (<whose>), seen by <role>"`` for every foreign publisher the
    nodes logged, each once, in the order of the log files."""
    found: dict[str, None] = {}
    for log in sorted(Path(log_dir).glob("*.log")):
        for line in _lines(log):
            m = _FOREIGN.search(line)
            if m and "stopping:" not in line:
                found[f"{m.group(3)} <- {m.group(1)} ({m.group(2)}), seen by {log.stem}"] = None
    return list(found)
