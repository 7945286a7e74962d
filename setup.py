"""pip installation of the kinematics core, CLI and message adapters (no ROS needed).

Under ROS 2 the package is built by colcon through CMakeLists.txt (ament_cmake), which installs the
same two Python packages; this file is for `pip install .` without ROS.
"""

from glob import glob

from setuptools import find_packages, setup

setup(
    name="kinematics_service",
    version="0.1.0",
    description="Product-of-exponentials kinematics (FK, Jacobians, IK) for ROS 2 and plain Python",
    long_description=open("README.md", encoding="utf-8").read(),
    long_description_content_type="text/markdown",
    license="Apache-2.0",
    python_requires=">=3.10",
    packages=find_packages(
        include=["kinematics_node", "kinematics_node.*", "msg_adapters", "msg_adapters.*"]
    ),
    package_data={"kinematics_node": ["py.typed"], "msg_adapters": ["py.typed"]},
    # Bundled robots and parameters land where a colcon install puts them too (share/<package>/config);
    # kinematics_node.sim.robots looks there, and in the source tree for editable installs.
    data_files=[
        (
            "share/kinematics_service/config",
            sorted(glob("config/*.yaml") + glob("config/*.rviz") + glob("config/*.xml")),
        ),
        ("share/kinematics_service/config/robots", sorted(glob("config/robots/*"))),
    ],
    install_requires=["numpy>=1.23", "scipy>=1.9", "yourdfpy>=0.0.53"],
    extras_require={
        "xacro": ["xacro>=2.0"],
        "demo": ["matplotlib>=3.5"],
        # `kinematics bag` and `record-demo`: rosbag2 recordings without ROS; tqdm's progress bar
        "bags": ["rosbags>=0.10", "tqdm>=4"],
        # `kinematics reach`'s HDF5 maps (Reuleaux's layout; .npz needs nothing) and progress bar
        "maps": ["h5py>=3", "tqdm>=4"],
        # many recordings and workspace maps on a Dask cluster: kinematics bag/reach --scheduler
        "dask": ["dask[distributed]>=2024.1"],
        # Jerk limits of kinematics_node.core.servo (optional: without it the servo smooths within
        # the position, velocity and acceleration limits, with no jerk limit)
        "servo": ["ruckig>=0.9"],
        "test": [
            "pytest>=7",
            "pin>=2.7",  # Pinocchio: the independent FK/Jacobian oracle
            "example-robot-data>=4",  # real robot descriptions nobody here wrote
            "rosbags>=0.10",  # ROS 2 message definitions and CDR without ROS
            "catkin_pkg>=1.0",
            "xacro>=2.0",
            "matplotlib>=3.5",
            "pyyaml>=5",  # reads config/kinematics.yaml in the package-file tests
            "ruckig>=0.9",  # the servo's jerk-limited smoothing (extra "servo")
            "tqdm>=4",  # the recordings' progress bar (extra "bags")
            "mcap-ros2-support>=0.5",  # decodes recordings independently of rosbags
            "dask[distributed]>=2024.1",  # a real local cluster and dask scheduler/worker commands
            "h5py>=3",  # kinematics reach's maps, read back (extra "maps")
        ],
        # Peers for the side-by-side benchmarks; KDL comes from Debian (apt install python3-pykdl).
        "bench": [
            "pin>=2.7",
            "example-robot-data>=4",
            "modern-robotics>=1.1",
            "ikpy>=3.3",
            "roboticstoolbox-python>=1.1",
            "pybullet>=3.2",  # only for its KUKA iiwa description
            "ruckig>=0.9",  # benchmarks/servo_benchmark.py
            "rosbags>=0.10",  # benchmarks/bag_benchmark.py
        ],
        # ruff within one minor release: `make test` checks the formatting, whose output may
        # change between minor releases
        "lint": ["ruff>=0.17,<0.18", "mypy>=1.10"],
    },
    entry_points={"console_scripts": ["kinematics = kinematics_node.cli.main:main"]},
)
