"""The package in a ROS 2 workspace: ``colcon build`` and ``colcon test`` in a fresh temporary
workspace, with colcon from PyPI (colcon-core, colcon-ros, colcon-python-setup-py, pinned in
requirements-test.txt), then the installed ``rigid_body_sim_node`` publishing a pose over DDS.

colcon runs from this interpreter's environment, as a ROS installation runs it from the
system python3 that has rclpy: the installed console scripts get its shebang.

The compiled numba kernels are cached beside the core's sources (rigid_body_sim/core/kernels/__pycache__);
a fresh installation compiles them once, about 100 s on this machine. So that the default suite
does not pay that, the checkout's cache is copied beside the installed core (the sources keep
their modification times, which is what numba checks). The default run builds once and runs the
installed node; the slow run (``make test-slow``) adds ``colcon test`` on a few files and on the
whole suite, and a fresh installation started cold (``test_cold_installed_node_compiles_and_publishes``):

    .venv/bin/python -m pytest -m slow test/test_workspace.py
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import rclpy
from geometry_msgs.msg import PoseStamped
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

pytestmark = [pytest.mark.ros, pytest.mark.timeout(900)]

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
PACKAGE = "rigid_body_sim"
SKIP_DIRS = {".git", ".venv", "build", "install", "log", "__pycache__", ".pytest_cache", ".hypothesis"}


def source_files() -> list[Path]:
    """The files of the package a user would clone: git's tracked and untracked-but-not-ignored
    files, or, without git, everything outside build output, caches and the venv."""
    try:
        out = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
                             capture_output=True, check=True).stdout
        files = [ROOT / name for name in out.decode().split("\0") if name]
    except (OSError, subprocess.CalledProcessError):
        files = [p for p in ROOT.rglob("*") if p.is_file() and not SKIP_DIRS & set(p.relative_to(ROOT).parts)]
    return [p for p in files if p.is_file()]


def copy_kernel_cache(package_dir: Path) -> None:
    """Copy the checkout's compiled numba kernels beside ``package_dir``'s core (same sources),
    with the stamp of the sources they were compiled from (core/kernels/jit.py keeps a cache only with
    its stamp)."""
    from rigid_body_sim.core.kernels.jit import COMPLETE_NAME, STAMP_NAME

    kernels = ROOT / PACKAGE / "core" / "kernels"
    for cache in [kernels / "__pycache__", *(p for p in kernels.rglob("__pycache__") if p.parent != kernels)]:
        target = package_dir / cache.relative_to(ROOT / PACKAGE)
        target.mkdir(parents=True, exist_ok=True)
        for path in [*cache.glob("*.nbi"), *cache.glob("*.nbc"), *cache.glob(STAMP_NAME), *cache.glob(COMPLETE_NAME)]:
            shutil.copy2(path, target / path.name)


def make_workspace(base: Path, *, kernel_cache: bool) -> Path:
    """A fresh workspace with a copy of the package in src/ (modification times kept), and the
    checkout's kernel cache if ``kernel_cache``."""
    src = base / "src" / PACKAGE
    for path in source_files():
        target = src / path.relative_to(ROOT)
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(path, target)
    if kernel_cache:
        copy_kernel_cache(src / PACKAGE)
    modules = ROOT / "test" / "foxglove" / "node_modules"  # Foxglove's readers (make foxglove-deps; git ignores them)
    if modules.is_dir():
        (src / "test" / "foxglove" / "node_modules").symlink_to(modules, target_is_directory=True)
    return base


def colcon(workspace: Path, *args: str, timeout: float = 600.0) -> tuple[subprocess.CompletedProcess, float]:
    env = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}", "COLCON_HOME": str(workspace / ".colcon")}
    start = time.monotonic()
    result = subprocess.run([str(BIN / "colcon"), "--log-base", str(workspace / "log"), *args], cwd=workspace,
                            env=env, capture_output=True, text=True, timeout=timeout)
    took = time.monotonic() - start
    assert result.returncode == 0, f"colcon {' '.join(args)} failed:\n{result.stdout}\n{result.stderr}"
    return result, took


def installed_environment(workspace: Path) -> dict[str, str]:
    """This process's environment after ``. install/setup.sh`` (what a user's shell would have)."""
    out = subprocess.run(["sh", "-c", f'. "{workspace}/install/setup.sh" && env -0'], capture_output=True, check=True,
                         env={**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}"}).stdout
    return dict(item.split("=", 1) for item in out.decode().split("\0") if "=" in item)


def site_packages(workspace: Path) -> Path:
    return workspace / "install" / PACKAGE / "lib" / f"python{sys.version_info[0]}.{sys.version_info[1]}" / "site-packages"


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> Path:
    workspace = make_workspace(tmp_path_factory.mktemp("ws"), kernel_cache=True)
    result, took = colcon(workspace, "build")
    print(f"\n[workspace] colcon build: {took:.1f} s")
    return workspace


def test_colcon_build_installs_only_the_package_and_its_data(built):
    site = site_packages(built)
    assert sorted(p.name for p in site.iterdir()) == [PACKAGE, f"{PACKAGE}-0.1.0-py{sys.version_info[0]}.{sys.version_info[1]}.egg-info"]
    assert not (site / "benchmarks").exists() and not (site / "test").exists()
    share = built / "install" / PACKAGE / "share"
    assert (share / "ament_index" / "resource_index" / "packages" / PACKAGE).is_file()
    assert (share / PACKAGE / "package.xml").read_text() == (ROOT / "package.xml").read_text()
    assert sorted(p.name for p in (share / PACKAGE / "config").iterdir()) == sorted(p.name for p in (ROOT / "config").glob("*.yaml"))
    scripts = built / "install" / PACKAGE / "lib" / PACKAGE
    for name in ("rigid_body_sim_node", "rigid-body-sim"):
        assert (scripts / name).read_text().splitlines()[0] == f"#!{sys.executable}", name


def run_installed_node_until_a_pose(workspace: Path, log: Path, timeout: float) -> tuple[PoseStamped, str]:
    env = installed_environment(workspace)
    node = workspace / "install" / PACKAGE / "lib" / PACKAGE / "rigid_body_sim_node"
    with open(log, "w") as out:
        process = subprocess.Popen([str(node), "--ros-args", "-p", "status_period:=0.0"], stdout=out,
                                   stderr=subprocess.STDOUT, env=env, cwd=workspace)
    context = Context()
    rclpy.init(context=context)
    listener = Node("workspace_listener", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(listener)
    poses: list[PoseStamped] = []
    listener.create_subscription(PoseStamped, "/box/pose", poses.append, 10)
    try:
        deadline = time.monotonic() + timeout
        while not poses:
            assert process.poll() is None, f"the installed node exited with {process.returncode}:\n{log.read_text()}"
            assert time.monotonic() < deadline, f"no pose from the installed node in {timeout:g} s:\n{log.read_text()}"
            executor.spin_once(timeout_sec=0.05)
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=20) == 0, log.read_text()
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        executor.shutdown()
        listener.destroy_node()
        rclpy.try_shutdown(context=context)
    return poses[0], log.read_text()


def test_installed_node_publishes_a_pose(built, tmp_path):
    """The console script colcon installed, in the environment of install/setup.sh, runs the
    installed default scene and publishes ``/box/pose``."""
    copy_kernel_cache(site_packages(built) / PACKAGE)
    pose, text = run_installed_node_until_a_pose(built, tmp_path / "node.log", timeout=120.0)
    assert pose.header.frame_id == "world"
    # The installed copy (package data of the installed package), not the source tree's.
    installed = re.search(r"scene (\S+default_scene\.yaml):", text)
    assert installed and Path(installed.group(1)).is_relative_to(built / "install" / PACKAGE), text
    assert "Traceback" not in text


@pytest.mark.slow
def test_colcon_test_runs_the_package_tests(built):
    """``colcon test`` finds pytest (setup.py's ``test`` extra) and runs the package's tests from the
    workspace; here a fast subset, the whole suite in the slow test below."""
    selection = ["test/test_quaternion.py", "test/test_parameters.py", "test/test_no_private_api.py"]
    result, took = colcon(built, "test", "--pytest-args", *selection)
    summary, _ = colcon(built, "test-result", "--all", "--verbose")
    print(f"\n[workspace] colcon test ({len(selection)} files): {took:.1f} s; {summary.stdout.strip().splitlines()[-1]}")
    last = summary.stdout.strip().splitlines()[-1]
    counts = dict(part.strip().split(" ")[::-1] for part in last.removeprefix("Summary:").split(","))
    assert int(counts["tests"]) > 50 and counts["errors"] == "0" and counts["failures"] == "0", summary.stdout


@pytest.mark.slow
@pytest.mark.timeout(3600)
def test_colcon_test_runs_the_whole_suite(tmp_path):
    """The whole suite from the workspace: in-process tests import the copy in src/, the node
    processes they start the installed copy; both get the checkout's kernels (the cold compile is
    the test below)."""
    workspace = make_workspace(tmp_path, kernel_cache=True)
    _, build_s = colcon(workspace, "build")
    copy_kernel_cache(site_packages(workspace) / PACKAGE)
    _, test_s = colcon(workspace, "test", timeout=3000.0)
    summary, _ = colcon(workspace, "test-result", "--all", "--verbose")
    print(f"\n[workspace] colcon build {build_s:.1f} s, colcon test (whole suite) {test_s:.1f} s: "
          f"{summary.stdout.strip().splitlines()[-1]}")


@pytest.mark.slow
@pytest.mark.timeout(1800)
def test_cold_installed_node_compiles_and_publishes(tmp_path):
    """A fresh installation without a kernel cache: the first start compiles (minutes on a busy
    machine), then publishes."""
    workspace = make_workspace(tmp_path / "ws", kernel_cache=False)
    colcon(workspace, "build")
    start = time.monotonic()
    pose, _text = run_installed_node_until_a_pose(workspace, tmp_path / "node.log", timeout=1500.0)
    print(f"\n[workspace] cold start of the installed node to the first pose: {time.monotonic() - start:.0f} s")
    assert pose.header.frame_id == "world"
