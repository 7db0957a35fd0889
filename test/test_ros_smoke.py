"""Our ROS set-up from PyPI wheels: the bootstrapped venv, the session's private domain, DDS on loopback.

The default run checks what this project sets up: rclpy imports inside the venv (through the
ros-wheels-bootstrapper re-exec) with discovery kept on loopback, and a private ``Context``
carries the domain id conftest.py claimed for the session. The slow run (``make test-slow``)
keeps the environment probes: two domains do not talk (what that claim relies on), another
process on the same domain reaches us over loopback, and the service and message types we use
round-trip. What rclpy itself guarantees (init on a private context, in-process round trips
through each executor) is rclpy's to test, not ours. Measured times are printed
(``pytest -s -m slow -k smoke``) and recorded in docs/ros_notes.md.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
from collections.abc import Callable, Iterator

import pytest
import rclpy  # noqa: F401  (a missing or broken rclpy fails the run; it is never skipped)
from rclpy.context import Context
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.node import Node

pytestmark = [pytest.mark.ros, pytest.mark.timeout(60)]


DISCOVERY_TIMEOUT_S = 15.0  # s; measured 0.2-1.5 s here, generous for a loaded CI machine


def spin_until(executor: Executor, done: Callable[[], bool], timeout_s: float) -> float:
    """Spin ``executor`` until ``done()`` is true; return the elapsed time in seconds.

    Raises
    ------
    AssertionError
        If ``done()`` is still false after ``timeout_s`` seconds.
    """
    start = time.monotonic()
    while not done():
        elapsed = time.monotonic() - start
        assert elapsed < timeout_s, f"condition not met within {timeout_s} s"
        executor.spin_once(timeout_sec=0.05)
    return time.monotonic() - start


@pytest.fixture
def context(ros_domain_id: int) -> Iterator[Context]:
    """A private, initialised rclpy context on this session's domain; shut down afterwards."""
    ctx = Context()
    ctx.init(domain_id=ros_domain_id)
    yield ctx
    ctx.try_shutdown()


def test_rclpy_imports_inside_bootstrapped_venv() -> None:
    # The bootstrapper's .pth re-executes the interpreter once with LD_LIBRARY_PATH set.
    assert os.environ.get("_ROS_WHEELS_BOOTSTRAP_COMPLETE") == "1"
    assert "ros_rclpy.libs" in os.environ.get("LD_LIBRARY_PATH", "")
    from rclpy.executors import ExternalShutdownException  # noqa: F401  (its 9.x home)

    assert os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"


def test_private_context_carries_its_domain_id(context: Context, ros_domain_id: int) -> None:
    assert context.ok()
    assert context.get_domain_id() == ros_domain_id


@pytest.mark.slow
def test_separate_domains_do_not_talk(ros_domain_id: int) -> None:
    """Two contexts in one process, different domain ids: no message crosses."""
    from std_msgs.msg import String

    other_id = 232 if ros_domain_id != 232 else 231  # only used for 1.5 s, in this process
    ctx_a, ctx_b = Context(), Context()
    ctx_a.init(domain_id=ros_domain_id)
    ctx_b.init(domain_id=other_id)
    node_a = Node("smoke_a", context=ctx_a)
    node_b = Node("smoke_b", context=ctx_b)
    got: list[String] = []
    pub = node_a.create_publisher(String, "smoke/isolation", 10)
    node_b.create_subscription(String, "smoke/isolation", got.append, 10)
    ex_b = SingleThreadedExecutor(context=ctx_b)
    ex_b.add_node(node_b)
    try:
        deadline = time.monotonic() + 1.5
        while time.monotonic() < deadline:
            pub.publish(String(data="leak?"))
            ex_b.spin_once(timeout_sec=0.05)
        assert got == []
        assert pub.get_subscription_count() == 0
    finally:
        ex_b.shutdown()
        node_a.destroy_node()
        node_b.destroy_node()
        ctx_a.try_shutdown()
        ctx_b.try_shutdown()


@pytest.mark.slow
def test_services_and_other_message_types(context: Context) -> None:
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from nav_msgs.msg import Odometry
    from rosgraph_msgs.msg import Clock
    from std_srvs.srv import SetBool, Trigger

    node = Node("smoke_types", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    state = {"enabled": False}

    def on_trigger(request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        response.success, response.message = True, "reset"
        return response

    def on_set_bool(request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        state["enabled"] = request.data
        response.success, response.message = True, f"enabled={request.data}"
        return response

    node.create_service(Trigger, "smoke/reset", on_trigger)
    node.create_service(SetBool, "smoke/enable", on_set_bool)
    trigger = node.create_client(Trigger, "smoke/reset")
    set_bool = node.create_client(SetBool, "smoke/enable")

    clocks: list[Clock] = []
    odoms: list[Odometry] = []
    diags: list[DiagnosticArray] = []
    node.create_subscription(Clock, "/clock", clocks.append, 10)
    node.create_subscription(Odometry, "smoke/odom", odoms.append, 10)
    node.create_subscription(DiagnosticArray, "/diagnostics", diags.append, 10)
    clock_pub = node.create_publisher(Clock, "/clock", 10)
    odom_pub = node.create_publisher(Odometry, "smoke/odom", 10)
    diag_pub = node.create_publisher(DiagnosticArray, "/diagnostics", 10)
    try:
        assert trigger.wait_for_service(timeout_sec=5.0)
        assert set_bool.wait_for_service(timeout_sec=5.0)
        f_trigger = trigger.call_async(Trigger.Request())
        f_set = set_bool.call_async(SetBool.Request(data=True))
        spin_until(executor, lambda: f_trigger.done() and f_set.done(), timeout_s=5.0)
        assert f_trigger.result().success and f_trigger.result().message == "reset"
        assert f_set.result().success and state["enabled"] is True

        clock = Clock()
        clock.clock.sec, clock.clock.nanosec = 12, 500_000_000
        clock_pub.publish(clock)
        odom = Odometry()
        odom.header.frame_id, odom.child_frame_id = "world", "body"
        odom.twist.twist.angular.z = 0.5
        odom.pose.covariance[0] = 1e-6
        odom_pub.publish(odom)
        diag_pub.publish(
            DiagnosticArray(status=[DiagnosticStatus(level=DiagnosticStatus.OK, name="sim")])
        )
        spin_until(executor, lambda: bool(clocks and odoms and diags), timeout_s=5.0)
        assert (clocks[0].clock.sec, clocks[0].clock.nanosec) == (12, 500_000_000)
        assert odoms[0].child_frame_id == "body" and odoms[0].twist.twist.angular.z == 0.5
        assert odoms[0].pose.covariance[0] == 1e-6
        assert diags[0].status[0].name == "sim"
    finally:
        executor.shutdown()
        node.destroy_node()


_PUBLISHER_SCRIPT = textwrap.dedent(
    """
    import sys, time
    import rclpy
    from geometry_msgs.msg import PoseStamped

    rclpy.init()  # domain id and discovery range come from the inherited environment
    node = rclpy.create_node("smoke_remote_publisher")
    pub = node.create_publisher(PoseStamped, "smoke/remote_pose", 10)
    print(f"READY {time.monotonic():.6f}", flush=True)
    msg = PoseStamped()
    msg.header.frame_id = "remote"
    msg.pose.orientation.w = 1.0
    deadline = time.monotonic() + float(sys.argv[1])
    i = 0
    while time.monotonic() < deadline:
        msg.pose.position.x = float(i)
        pub.publish(msg)
        i += 1
        time.sleep(0.02)
    node.destroy_node()
    rclpy.shutdown()
    """
)


@pytest.mark.slow
def test_pose_from_another_process_over_loopback(context: Context) -> None:
    from geometry_msgs.msg import PoseStamped

    node = Node("smoke_remote_listener", context=context)
    received: list[PoseStamped] = []
    node.create_subscription(PoseStamped, "smoke/remote_pose", received.append, 10)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    t_spawn = time.monotonic()
    child = subprocess.Popen(
        [sys.executable, "-c", _PUBLISHER_SCRIPT, str(DISCOVERY_TIMEOUT_S + 5.0)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        stdin=subprocess.DEVNULL,
        text=True,
    )
    try:
        spin_until(executor, lambda: bool(received), timeout_s=DISCOVERY_TIMEOUT_S)
        t_first = time.monotonic()
    finally:
        child.terminate()
        out, err = child.communicate(timeout=10.0)
        executor.shutdown()
        node.destroy_node()
    ready = [line for line in out.splitlines() if line.startswith("READY ")]
    assert ready, f"publisher never got ready; stderr:\n{err}"
    t_ready = float(ready[0].split()[1])
    print(
        f"\ncross-process: child start-up (spawn to publisher ready) "
        f"{(t_ready - t_spawn) * 1e3:.0f} ms, discovery + first message "
        f"{(t_first - t_ready) * 1e3:.0f} ms"
    )
    assert received[0].header.frame_id == "remote"
