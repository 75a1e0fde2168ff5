"""Run one scenario through the ROS 2 nodes and record it (full ROS 2 installs: needs launch_ros).

Usage, after building and sourcing the workspace (see ros2_ws/README.md)::

    ros2 launch attitude_bringup scenario.launch.py scenario:=$PWD/scenarios/case1.yaml
    ros2 launch attitude_bringup scenario.launch.py scenario:=$PWD/scenarios/case2.yaml \\
        time_mode:=realtime bag_dir:=runs/case2_bag

Launch arguments:

* ``scenario`` (required): path of the scenario parameters file, given to every node
  (an absolute path is safest: relative paths are taken from the launch's working directory).
* ``time_mode``: ``lockstep`` (default) or ``realtime``, the simulator's pacing (see
  spacecraft_sim).
* ``bag_dir``: output directory of the bag written by ``bag_recorder`` (default ``bag``).

Starts the nodes of :func:`attitude_core.config.node_graph.graph` for the scenario
(recorder, planner, controller, simulator; and the estimator first when the scenario
declares ``sensors.*``), the same table ``attitude-run`` starts; the simulator waits for
every state listener of that table (``node_graph.state_listeners``: planner, controller
and recorder; estimator and recorder with sensors). The scenario file is read when the
launch runs (an ``OpaqueFunction``), to choose the graph. The whole launch shuts down
when the simulator exits (end of the simulated time, or an error).

The nodes are managed (``launch_ros.actions.LifecycleNode``) and brought up with
launch_ros's lifecycle events in the node table's order, as ``attitude-run``'s manager
does: the first node is configured at once; each node reaching ``inactive`` has the
next configured, the last one has the first activated; each node reaching ``active``
has the next activated. A node whose configure fails (a bad scenario) exits 2 and the
bring-up stops there.

Machines without ROS 2's launch (pip wheels only) run the same nodes with ``attitude-run``.
"""

from launch import LaunchDescription
from launch.actions import (
    DeclareLaunchArgument,
    EmitEvent,
    OpaqueFunction,
    RegisterEventHandler,
    Shutdown,
)
from launch.event_handlers import OnProcessExit
from launch.events import matches_action
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import LifecycleNode
from launch_ros.event_handlers import OnStateTransition
from launch_ros.events.lifecycle import ChangeState
from launch_ros.parameter_descriptions import ParameterValue
from lifecycle_msgs.msg import Transition

from attitude_core.config import node_graph as graph
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.time_mode import TimeMode


def _nodes(context):
    """The scenario's node graph and the shutdown on the simulator's exit."""
    scenario = LaunchConfiguration('scenario')
    time_mode = LaunchConfiguration('time_mode')
    bag_dir = LaunchConfiguration('bag_dir')
    loaded = load_scenario(context.launch_configurations['scenario'])
    run_graph = graph.graph(loaded.sensors is not None, loaded.wheels is not None)

    own_parameters = {
        graph.RECORDER.role: {
            'output_dir': ParameterValue(bag_dir, value_type=str),
            # The scenario travels inside the bag, so attitude-report needs nothing else.
            'scenario_file': ParameterValue(scenario, value_type=str),
        },
        graph.SIMULATOR.role: {
            'time_mode': ParameterValue(time_mode, value_type=str),
            'lockstep.expected_subscribers': graph.state_listeners(run_graph.nodes),
        },
    }
    nodes = {}
    for spec in run_graph.nodes:
        files = [scenario] if spec.parameters.scenario is not None else []
        nodes[spec.role] = LifecycleNode(
            package=spec.package,
            executable=spec.executable,
            name=spec.node_name,
            namespace='',
            parameters=files + [own_parameters.get(spec.role, {})],
            output='screen',
        )
    return [
        *nodes.values(),
        *_bring_up(list(nodes.values())),
        RegisterEventHandler(
            OnProcessExit(
                target_action=nodes[graph.SIMULATOR.role],
                on_exit=[Shutdown(reason=f'{graph.SIMULATOR.executable} exited')],
            )
        ),
    ]


def _change(node, transition_id):
    return EmitEvent(
        event=ChangeState(lifecycle_node_matcher=matches_action(node), transition_id=transition_id)
    )


def _when(node, start_state, goal_state, action):
    """``action`` when ``node`` ends a transition (only that one: a later deactivation
    does not configure or activate anything)."""
    return RegisterEventHandler(
        OnStateTransition(
            target_lifecycle_node=node,
            start_state=start_state,
            goal_state=goal_state,
            entities=[action],
        )
    )


def _bring_up(order):
    """Configure in order, then activate in order (one node at a time)."""
    configure, activate = Transition.TRANSITION_CONFIGURE, Transition.TRANSITION_ACTIVATE
    actions = [_change(order[0], configure)]
    for node, following in zip(order, order[1:], strict=False):
        actions.append(_when(node, 'configuring', 'inactive', _change(following, configure)))
        actions.append(_when(node, 'activating', 'active', _change(following, activate)))
    actions.append(_when(order[-1], 'configuring', 'inactive', _change(order[0], activate)))
    return actions


def generate_launch_description():
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                'scenario',
                description='Path of the scenario parameters file (e.g. $PWD/scenarios/case1.yaml)',
            ),
            DeclareLaunchArgument(
                'time_mode',
                default_value=TimeMode.LOCKSTEP.value,
                choices=[m.value for m in TimeMode],
                description='Pacing of the simulator: lockstep or realtime',
            ),
            DeclareLaunchArgument(
                'bag_dir', default_value='bag', description='Output directory of the recorded bag'
            ),
            OpaqueFunction(function=_nodes),
        ]
    )
