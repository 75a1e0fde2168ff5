"""Structure of attitude_bringup's scenario.launch.py (launch/launch_ros are not installed here).

The file is read with ``ast``: launch arguments, the nodes it starts (each one must be a
console script of its package's setup.py, so ``ros2 launch`` can find it), the shutdown on
the simulator's exit, and its installation by attitude_bringup's setup.py.
"""

import ast
from glob import glob
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / 'src'
BRINGUP = SRC / 'attitude_bringup'
LAUNCH = BRINGUP / 'launch' / 'scenario.launch.py'
NODES = {
    'bag_recorder': 'attitude_bringup',
    'fepf_planner': 'attitude_planner',
    'pd_controller': 'attitude_controller',
    'rigid_body_sim': 'spacecraft_sim',
}


def _name(func):
    """``Node`` for ``Node(...)`` and ``launch_ros.actions.Node(...)``."""
    if isinstance(func, ast.Name):
        return func.id
    if isinstance(func, ast.Attribute):
        return func.attr
    return None


def _calls(tree, name):
    return [n for n in ast.walk(tree) if isinstance(n, ast.Call) and _name(n.func) == name]


def _kwargs(call):
    return {kw.arg: kw.value for kw in call.keywords}


def _const(node):
    assert isinstance(node, ast.Constant), ast.unparse(node)
    return node.value


@pytest.fixture(scope='module')
def tree():
    return ast.parse(LAUNCH.read_text(), filename=str(LAUNCH))


@pytest.fixture(scope='module')
def assignments(tree):
    """Simple ``name = <expr>`` assignments anywhere in the file."""
    out = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign):
            for target in node.targets:
                if isinstance(target, ast.Name):
                    out[target.id] = node.value
    return out


@pytest.fixture(scope='module')
def nodes(tree):
    """executable name -> the Node(...) call."""
    out = {}
    for call in _calls(tree, 'Node'):
        kwargs = _kwargs(call)
        exe = _const(kwargs['executable'])
        assert exe not in out, f'{exe} started twice'
        out[exe] = call
    return out


def test_defines_generate_launch_description(tree):
    funcs = [n for n in tree.body if isinstance(n, ast.FunctionDef)]
    assert 'generate_launch_description' in [f.name for f in funcs]
    imports = {(n.module, a.name) for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
               for a in n.names}
    assert ('launch_ros.actions', 'Node') in imports
    assert ('launch', 'LaunchDescription') in imports


def test_usage_in_docstring(tree):
    doc = ast.get_docstring(tree)
    assert doc and 'ros2 launch attitude_bringup scenario.launch.py scenario:=' in doc


def test_launch_arguments(tree):
    declared = {}
    for call in _calls(tree, 'DeclareLaunchArgument'):
        declared[_const(call.args[0])] = _kwargs(call)
    assert set(declared) == {'scenario', 'time_mode', 'bag_dir'}
    assert 'default_value' not in declared['scenario'], 'scenario is required'
    assert _const(declared['time_mode']['default_value']) == 'lockstep'
    if 'choices' in declared['time_mode']:
        assert ast.literal_eval(declared['time_mode']['choices']) == ['lockstep', 'realtime']
    assert _const(declared['bag_dir']['default_value']) == 'bag'
    for kwargs in declared.values():
        assert 'description' in kwargs


def test_starts_the_four_nodes_on_screen(nodes):
    assert set(nodes) == set(NODES)
    for exe, call in nodes.items():
        kwargs = _kwargs(call)
        assert _const(kwargs['package']) == NODES[exe]
        assert _const(kwargs['output']) == 'screen'


def _console_scripts(pkg):
    tree = ast.parse((SRC / pkg / 'setup.py').read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.keyword) and node.arg == 'entry_points':
            entries = ast.literal_eval(node.value).get('console_scripts', [])
            return {entry.split('=', 1)[0].strip() for entry in entries}
    return set()


@pytest.mark.parametrize('exe', sorted(NODES))
def test_node_executable_is_a_console_script(nodes, exe):
    pkg = _const(_kwargs(nodes[exe])['package'])
    scripts = _console_scripts(pkg)
    assert exe in scripts, (
        f"scenario.launch.py starts {pkg}/{exe}, but src/{pkg}/setup.py declares no console "
        f"script '{exe}' (console_scripts: {sorted(scripts)})")


def _launch_configuration(node, assignments):
    """The launch argument name if ``node`` is LaunchConfiguration('x') or a name bound to it."""
    if isinstance(node, ast.Name) and node.id in assignments:
        node = assignments[node.id]
    if isinstance(node, ast.Call) and _name(node.func) == 'LaunchConfiguration':
        return _const(node.args[0])
    return None


def _parameters(call, assignments):
    """(launch arguments used as parameter files, {parameter name: value node})."""
    files, values = [], {}
    params = _kwargs(call).get('parameters')
    assert isinstance(params, ast.List), 'parameters must be a list'
    for item in params.elts:
        if isinstance(item, ast.Dict):
            values.update({_const(k): v for k, v in zip(item.keys, item.values)})
        else:
            files.append(_launch_configuration(item, assignments))
    return files, values


def _value_from(node, assignments):
    """Launch argument behind a parameter value (plain or wrapped in ParameterValue)."""
    if isinstance(node, ast.Call) and _name(node.func) == 'ParameterValue':
        node = node.args[0]
    return _launch_configuration(node, assignments)


def test_every_node_gets_the_scenario_file(nodes, assignments):
    for exe, call in nodes.items():
        files, _ = _parameters(call, assignments)
        assert files == ['scenario'], f'{exe}: parameter files {files}'


def test_node_parameters(nodes, assignments):
    _, sim = _parameters(nodes['rigid_body_sim'], assignments)
    assert _value_from(sim['time_mode'], assignments) == 'time_mode'
    assert _const(sim['lockstep.expected_subscribers']) == 3
    _, recorder = _parameters(nodes['bag_recorder'], assignments)
    assert _value_from(recorder['output_dir'], assignments) == 'bag_dir'


def test_shutdown_when_the_simulator_exits(tree, assignments):
    handlers = _calls(tree, 'OnProcessExit')
    assert len(handlers) == 1
    kwargs = _kwargs(handlers[0])
    target = kwargs['target_action']
    if isinstance(target, ast.Name):
        target = assignments[target.id]
    assert _name(target.func) == 'Node'
    assert _const(_kwargs(target)['executable']) == 'rigid_body_sim'
    on_exit = ast.unparse(kwargs['on_exit'])
    assert 'Shutdown(' in on_exit
    assert handlers[0] in [a for c in _calls(tree, 'RegisterEventHandler') for a in c.args]


def _eval(node, names, cwd):
    """Evaluate the small subset of Python setup.py uses for data_files."""
    if isinstance(node, ast.Constant):
        return node.value
    if isinstance(node, ast.Name):
        return names[node.id]
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add):
        return _eval(node.left, names, cwd) + _eval(node.right, names, cwd)
    if isinstance(node, (ast.List, ast.Tuple)):
        return [_eval(e, names, cwd) for e in node.elts]
    if isinstance(node, ast.Call) and _name(node.func) == 'glob':
        pattern = _eval(node.args[0], names, cwd)
        return sorted(str(Path(p).relative_to(cwd)) for p in glob(str(cwd / pattern)))
    raise AssertionError(f'cannot evaluate {ast.unparse(node)}')


def test_launch_file_installed_by_setup_py():
    tree = ast.parse((BRINGUP / 'setup.py').read_text())
    names = {t.id: n.value.value for n in tree.body
             if isinstance(n, ast.Assign) and isinstance(n.value, ast.Constant)
             for t in n.targets if isinstance(t, ast.Name)}
    data_files = [kw.value for kw in ast.walk(tree)
                  if isinstance(kw, ast.keyword) and kw.arg == 'data_files']
    assert len(data_files) == 1
    installed = {}
    for dest, files in _eval(data_files[0], names, BRINGUP):
        installed.setdefault(dest, []).extend(files)
    assert 'launch/scenario.launch.py' in installed.get('share/attitude_bringup/launch', [])


def test_launch_file_in_built_workspace():
    install = ROOT / 'ros2_ws' / 'install'
    if not (install / 'setup.bash').is_file():
        pytest.skip('ros2_ws not built (bash tools/bootstrap builds it)')
    installed = install / 'attitude_bringup' / 'share' / 'attitude_bringup' / 'launch'
    assert (installed / 'scenario.launch.py').resolve() == LAUNCH.resolve(), (
        'ros2_ws/install is out of date: run bash tools/bootstrap')
