"""A minimal ``ros2`` command for machines without the ROS 2 command line (ROS 2 from pip).

The ROS 2 Jazzy wheels give us rclpy and the message packages but not ros2cli. This shim
implements ``ros2 run`` here, and a few inspection verbs (``topic list|echo|hz``, ``node
list``, ``lifecycle nodes|get|set|list``, ``param list|get``, ``bag info``) in
:mod:`attitude_tools.ros2cli`, whose modules say where they differ from ros2cli. Other
verbs print the usage and exit 2. ``ros2 run`` has the behaviour of ros2cli's ``ros2run``::

    ros2 run [--prefix PREFIX] <package_name> <executable_name> [argv ...]

* The package is looked up in the ament index (``AMENT_PREFIX_PATH``, set by sourcing
  ``ros2_ws/install/setup.bash``); the executable is the one executable file named
  ``executable_name`` anywhere under ``<prefix>/lib/<package_name>/`` (folders starting
  with ``.`` skipped), like ros2run.
* ``argv`` is passed on untouched, ``--ros-args ...`` included; everything after the
  executable name belongs to the executable (``-h`` too).
* ``--prefix 'gdb -ex run --args'`` runs the executable through that command (split with
  :func:`shlex.split`, looked up on ``PATH``).
* Errors print ros2run's messages (``Package 'x' not found``, ``No executable found``,
  ``Multiple executables found:``) to stderr and exit 1, like ``ros2``.

One deliberate difference: ros2run starts the executable as a child process and waits;
this shim *replaces* itself with the executable (``exec``), so the node has the shim's
PID, receives signals (Ctrl-C, ``kill``) directly and its exit status is the command's.
Hence ros2run's ``[ros2run]: Process exited with failure N`` line is not printed.

Installed as ``.venv/bin/ros2`` by ``tools/bootstrap`` only when no real ``ros2`` is on
``PATH``; also runnable as ``python -m attitude_tools.ros2_cli run ...``.
"""

import argparse
import importlib
import os
import shlex
import signal
import sys
from collections.abc import Mapping, Sequence

from ament_index_python import PackageNotFoundError, get_package_prefix

from attitude_tools.ros2cli import VERBS

USAGE = """\
usage: ros2 run [--prefix PREFIX] <package_name> <executable_name> [argv ...]
       ros2 topic list|echo|hz ...
       ros2 node list ...
       ros2 lifecycle nodes|get|set|list ...
       ros2 param list|get ...
       ros2 bag info <bag_path>

This 'ros2' is the attitude stack's minimal shim for machines without the ROS 2
command line tools (ROS 2 from pip wheels): it implements only these verbs, in
ros2cli's formats ('ros2 run' as ros2cli's ros2run does). For other verbs (launch,
service, bag record, ...) install ROS 2. See 'ros2 <verb> -h'.
"""


class PackageNotFound(Exception):
    """The package is not in the ament index."""


class MultipleExecutables(Exception):
    """More than one executable file of that name under ``<prefix>/lib/<package>``."""

    def __init__(self, paths: Sequence[str]) -> None:
        super().__init__(paths)
        self.paths = list(paths)


def package_prefix(package_name: str, env: Mapping[str, str] | None = None) -> str:
    """Install prefix of ``package_name`` from the ament index of ``env``'s
    ``AMENT_PREFIX_PATH`` (default: this process's environment, through ament_index_python);
    with ``env``, the first prefix whose index lists the package (its marker file
    ``share/ament_index/resource_index/packages/<name>``), as ament_index_python does."""
    paths = (os.environ if env is None else env).get('AMENT_PREFIX_PATH', '')
    if not paths:  # get_package_prefix would raise OSError
        raise PackageNotFound(package_name)
    if env is not None:
        for prefix in (p for p in paths.split(os.pathsep) if p):
            marker = os.path.join(prefix, 'share', 'ament_index', 'resource_index', 'packages')
            if os.path.isfile(os.path.join(marker, package_name)):
                return prefix
        raise PackageNotFound(package_name)
    try:
        found: str = get_package_prefix(package_name)
        return found
    except (PackageNotFoundError, ValueError):
        raise PackageNotFound(package_name) from None


def executable_paths(package_name: str, env: Mapping[str, str] | None = None) -> list[str]:
    """Every executable file under ``<prefix>/lib/<package_name>``, in a stable order."""
    base = os.path.join(package_prefix(package_name, env), 'lib', package_name)
    found: list[str] = []
    for dirpath, dirnames, filenames in os.walk(base):
        dirnames[:] = sorted(d for d in dirnames if not d.startswith('.'))
        for name in sorted(filenames):
            path = os.path.join(dirpath, name)
            if os.access(path, os.X_OK):
                found.append(path)
    return found


def find_executable(
    package_name: str, executable_name: str, env: Mapping[str, str] | None = None
) -> str | None:
    """Path of the executable, None if there is none; raises on several or no package.
    ``env``: whose ``AMENT_PREFIX_PATH`` to search (default: this process's)."""
    paths = executable_paths(package_name, env)
    matches = [p for p in paths if os.path.basename(p) == executable_name]
    if len(matches) > 1:
        raise MultipleExecutables(matches)
    return matches[0] if matches else None


def _run_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='ros2 run',
        description='Run a package specific executable (minimal shim of ros2run: '
        'the executable replaces this process).',
    )
    parser.add_argument(
        '--prefix',
        help='Prefix command, which should go before the executable. Command must be '
        "wrapped in quotes if it contains spaces (e.g. --prefix 'gdb -ex run --args').",
    )
    parser.add_argument('package_name', help='Name of the ROS package')
    parser.add_argument('executable_name', help='Name of the executable')
    parser.add_argument(
        'argv', nargs=argparse.REMAINDER, help='Pass arbitrary arguments to the executable'
    )
    return parser


def _exec(cmd: list[str]) -> None:
    """Replace this process with ``cmd`` (``cmd[0]`` is looked up on PATH if it has no '/')."""
    sys.stdout.flush()
    sys.stderr.flush()
    # Python ignores SIGPIPE and SIGXFSZ; an ignored signal stays ignored across exec, so
    # give the executable the defaults a shell (or subprocess, as ros2run uses) would.
    for name in ('SIGPIPE', 'SIGXFSZ'):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_DFL)
    os.execvp(cmd[0], cmd)


def run(args: argparse.Namespace) -> int:
    try:
        path = find_executable(args.package_name, args.executable_name)
    except PackageNotFound:
        print(f"Package '{args.package_name}' not found", file=sys.stderr)
        if not os.environ.get('AMENT_PREFIX_PATH'):
            print(
                '(AMENT_PREFIX_PATH is not set: source ros2_ws/install/setup.bash)', file=sys.stderr
            )
        return 1
    except MultipleExecutables as e:
        print('Multiple executables found:' + ''.join(f'\n- {p}' for p in e.paths), file=sys.stderr)
        return 1
    if path is None:
        print('No executable found', file=sys.stderr)
        return 1
    try:
        prefix = shlex.split(args.prefix) if args.prefix is not None else []
    except ValueError as e:  # e.g. an unbalanced quote
        print(f'ros2 run: --prefix {args.prefix!r}: {e}', file=sys.stderr)
        return 2
    cmd = prefix + [path] + list(args.argv)
    try:
        _exec(cmd)  # does not return on success
    except OSError as e:
        print(f"ros2 run: cannot execute '{cmd[0]}': {e.strerror or e}", file=sys.stderr)
        return 127 if isinstance(e, FileNotFoundError) else 126
    return 1  # not reached


def _verb(name: str, argv: list[str]) -> int:
    """Run an inspection verb of :mod:`attitude_tools.ros2cli` (imported only now)."""
    module = importlib.import_module(VERBS[name])
    try:
        status: int = module.main(argv)
    except KeyboardInterrupt:  # ros2cli's status for an interrupted verb
        return int(signal.SIGINT)
    return status


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv and argv[0] in ('-h', '--help'):
        print(USAGE, end='')
        return 0
    if argv and argv[0] in VERBS:
        return _verb(argv[0], argv[1:])
    if not argv or argv[0] != 'run':
        print(USAGE, end='', file=sys.stderr)
        if argv:
            print(f"ros2: verb '{argv[0]}' is not implemented by this shim", file=sys.stderr)
        return 2
    try:
        args = _run_parser().parse_args(argv[1:])
    except SystemExit as e:  # -h, or a usage error (argparse printed it)
        return e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
    return run(args)


if __name__ == '__main__':
    sys.exit(main())
