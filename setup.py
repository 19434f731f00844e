"""ament_python packaging: `ros2 run sail_ros <tool>` runs lib/sail_ros/<tool>."""

from glob import glob

from setuptools import find_packages, setup

from sail_ros.cli import TOOLS

package_name = "sail_ros"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    package_data={"sail_ros.ros": ["fastdds_discovery.xml", "fastdds_client.xml"]},  # by path
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", glob("config/*.yaml") + glob("config/*.json")),
        ("share/" + package_name + "/launch", glob("launch/*.launch.py")),
        ("share/" + package_name + "/msg_docs", glob("msg_docs/*.md")),
        ("share/" + package_name + "/docs", ["docs/model.md", "docs/control.md"]),
    ],
    install_requires=["setuptools"],
    zip_safe=False,  # the fastdds_*.xml files are read from their paths
    maintainer="sail_ros maintainers",
    maintainer_email="maintainers@sail-ros.dev",
    description="Real-time deployment dynamics of a four-quadrant solar sail.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [f"{name} = sail_ros.cli:main_{name}" for name in TOOLS]
        + ["sail-ros = sail_ros.cli:main"],
    },
)
