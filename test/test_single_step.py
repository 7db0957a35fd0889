"""The single-step path (kernels/single_step.py): step(1) through one compiled call of one pointer.

It runs the same compiled stepping.advance (or controls.advance_controlled) on the same
buffers as the general path, so both are compared bitwise: the kernel on two copies of the
same buffers, with every compiled integrator, every reduced model, a pending wrench, control
rows (one rejected), a failing step and a cancelled one; then the Simulator's step(1) against
its own step(k) and its error paths (a blow-up, cancel, a rejected control).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from rigid_body_sim.core import INTEGRATORS, Simulator, load_scene
from rigid_body_sim.core import reduction
from rigid_body_sim.core.kernels import controls, stepping
from rigid_body_sim.core.kernels import layout as L
from rigid_body_sim.core.simulator import ControlRejectedWarning, DivergenceError, ensure_kernels
from rigid_body_sim.core.mechanics import kinetic_energy
from rigid_body_sim.core.stepping import pack_parameters

COMPILED = [name for name, method in INTEGRATORS.items() if method.code is not None]


def _module():
    """kernels/single_step, imported once the kernel cache is complete: a cfunc is compiled where it is
    defined, so importing it first (at collection, in several workers) would compile outside the cache's lock."""
    ensure_kernels()
    from rigid_body_sim.core.kernels import single_step

    return single_step


def _body(inertia, angular=(0.3, 1.0, 0.2), linear=(0.1, -0.2, 0.3), **extra) -> dict:
    return {"mass": 2.0, "inertia": inertia, "twist": {"linear": list(linear), "angular": list(angular)},
            "sites": {"s": {"position": [0.5, 0.3, 0.0]}}, **extra}


#: One body of every reduced model (reduction.py), and a free asymmetric one.
SCENE = {"gravity": [0.0, 0.0, -9.81], "bodies": {
    "box": _body({"box": [1.0, 0.6, 0.4]}),
    "ball": _body({"sphere": 0.2}),
    "can": _body({"cylinder": [0.1, 0.5]}),
    "spinner": _body({"box": [1.0, 0.6, 0.4]}, motion="kinematic"),
    "slider": _body({"box": [1.0, 0.6, 0.4]}, angular=(0.0, 0.0, 0.0), motion="translation_only"),
    "puck": _body({"box": [1.0, 0.6, 0.4]}, angular=(0.0, 0.0, 0.5), linear=(0.1, -0.2, 0.0), motion={"kind": "planar", "normal": [0.0, 0.0, 1.0]}),
    "wall": _body({"box": [1.0, 0.6, 0.4]}, angular=(0.0, 0.0, 0.0), linear=(0.0, 0.0, 0.0), motion="static"),
}}


def _buffers(integrator: str, with_table: bool) -> dict[str, np.ndarray]:
    """The compiled step's buffers for SCENE, as the Simulator builds them (model reduction on)."""
    scene = load_scene(SCENE)
    model, n = scene.model, scene.model.count
    prm = pack_parameters(model)
    Ys, status, control, inputs = stepping.new_buffers(n)
    Ys[:, :, :L.STATE_WIDTH] = scene.initial_state.rows()
    Ys[:, :, L.BOUND] = np.sqrt(kinetic_energy(model, scene.initial_state))  # as Simulator.reset
    members, groups = reduction.apply_plan(prm, model, scene.initial_state, scene.initial_state,
                                           reduction.model_codes(model))
    control[L.GROUPS:L.GROUPS + groups.size] = groups.ravel()
    control[L.METHOD] = INTEGRATORS[integrator].code
    inputs[L.DT], inputs[L.LIMIT] = 0.01, 1e6
    buffers = {"Ys": Ys, "prm": prm, "wrenches": np.zeros((n, L.WRENCH_WIDTH)), "members": members,
               "status": status, "control": control, "inputs": inputs, "cancel": np.zeros(1, dtype=np.int64)}
    if with_table:
        table = controls.new_table(3)
        table[0, controls.HEAD:controls.REJECTED] = (0, L.FRAME_SITE_BODY_AXES, 0.5, 0.3, 0.0)
        table[1, controls.HEAD:controls.REJECTED] = (1, L.FRAME_WORLD, 0.0, 0.0, 0.0)
        table[-1, 0] = 2
        buffers["table"] = table
    return buffers


def _general(b: dict) -> int:
    args = (b["Ys"], b["prm"], b["wrenches"], b["members"], b["status"], b["control"], b["inputs"], 1, b["cancel"])
    return controls.advance_controlled(*args, b["table"]) if "table" in b else stepping.advance(*args)


def _single(b: dict, block: np.ndarray, sizes: np.ndarray) -> int:
    single_step = _module()
    single_step.fill_block(block, sizes, b["Ys"], b["prm"], b["wrenches"], b["members"], b["status"], b["control"],
                           b["inputs"], b["cancel"], b.get("table"), *_scratch(b))
    return single_step.entry()(block.ctypes.data)


def _scratch(b: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Scratch for the block, filled with NaN and junk: its contents must not matter."""
    return (np.full((stepping.SCRATCH_ROWS, L.ROW_WIDTH), np.nan), np.full(b["members"].shape[0], -7, dtype=np.int64),
            np.full(L.WRENCH_WIDTH, np.nan))


def _set_inputs(b: dict, k: int) -> None:
    """Step k's inputs: a pending force at the box's site, and the control rows (row 1 non-finite at k = 3)."""
    rng = np.random.default_rng(k)
    inputs = b["inputs"]
    inputs[L.PENDING:L.INPUT_WIDTH] = (1.0, 0.0, L.FRAME_SITE_BODY_AXES, 0.5, 0.3, 0.0, *rng.normal(size=6))
    if "table" in b:
        b["table"][:2, :6] = rng.normal(size=(2, 6))
        if k == 3:
            b["table"][1, 2] = np.nan


def _assert_same(a: dict, b: dict) -> None:
    for key in a:
        if key != "cancel":
            assert np.array_equal(a[key], b[key], equal_nan=True), key


@pytest.mark.parametrize("with_table", [False, True], ids=["advance", "advance_controlled"])
@pytest.mark.parametrize("integrator", COMPILED)
def test_the_block_steps_bitwise_as_the_general_call(integrator: str, with_table: bool) -> None:
    general, single = _buffers(integrator, with_table), _buffers(integrator, with_table)
    single_step = _module()
    block, sizes = single_step.new_block()
    for k in range(8):
        _set_inputs(general, k)
        _set_inputs(single, k)
        assert _single(single, block, sizes) == _general(general) == (-2 if with_table and k == 3 else 1)
        _assert_same(general, single)
    assert (general["Ys"][0] != general["Ys"][1]).any()


@pytest.mark.parametrize("with_table", [False, True], ids=["advance", "advance_controlled"])
def test_a_failed_or_cancelled_step_is_the_same_and_the_block_clears_the_cancel_flag(with_table: bool) -> None:
    general, single = _buffers("euler", with_table), _buffers("euler", with_table)
    single_step = _module()
    block, sizes = single_step.new_block()
    for b in (general, single):
        b["Ys"][:, 0, L.W:L.W + 3] = 1e200  # the box's gyroscopic term overflows: NON_FINITE
    assert _single(single, block, sizes) == _general(general) == 0
    assert general["control"][L.OUTCOME] == L.NON_FINITE and general["status"][0] == L.NON_FINITE
    _assert_same(general, single)
    for b in (general, single):
        b["Ys"][:, 0, L.W:L.W + 3] = 0.0
        b["cancel"][0] = 1
    assert _single(single, block, sizes) == _general(general) == 0
    _assert_same(general, single)
    assert general["cancel"][0] == 1 and single["cancel"][0] == 0


def test_the_block_refuses_buffers_of_the_wrong_kind() -> None:
    b = _buffers("rk4", False)
    single_step = _module()
    block, sizes = single_step.new_block()
    with pytest.raises(ValueError, match="single-step block: buffer 1 has dtype float64, shape"):
        single_step.fill_block(block, sizes, b["Ys"], b["prm"][:, :10], b["wrenches"], b["members"], b["status"],
                               b["control"], b["inputs"], b["cancel"], None, *_scratch(b))
    with pytest.raises(ValueError, match="buffer 3 has dtype float64"):
        single_step.fill_block(block, sizes, b["Ys"], b["prm"], b["wrenches"], b["members"].astype(float),
                               b["status"], b["control"], b["inputs"], b["cancel"], None, *_scratch(b))


@pytest.mark.parametrize("integrator", COMPILED)
def test_step_one_k_times_is_step_k_with_a_control_held(integrator: str) -> None:
    scene = load_scene(SCENE)
    one, many = Simulator(scene, integrator=integrator, dt=0.01), Simulator(scene, integrator=integrator, dt=0.01)
    for sim in (one, many):
        sim.control("box", "box/s")[:] = (0.0, 3.0, 0.0, 0.0, 0.0, 0.2)
        sim.control("ball")[:] = (1.0, 0.0, 0.0, 0.0, 0.5, 0.0)
    for _ in range(6):
        assert one.step(1) == 1
    assert many.step(6) == 6
    assert np.array_equal(one.state.rows(), many.state.rows())
    assert one.step_count == many.step_count == 6 and one.time == many.time


def test_step_one_reports_a_blow_up_cancel_and_a_rejected_control() -> None:
    scene = load_scene({"bodies": {"b": _body({"box": [1.0, 0.6, 0.4]}, angular=(0.0, 400.0, 1e-3))}})
    sim = Simulator(scene, integrator="euler", dt=0.01)
    before = sim.state.rows()
    with pytest.raises(DivergenceError):
        for _ in range(100):
            sim.step(1)
    assert sim.step_count < 100 and np.isfinite(sim.state.rows()).all() and (sim.state.rows() != before).any()
    sim.reset()
    sim.cancel()
    assert sim.step(1) == 0 and sim.step_count == 0
    assert sim.step(1) == 1 and sim.step_count == 1  # the flag was cleared
    u = sim.control("b", "b/s")
    u[0] = np.inf
    with pytest.warns(ControlRejectedWarning) as record:
        assert sim.step(1) == 1
    assert record[0].filename == __file__  # the warning names the caller of step()
    assert [(body, frame) for body, frame, _ in sim.rejected_controls] == [("b", "b/s")]
    u[0] = 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.step(1)
    assert sim.rejected_controls == ()


#: Two boxes dropped onto the ground, one on the other (stepped by the contact solver, not the single-step path).
CONTACT_SCENE = {"gravity": [0.0, 0.0, -9.81], "ground": [{"normal": [0, 0, 1], "offset": 0.0}], "bodies": {
    f"c{k}": {"mass": 1.0, "inertia": {"box": [0.2, 0.2, 0.2]}, "collision": {"box": [0.2, 0.2, 0.2]},
              "pose": {"position": [0.01 * k, 0.0, 0.12 + 0.21 * k]}} for k in range(2)}}


@pytest.mark.parametrize("copier", ["deepcopy", "pickle"])
@pytest.mark.parametrize("spec", [SCENE, CONTACT_SCENE], ids=["free", "contact"])
def test_a_copied_simulator_steps_and_reads_its_own_buffers(spec: dict, copier: str) -> None:
    import copy
    import pickle

    sim = Simulator(load_scene(spec), dt=0.01)
    sim.step(3)
    start = sim.state.rows()
    twin = copy.deepcopy(sim) if copier == "deepcopy" else pickle.loads(pickle.dumps(sim))
    assert np.array_equal(twin.state.rows(), start)
    for k in (1, 1, 5):  # step(1) on the single-step path where the scene has one, then step(k)
        assert twin.step(k) == k
    assert np.array_equal(sim.state.rows(), start)  # the original is not stepped through the copy
    assert not np.array_equal(twin.state.rows(), start)  # the copy's state reads what it stepped
    for k in (1, 1, 5):
        sim.step(k)
    assert np.array_equal(twin.state.rows(), sim.state.rows()) and twin.time == sim.time
