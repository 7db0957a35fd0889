"""The benchmark code runs, and its comparisons are like for like (tiny sizes; no timing is asserted).

* The floors and the do-it-yourself numpy loop (benchmarks/floors.py) take the same step as our
  ``euler`` and ``rk4``: same problem, states equal to round-off after a few steps (different
  code computes each side, so a tolerance: 1e-12 over 20 steps of order-1 quantities).
* MuJoCo's site motor pushes the box as the closed form does (when MuJoCo is installed): the
  mapping of "a force fixed in the body at a site" onto MuJoCo is the same physical input.
* ``python -m benchmarks.run --smoke`` writes every file of every part (tiny sizes): two parts
  in the default run, all of them in the slow run (about 40 s on a loaded 2-core machine).

The package never imports benchmarks/ (test_core_purity-style check below).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rigid_body_sim.core import Simulator
from rigid_body_sim.exact import closed_form

REPO = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.timeout(600)


def _our_rows(sim: Simulator) -> np.ndarray:
    rows = []
    for name in sim.body_names:
        s = sim.body_state(name)
        x, y, z, w = s.orientation_xyzw
        rows.append(np.concatenate((s.position_world, (w, x, y, z), s.linear_velocity_world, s.angular_velocity_body)))
    return np.array(rows)


@pytest.mark.parametrize("method", ["euler", "rk4"])
def test_floor_and_numpy_loop_take_our_step(method):
    from benchmarks import floors, throughput

    count, steps = 3, 20
    sim = Simulator(throughput.scene(count), integrator=method, dt=throughput.DT)
    sim.step(steps)
    Y = floors.initial_rows(count, throughput.ANGULAR_VELOCITY)
    floors.FLOORS[method](Y, np.tile(throughput.INERTIA_BOX, (count, 1)), throughput.DT, steps)
    bodies = floors.NumpyBodies(floors.initial_rows(count, throughput.ANGULAR_VELOCITY),
                                np.tile(throughput.INERTIA_BOX, (count, 1)), np.full(count, throughput.MASS), method)
    for _ in range(steps):
        bodies.step(throughput.DT)
    ours = _our_rows(sim)
    np.testing.assert_allclose(Y, ours, rtol=0, atol=1e-12)
    np.testing.assert_allclose(bodies.rows(), ours, rtol=0, atol=1e-12)


@pytest.mark.bench
def test_mujoco_site_motor_is_a_force_fixed_in_the_body():
    import mujoco

    from benchmarks import mujoco_models as mjm
    from benchmarks import problems as P

    h, steps = 1e-3, 500
    m, d = mjm.make(1, P.box_inertia(), P.BOX_MASS, h, "RK4", site=tuple(P.BOX_SITE_B))
    d.ctrl[0] = P.BOX_FORCE_S[1]
    mujoco.mj_step(m, d, nstep=steps)
    _q, _w, _v, p_ref = closed_form.box_body_fixed_force(P.BOX_MASS, P.box_inertia()[2], P.BOX_FORCE_S, P.BOX_SITE_B,
                                                        np.array([steps * h]))
    # RK4 at h = 1 ms over 0.5 s: fourth order, error ~1e-12 m (4.9e-12 m was seen over 1 s)
    assert np.linalg.norm(d.qpos[0:3] - p_ref[0]) < 1e-9


def _bench_smoke(tmp_path: Path, parts: str) -> tuple[Path, Path]:
    out, docs = tmp_path / "results", tmp_path / "docs"
    docs.mkdir()
    (docs / "stability.md").write_text((REPO / "docs" / "stability.md").read_text())
    proc = subprocess.run([sys.executable, "-m", "benchmarks.run", "--smoke", "--out", str(out), "--docs", str(docs),
                           "--parts", parts], cwd=REPO, capture_output=True, text=True, timeout=540)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return out, docs


def test_bench_smoke_run_writes_the_files_of_its_parts(tmp_path):
    """The default run's representative: the two quickest parts in one --smoke run (the slow run
    below runs every part)."""
    out, _docs = _bench_smoke(tmp_path, "throughput,apply")
    for name in ("results_partial.md", "throughput.csv", "apply_cost.csv", "site_force.csv", "targets.csv",
                 "throughput.png"):
        assert (out / name).stat().st_size > 0, name
    results = (out / "results_partial.md").read_text()
    assert "Parts not run in this run: work, reduction, profile" in results
    assert "plain numba loop" in results


@pytest.mark.slow
def test_bench_smoke_run_writes_every_file(tmp_path):
    out, docs = _bench_smoke(tmp_path, "throughput,apply,work,reduction,profile")
    for name in ("results.md", "throughput.csv", "apply_cost.csv", "site_force.csv", "work_precision.csv",
                 "reduction.csv", "targets.csv", "throughput.png", "work_precision_top.png", "work_precision_box.png",
                 "profile_kernels.txt"):
        assert (out / name).stat().st_size > 0, name
    results = (out / "results.md").read_text()
    assert "Parts not run in this run" not in results
    assert "plain numba loop" in results and "site motor" in results
    claims = json.loads((docs / "choosing_an_integrator.claims.json").read_text())
    assert {c["kind"] for c in claims["claims"]} >= {"reached", "not_reached"}
    assert "Choosing an integrator" in (docs / "choosing_an_integrator.md").read_text()


def test_the_package_never_imports_benchmarks():
    offenders = [str(p.relative_to(REPO)) for p in (REPO / "rigid_body_sim").rglob("*.py")
                 if "benchmarks" in p.read_text().replace("benchmarks/", "")
                 and any(line.lstrip().startswith(("import benchmarks", "from benchmarks"))
                         for line in p.read_text().splitlines())]
    assert offenders == []


def test_performance_page_block_is_the_one_in_results_md():
    """docs/performance.md's generated block is text of results.md, from the same run (make bench writes both):
    the provenance and machine, the per-integrator table, and the per-frame cost tables one heading level down."""
    page = (REPO / "docs" / "performance.md").read_text()
    block = page.split("<!-- bench:begin -->", 1)[1].split("<!-- bench:end -->", 1)[0].strip()
    assert block, "docs/performance.md's benchmark block is empty: run `make bench`"
    results = (REPO / "benchmarks" / "results" / "results.md").read_text()
    head, marker, costs = block.partition("**What a force costs from Python**")
    assert marker, "the block lacks the per-frame cost tables: run `make bench`"
    machine, per_integrator_marker, per_integrator = head.partition("Per integrator, this run")
    assert per_integrator_marker, "the block lacks the per-integrator table: run `make bench`"
    assert machine.strip() in results
    assert (per_integrator_marker + per_integrator).strip() in results
    tables = costs.split("\n", 2)[2].strip()  # after the one-line lead-in: the two tables, one heading level down
    assert tables.replace("\n#### ", "\n### ").replace("#### ", "### ", 1) in results


def test_mixed_piles_draws_its_documented_settings_and_counts_a_run_beyond_its_tolerance(tmp_path, capsys):
    """benchmarks/mixed_piles.py (docs/contact.md's mixed-pile figures): each seed's settings are among those its
    docstring lists (at most 64 bodies at dt = 1 ms) and the same when drawn again; ``summary`` counts a run
    beyond its tolerance where an overlap is deeper than the tolerance + 1e-9 m, body, wall and ground apart."""
    from benchmarks.mixed_piles import settings, summary
    for seed in range(200):
        s = settings(seed)
        assert s == settings(seed)
        assert s["n"] in (27, 64, 125, 216) and s["e"] in (0.0, 0.5) and s["tol"] in (0.0, 1e-5, 1e-3)
        assert s["integrator"] in ("rk4", "semi_implicit_euler") and s["dt"] in (1e-3, 5e-3, 1e-2)
        assert s["dt"] != 1e-3 or s["n"] <= 64
    common = "integrator=rk4 dt=0.01 sleep=False finite=True rise=0.00e+00 worst=- seconds=1"
    lines = [f"seed=1 n=27 e=0.0 tol=1e-05 body=1.000e-05 wall=0.000e+00 ground=1.0000005e-05 {common}",  # within
             f"seed=2 n=27 e=0.0 tol=0.0 body=2.000e-09 wall=0.000e+00 ground=0.000e+00 {common}",  # body beyond
             f"seed=3 n=27 e=0.0 tol=0.001 body=0.000e+00 wall=0.000e+00 ground=1.1e-03 {common}",  # ground beyond
             "seed=4 n=216 skipped: bodies that start apart"]
    runs = tmp_path / "piles.txt"
    runs.write_text("\n".join(lines) + "\n")
    summary([str(runs)])
    out = capsys.readouterr().out
    assert out.startswith("3 runs, all finite: True")
    assert "dt = 0.01 s: 3 runs" in out and "beyond tolerance 2: body 1" in out and "wall 0, ground 1" in out
