"""The node's parameters from one table (rigid_body_sim/ros/parameters.py): what a client sees
through ``describe_parameters``, refusals of out-of-range values with a reason (all or nothing),
and the files generated from the table (config/params.yaml, the table in docs/interface.md).
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.parameter import Parameter

from rigid_body_sim.ros.publishers import OVERRIDABLE_TOPICS
from rigid_body_sim.ros.parameters import (BY_NAME, PARAMETERS, change_problems, coerce, markdown_table, params_yaml,
                                           problem)
from rigid_body_sim.testing import SimHarness

ROOT = Path(__file__).resolve().parents[1]


def describe(harness: SimHarness, names: list[str]) -> list[ParameterDescriptor]:
    future = harness._parameters.describe_parameters(names)
    harness.spin_until(future.done, "describe_parameters")
    return list(future.result().descriptors)


@pytest.mark.ros
def test_describe_parameters_from_a_client_shows_every_type_range_and_description():
    with SimHarness() as harness:
        names = [spec.name for spec in PARAMETERS]
        descriptors = describe(harness, names)
        for spec, got in zip(PARAMETERS, descriptors):
            assert got.name == spec.name
            assert got.type == spec.type.value, spec.name
            assert got.description == spec.description and got.description, spec.name
            assert got.read_only == (spec.read_only or spec.node_owned), spec.name
            assert not got.dynamic_typing, spec.name
            if spec.type is Parameter.Type.DOUBLE and spec.range is not None:
                (r,) = got.floating_point_range
                assert (r.from_value, r.to_value, r.step) == (spec.range[0], spec.range[1], 0.0), spec.name
            elif spec.type is Parameter.Type.INTEGER and spec.range is not None:
                (r,) = got.integer_range
                assert (r.from_value, r.to_value, r.step) == (spec.range[0], spec.range[1], 1), spec.name
            else:
                assert not got.floating_point_range and not got.integer_range, spec.name
            for choice in spec.choices:
                assert choice in got.additional_constraints, spec.name
        # What docs/interface.md says of each parameter is what a client is told.
        docs = {}
        for line in (ROOT / "docs" / "interface.md").read_text().splitlines():
            cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
            if len(cells) == 6 and cells[0].startswith("`") and cells[0].strip("`") in BY_NAME:
                docs[cells[0].strip("`")] = cells
        assert set(docs) == set(names)
        type_names = {1: "bool", 2: "integer", 3: "double", 4: "string", 9: "string array"}
        for got in descriptors:
            assert docs[got.name][1] == type_names[got.type], got.name
            assert (docs[got.name][4] == "read-only") == got.read_only, got.name
        # Every declared parameter is in the table, but rclpy's own two and the standard
        # qos_overrides of the batch and /clock publishers.
        future = harness._parameters.list_parameters()
        harness.spin_until(future.done, "list_parameters")
        qos = {f"qos_overrides.{'/' + t.lstrip('/')}.publisher.{policy}" for t in OVERRIDABLE_TOPICS
               for policy in ("history", "depth", "reliability", "durability")}
        assert set(future.result().result.names) == set(names) | {"use_sim_time", "start_type_description_service"} | qos


def ranged() -> list[tuple[str, object]]:
    """(name, bad value) for every ranged parameter: just outside each end of its range."""
    cases = []
    for spec in PARAMETERS:
        if spec.range is None:
            continue
        low, high = spec.range
        if spec.type is Parameter.Type.INTEGER:
            cases += [(spec.name, int(low) - 1), (spec.name, int(high) + 1)]
        else:
            cases += [(spec.name, low - max(1e-3, abs(low) * 1e-3)), (spec.name, high * 1.01), (spec.name, math.nan)]
    return cases


@pytest.mark.ros
def test_out_of_range_sets_are_refused_whole_with_a_reason():
    """Each ranged parameter just outside either end (and NaN), sent together with a valid change
    of another parameter: the request is refused with the parameter's name in the reason, and
    neither value changes."""
    with SimHarness() as harness:
        names = [spec.name for spec in PARAMETERS]
        before = harness.get_parameters(names)
        dt = harness.node.simulator.dt
        for name, bad in ranged():
            other = ("paused", False) if name != "paused" else ("publish_clock", False)
            result = harness.set_parameters_atomically(**{name: bad, other[0]: other[1]})
            assert not result.successful, (name, bad)
            assert name in result.reason, (name, bad, result.reason)
            after = harness.get_parameters(names)
            assert after == before, (name, bad)
            assert harness.node.simulator.dt == dt
        harness.step()  # still runs


@pytest.mark.ros
def test_every_bad_start_up_value_is_named_at_once():
    with pytest.raises(ValueError) as info:
        SimHarness(parameters={"rate_hz": -1.0, "substeps": 0, "integrator": "leapfrog", "paused": True})
    for name in ("rate_hz", "substeps", "integrator"):
        assert name in str(info.value)


@pytest.mark.ros
def test_whole_numbers_for_float_parameters_at_start_up_and_at_run_time():
    with SimHarness(parameters={"rate_hz": 200, "wrench_timeout": 0}) as harness:
        assert harness.get_parameter("rate_hz") == 200.0 and isinstance(harness.get_parameter("rate_hz"), float)
        assert harness.get_parameter("wrench_timeout") == 0.0
        assert all(r.successful for r in harness.set_parameters(real_time_factor=2))
        assert harness.node.simulator.dt == pytest.approx(2.0 / 200.0)
        (got,) = describe(harness, ["rate_hz"])
        assert got.type == Parameter.Type.DOUBLE.value  # static type after the start-up conversion


def test_the_table_is_complete():
    for spec in PARAMETERS:
        assert spec.description.endswith((".", ")")), spec.name
        if spec.type in (Parameter.Type.DOUBLE, Parameter.Type.INTEGER):
            assert spec.range is not None, f"{spec.name}: a number needs a range"
        if spec.default is not None:
            assert problem(spec.name, spec.default) is None, spec.name


def test_problem_names_what_was_wrong_and_what_was_expected():
    assert "out of range" in problem("rate_hz", 0.0) and "0.001" in problem("rate_hz", 0.0)
    assert "finite number" in problem("rate_hz", math.inf)
    # Wrong types in the project's words: the parameter, the type given and the type expected.
    assert problem("substeps", 2.5) == "substeps must be an integer, got a double (2.5): wrong type"
    assert problem("rate_hz", "fast") == "rate_hz must be a double, got a string ('fast'): wrong type"
    assert problem("scene", ["a", "b"]) == "scene must be a string, got a string array (['a', 'b']): wrong type"
    assert "one of" in problem("integrator", "RK4")
    assert "bool" in problem("paused", 1)
    assert "not a parameter" in problem("no_such", 1)


def test_change_problems_name_every_bad_value():
    """The reason the node refuses a run-time change with (its pre-set coercion, then
    ``change_problems``) names the parameter and what was wrong: names are exact (no case folding or
    stripping), a value of another type is refused with the type given, and every read-only
    parameter is refused as such. test_parameter_abuse.py sends a bad change of each kind through
    the parameter service and checks that the refusal changes nothing."""
    cases = [
        ({"integrator": "rk4 "}, "integrator must be one of"),
        ({"integrator": ""}, "integrator must be one of"),
        ({"integrator": 3}, "integrator must be a string, got an integer (3)"),
        ({"scene": 42}, "scene must be a string, got an integer (42)"),
        ({"paused": "yes"}, "paused must be a bool, got a string ('yes')"),
        ({"publish_clock": 1}, "publish_clock must be a bool, got an integer (1)"),
        ({"frame_prefix": "other/"}, "frame_prefix is read-only: set at start-up only"),
        ({"per_body_topics": False}, "per_body_topics is read-only: set at start-up only"),
    ]
    for changes, phrase in cases:
        reason = "; ".join(change_problems({name: coerce(BY_NAME[name], v) for name, v in changes.items()}))
        assert phrase in reason, (changes, reason)


def test_params_yaml_is_generated_from_the_table():
    assert (ROOT / "config" / "params.yaml").read_text() == params_yaml()
    loaded = yaml.safe_load(params_yaml())["rigid_body_sim"]["ros__parameters"]
    assert loaded == {spec.name: spec.default for spec in PARAMETERS if spec.default is not None}


def test_docs_table_is_generated_from_the_table():
    page = (ROOT / "docs" / "interface.md").read_text()
    begin = page.index("<!-- parameters:begin")
    begin = page.index("\n", begin) + 1
    end = page.index("<!-- parameters:end -->")
    assert page[begin:end] == markdown_table()
    for spec in PARAMETERS:
        assert f"| `{spec.name}` |" in markdown_table()
    assert BY_NAME["world_frame"].read_only


@pytest.mark.ros
@pytest.mark.timeout(900)
def test_a_misspelt_start_up_parameter_is_named_with_the_closest_valid_one(tmp_path):
    """``rate_hx:=200`` (and a misspelt key in a params file): the node process warns, naming it
    and ``rate_hz``; valid names, rclpy's own and qos_overrides give no warning. The node starts
    with the documented config/params.yaml and a whole number for a float parameter (``status_period:=0``)."""
    import time

    from rigid_body_sim.testing import start_process, stop_process

    params_file = tmp_path / "params.yaml"
    params_file.write_text(yaml.safe_dump({"/**": {"ros__parameters": {"wrench_timout": 1.0, "paused": True}}}))
    log_path = tmp_path / "node.log"
    process = start_process(["-p", "rate_hx:=200", "-p", "status_period:=0", "-p", "use_sim_time:=false",
                             "-p", "qos_overrides./poses.publisher.depth:=3", "-p", "other_node:rate_hy:=1",
                             "--params-file", str(ROOT / "config" / "params.yaml"), "--params-file", str(params_file)],
                            log_path)
    try:
        deadline = time.monotonic() + 600.0  # a fresh installation (colcon test) compiles the kernels first
        while "scene " not in log_path.read_text():
            assert process.poll() is None, log_path.read_text()
            assert time.monotonic() < deadline, log_path.read_text()
            time.sleep(0.05)
    finally:
        assert stop_process(process) == 0, log_path.read_text()
    log = log_path.read_text()
    warnings = [line for line in log.splitlines() if "unknown start-up parameter" in line]
    assert any("WARN" in line and "'rate_hx'" in line and "did you mean 'rate_hz'?" in line for line in warnings), log
    assert any("'wrench_timout'" in line and "did you mean 'wrench_timeout'?" in line for line in warnings), log
    assert len(warnings) == 2, warnings  # not use_sim_time, qos_overrides or another node's rate_hy


@pytest.mark.ros
def test_plain_set_parameters_applies_per_parameter_and_atomically_all_or_nothing():
    """rclpy's semantics, as docs/interface.md says: set_parameters takes each parameter on its
    own (a bad one does not stop a good one), set_parameters_atomically all or none."""
    with SimHarness() as harness:
        good, bad = harness.set_parameters(wrench_timeout=2.0, rate_hz="fast")
        assert good.successful and not bad.successful
        assert bad.reason == "rate_hz must be a double, got a string ('fast'): wrong type"
        assert harness.get_parameter("wrench_timeout") == 2.0
        result = harness.set_parameters_atomically(wrench_timeout=3.0, rate_hz="fast")
        assert not result.successful and "rate_hz must be a double" in result.reason
        assert harness.get_parameter("wrench_timeout") == 2.0 and harness.get_parameter("rate_hz") == 100.0


@pytest.mark.ros
def test_body_names_is_read_only_to_clients_and_kept_by_the_node():
    with SimHarness() as harness:
        (descriptor,) = describe(harness, ["body_names"])
        assert descriptor.read_only
        result = harness.set_parameters_atomically(body_names=["x"])
        assert not result.successful and "body_names is read-only: the node sets it" in result.reason
        assert harness.get_parameter("body_names") == list(harness.node.simulator.body_names)


@pytest.mark.ros
def test_a_recording_declares_the_qos_that_qos_overrides_give(tmp_path):
    """With ``qos_overrides./poses.publisher.*`` (and /clock's), the recording's
    ``offered_qos_profiles`` says what the publishers really offer, as another participant
    discovers it; topics without overrides keep the default."""
    import time

    import rclpy
    from mcap.reader import make_reader
    from rclpy.context import Context
    from rclpy.node import Node
    from rclpy.qos import DurabilityPolicy, ReliabilityPolicy

    path = tmp_path / "overridden.mcap"
    overrides = {"qos_overrides./poses.publisher.depth": 5,
                 "qos_overrides./poses.publisher.durability": "volatile",
                 "qos_overrides./clock.publisher.reliability": "best_effort",
                 "per_body_topics": False, "record_path": str(path)}
    with SimHarness(parameters=overrides) as harness:
        harness.step(3)
        context = Context()
        rclpy.init(context=context)
        try:  # the QoS another participant discovers
            observer = Node("qos_observer", context=context)
            deadline = time.monotonic() + 10.0
            while not observer.get_publishers_info_by_topic("/poses") and time.monotonic() < deadline:
                harness.spin_for(0.05)
            (poses_info,) = observer.get_publishers_info_by_topic("/poses")
            (clock_info,) = observer.get_publishers_info_by_topic("/clock")
            assert poses_info.qos_profile.durability == DurabilityPolicy.VOLATILE
            assert clock_info.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT
        finally:
            rclpy.try_shutdown(context=context)
    with open(path, "rb") as handle:
        channels = {c.topic: c for c in make_reader(handle).get_summary().channels.values()}
    declared = {topic: yaml.safe_load(channels[topic].metadata["offered_qos_profiles"])[0]
                for topic in ("/poses", "/velocities", "/clock")}
    assert (declared["/poses"]["history"], declared["/poses"]["depth"], declared["/poses"]["reliability"],
            declared["/poses"]["durability"]) == ("keep_last", 5, "reliable", "volatile")
    assert (declared["/clock"]["reliability"], declared["/clock"]["durability"]) == ("best_effort", "transient_local")
    assert (declared["/velocities"]["depth"], declared["/velocities"]["reliability"],
            declared["/velocities"]["durability"]) == (1, "reliable", "transient_local")
