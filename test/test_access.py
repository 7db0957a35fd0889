"""What a peer on the ROS domain can make the node do with files, and the limits at every door.

Each test is an outside attack (a hostile peer on the same domain) through the node's real
interfaces, over DDS: a peer's ``set_parameters`` on the ``rigid_body_sim_node`` process or on the
harness's node, ``~/spawn``, and the process's start-up. ``record_path`` must not overwrite a
read-only decoy, the running scene or the file being recorded; ``scene`` must not put a file's
content into the refusal nor tell whether a path exists; ROS security variables without security
libraries, or a long namespace, end in one line and exit 2; a spawn of 20,000 IMU sites is refused
at once; ``diagnostics_period`` has a floor.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
import rclpy
import yaml
from rcl_interfaces.srv import SetParameters
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from rigid_body_sim.core import SceneError
from rigid_body_sim.core.scene import load_scene_text
from rigid_body_sim.core.scene import MAX_IMUS, MAX_IMUS_PER_BODY, MAX_NAME_LENGTH, MAX_NAMESPACE_LENGTH
from rigid_body_sim.offline.recording import read_recording
from rigid_body_sim.ros.parameters import MIN_DIAGNOSTICS_PERIOD_S
from rigid_body_sim.testing import SimHarness, node_command, start_process, stop_process

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[1]
BOX = {"mass": 1.0, "inertia": {"box": [1.0, 0.6, 0.4]}}
SECRET = "SECRET-FIRST-LINE-do-not-echo"
START_TIMEOUT_S = 600.0  # a fresh installation compiles the kernels first


def write_scene(path: Path, bodies: dict | None = None) -> Path:
    path.write_text(yaml.safe_dump({"bodies": bodies or {"box": BOX}}))
    return path


def run_to_exit(arguments: list[str], env: dict[str, str] | None = None, timeout: float = START_TIMEOUT_S,
                cwd: Path | None = None) -> subprocess.CompletedProcess:
    """Run ``rigid_body_sim_node --ros-args *arguments`` until it exits on its own."""
    return subprocess.run([*node_command(), "--ros-args", *arguments], capture_output=True, text=True,
                          timeout=timeout, env=env if env is not None else os.environ.copy(), cwd=cwd)


def not_info(text: str) -> list[str]:
    """The lines an operator would notice: all but the ROS log's INFO lines."""
    return [line for line in text.splitlines() if line.strip() and not line.startswith("[INFO]")]


class Peer:
    """Another participant on the domain that calls the node's parameter service, as ``ros2 param set`` would."""

    def __init__(self, node_name: str = "/rigid_body_sim"):
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = Node("hostile_peer", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.client = self.node.create_client(SetParameters, f"{node_name}/set_parameters")

    def set(self, timeout: float = 60.0, **values):
        assert self.client.wait_for_service(timeout_sec=timeout), "the node's parameter service never appeared"
        request = SetParameters.Request(parameters=[Parameter(k, value=v).to_parameter_msg() for k, v in values.items()])
        future = self.client.call_async(request)
        self.executor.spin_until_future_complete(future, timeout_sec=timeout)
        assert future.done(), "no answer from the node"
        return future.result().results[0]

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()


# ---------------------------------------------------------------------- files: over DDS, the node process


@pytest.mark.timeout(900)  # a fresh installation compiles the kernels first (START_TIMEOUT_S)
def test_a_peer_cannot_write_or_read_files_outside_the_configured_directories(tmp_path):
    """``record_path:=`` and ``scene:=`` outside the configured directories (a read-only decoy among them)
    are refused before the file system is looked at: the same words for an existing and a missing path,
    no file content in the refusal, the decoy untouched."""
    allowed = tmp_path / "allowed"
    allowed.mkdir()
    outside = tmp_path / "outside"
    outside.mkdir()
    decoy = outside / "decoy.mcap"
    decoy.write_text(f"{SECRET}\nprecious\n")
    decoy.chmod(0o400)
    secret_scene = outside / "secret.yaml"
    secret_scene.write_text(f"{SECRET}\n")
    scene = write_scene(allowed / "scene.yaml")
    log = tmp_path / "node.log"
    process = start_process(["-p", f"scene:={scene}", "-p", "status_period:=0.0", "-p", "diagnostics_period:=0.0",
                             "-p", f"scene_dirs:=[{allowed}]", "-p", f"record_dirs:=[{allowed}]"], log)
    peer = Peer()
    try:
        refused = {}
        for name, existing, missing in (("record_path", decoy, outside / "missing.mcap"),
                                        ("scene", secret_scene, outside / "missing.yaml")):
            for path in (existing, missing):
                result = peer.set(**{name: str(path)})
                assert not result.successful, (name, path)
                assert SECRET not in result.reason
                assert "not inside" in result.reason and f"{name.split('_')[0]}_dirs" in result.reason, result.reason
                refused[path] = result.reason.replace(str(path), "<path>")
            assert refused[existing] == refused[missing]  # nothing tells whether it exists
        # A link inside the allowed directory to a file outside is outside too.
        (allowed / "link.mcap").symlink_to(decoy)
        assert not peer.set(record_path=str(allowed / "link.mcap")).successful
        assert not peer.set(record_path=str(allowed / ".." / "outside" / "decoy.mcap")).successful
        assert decoy.read_text() == f"{SECRET}\nprecious\n"
        # Inside the directory, only an .mcap file: no shell start-up file or key file is created.
        result = peer.set(record_path=str(allowed / ".bashrc"))
        assert not result.successful and "does not end with .mcap" in result.reason, result.reason
        assert not (allowed / ".bashrc").exists()
        # Inside the directories, what the peer asks for is done.
        assert peer.set(record_path=str(allowed / "rec.mcap")).successful
        assert peer.set(scene=str(write_scene(allowed / "other.yaml", {"ball": BOX}))).successful
        assert process.poll() is None, log.read_text()
    finally:
        peer.close()
        stop_process(process)
    assert "Traceback" not in log.read_text()
    assert decoy.read_text() == f"{SECRET}\nprecious\n"


# ---------------------------------------------------------------------- files: through the harness (DDS parameter service)


def test_record_path_never_targets_the_scene_the_recording_or_an_existing_file(tmp_path):
    """record_path equal to the running scene's file or to the file being recorded is refused; an
    existing file the node did not create is refused unless record_overwrite was set at start-up;
    a file the node created may be recorded to again."""
    scene = write_scene(tmp_path / "scene.yaml")
    scene_text = scene.read_text()
    existing = tmp_path / "existing.mcap"
    existing.write_text("someone's data\n")
    dirs = {"scene_dirs": [str(tmp_path)], "record_dirs": [str(tmp_path)], "diagnostics_period": 0.0}
    with SimHarness(scene, dirs) as harness:
        result = harness.set_parameters_atomically(record_path=str(scene))
        assert not result.successful and "is the scene file" in result.reason, result.reason
        assert scene.read_text() == scene_text
        first = tmp_path / "first.mcap"
        assert harness.set_parameters_atomically(record_path=str(first)).successful
        harness.step(3)
        result = harness.set_parameters_atomically(record_path=str(first))
        assert not result.successful and "is the file being recorded now" in result.reason, result.reason
        result = harness.set_parameters_atomically(record_path=str(existing))
        assert not result.successful and "record_overwrite" in result.reason, result.reason
        assert existing.read_text() == "someone's data\n"
        # Scene and record_path in one request: the new recording may not be the new scene either.
        other = write_scene(tmp_path / "other.yaml", {"ball": BOX})
        result = harness.set_parameters_atomically(scene=str(other), record_path=str(other))
        assert not result.successful and "is the scene file" in result.reason
        assert harness.set_parameters_atomically(record_path="").successful
        recording, _ = read_recording(first)  # finished whole: never truncated under its writer
        assert len(recording.time) >= 4
        assert harness.set_parameters_atomically(record_path=str(first)).successful  # created by this node
        assert harness.spawn(ball=yaml.safe_dump(BOX)).successful  # the scene is now the edited one...
        result = harness.set_parameters_atomically(record_path=str(scene))  # ...its file is still the scene
        assert not result.successful and "is the scene file" in result.reason, result.reason
    with SimHarness(scene, {**dirs, "record_overwrite": True}) as harness:
        assert harness.set_parameters_atomically(record_path=str(existing)).successful
        assert not harness.set_parameters_atomically(record_path=str(scene)).successful
    assert existing.read_bytes().startswith(b"\x89MCAP")
    assert scene.read_text() == scene_text


@pytest.mark.timeout(900)  # a fresh installation compiles the kernels first (START_TIMEOUT_S)
def test_an_existing_record_path_at_start_up_is_refused_without_record_overwrite(tmp_path):
    """The operator's start-up record_path is not confined to record_dirs, but never overwrites an
    existing file without record_overwrite:=true: exit 2 with the reason, the file intact."""
    existing = tmp_path / "existing.mcap"
    existing.write_text("someone's data\n")
    result = run_to_exit(["-p", f"record_path:={existing}", "-p", "status_period:=0.0"], timeout=START_TIMEOUT_S)
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    assert "record_overwrite" in result.stderr
    assert existing.read_text() == "someone's data\n"


def test_default_directories_are_the_package_config_and_the_working_directory():
    with SimHarness(parameters={"diagnostics_period": 0.0}) as harness:
        scene_dirs = harness.get_parameter("scene_dirs")
        assert scene_dirs == [str(ROOT / "config"), "."]
        assert harness.get_parameter("record_dirs") == ["."]
        assert harness.get_parameter("record_overwrite") is False
        # A packaged scene may be chosen at run time; a file elsewhere may not.
        assert harness.set_parameters_atomically(scene=str(ROOT / "config" / "tumbling_phone.yaml")).successful
        result = harness.set_parameters_atomically(scene="/etc/hostname")
        assert not result.successful and "scene_dirs" in result.reason
        # The directories are read-only: no peer widens them.
        result = harness.set_parameters_atomically(scene_dirs=["/"])
        assert not result.successful
        assert harness.get_parameter("scene_dirs") == scene_dirs


# ---------------------------------------------------------------------- access: discovery range and ROS security


@pytest.mark.timeout(900)  # a fresh installation compiles the kernels first (START_TIMEOUT_S)
def test_security_variables_without_security_libraries_exit_2_in_one_line(tmp_path):
    """ROS_SECURITY_ENABLE=true with Enforce, with an SROS2-layout keystore or a missing one, on a Fast DDS
    without the security libraries: one line saying why, exit 2 (no traceback)."""
    keystore = tmp_path / "keystore"
    enclave = keystore / "enclaves"
    enclave.mkdir(parents=True)
    for name in ("identity_ca.cert.pem", "cert.pem", "key.pem", "permissions_ca.cert.pem", "governance.p7s",
                 "permissions.p7s"):
        (enclave / name).write_text("not a real certificate\n")
    env = {**os.environ, "ROS_SECURITY_ENABLE": "true", "ROS_SECURITY_KEYSTORE": str(keystore),
           "ROS_SECURITY_STRATEGY": "Enforce"}
    result = run_to_exit(["-p", "status_period:=0.0"], env=env)
    output = result.stdout + result.stderr
    assert result.returncode == 2, output
    assert "Traceback" not in output
    lines = not_info(output)
    assert len(lines) == 1, lines
    assert "security libraries" in lines[0] and "ROS_SECURITY_ENABLE=true" in lines[0], lines

    env["ROS_SECURITY_KEYSTORE"] = str(tmp_path / "no-keystore")
    result = run_to_exit(["-p", "status_period:=0.0"], env=env)
    output = result.stdout + result.stderr
    assert result.returncode == 2, output
    assert "Traceback" not in output
    lines = not_info(output)
    assert len(lines) == 1 and "does not exist" in lines[0], lines


@pytest.mark.timeout(900)  # a fresh installation compiles the kernels first (START_TIMEOUT_S)
def test_discovery_range_is_the_local_host_unless_the_environment_says_otherwise(tmp_path):
    """Run directly (not through `make run`), the node's process has ROS_AUTOMATIC_DISCOVERY_RANGE
    LOCALHOST unless the environment sets it, and the node says which range it uses."""
    program = ("import os, sys; from rigid_body_sim.ros.access import prepare_access; "
               "code = prepare_access([]); print(code, os.environ.get('ROS_AUTOMATIC_DISCOVERY_RANGE'))")
    env = {k: v for k, v in os.environ.items() if k != "ROS_AUTOMATIC_DISCOVERY_RANGE"}
    unset = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, env=env, timeout=120)
    assert unset.stdout.split() == ["None", "LOCALHOST"], unset.stderr
    assert "discovery range LOCALHOST" in unset.stderr
    subnet = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, timeout=120,
                            env={**env, "ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"})
    assert subnet.stdout.split() == ["None", "SUBNET"] and "discovery range SUBNET" in subnet.stderr
    bad = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, timeout=120,
                         env={**env, "ROS_AUTOMATIC_DISCOVERY_RANGE": "EVERYWHERE"})
    assert bad.stdout.split()[0] == "2" and "is not one of" in bad.stderr


SUBNET_PEER_PROFILE = """<?xml version="1.0" encoding="UTF-8" ?>
<dds xmlns="http://www.eprosima.com">
  <profiles>
    <transport_descriptors>
      <transport_descriptor>
        <transport_id>subnet_only</transport_id>
        <type>UDPv4</type>
        <interfaces><allowlist><interface name="{interface}"/></allowlist></interfaces>
      </transport_descriptor>
    </transport_descriptors>
    <participant profile_name="subnet_peer" is_default_profile="true">
      <rtps>
        <userTransports><transport_id>subnet_only</transport_id></userTransports>
        <useBuiltinTransports>false</useBuiltinTransports>
      </rtps>
    </participant>
  </profiles>
</dds>
"""

SUBNET_PEER = """
import sys, time, rclpy
from rclpy.node import Node
rclpy.init()
node = Node("subnet_peer")
deadline = time.monotonic() + float(sys.argv[1])  # looks this long, or this grace after it sees one of them
grace = float(sys.argv[2])
wanted = set(sys.argv[3:])
seen = set()
while time.monotonic() < deadline and not wanted <= seen:
    rclpy.spin_once(node, timeout_sec=0.2)
    found = {name for name, _ in node.get_topic_names_and_types()}
    if found & wanted and not seen & wanted:
        deadline = min(deadline, time.monotonic() + grace)
    seen |= found
print(" ".join(sorted(wanted & seen)) or "none")
"""


def network_interface() -> str | None:
    """The name of a network interface other than loopback that has an IPv4 address (the subnet)."""
    import fcntl
    import socket
    import struct

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        for _, name in socket.if_nameindex():
            if name == "lo":
                continue
            try:
                fcntl.ioctl(probe.fileno(), 0x8915, struct.pack("256s", name[:15].encode()))  # SIOCGIFADDR
            except OSError:
                continue
            return name
    return None


@pytest.mark.timeout(900)  # a fresh installation compiles the kernels first (START_TIMEOUT_S)
def test_a_peer_on_the_subnet_does_not_discover_the_node_run_directly(tmp_path):
    """Run directly (not through `make run`, which exports the variable): a peer whose only transport is
    the subnet interface (a Fast DDS profile allowing only it) does not discover the node started without
    ROS_AUTOMATIC_DISCOVERY_RANGE; it does discover one started with SUBNET beside it (so it could)."""
    interface = network_interface()
    assert interface is not None, "this test needs a network interface besides loopback (the subnet a peer uses)"
    profile = tmp_path / "subnet_peer.xml"
    profile.write_text(SUBNET_PEER_PROFILE.format(interface=interface))
    peer_env = {**os.environ, "ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT",
                "FASTDDS_DEFAULT_PROFILES_FILE": str(profile)}
    # Both nodes at once, one per namespace; one peer looks for both for up to 8 s, and 3 s after it found
    # one (both nodes are up then: the other, were it reachable, is found in the same discovery round).
    processes = {}
    try:
        for namespace, node_range in (("direct", None), ("subnet", "SUBNET")):
            saved = os.environ.pop("ROS_AUTOMATIC_DISCOVERY_RANGE", None)
            if node_range is not None:
                os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = node_range
            try:
                processes[namespace] = start_process(["-r", f"__ns:=/{namespace}", "-p", "status_period:=0.0",
                                                      "-p", "diagnostics_period:=0.0"], tmp_path / f"node-{namespace}.log")
            finally:
                os.environ.pop("ROS_AUTOMATIC_DISCOVERY_RANGE", None)
                if saved is not None:
                    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = saved
        deadline = time.monotonic() + START_TIMEOUT_S
        for namespace, process in processes.items():
            log = tmp_path / f"node-{namespace}.log"
            while "scene " not in log.read_text():
                assert process.poll() is None and time.monotonic() < deadline, log.read_text()
                time.sleep(0.05)
        peer = subprocess.run([sys.executable, "-c", SUBNET_PEER, "8", "3", "/direct/box/pose", "/subnet/box/pose"],
                              capture_output=True, text=True, env=peer_env, timeout=120)
        seen = peer.stdout.strip().splitlines()[-1] if peer.stdout.strip() else peer.stderr[-500:]
    finally:
        for process in processes.values():
            stop_process(process)
    # run directly: not seen; asked for SUBNET: seen (so the peer could)
    assert seen == "/subnet/box/pose", seen
    assert "discovery range LOCALHOST" in (tmp_path / "node-direct.log").read_text()  # it says which range it uses
    assert "discovery range SUBNET" in (tmp_path / "node-subnet.log").read_text()


# ---------------------------------------------------------------------- limits at every door


def imu_body(sites: int, name_length: int = 2) -> dict:
    return {**BOX, "sites": {f"s{i:0{max(1, name_length - 1)}d}": {"position": [0.0, 0.0, 0.0], "imu": {}}
                             for i in range(sites)}}


def test_a_spawn_of_20000_imu_sites_is_refused_naming_the_limit():
    """A ~/spawn body with 20,000 IMU sites (a publisher each, if accepted) is refused at once, naming
    MAX_IMUS_PER_BODY, and the ticks go on."""
    definition = yaml.dump(imu_body(20_000), Dumper=yaml.CSafeDumper)  # safe_dump's text, in 1 s instead of 3 s
    with SimHarness(paused=False, parameters={"diagnostics_period": 0.0}) as harness:
        with harness.node.locked_simulator() as sim:
            before = sim.time
        start = time.monotonic()
        result = harness.spawn(crate=definition)
        took = time.monotonic() - start
        assert not result.successful
        assert "MAX_IMUS_PER_BODY" in result.reason and f"at most {MAX_IMUS_PER_BODY}" in result.reason, result.reason
        assert took < 5.0, f"{took:.1f} s"
        assert harness.node.simulator.body_names == ("box",)
        harness.spin_for(0.2)
        assert harness.node.simulator.time > before


def test_sites_and_imus_per_scene_are_bounded():
    """A scene with more IMUs than MAX_IMUS (or a body with more sites than MAX_SITES_PER_BODY) is
    refused naming the limit."""
    bodies = {f"b{k}": imu_body(MAX_IMUS_PER_BODY) for k in range(MAX_IMUS // MAX_IMUS_PER_BODY + 1)}
    with pytest.raises(SceneError, match=f"at most {MAX_IMUS:,} IMUs in a scene \\(MAX_IMUS"):
        load_scene_text(yaml.safe_dump({"bodies": bodies}))
    bodies = {"b": {**BOX, "sites": {f"s{i}": {"position": [0, 0, 0]} for i in range(1_001)}}}
    with pytest.raises(SceneError, match="MAX_SITES_PER_BODY"):
        load_scene_text(yaml.safe_dump({"bodies": bodies}))


@pytest.mark.timeout(900)  # a fresh installation compiles the kernels first (START_TIMEOUT_S)
def test_a_120_character_namespace_exits_2_with_the_reason(tmp_path):
    """A 120-character namespace (with which a 63-character body's 63-character IMU site would make an
    invalid topic name) is refused at start-up: exit 2 with the reason, with or without that scene."""
    long_name = "b" * MAX_NAME_LENGTH
    site = "s" * MAX_NAME_LENGTH
    scene = write_scene(tmp_path / "long.yaml", {long_name: {**BOX, "sites": {site: {"position": [0, 0, 0],
                                                                                      "imu": {}}}}})
    namespace = "/" + "n" * 119
    for arguments in (["-r", f"__ns:={namespace}"], ["-r", f"__ns:={namespace}", "-p", f"scene:={scene}"]):
        result = run_to_exit([*arguments, "-p", "status_period:=0.0"])
        output = result.stdout + result.stderr
        assert result.returncode == 2, output
        assert "Traceback" not in output
        assert f"at most {MAX_NAMESPACE_LENGTH}" in output and "MAX_NAMESPACE_LENGTH" in output, output


@pytest.mark.timeout(900)  # a fresh installation compiles the kernels first (START_TIMEOUT_S)
def test_a_node_name_too_long_for_its_services_exits_2_in_one_line():
    """A namespace within its limit and a node name so long that ~/set_parameters_atomically
    exceeds ROS's 247 characters (rclpy's InvalidServiceNameException from the node's constructor,
    if let through): one line naming the limit, exit 2."""
    namespace = "/" + "n" * (MAX_NAMESPACE_LENGTH - 1)
    result = run_to_exit(["-r", f"__ns:={namespace}", "-r", f"__node:={'m' * 140}", "-p", "status_period:=0.0"])
    output = result.stdout + result.stderr
    assert result.returncode == 2, output
    assert "Traceback" not in output
    lines = not_info(output)
    assert len(lines) == 1 and "MAX_TOPIC_NAME_LENGTH 247" in lines[0], lines


def test_the_longest_namespace_takes_the_longest_names():
    """At MAX_NAMESPACE_LENGTH, a spawned body and IMU site of MAX_NAME_LENGTH characters each work."""
    namespace = "/" + "n" * (MAX_NAMESPACE_LENGTH - 1)
    body = {**BOX, "sites": {"s" * MAX_NAME_LENGTH: {"position": [0.0, 0.0, 0.0], "imu": {}}}}
    with SimHarness(namespace=namespace, parameters={"diagnostics_period": 0.0}) as harness:
        result = harness.spawn(**{"b" * MAX_NAME_LENGTH: yaml.safe_dump(body)})
        assert result.successful, result.reason
        assert len(harness.node.simulator.body_names) == 2


def test_diagnostics_period_has_a_floor():
    """diagnostics_period below its floor (1e-9 would flood /diagnostics) is refused."""
    with SimHarness(parameters={"diagnostics_period": 0.0}) as harness:
        result = harness.set_parameters_atomically(diagnostics_period=1e-9)
        assert not result.successful
        assert f"at least {MIN_DIAGNOSTICS_PERIOD_S:g} s" in result.reason, result.reason
        assert harness.set_parameters_atomically(diagnostics_period=MIN_DIAGNOSTICS_PERIOD_S).successful
        result = harness.set_parameters_atomically(marker_rate_hz=1e6)
        assert not result.successful and "marker_rate_hz" in result.reason

