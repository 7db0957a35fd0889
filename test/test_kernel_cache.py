"""The compiled kernels' cache: kept across edits outside core/kernels/, dropped by an edit inside it.

The first test works on a copy of the package in a temporary folder (its own numba cache, next
to the copied kernels) and compiles one small kernel, reading numba's own count of cache hits
and misses in a fresh interpreter after each edit: no timing involved. The second checks that
:func:`compile_kernels` gives every entry point the signature the Simulator later calls it
with, so that a compiled checkout never compiles again at its first step.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / "rigid_body_sim"

#: Compiles (or loads) one kernel of the copy and reports what numba did.
PROBE = (
    "import json, rigid_body_sim\n"
    "from rigid_body_sim.core.kernels.rotation import normalise\n"
    "normalise(2.0, 0.0, 0.0, 0.0)\n"
    "stats = normalise.stats\n"
    "print(json.dumps({'package': rigid_body_sim.__file__, 'hits': sum(stats.cache_hits.values()),\n"
    "                  'misses': sum(stats.cache_misses.values())}))\n"
)


def _probe(root: Path) -> dict:
    env = {key: value for key, value in os.environ.items() if key not in ("NUMBA_CACHE_DIR", "NUMBA_DISABLE_JIT")}
    env["PYTHONPATH"] = str(root)
    result = subprocess.run([sys.executable, "-c", PROBE], cwd=root, env=env, capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout.strip().splitlines()[-1])


def _append(path: Path, text: str) -> None:
    path.write_text(path.read_text(encoding="utf-8") + text, encoding="utf-8")


def test_only_an_edit_under_kernels_recompiles(tmp_path: Path) -> None:
    root = tmp_path / "src"
    shutil.copytree(PACKAGE, root / "rigid_body_sim", ignore=shutil.ignore_patterns("__pycache__"))
    kernels = root / "rigid_body_sim" / "core" / "kernels"
    cache = kernels / "__pycache__"

    first = _probe(root)
    assert Path(first["package"]).is_relative_to(root), "the probe must import the copy"
    assert (first["hits"], first["misses"]) == (0, 1)  # an empty cache: compiled
    index_files = sorted(cache.glob("rotation.normalise-*.nbi"))
    assert index_files, "numba wrote no cache index next to the kernels"
    stamp = (cache / "numba-sources.sha256").read_text()

    # an error message in scene.py, a docstring in describe.py, the oracle: none is compiled
    _append(root / "rigid_body_sim" / "core" / "scene.py", "\n# an edit outside the kernels\n")
    _append(root / "rigid_body_sim" / "core" / "describe.py", '\n"""another one"""\n')
    second = _probe(root)
    assert (second["hits"], second["misses"]) == (1, 0), "an edit outside core/kernels/ recompiled the kernels"
    assert (cache / "numba-sources.sha256").read_text() == stamp
    assert sorted(cache.glob("rotation.normalise-*.nbi")) == index_files

    # layout.py is inlined into every kernel, though normalise's own file did not change
    _append(kernels / "layout.py", "\n# an edit inside the kernels\n")
    third = _probe(root)
    assert (third["hits"], third["misses"]) == (0, 1), "an edit under core/kernels/ kept the stale cache"
    assert (cache / "numba-sources.sha256").read_text() != stamp


def test_compile_kernels_covers_what_the_simulator_calls() -> None:
    from rigid_body_sim.core import INTEGRATORS, Simulator, load_scene
    from rigid_body_sim.core.kernels.compile import ENTRY_POINTS, compile_kernels
    from rigid_body_sim.core.stepping import unchecked_steps

    compile_kernels()
    before = {f.__name__: len(f.signatures) for f in ENTRY_POINTS}

    def spec(inertia: dict, motion: str = "free", **twist: list) -> dict:
        return {"mass": 1.0, "inertia": inertia, "motion": motion, "twist": twist,
                "sites": {"s": {"position": [0.1, 0.0, 0.0], "axes": "world"}, "b": {"position": [0.0, 0.1, 0.0]}}}

    box = {"box": [1.0, 0.6, 0.4]}
    scene = load_scene({"gravity": [0.0, 0.0, -9.81], "bodies": {
        "full": spec(box, angular=[0.3, 1.0, 0.2]), "ball": spec({"sphere": 0.1}, angular=[1.0, 0.0, 0.0]),
        "can": spec({"cylinder": [0.1, 0.5]}, angular=[1.0, 0.0, 3.0]), "wall": spec(box, "static"),
        "belt": spec(box, "kinematic", linear=[1.0, 0.0, 0.0]), "puck": spec(box, "planar"),
        "sat": spec(box, "rotation_only"), "cart": spec(box, "translation_only")},
        "wrenches": [{"body": "full", "frame": "full", "force": [0, 0, 1], "start": 0.0, "duration": 0.02}]})
    for name in INTEGRATORS:
        for reduce in (True, False):
            sim = Simulator(scene, integrator=name, dt=0.01, model_reduction=reduce)
            sim.step(1)
            sim.apply_force_at_point("full", [0.0, 1.0, 0.0], [0.5, 0.3, 0.0], frame="full")
            sim.apply_wrench("ball", torque=[0.0, 0.0, 0.1], frame="ball/s")
            sim.step(3)
            sim.apply_impulse("can", linear=[0.1, 0.0, 0.0], frame="can/b")
            sim.set_body_state("puck", linear_velocity_world=[0.1, 0.2, 0.0])
            sim.apply_wrench("puck", force=[0.0, 1.0, 0.0], frame="puck/s")
            sim.step(1)
            sim.site_readings()
            sim.clear_wrenches()
        unchecked_steps(name, scene.model, scene.initial_state, 0.01, 1)
    after = {f.__name__: len(f.signatures) for f in ENTRY_POINTS}
    assert after == before, "the Simulator compiled a signature compile_kernels does not make"


def test_compile_kernels_covers_the_body_body_kernels_the_scene_loader_calls() -> None:
    """The loader's overlap check (a scene with a ground) and a spawn's add no signature to the pair kernels."""
    import numpy as np

    from rigid_body_sim.core import SceneError, load_scene
    from rigid_body_sim.core.contact.compile_pairs import PAIR_ENTRY_POINTS, compile_pair_kernels
    from rigid_body_sim.core.contact.query import overlapping_bodies

    compile_pair_kernels()
    before = {f.__name__: len(f.signatures) for f in PAIR_ENTRY_POINTS}
    bodies = {"ball": {"mass": 1.0, "inertia": {"sphere": 0.1}, "pose": {"position": [0.0, 0.0, 1.0]}},
              "crate": {"mass": 1.0, "inertia": {"box": [0.2, 0.2, 0.2]}, "pose": {"position": [0.35, 0.0, 1.0]}},
              "can": {"mass": 1.0, "inertia": {"cylinder": [0.1, 0.2]}, "pose": {"position": [0.7, 0.0, 1.0]}},
              "pill": {"mass": 1.0, "inertia": {"sphere": 0.1}, "collision": {"capsule": [0.05, 0.1]},
                       "pose": {"position": [1.05, 0.0, 1.0]}}}
    scene = load_scene({"ground": [{"normal": [0.0, 0.0, 1.0]}], "bodies": bodies})
    with pytest.raises(SceneError, match="overlap"):
        load_scene({"ground": [{"normal": [0.0, 0.0, 1.0]}],
                    "bodies": {**bodies, "pea": {**bodies["ball"], "pose": {"position": [0.05, 0.0, 1.0]}}}})
    overlapping_bodies(scene.initial_state.p_WC_W, scene.initial_state.q_WP, scene.contact.shapes,
                       np.ones(4, dtype=bool), of=[3])
    after = {f.__name__: len(f.signatures) for f in PAIR_ENTRY_POINTS}
    assert after == before, "the overlap check compiled a signature compile_pair_kernels does not make"


@pytest.mark.parametrize("copier", ["deepcopy", "pickle"])
def test_a_copied_contact_simulator_steps_on_the_kernels_its_original_uses(copier: str) -> None:
    """A copy of a simulator with contact (``copy.deepcopy``, ``pickle``: numpy's copies of arrays are
    writable) passes its kernels the same array types as the original: no signature is added, so a copy
    never compiles (the islands' pass alone takes minutes to compile)."""
    import copy
    import pickle

    import numba
    import numpy as np

    from rigid_body_sim.core import Simulator, load_scene
    from rigid_body_sim.core.kernels.contact import batch, island, shapes, stage

    kernels = (island.island_pass, batch.hold_all, batch.settle_all, batch.split_bodies, batch.record_holds,
               batch.gravity_gains, batch.busy_bodies, stage.stage_rows, shapes.min_gaps, shapes.body_gap)
    scene = load_scene({"gravity": [0.0, 0.0, -9.81], "ground": [{"normal": [0, 0, 1], "offset": 0.0}], "bodies": {
        f"c{k}": {"mass": 1.0, "inertia": {"box": [0.2, 0.2, 0.2]}, "pose": {"position": [0.01 * k, 0.0, 0.1 + 0.2 * k]}}
        for k in range(2)}})
    sim = Simulator(scene, "rk4", 0.01)
    sim.step(20)
    assert sim.contact.in_island("c1")  # the islands' pass ran
    before = {f.__name__: len(f.signatures) for f in kernels}
    twin = copy.deepcopy(sim) if copier == "deepcopy" else pickle.loads(pickle.dumps(sim))

    def array_types(solver) -> dict[str, str]:  # numba's type of every array the contact solver holds
        found = {}
        for owner, part in (("", solver), ("pairs.", solver.pairs), ("islands.", solver.pairs.islands)):
            for name, value in vars(part).items():
                if isinstance(value, np.ndarray):
                    found[owner + name] = str(numba.typeof(value))
        return found

    assert array_types(twin.contact) == array_types(sim.contact)
    twin.step(20)
    twin.contact.reset(twin)
    after = {f.__name__: len(f.signatures) for f in kernels}
    assert after == before, "a copied simulator called a kernel with other array types than its original"


def test_every_compiled_function_has_a_name_of_its_own() -> None:
    """numba names a function's machine code by module, qualname, a count per process and argument types, and
    a cached function carries its callees' code under those names as weak symbols. Two closures of one factory
    compiled in different processes can so share a name, and a process loading both cached callers keeps one
    body for both: one caller then runs the other's closure (kernels/jit.py, named). So no two compiled functions
    of the core share a module and qualname."""
    import gc
    import importlib
    import pkgutil
    from collections import Counter

    from numba.extending import is_jitted

    import rigid_body_sim.core
    from rigid_body_sim.core.simulator import ensure_kernels

    ensure_kernels()  # kernels/single_step.py compiles (or loads) a cfunc at import
    for module in pkgutil.walk_packages(rigid_body_sim.core.__path__, "rigid_body_sim.core."):
        importlib.import_module(module.name)
    compiled = [f.py_func for f in gc.get_objects() if is_jitted(f) and f.py_func.__module__.startswith("rigid_body_sim.")]
    assert len(compiled) > 100, "the search found too few of the core's compiled functions"
    names = Counter((f.__module__, f.__qualname__) for f in compiled)
    assert [name for name, count in names.items() if count > 1] == []


def test_an_unpickled_simulator_waits_for_a_complete_kernel_cache(monkeypatch) -> None:
    """An unpickled Simulator skips ``__init__``; in a fresh process it still steps only once every kernel is
    compiled into the cache under its lock (ensure_kernels), never compiling them one by one as it calls them."""
    import pickle

    from rigid_body_sim.core import Simulator, load_scene
    from rigid_body_sim.core import simulator

    scene = load_scene({"bodies": {"ball": {"mass": 1.0, "inertia": {"sphere": 0.1}}}})
    data = pickle.dumps(Simulator(scene, "rk4", 0.01))
    monkeypatch.setattr(simulator, "_kernels_ready", False)  # as in a process that has built no Simulator yet
    pickle.loads(data)
    assert simulator._kernels_ready


#: Waits for the kernel cache (ensure_kernels) and says when it got past it.
WAITER = (
    "import time\n"
    "from rigid_body_sim.core.simulator import ensure_kernels\n"
    "ensure_kernels()\n"
    "print(time.monotonic(), flush=True)\n"
)


def wait_until_blocked_on(handle, process: subprocess.Popen, timeout: float = 120.0) -> None:
    """Wait until ``process`` waits for the flock held on ``handle``: the kernel lists a blocked
    request (``->``) of that pid on that file's inode in /proc/locks. Fails if it ends first."""
    import time

    inode = os.fstat(handle.fileno()).st_ino
    deadline = time.monotonic() + timeout
    while True:
        for line in Path("/proc/locks").read_text().splitlines():
            fields = line.split()
            if len(fields) > 5 and fields[1] == "->" and fields[5] == str(process.pid) \
                    and fields[6].rsplit(":", 1)[-1] == str(inode):
                return
        assert process.poll() is None, "a process went past the cache while another held its lock"
        assert time.monotonic() < deadline, f"the process never waited for the lock within {timeout} s"
        time.sleep(0.02)


def test_a_process_waits_while_another_compiles(tmp_path: Path) -> None:
    """Processes starting together on one cache take turns (cache_lock): while one holds the lock
    (compiling), another's first Simulator waits, and goes on the moment it is released."""
    import time

    from rigid_body_sim.core.kernels import jit

    cache = tmp_path / "numba_cache"
    cache.mkdir()
    (cache / jit.COMPLETE_NAME).write_text(jit.SOURCE_DIGEST)  # complete: once past the lock, nothing to compile
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(REPO)}
    with open(cache / jit.LOCK_NAME, "a+b") as handle:
        import fcntl

        fcntl.flock(handle, fcntl.LOCK_EX)  # another process compiling
        waiter = subprocess.Popen([sys.executable, "-c", WAITER], env=env, stdout=subprocess.PIPE, text=True)
        wait_until_blocked_on(handle, waiter)
        assert waiter.poll() is None, "a process went past the cache while another held its lock"
        released = time.monotonic()
        fcntl.flock(handle, fcntl.LOCK_UN)
    out, _ = waiter.communicate(timeout=120)
    assert waiter.returncode == 0
    assert float(out.strip().splitlines()[-1]) >= released


def test_compiling_refuses_sources_changed_under_the_process(monkeypatch) -> None:
    """A process whose kernel sources changed on disk after it imported them would cache its old
    machine code under the new sources' name: compile_kernels refuses, naming why."""

    from rigid_body_sim.core import simulator
    from rigid_body_sim.core.kernels import jit

    monkeypatch.setattr(jit, "SOURCE_DIGEST", "0" * 64)
    with pytest.raises(RuntimeError, match="changed since this process started"):
        simulator.compile_kernels()


def test_a_stale_cache_is_no_longer_complete(tmp_path: Path) -> None:
    from rigid_body_sim.core.kernels import jit

    source = tmp_path / "kernels"
    source.mkdir()
    (source / "a.py").write_text("x = 1\n")
    cache = source / "__pycache__"
    jit.invalidate_stale_cache(source, cache)
    (cache / jit.COMPLETE_NAME).write_text("digest of the old sources")
    (source / "a.py").write_text("x = 2\n")
    assert jit.invalidate_stale_cache(source, cache)
    assert not (cache / jit.COMPLETE_NAME).exists()
