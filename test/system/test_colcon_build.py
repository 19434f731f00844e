"""The package builds with colcon, and the installed `sim` (what `ros2 run sail_ros
sim` executes) runs from the install space and publishes."""

import contextlib
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from harness import ROOT, private_context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from sail_ros import topics

pytestmark = pytest.mark.multiprocess

PYTHON = f"python{sys.version_info.major}.{sys.version_info.minor}"


@pytest.fixture(scope="module")
def install(tmp_path_factory):
    """Colcon build (not --symlink-install) into a private build, install and log base."""
    colcon = shutil.which("colcon") or shutil.which("colcon", path=Path(sys.executable).parent)
    assert colcon, "colcon is not installed (scripts/setup_env.sh installs it)"
    base = tmp_path_factory.mktemp("colcon")
    result = subprocess.run(
        [
            colcon,
            "--log-base",
            str(base / "log"),
            "build",
            "--base-paths",
            str(ROOT),
            "--packages-select",
            "sail_ros",
            "--build-base",
            str(base / "build"),
            "--install-base",
            str(base / "install"),
            "--event-handlers",
            "console_direct-",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=base,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    return base / "install"


def install_env(install: Path, home: Path) -> dict:
    """What sourcing install/setup.bash would add: the package's prefix for ament and
    its site-packages for Python; the test domain (conftest), a private home."""
    prefix = install / "sail_ros"
    return dict(
        os.environ,
        AMENT_PREFIX_PATH=os.pathsep.join(
            filter(None, [str(prefix), os.environ.get("AMENT_PREFIX_PATH")])
        ),
        PYTHONPATH=os.pathsep.join(
            filter(
                None, [str(prefix / "lib" / PYTHON / "site-packages"), os.environ.get("PYTHONPATH")]
            )
        ),
        HOME=str(home),
        ROS_LOG_DIR=str(home / "log"),
        PYTHONUNBUFFERED="1",
    )


def test_install_space_holds_the_executables_and_config(install):
    prefix = install / "sail_ros"
    for tool in ("sim", "recorder", "replay", "sail-ros"):
        assert os.access(prefix / "lib" / "sail_ros" / tool, os.X_OK), tool
    assert (prefix / "share" / "sail_ros" / "config" / "sim.yaml").is_file()
    assert (prefix / "share" / "sail_ros" / "package.xml").is_file()
    assert (prefix / "share" / "sail_ros" / "docs" / "model.md").is_file()
    package = prefix / "lib" / PYTHON / "site-packages" / "sail_ros"
    for profile in ("fastdds_discovery.xml", "fastdds_client.xml"):  # read by Fast DDS, by path
        assert (package / "ros" / profile).is_file()
    assert (prefix / "share" / "ament_index" / "resource_index" / "packages" / "sail_ros").is_file()


def test_installed_sim_runs_and_publishes(install, tmp_path, monkeypatch):
    env = install_env(install, tmp_path)
    prefix = install / "sail_ros"
    # the installed copy is the one imported, not the source tree
    where = subprocess.run(
        [sys.executable, "-c", "import sail_ros.nodes.sim as m; print(m.__file__)"],
        env=env,
        capture_output=True,
        text=True,
        cwd=tmp_path,
        check=True,
    ).stdout.strip()
    assert Path(where).is_relative_to(prefix), where

    contexts = contextlib.ExitStack()
    context = contexts.enter_context(private_context(int(env["ROS_DOMAIN_ID"])))
    node = Node("colcon_test_listener", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    states, clocks = [], []
    node.create_subscription(JointState, topics.BOOM_STATE, states.append, topics.STATE_QOS)
    node.create_subscription(Clock, topics.CLOCK, clocks.append, topics.CLOCK_QOS)
    log = tmp_path / "sim.log"
    with open(log, "w") as output:
        sim = subprocess.Popen(
            [
                str(prefix / "lib" / "sail_ros" / "sim"),
                "--ros-args",
                "--params-file",
                str(prefix / "share" / "sail_ros" / "config" / "sim.yaml"),
                "-p",
                "time_scale:=5.0",
            ],
            env=env,
            stdout=output,
            stderr=subprocess.STDOUT,
            cwd=tmp_path,
        )
    try:
        deadline = time.monotonic() + 30.0
        while len(states) < 20 or len(clocks) < 20:
            assert sim.poll() is None, log.read_text()
            assert time.monotonic() < deadline, "no boom_state and /clock from the installed sim"
            executor.spin_once(timeout_sec=0.05)
        sim.send_signal(signal.SIGINT)
        assert sim.wait(20) == 0, log.read_text()
    finally:
        if sim.poll() is None:
            sim.kill()
            sim.wait()
        executor.shutdown()
        node.destroy_node()
        contexts.close()
    assert list(states[-1].position) == [10.0] * 4
    assert "time scale 5" in log.read_text()
