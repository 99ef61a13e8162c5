"""Launch one cable_sim mooring leg: the simulator node, robot_state_publisher, optional Foxglove.

    ros2 launch cable_sim cable_sim.launch.py scene:=mooring_line namespace:=leg1 frame_prefix:=leg1/

- ``cable_sim_node`` runs with the scene's parameter file from ``share/cable_sim/config`` in the
  namespace (its topics become ``/<namespace>/joint_states`` ...) and stamps its outputs in
  ``<frame_prefix>world``;
- ``robot_state_publisher`` in the same namespace gets ``robot_description`` from
  ``cable_sim_urdf <the same parameter file>`` and turns the node's ``joint_states`` into
  ``/tf`` (moving joints) and ``/tf_static`` (fixed frames), its frames prefixed with
  ``frame_prefix`` so that several legs do not fight over the same frame names;
- ``foxglove_bridge`` (package foxglove_bridge) when ``use_foxglove:=true``: start it in one
  launch only, it serves every topic of the ROS graph on ``foxglove_port``.

Needs ROS 2 (launch, launch_ros, robot_state_publisher); this file is only parsed and executed
against stubs in the package's tests (test/ros/test_launch_file.py).
"""

# ruff: noqa: I001 - ruff takes `launch` for this repository's launch/ folder (first party)
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import Command, LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackagePrefix, FindPackageShare

#: name, default, description of every launch argument (documented in the README).
ARGUMENTS = (
    ("scene", "mooring_line", "shipped scene name: share/cable_sim/config/<scene>.yaml"),
    ("namespace", "", "ROS namespace of the node and its robot_state_publisher (one per mooring leg)"),
    ("frame_prefix", "", "prefix of every TF frame of this leg, e.g. leg1/ (empty: world, link_1, ...)"),
    ("record", "true", "record the run to MCAP (the node's record parameter)"),
    ("use_foxglove", "false", "also start foxglove_bridge (start it in one launch only)"),
    ("foxglove_port", "8765", "WebSocket port of foxglove_bridge"),
)


def generate_launch_description() -> LaunchDescription:
    """The launch description: arguments, cable_sim_node, robot_state_publisher, foxglove_bridge."""
    scene = LaunchConfiguration("scene")
    namespace = LaunchConfiguration("namespace")
    frame_prefix = LaunchConfiguration("frame_prefix")
    # lists of substitutions concatenate: <share>/config/<scene>.yaml, <prefix>/lib/cable_sim/...
    params_file = [FindPackageShare("cable_sim"), "/config/", scene, ".yaml"]
    urdf_exe = [FindPackagePrefix("cable_sim"), "/lib/cable_sim/cable_sim_urdf"]
    robot_description = ParameterValue(Command([*urdf_exe, " ", *params_file]), value_type=str)
    return LaunchDescription([
        *(DeclareLaunchArgument(name, default_value=default, description=desc)
          for name, default, desc in ARGUMENTS),
        Node(package="cable_sim", executable="cable_sim_node", name="cable_sim_node", namespace=namespace,
             output="screen",
             parameters=[params_file,
                         {"record": ParameterValue(LaunchConfiguration("record"), value_type=bool),
                          "frame_id": ParameterValue([frame_prefix, "world"], value_type=str)}]),
        Node(package="robot_state_publisher", executable="robot_state_publisher",
             name="robot_state_publisher", namespace=namespace, output="screen",
             parameters=[{"robot_description": robot_description,
                          "frame_prefix": ParameterValue(frame_prefix, value_type=str)}]),
        Node(package="foxglove_bridge", executable="foxglove_bridge", name="foxglove_bridge",
             output="screen", condition=IfCondition(LaunchConfiguration("use_foxglove")),
             parameters=[{"port": ParameterValue(LaunchConfiguration("foxglove_port"), value_type=int)}]),
    ])
