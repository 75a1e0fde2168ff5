"""argparse helpers shared by the verbs: sub-verb parsing, ros2cli's error convention."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

Handler = Callable[[argparse.Namespace], int]


def parse(parser: argparse.ArgumentParser, argv: Sequence[str]) -> argparse.Namespace | int:
    """Parsed arguments, or the exit status argparse chose (0 for -h, 2 for a usage error)."""
    try:
        return parser.parse_args(list(argv))
    except SystemExit as e:
        return e.code if isinstance(e.code, int) else (0 if e.code is None else 2)


def run_subverb(parser: argparse.ArgumentParser, argv: Sequence[str]) -> int:
    """Parse ``argv`` and call the handler the sub-verb set (``handler`` default).

    Without a sub-verb: the help to stderr, status 2 (ros2cli prints it and exits 0).
    """
    args = parse(parser, argv)
    if isinstance(args, int):
        return args
    handler: Handler | None = getattr(args, "handler", None)
    if handler is None:
        parser.print_help(sys.stderr)
        return 2
    return handler(args)


def fail(message: str) -> int:
    """Print ``message`` to stderr and return 1, as ros2cli does with a verb's error string."""
    print(message, file=sys.stderr)
    return 1


def positive_int(text: str) -> int:
    """argparse type: an int > 0."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value <= 0:
        raise argparse.ArgumentTypeError("value must be a positive integer")
    return value


def positive_float(text: str) -> float:
    """argparse type: a float > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError("Expects a floating point number") from None
    if not value > 0.0:
        raise argparse.ArgumentTypeError("Value must be positive")
    return value


def add_spin_time(parser: argparse.ArgumentParser) -> None:
    """``--spin-time``, as ros2cli's daemon-less node takes it."""
    parser.add_argument(
        "--spin-time",
        type=positive_float,
        default=1.0,
        help="Spin time in seconds to wait for discovery (default: 1.0; ros2cli: 0.5)",
    )
