"""The simulator and its recorder (and, if asked, the Foxglove bridge) with params files.

Needs a full ROS 2 install (`ros2 launch`), which the PyPI ROS packages do not have:

    ros2 launch sail_ros sail.launch.py
    ros2 launch sail_ros sail.launch.py namespace:=sat2 bridge:=true
    ros2 launch sail_ros sail.launch.py sim_params:=my_sim.yaml

Each params file holds a section for its node (`sail_sim:`, `sail_recorder:`,
`sail_bridge:`); the defaults are the package's config/sim.yaml, recorder.yaml and
bridge.yaml (every parameter at its default value).
"""

from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

from launch import LaunchDescription

PACKAGE = "sail_ros"
# executable (a tool of `sail-ros`) -> (node name, its params file argument, default file)
NODES = {
    "sim": ("sail_sim", "sim_params", "sim.yaml"),
    "recorder": ("sail_recorder", "recorder_params", "recorder.yaml"),
    "bridge": ("sail_bridge", "bridge_params", "bridge.yaml"),
}


def generate_launch_description() -> LaunchDescription:
    namespace = LaunchConfiguration("namespace")
    arguments = [
        DeclareLaunchArgument(
            "namespace",
            default_value="",
            description="namespace of the sail's nodes and topics (several sails: one each)",
        ),
        DeclareLaunchArgument(
            "bridge",
            default_value="false",
            description="also start sail-ros bridge (Foxglove WebSocket on 127.0.0.1:8765)",
        ),
    ]
    nodes = []
    for executable, (name, argument, default_file) in NODES.items():
        arguments.append(
            DeclareLaunchArgument(
                argument,
                default_value=PathJoinSubstitution(
                    [FindPackageShare(PACKAGE), "config", default_file]
                ),
                description=f"params file of {name} (a section '{name}:')",
            )
        )
        nodes.append(
            Node(
                package=PACKAGE,
                executable=executable,
                name=name,
                namespace=namespace,
                parameters=[LaunchConfiguration(argument)],
                output="screen",
                condition=IfCondition(LaunchConfiguration("bridge"))
                if executable == "bridge"
                else None,
            )
        )
    return LaunchDescription(arguments + nodes)
