"""Build script for rigid_body_sim (ament_python): works with colcon and with plain pip."""

import os
import xml.etree.ElementTree as ET
from glob import glob

from setuptools import find_packages, setup

package_name = "rigid_body_sim"
here = os.path.dirname(os.path.abspath(__file__))
# package.xml is the single source of the version.
version = ET.parse(os.path.join(here, "package.xml")).getroot().findtext("version")

setup(
    name=package_name,
    version=version,
    # Only the package itself: benchmarks/, test/ and tools of this repository stay out of the
    # user's environment (a test checks what a colcon install contains).
    packages=find_packages(include=[package_name, package_name + ".*"]) + [package_name + ".config"],
    # config/ is also the package data of rigid_body_sim.config: the default scene is found with
    # importlib.resources wherever the package is installed (rigid_body_sim/package_data.py).
    package_dir={package_name + ".config": "config"},
    package_data={package_name + ".config": ["*.yaml"]},
    # Its data: the manifest, the ament index marker, and config/ (scenes, params.yaml).
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", sorted(glob("config/*.yaml"))),
    ],
    python_requires=">=3.10",
    # Exact pins are in requirements.txt; these name what the package imports.
    install_requires=["numpy", "scipy", "numba", "pyyaml", "matplotlib", "mcap", "mcap-ros2-support", "tqdm"],
    # test: what `colcon test` looks for to run pytest (pins in requirements-test.txt);
    # bench: benchmarks/ compares with MuJoCo and PyBullet (pip install -e .[bench]; pin in requirements-bench.txt);
    # view: `rigid-body-sim view` (rigid_body_sim/view/; pins in requirements-view.txt).
    extras_require={"test": ["pytest", "hypothesis"], "bench": ["mujoco==4.0.0", "pybullet==3.2.7"], "view": ["viser==1.1.1"]},
    zip_safe=True,
    maintainer="rigid_body_sim maintainers",
    maintainer_email="rigid-body-sim@example.com",
    description="Rigid-body dynamics simulator with a ROS 2 interface.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "rigid_body_sim_node = rigid_body_sim.ros.main:main",
            "rigid-body-sim = rigid_body_sim.cli:main",
        ],
    },
)
