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

Starts ``bag_recorder``, ``fepf_planner``, ``pd_controller`` and ``rigid_body_sim``. In
lockstep the simulator expects three subscribers: the planner, the controller and the
recorder. The whole launch shuts down when the simulator exits (end of the simulated time,
or an error).

Machines without ROS 2's launch (pip wheels only) run the same nodes with ``attitude-run``.
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, RegisterEventHandler, Shutdown
from launch.event_handlers import OnProcessExit
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue


def generate_launch_description():
    scenario = LaunchConfiguration('scenario')
    time_mode = LaunchConfiguration('time_mode')
    bag_dir = LaunchConfiguration('bag_dir')

    recorder = Node(
        package='attitude_bringup',
        executable='bag_recorder',
        parameters=[scenario, {
            'output_dir': ParameterValue(bag_dir, value_type=str),
            # The scenario travels inside the bag, so attitude-report needs nothing else.
            'scenario_file': ParameterValue(scenario, value_type=str),
        }],
        output='screen',
    )
    planner = Node(
        package='attitude_planner',
        executable='fepf_planner',
        parameters=[scenario],
        output='screen',
    )
    controller = Node(
        package='attitude_controller',
        executable='pd_controller',
        parameters=[scenario],
        output='screen',
    )
    simulator = Node(
        package='spacecraft_sim',
        executable='rigid_body_sim',
        parameters=[scenario, {
            'time_mode': ParameterValue(time_mode, value_type=str),
            # planner, controller and bag_recorder all subscribe to the simulator's state
            'lockstep.expected_subscribers': 3,
        }],
        output='screen',
    )

    return LaunchDescription([
        DeclareLaunchArgument(
            'scenario',
            description='Path of the scenario parameters file (e.g. $PWD/scenarios/case1.yaml)'),
        DeclareLaunchArgument(
            'time_mode', default_value='lockstep', choices=['lockstep', 'realtime'],
            description='Pacing of the simulator: lockstep or realtime'),
        DeclareLaunchArgument(
            'bag_dir', default_value='bag',
            description='Output directory of the recorded bag'),
        recorder,
        planner,
        controller,
        simulator,
        RegisterEventHandler(OnProcessExit(
            target_action=simulator,
            on_exit=[Shutdown(reason='rigid_body_sim exited')],
        )),
    ])
