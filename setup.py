"""ament_python package setup for cable_sim (also pip-installable into a plain venv)."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = "cable_sim"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config", glob("config/*.yaml") + glob("config/*.json")),
        (f"share/{PACKAGE}/config/studies", glob("config/studies/*.yaml")),
        (f"share/{PACKAGE}/msg_configs", glob("msg_configs/*")),
        (f"share/{PACKAGE}/launch", glob("launch/*.launch.py")),
    ],
    # Every third-party runtime import of cable_sim/ (the batch tool's are the 'batch' extra; the
    # ROS packages come from the ROS install / the ros-jazzy-* wheels and are declared in
    # package.xml). Lower bounds only; the Makefile pins the versions the project is tested with.
    install_requires=[
        "setuptools",
        "numpy>=1.26",  # everywhere
        "scipy>=1.11",  # integrators, dynamics, statics
        "pyyaml>=6.0",  # scenes
        "numba>=0.59",  # fast kernel (imported by the node at start-up)
        "mcap>=1.1",  # recorder (writer), replay (reader)
        "mcap-ros2-support>=0.5",  # replay: decoding the recorded ROS 2 messages
        "matplotlib>=3.8",  # replay figures / GIF, bench figures
    ],
    extras_require={
        # the MuJoCo side-by-side benchmark and the MoorDyn peer on the mooring line
        "bench": ["mujoco", "moordyn>=2.7"],
        # cable_sim_batch: design studies on a Dask cluster, Parquet results, progress bar
        "batch": ["dask>=2024.1", "distributed>=2024.1", "pyarrow>=14", "tqdm>=4.60"],
        "foxglove": ["foxglove-sdk>=0.30"],  # live view (foxglove_port); speaks foxglove.sdk.v1
    },
    zip_safe=True,
    maintainer="cable_sim developers",
    maintainer_email="dev@cable-sim.local",
    description="Real-time n-link submerged cable simulator (ROS 2 Jazzy)",
    license="Apache-2.0",
    python_requires=">=3.11",
    entry_points={
        "console_scripts": [
            "cable_sim_node = cable_sim.ros.node:main",
            "cable_sim_replay = cable_sim.analysis.replay:main",
            "cable_sim_bench = cable_sim.analysis.bench:main",
            "cable_sim_batch = cable_sim.analysis.batch.cli:main",
            "cable_sim_urdf = cable_sim.ros.urdf_cli:main",
        ],
    },
)
