"""Code lines of Python files: every non-blank line that is not a comment (docstrings
count). The node shells are held to 150 (tests/core/test_layers.py).

Usage: .venv/bin/python tools/code_lines.py FILE...
"""

from __future__ import annotations

import sys


def code_lines(source: str) -> int:
    lines = (line.strip() for line in source.splitlines())
    return sum(1 for line in lines if line and not line.startswith("#"))


if __name__ == "__main__":
    for path in sys.argv[1:]:
        with open(path, encoding="utf-8") as f:
            print(f"{code_lines(f.read()):5d} {path}")
