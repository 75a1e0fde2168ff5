"""The ``ros2 run`` shim (attitude_tools.ros2_cli): a fake ament prefix, then the real workspace.

The shim runs as ``.venv/bin/python -m attitude_tools.ros2_cli ...`` in a subprocess with a
controlled environment, so exec, exit status and signals are the real ones.
"""

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PYTHON = sys.executable
BASE_ENV = {'PATH': '/usr/bin:/bin', 'LC_ALL': 'C.UTF-8'}

# Prints its PID, $0 and one line per argument, then exits 3 (sh: $$ is the process itself).
FAKE_NODE = """#!/bin/sh
echo "pid=$$"
echo "argv0=$0"
echo "greeting=${GREETING:-}"
for a in "$@"; do echo "arg=$a"; done
exit 3
"""


def make_prefix(root, package, executables=None, marker=True):
    """An install prefix holding ``package`` in its ament index and ``lib/<package>/<rel>`` files.

    ``executables`` maps a path relative to ``lib/<package>`` to (text, mode).
    """
    if marker:
        index = root / 'share' / 'ament_index' / 'resource_index' / 'packages'
        index.mkdir(parents=True, exist_ok=True)
        (index / package).write_text('')
    for rel, (text, mode) in (executables or {}).items():
        path = root / 'lib' / package / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
        path.chmod(mode)
    return root


def shim(*args, ament_prefix_path=None, env=None, **kwargs):
    full_env = dict(BASE_ENV)
    if ament_prefix_path is not None:
        full_env['AMENT_PREFIX_PATH'] = os.pathsep.join(str(p) for p in ament_prefix_path)
    full_env.update(env or {})
    return subprocess.run(
        [PYTHON, '-m', 'attitude_tools.ros2_cli', *args],
        env=full_env,
        capture_output=True,
        text=True,
        timeout=30,
        **kwargs,
    )


def parse(stdout):
    """pid, argv0, greeting and the list of arguments printed by FAKE_NODE."""
    lines = stdout.splitlines()
    fields = dict(line.split('=', 1) for line in lines[:3])
    args = [line[len('arg=') :] for line in lines[3:]]
    assert all(line.startswith('arg=') for line in lines[3:])
    return int(fields['pid']), fields['argv0'], fields['greeting'], args


@pytest.fixture
def prefix(tmp_path):
    return make_prefix(tmp_path / 'install', 'demo_pkg', {'talker': (FAKE_NODE, 0o755)})


def test_exit_status_and_argv_pass_through(prefix):
    argv = [
        '--ros-args',
        '-p',
        'a:=1',
        '--params-file',
        'f.yaml',
        '-r',
        '__node:=x',
        'two words',
        '',
        '-h',
        '--prefix',
        'x',
        '--',
    ]
    res = shim('run', 'demo_pkg', 'talker', *argv, ament_prefix_path=[prefix])
    assert res.returncode == 3, res.stderr
    assert res.stderr == ''
    _, argv0, _, args = parse(res.stdout)
    assert argv0 == str(prefix / 'lib' / 'demo_pkg' / 'talker')
    assert args == argv


def test_process_is_replaced_by_the_executable(prefix):
    """exec: the node runs with the PID of the ros2 process, no Python parent left behind."""
    env = dict(BASE_ENV, AMENT_PREFIX_PATH=str(prefix))
    proc = subprocess.Popen(
        [PYTHON, '-m', 'attitude_tools.ros2_cli', 'run', 'demo_pkg', 'talker'],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 3, err
    pid, _, _, _ = parse(out)
    assert pid == proc.pid


def test_signal_reaches_the_node_directly(tmp_path):
    node = """#!/bin/sh
trap 'echo "got TERM"; exit 5' TERM
echo ready
while :; do sleep 0.05; done
"""
    prefix = make_prefix(tmp_path / 'install', 'demo_pkg', {'waiter': (node, 0o755)})
    env = dict(BASE_ENV, AMENT_PREFIX_PATH=str(prefix))
    proc = subprocess.Popen(
        [PYTHON, '-m', 'attitude_tools.ros2_cli', 'run', 'demo_pkg', 'waiter'],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout.readline() == 'ready\n'
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 5, err
    assert out == 'got TERM\n'


def test_prefix_command_is_split_like_a_shell(prefix):
    res = shim(
        'run',
        '--prefix',
        "env 'GREETING=hello world'",
        'demo_pkg',
        'talker',
        '--ros-args',
        '-p',
        'a:=1',
        ament_prefix_path=[prefix],
    )
    assert res.returncode == 3, res.stderr
    _, argv0, greeting, args = parse(res.stdout)
    assert greeting == 'hello world'
    assert argv0 == str(prefix / 'lib' / 'demo_pkg' / 'talker')
    assert args == ['--ros-args', '-p', 'a:=1']


def test_prefix_keeps_the_pid(prefix):
    env = dict(BASE_ENV, AMENT_PREFIX_PATH=str(prefix))
    proc = subprocess.Popen(
        [PYTHON, '-m', 'attitude_tools.ros2_cli', 'run', '--prefix', 'env', 'demo_pkg', 'talker'],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 3, err
    assert parse(out)[0] == proc.pid


def test_prefix_command_not_found(prefix):
    res = shim(
        'run',
        '--prefix',
        'no-such-wrapper-xyz --flag',
        'demo_pkg',
        'talker',
        ament_prefix_path=[prefix],
    )
    assert res.returncode == 127
    assert "cannot execute 'no-such-wrapper-xyz'" in res.stderr
    assert res.stdout == ''


def test_prefix_with_unbalanced_quote(prefix):
    res = shim('run', '--prefix', "env 'A=b", 'demo_pkg', 'talker', ament_prefix_path=[prefix])
    assert res.returncode == 2
    assert 'No closing quotation' in res.stderr
    assert res.stdout == ''


def test_package_not_found(prefix):
    res = shim('run', 'other_pkg', 'talker', ament_prefix_path=[prefix])
    assert res.returncode == 1
    assert res.stderr == "Package 'other_pkg' not found\n"
    assert res.stdout == ''


def test_package_not_found_without_ament_prefix_path():
    res = shim('run', 'demo_pkg', 'talker')
    assert res.returncode == 1
    assert res.stderr.startswith("Package 'demo_pkg' not found\n")
    assert 'AMENT_PREFIX_PATH' in res.stderr


def test_package_without_lib_directory(tmp_path):
    prefix = make_prefix(tmp_path / 'install', 'demo_pkg')
    res = shim('run', 'demo_pkg', 'talker', ament_prefix_path=[prefix])
    assert res.returncode == 1
    assert res.stderr == 'No executable found\n'


def test_no_executable_found(tmp_path):
    prefix = make_prefix(
        tmp_path / 'install',
        'demo_pkg',
        {
            'talker': (FAKE_NODE, 0o644),  # not executable
            '.hidden/talker': (FAKE_NODE, 0o755),  # folders starting with '.' are skipped
            'listener': (FAKE_NODE, 0o755),  # another name
        },
    )
    res = shim('run', 'demo_pkg', 'talker', ament_prefix_path=[prefix])
    assert res.returncode == 1
    assert res.stderr == 'No executable found\n'
    assert res.stdout == ''


def test_executable_in_a_subfolder_is_found(tmp_path):
    prefix = make_prefix(tmp_path / 'install', 'demo_pkg', {'sub/talker': (FAKE_NODE, 0o755)})
    res = shim('run', 'demo_pkg', 'talker', ament_prefix_path=[prefix])
    assert res.returncode == 3, res.stderr
    assert parse(res.stdout)[1] == str(prefix / 'lib' / 'demo_pkg' / 'sub' / 'talker')


def test_multiple_executables_found(tmp_path):
    prefix = make_prefix(
        tmp_path / 'install',
        'demo_pkg',
        {
            'talker': (FAKE_NODE, 0o755),
            'sub/talker': (FAKE_NODE, 0o755),
        },
    )
    res = shim('run', 'demo_pkg', 'talker', ament_prefix_path=[prefix])
    assert res.returncode == 1
    lib = prefix / 'lib' / 'demo_pkg'
    assert res.stderr == (
        f'Multiple executables found:\n- {lib / "talker"}\n- {lib / "sub" / "talker"}\n'
    )
    assert res.stdout == ''


def test_first_prefix_on_ament_prefix_path_wins(tmp_path):
    overlay = make_prefix(tmp_path / 'overlay', 'demo_pkg', {'talker': (FAKE_NODE, 0o755)})
    underlay = make_prefix(tmp_path / 'underlay', 'demo_pkg', {'talker': (FAKE_NODE, 0o755)})
    res = shim('run', 'demo_pkg', 'talker', ament_prefix_path=[overlay, underlay])
    assert res.returncode == 3, res.stderr
    assert parse(res.stdout)[1] == str(overlay / 'lib' / 'demo_pkg' / 'talker')


@pytest.mark.parametrize('argv', [['service', 'list'], ['launch', 'x', 'y.launch.py'], []])
def test_other_verbs_print_usage_and_exit_2(argv, prefix):
    res = shim(*argv, ament_prefix_path=[prefix])
    assert res.returncode == 2
    assert res.stdout == ''
    assert 'usage: ros2 run' in res.stderr
    assert 'shim' in res.stderr and 'only these verbs' in res.stderr
    for verb in ('ros2 topic', 'ros2 node', 'ros2 lifecycle', 'ros2 param', 'ros2 bag info'):
        assert verb in res.stderr
    if argv:
        assert f"verb '{argv[0]}' is not implemented" in res.stderr


@pytest.mark.parametrize('flag', ['-h', '--help'])
def test_help_exits_0(flag):
    res = shim(flag)
    assert res.returncode == 0
    assert 'usage: ros2 run' in res.stdout and 'only these verbs' in res.stdout


def test_run_help_and_usage_errors():
    res = shim('run', '-h')
    assert res.returncode == 0
    assert res.stdout.startswith('usage: ros2 run')
    assert '--prefix' in res.stdout
    res = shim('run', 'demo_pkg')
    assert res.returncode == 2
    assert 'executable_name' in res.stderr


def test_main_returns_int_in_process(capsys):
    from attitude_tools.ros2_cli import main

    assert main(['-h']) == 0
    assert main(['topic']) == 2
    assert main(['run']) == 2
    capsys.readouterr()


# The real workspace (built by tools/bootstrap) -------------------------------------------------

WS = ROOT / 'ros2_ws'


def sourced(command):
    """Run ``command`` in bash after sourcing the workspace like the README says."""
    script = (
        f'export AMENT_PREFIX_PATH={ROOT / ".venv"}; '
        f'source {WS / "install" / "setup.bash"}; {command}'
    )
    return subprocess.run(
        ['bash', '-c', script],
        cwd=WS,
        env=dict(BASE_ENV),
        capture_output=True,
        text=True,
        timeout=60,
    )


@pytest.mark.skipif(
    not (WS / 'install' / 'setup.bash').is_file(),
    reason='ros2_ws not built (bash tools/bootstrap builds it)',
)
def test_workspace_index_resolves_packages():
    res = sourced(
        f'{PYTHON} -c "import os; from ament_index_python import get_package_prefix; '
        f"print(os.environ['AMENT_PREFIX_PATH']); "
        f"print(get_package_prefix('attitude_planner')); "
        f"print(get_package_prefix('rclpy'))\""
    )
    assert res.returncode == 0, res.stderr
    path, planner, rclpy = res.stdout.splitlines()
    assert str(WS / 'install' / 'attitude_planner') in path.split(os.pathsep)
    assert Path(planner) == WS / 'install' / 'attitude_planner'
    assert Path(rclpy).resolve() == (ROOT / '.venv').resolve()
    # and the shim sees the same index
    res = sourced(f'{PYTHON} -m attitude_tools.ros2_cli run attitude_planner no_such_executable')
    assert res.returncode == 1
    assert res.stderr == 'No executable found\n'


def console_scripts(pkg):
    """Names of the console_scripts declared in src/<pkg>/setup.py."""
    import ast

    tree = ast.parse((ROOT / 'src' / pkg / 'setup.py').read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.keyword) and node.arg == 'entry_points':
            entries = ast.literal_eval(node.value).get('console_scripts', [])
            return [entry.split('=', 1)[0].strip() for entry in entries]
    return []


WS_EXECUTABLES = [
    (pkg.name, exe)
    for pkg in sorted((ROOT / 'src').iterdir())
    if (pkg / 'package.xml').is_file() and (pkg / 'setup.py').is_file()
    for exe in console_scripts(pkg.name)
]


@pytest.mark.skipif(
    not (WS / 'install' / 'setup.bash').is_file(),
    reason='ros2_ws not built (bash tools/bootstrap builds it)',
)
@pytest.mark.parametrize('pkg, exe', WS_EXECUTABLES)
def test_workspace_executables_resolve(pkg, exe):
    """Every console script of a ROS package is where `ros2 run <pkg> <exe>` looks for it."""
    res = sourced(
        f'{PYTHON} -c "from attitude_tools.ros2_cli import find_executable; '
        f"print(find_executable('{pkg}', '{exe}'))\""
    )
    assert res.returncode == 0, res.stderr
    assert Path(res.stdout.strip()) == WS / 'install' / pkg / 'lib' / pkg / exe, (
        'ros2_ws/install is out of date: run bash tools/bootstrap'
    )


def test_lookup_in_a_given_environment_matches_the_shim(tmp_path):
    """``find_executable(..., env)`` (attitude-run's start of its nodes) finds what the
    shim, with that environment, runs: the first prefix whose ament index lists the
    package wins, a prefix without the package's marker file is not searched."""
    from attitude_tools.ros2_cli import PackageNotFound, find_executable

    first = make_prefix(tmp_path / 'a', 'demo_pkg', {'talker': (FAKE_NODE, 0o755)})
    second = make_prefix(tmp_path / 'b', 'demo_pkg', {'talker': (FAKE_NODE, 0o755)})
    unlisted = make_prefix(tmp_path / 'c', 'demo_pkg', {'talker': (FAKE_NODE, 0o755)}, False)
    paths = [unlisted, first, second]
    env = {'AMENT_PREFIX_PATH': os.pathsep.join(str(p) for p in paths)}
    found = find_executable('demo_pkg', 'talker', env)
    assert found == str(first / 'lib' / 'demo_pkg' / 'talker')
    res = shim('run', 'demo_pkg', 'talker', ament_prefix_path=paths)
    assert res.returncode == 3 and parse(res.stdout)[1] == found  # the shim ran that file
    assert find_executable('demo_pkg', 'listener', env) is None
    with pytest.raises(PackageNotFound):
        find_executable('other_pkg', 'talker', env)
    with pytest.raises(PackageNotFound):
        find_executable('demo_pkg', 'talker', {})


def test_attitude_run_names_a_missing_node_package_before_starting_anything(tmp_path):
    from attitude_core.config import node_graph
    from attitude_tools.run.environment import node_executables
    from attitude_tools.run.errors import RunError

    env = {'AMENT_PREFIX_PATH': str(make_prefix(tmp_path / 'p', 'demo_pkg'))}
    with pytest.raises(RunError, match="package 'attitude_planner' not found"):
        node_executables(env, [node_graph.PLANNER])
