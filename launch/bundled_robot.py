"""What sim_arm.launch.py and servo.launch.py share: a robot (bundled, or the user's own URDF or
xacro file), simulated, described and watched by the kinematics node.

Not a launch file (`ros2 launch` takes *.launch.py). The launch files load it by its path, from
beside their own (`__file__`; four lines at the top of each): `ros2 launch` loads a launch file
from share/kinematics_service/launch (CMakeLists.txt installs launch/ whole, this file with it),
which is not on sys.path (nor is the working directory of `ros2 launch` that folder).

Their common arguments (`arguments`): robot, description_file, xacro_args, base_link, tip_link,
rate, rviz, state_publisher. Their common nodes (`robot_nodes`): robot_state_publisher (TF and the
robot_description topic, from the file's XML, xacro expanded; with state_publisher:=kinematics_node
none, and the kinematics node publishes /tf and /tf_static itself: publish_tf), sim_arm (joint_states of every
moving joint without <mimic>, which robot_state_publisher needs: a Panda's finger too), the kinematics node on the chosen chain
(config/kinematics.yaml, then the bundled file and the chain), and RViz on request; all with
the package's Fast DDS profile (`kinematics_node.ros.env.fastdds_profile_env`).

The user's own robot (description_file, which overrides robot): the nodes read the file
themselves (robot_description_file and xacro_args, as kinematics.launch.py passes them); the
chain is base_link -> tip_link, empty meaning the nodes' own choice (the one tip when there is
one; with several, set tip_link: the nodes wait for it and list the candidates).
"""

import os  # noqa: I001  (ruff would sort `launch` as first-party: the repo has a launch/ folder)

from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue

from kinematics_node.ros.env import fastdds_profile_env
from kinematics_node.service.description_file import read_description_file
from kinematics_node.service.robot_model import LinkTree
from kinematics_node.sim.robots import default_chain_links

PACKAGE = "kinematics_service"


def arguments():
    """The launch arguments both launch files declare (robot, description_file, xacro_args,
    base_link, tip_link, rate, rviz, state_publisher)."""
    return [
        DeclareLaunchArgument(
            "robot",
            default_value="ur5e",
            description="bundled robot: ur5e, panda, iiwa14, scara or planar3r",
        ),
        DeclareLaunchArgument(
            "description_file",
            default_value="",
            description="your own robot instead: a URDF or xacro file (relative to here)",
        ),
        DeclareLaunchArgument(
            "xacro_args",
            default_value="",
            description="xacro arguments for description_file: 'name:=value other:=value'",
        ),
        DeclareLaunchArgument(
            "base_link", default_value="", description="chain root (empty: robot default)"
        ),
        DeclareLaunchArgument(
            "tip_link", default_value="", description="end effector (empty: robot default)"
        ),
        DeclareLaunchArgument("rate", default_value="100.0", description="sim rate [Hz]"),
        DeclareLaunchArgument("rviz", default_value="false", description="start RViz"),
        DeclareLaunchArgument(
            "state_publisher",
            default_value="robot_state_publisher",
            description="who publishes the robot's /tf and /tf_static: robot_state_publisher, "
            "or kinematics_node (its publish_tf; for a ROS 2 without robot_state_publisher; "
            "nothing then publishes the robot_description topic, which RViz's robot model reads)",
        ),
    ]


#: The values of the state_publisher argument (the first is the default).
STATE_PUBLISHERS = ("robot_state_publisher", "kinematics_node")


def state_publisher(context):
    """The state_publisher argument: "robot_state_publisher" or "kinematics_node"; raises
    RuntimeError naming the argument and its values for anything else."""
    chosen = LaunchConfiguration("state_publisher").perform(context)
    if chosen not in STATE_PUBLISHERS:
        raise RuntimeError(
            f"state_publisher must be {' or '.join(STATE_PUBLISHERS)}, got {chosen!r}"
        )
    return chosen


def chosen_robot(context, share):
    """{robot, description_file, xacro_args, xml, base_link, tip_link, frame, default_chain,
    rate} of the launch arguments (robot None for the user's own file; frame: RViz's fixed
    frame, base_link or else the description's root link); raises RuntimeError naming the
    bundled robots when `robot` is none of them, or saying what is wrong with description_file."""
    rate = float(LaunchConfiguration("rate").perform(context))
    own = LaunchConfiguration("description_file").perform(context)
    if own:  # absolute: relative to where `ros2 launch` runs, not the nodes
        path = os.path.abspath(os.path.expanduser(own))
        xacro_args = LaunchConfiguration("xacro_args").perform(context)
        base_link = LaunchConfiguration("base_link").perform(context)
        try:
            description = read_description_file(path, xacro_args)
            frame = base_link or LinkTree(description).root_link
        except Exception as exc:  # RobotDescriptionError: the file, the xacro run, an argument
            raise RuntimeError(f"description_file: {exc}") from None
        return {
            "robot": None,
            "description_file": path,
            "xacro_args": xacro_args,
            "xml": description.xml,
            "base_link": base_link,
            "tip_link": LaunchConfiguration("tip_link").perform(context),
            "frame": frame,
            "default_chain": False,
            "rate": rate,
        }
    robot = LaunchConfiguration("robot").perform(context)
    robots_dir = os.path.join(share, "config", "robots")
    description_file = os.path.join(robots_dir, robot + ".urdf")
    if not os.path.isfile(description_file):
        names = sorted(f[: -len(".urdf")] for f in os.listdir(robots_dir) if f.endswith(".urdf"))
        raise RuntimeError(f"unknown robot {robot!r}; bundled robots are: {', '.join(names)}")
    default_base, default_tip = default_chain_links(robot)
    base_link = LaunchConfiguration("base_link").perform(context) or default_base
    tip_link = LaunchConfiguration("tip_link").perform(context) or default_tip
    with open(description_file, encoding="utf-8") as fh:
        xml = fh.read()
    return {
        "robot": robot,
        "description_file": description_file,
        "xacro_args": "",
        "xml": xml,
        "base_link": base_link,
        "tip_link": tip_link,
        "frame": base_link,
        "default_chain": (base_link, tip_link) == (default_base, default_tip),
        "rate": rate,
    }


def description_parameters(robot):
    """The parameters that give a node the robot's file (and its xacro arguments, if any)."""
    params = {"robot_description_file": robot["description_file"]}
    if robot["xacro_args"]:
        params["xacro_args"] = robot["xacro_args"]
    return params


def chain_parameters(robot):
    """The description parameters of the nodes that work on the chain (kinematics node, servo)."""
    return {
        **description_parameters(robot),
        "base_link": robot["base_link"],
        "tip_link": robot["tip_link"],
    }


def dds_env(share):
    """The environment that gives a node the package's Fast DDS profile (unless the caller's
    names one)."""
    return fastdds_profile_env(os.path.join(share, "config", "fastdds_profile.xml"))


def robot_nodes(share, robot, sim_parameters, env, publisher=STATE_PUBLISHERS[0]):
    """robot_state_publisher (where `publisher`, the state_publisher argument, names it), sim_arm
    (the robot and the rate, then `sim_parameters`), the kinematics node (publishing /tf itself
    where `publisher` is "kinematics_node"), and RViz where the rviz argument is true, all in the
    environment `env`."""
    robot_description = ParameterValue(robot["xml"], value_type=str)
    given = {"robot": robot["robot"]} if robot["robot"] else description_parameters(robot)
    ours = publisher == "kinematics_node"
    state = Node(
        package="robot_state_publisher",
        executable="robot_state_publisher",
        name="robot_state_publisher",
        parameters=[{"robot_description": robot_description}],
        output="screen",
        additional_env=env,
    )
    return [
        *([] if ours else [state]),
        Node(
            package=PACKAGE,
            executable="sim_arm",
            name="sim_arm",
            parameters=[{**given, "rate": robot["rate"], **sim_parameters}],
            output="screen",
            additional_env=env,
        ),
        Node(
            package=PACKAGE,
            executable="kinematics_node",
            name="kinematics_node",
            parameters=[
                os.path.join(share, "config", "kinematics.yaml"),
                {**chain_parameters(robot), **({"publish_tf": True} if ours else {})},
            ],
            output="screen",
            additional_env=env,
        ),
        Node(
            package="rviz2",
            executable="rviz2",
            name="rviz2",
            arguments=[
                "-d",
                os.path.join(share, "config", "sim_arm.rviz"),
                "-f",
                robot["frame"],
            ],
            condition=IfCondition(LaunchConfiguration("rviz")),
            output="screen",
            additional_env=env,
        ),
    ]
