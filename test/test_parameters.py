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
from rigid_body_sim.ros.parameters import BY_NAME, PARAMETERS, markdown_table, params_yaml, problem
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
            assert got.read_only == spec.read_only, spec.name
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
        # Every declared parameter is in the table, but rclpy's own two and the standard
        # qos_overrides of the batch and /clock publishers (issue 15).
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
        before = {spec.name: harness.get_parameter(spec.name) for spec in PARAMETERS}
        dt = harness.node.simulator.dt
        for name, bad in ranged():
            other = ("paused", False) if name != "paused" else ("publish_clock", False)
            result = harness.set_parameters_atomically(**{name: bad, other[0]: other[1]})
            assert not result.successful, (name, bad)
            assert name in result.reason, (name, bad, result.reason)
            after = {spec.name: harness.get_parameter(spec.name) for spec in PARAMETERS}
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
    assert "whole number" in problem("substeps", 2.5)
    assert "one of" in problem("integrator", "RK4")
    assert "bool" in problem("paused", 1)
    assert "not a parameter" in problem("no_such", 1)


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
