"""Behaviour of attitude_bringup's scenario.launch.py (launch/launch_ros are not on PyPI).

The launch file is executed against recording stand-ins of the few ``launch`` and
``launch_ros`` classes it uses (each records its arguments), so what is checked is the
launch description it really builds: the launch arguments, the nodes of
``attitude_core.config.node_graph.NODES`` with their packages, executables, names and
parameters (``SENSING_NODES`` for a scenario with sensors: the graph is chosen when the
launch runs, by an ``OpaqueFunction`` called here with a stand-in context), the
simulator's expected listeners, and the shutdown on the simulator's exit. Each
executable must be a console script of its package's setup.py (so ``ros2 launch`` can
find it), and the file must be installed by attitude_bringup.
"""

import ast
import importlib.util
import sys
import types
from glob import glob
from pathlib import Path

import pytest

from attitude_core.config import node_graph
from attitude_core.contract.time_mode import TimeMode

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / 'src'
BRINGUP = SRC / 'attitude_bringup'
LAUNCH = BRINGUP / 'launch' / 'scenario.launch.py'
CASE1 = ROOT / 'scenarios' / 'case1.yaml'
SENSING = ROOT / 'scenarios' / 'case1_wheels_sensors.yaml'


class Recorded:
    """Stand-in of a launch class: keeps its positional and keyword arguments."""

    def __init__(self, *args, **kwargs):
        self.args, self.kwargs = args, kwargs


def _stand_in(name):
    return type(name, (Recorded,), {})


STAND_INS = {
    'launch': ['LaunchDescription'],
    'launch.actions': [
        'DeclareLaunchArgument',
        'EmitEvent',
        'OpaqueFunction',
        'RegisterEventHandler',
        'Shutdown',
    ],
    'launch.event_handlers': ['OnProcessExit'],
    'launch.events': ['matches_action'],
    'launch.substitutions': ['LaunchConfiguration'],
    'launch_ros.actions': ['LifecycleNode'],
    'launch_ros.event_handlers': ['OnStateTransition'],
    'launch_ros.events.lifecycle': ['ChangeState'],
    'launch_ros.parameter_descriptions': ['ParameterValue'],
}


@pytest.fixture(scope='module')
def description():
    """The LaunchDescription stand-in returned by generate_launch_description()."""
    saved = {m: sys.modules.get(m) for m in [*STAND_INS, 'launch_ros', 'launch_ros.events']}
    classes = {}
    try:
        for module_name, names in STAND_INS.items():
            module = types.ModuleType(module_name)
            for name in names:
                classes[name] = _stand_in(name)
                setattr(module, name, classes[name])
            sys.modules[module_name] = module
        sys.modules.setdefault('launch_ros', types.ModuleType('launch_ros'))
        sys.modules.setdefault('launch_ros.events', types.ModuleType('launch_ros.events'))
        spec = importlib.util.spec_from_file_location('scenario_launch', LAUNCH)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        ld = module.generate_launch_description()
    finally:
        for name, old in saved.items():
            if old is None:
                sys.modules.pop(name, None)
            else:
                sys.modules[name] = old
    assert type(ld).__name__ == 'LaunchDescription'
    return ld


class _Context:
    """Stand-in of a LaunchContext: the launch arguments as given."""

    def __init__(self, scenario):
        self.launch_configurations = {'scenario': str(scenario)}


def _entities(ld, kind, scenario=CASE1):
    """The entities of ``kind``, with the opaque functions run for ``scenario``."""
    key = (id(ld), str(scenario))
    if key not in _EVALUATED:  # once per description and scenario: the same objects
        (entities,) = ld.args
        flat = []
        for e in entities:
            if type(e).__name__ == 'OpaqueFunction':
                flat.extend(e.kwargs['function'](_Context(scenario)))
            else:
                flat.append(e)
        _EVALUATED[key] = flat
    return [e for e in _EVALUATED[key] if type(e).__name__ == kind]


_EVALUATED: dict = {}


def _configuration(value):
    """The launch argument name behind LaunchConfiguration('x') or ParameterValue(it)."""
    if type(value).__name__ == 'ParameterValue':
        assert value.kwargs.get('value_type') is str
        value = value.args[0]
    assert type(value).__name__ == 'LaunchConfiguration', value
    return value.args[0]


@pytest.fixture(scope='module')
def nodes(description):
    return {n.kwargs['executable']: n for n in _entities(description, 'LifecycleNode')}


def test_usage_in_docstring():
    doc = ast.get_docstring(ast.parse(LAUNCH.read_text()))
    assert 'ros2 launch attitude_bringup scenario.launch.py scenario:=' in doc


def test_launch_arguments(description):
    declared = {a.args[0]: a.kwargs for a in _entities(description, 'DeclareLaunchArgument')}
    assert set(declared) == {'scenario', 'time_mode', 'bag_dir'}
    assert 'default_value' not in declared['scenario']  # required
    assert declared['time_mode']['default_value'] == 'lockstep'
    assert declared['time_mode']['choices'] == [m.value for m in TimeMode]
    assert declared['bag_dir']['default_value'] == 'bag'
    for kwargs in declared.values():
        assert kwargs['description'].strip()


def test_starts_the_node_graph_in_order_on_screen(description):
    started = [
        (n.kwargs['package'], n.kwargs['executable'], n.kwargs['name'])
        for n in _entities(description, 'LifecycleNode')
    ]
    assert started == [(s.package, s.executable, s.node_name) for s in node_graph.NODES]
    for n in _entities(description, 'LifecycleNode'):
        assert n.kwargs['output'] == 'screen'


def _console_scripts(pkg):
    tree = ast.parse((SRC / pkg / 'setup.py').read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.keyword) and node.arg == 'entry_points':
            entries = ast.literal_eval(node.value).get('console_scripts', [])
            return {entry.split('=', 1)[0].strip() for entry in entries}
    return set()


def test_a_scenario_with_sensors_starts_the_estimator(description):
    started = [n.kwargs['executable'] for n in _entities(description, 'LifecycleNode', SENSING)]
    assert started == [s.executable for s in node_graph.SENSING_NODES]
    nodes = {n.kwargs['executable']: n for n in _entities(description, 'LifecycleNode', SENSING)}
    files, _ = _parameters(nodes[node_graph.ESTIMATOR.executable])
    assert files == ['scenario']
    _, sim = _parameters(nodes[node_graph.SIMULATOR.executable])
    # the estimator and the recorder listen to the simulator's measurements
    assert sim['lockstep.expected_subscribers'] == 2
    assert node_graph.state_listeners(node_graph.SENSING_NODES) == 2


@pytest.mark.parametrize('spec', node_graph.SENSING_NODES, ids=lambda s: s.executable)
def test_node_executable_is_a_console_script(spec):
    scripts = _console_scripts(spec.package)
    assert spec.executable in scripts, (
        f"the node graph starts {spec.package}/{spec.executable}, but src/{spec.package}/"
        f"setup.py declares no console script '{spec.executable}' (console_scripts: "
        f"{sorted(scripts)})"
    )


def _parameters(node):
    """(launch arguments used as parameter files, {parameter name: value})."""
    files, values = [], {}
    for item in node.kwargs['parameters']:
        if isinstance(item, dict):
            values.update(item)
        else:
            files.append(_configuration(item))
    return files, values


def test_nodes_that_read_the_scenario_get_the_scenario_file(nodes):
    for spec in node_graph.NODES:
        files, _ = _parameters(nodes[spec.executable])
        want = ['scenario'] if spec.parameters.scenario is not None else []
        assert files == want, f'{spec.executable}: parameter files {files}'


def test_node_parameters(nodes):
    _, sim = _parameters(nodes[node_graph.SIMULATOR.executable])
    assert _configuration(sim['time_mode']) == 'time_mode'
    # planner, controller and recorder all listen to the simulator's state
    assert sim['lockstep.expected_subscribers'] == 3 == node_graph.state_listeners()
    _, recorder = _parameters(nodes[node_graph.RECORDER.executable])
    assert _configuration(recorder['output_dir']) == 'bag_dir'
    assert _configuration(recorder['scenario_file']) == 'scenario'
    own = {spec.executable: {p.key for p in spec.parameters.own} for spec in node_graph.NODES}
    for exe, node in nodes.items():
        _, values = _parameters(node)
        assert set(values) <= own[exe], exe  # only parameters the node declares


def _transition(emit):
    """(the node an EmitEvent(ChangeState) targets, its transition id)."""
    assert type(emit).__name__ == 'EmitEvent'
    change = emit.kwargs['event']
    assert type(change).__name__ == 'ChangeState'
    matcher = change.kwargs['lifecycle_node_matcher']
    assert type(matcher).__name__ == 'matches_action'
    return matcher.args[0], change.kwargs['transition_id']


@pytest.mark.parametrize('scenario', [CASE1, SENSING], ids=['case1', 'sensors'])
def test_managed_nodes_are_configured_then_activated_in_table_order(description, scenario):
    """Walk the launch's lifecycle events as launch_ros would fire them: each node's
    configure and activate, one at a time, in the node table's order."""
    from lifecycle_msgs.msg import Transition

    nodes = _entities(description, 'LifecycleNode', scenario)
    for n in nodes:
        assert n.kwargs['namespace'] == ''  # managed nodes need one (root, as by hand)
    handlers = {}
    for h in _entities(description, 'RegisterEventHandler', scenario):
        (event,) = h.args
        if type(event).__name__ == 'OnStateTransition':
            key = (id(event.kwargs['target_lifecycle_node']), event.kwargs['start_state'],
                   event.kwargs['goal_state'])  # fmt: skip
            assert key not in handlers
            (handlers[key],) = event.kwargs['entities']
    (first,) = _entities(description, 'EmitEvent', scenario)  # at launch
    pending, done = [_transition(first)], []
    ends = {Transition.TRANSITION_CONFIGURE: ('configuring', 'inactive'),
            Transition.TRANSITION_ACTIVATE: ('activating', 'active')}  # fmt: skip
    while pending:
        node, transition = pending.pop()
        done.append((node.kwargs['executable'], transition))
        follow = handlers.get((id(node), *ends[transition]))
        if follow is not None:
            pending.append(_transition(follow))
    order = [n.kwargs['executable'] for n in nodes]
    assert done == [(e, Transition.TRANSITION_CONFIGURE) for e in order] + [
        (e, Transition.TRANSITION_ACTIVATE) for e in order
    ]


def test_shutdown_when_the_simulator_exits(description, nodes):
    handlers = [
        h
        for h in _entities(description, 'RegisterEventHandler')
        if type(h.args[0]).__name__ == 'OnProcessExit'
    ]
    (handler,) = handlers
    (on_exit,) = handler.args
    assert type(on_exit).__name__ == 'OnProcessExit'
    assert on_exit.kwargs['target_action'] is nodes[node_graph.SIMULATOR.executable]
    assert [type(a).__name__ for a in on_exit.kwargs['on_exit']] == ['Shutdown']


def _name(func):
    """``glob`` for ``glob(...)`` and ``x.glob(...)``."""
    if isinstance(func, ast.Name):
        return func.id
    if isinstance(func, ast.Attribute):
        return func.attr
    return None


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
    names = {
        t.id: n.value.value
        for n in tree.body
        if isinstance(n, ast.Assign) and isinstance(n.value, ast.Constant)
        for t in n.targets
        if isinstance(t, ast.Name)
    }
    data_files = [
        kw.value for kw in ast.walk(tree) if isinstance(kw, ast.keyword) and kw.arg == 'data_files'
    ]
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
        'ros2_ws/install is out of date: run bash tools/bootstrap'
    )
