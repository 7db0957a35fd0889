"""benchmarks/contact_peers.py: the peers are set up as docs/contact_benchmarks.md says, and the docs block is one run's.

* The generated block of docs/contact_benchmarks.md is text of benchmarks/results/contact_peers.md
  (``make bench-contact`` writes both from one run).
* (bench: needs MuJoCo and PyBullet) Each peer's body has the inertia of the solid shape (2/5 m r²
  for the sphere, m (b² + c²)/12 for the cube), as ours; PyBullet's default damping is switched off
  (a free sphere keeps its speed over 1 s, the damping PyBullet applies by default would take
  7.5 % of it); MuJoCo's calibrated solref gives the first apex of the closed form; and the
  sampled-impact reading finds a peer's first impact within one step of the closed form.
* The rocking box: the bench's reading of ours meets Housner's closed form (1e-9); (bench) MuJoCo and
  PyBullet start it tilted and land it near the closed form's first landing.
* Between bodies (benchmarks/contact_bodies.py): the bench's reading of ours meets the closed
  forms (two spheres head-on and oblique within 1e-9, both tunnelling scenes held at dt = 10 ms)
  and its tables print; a peer's impact time read from samples is the end of the step holding
  the first velocity change (synthetic samples of a known impact); (bench) one dt of every case on
  every engine runs, PyBullet's spheres carry √e and √μ and its ccd setting its swept sphere.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.timeout(300)


def test_docs_block_is_text_of_the_results_of_the_same_run():
    page = (REPO / "docs" / "contact_benchmarks.md").read_text()
    block = page.split("<!-- contact-bench:begin -->", 1)[1].split("<!-- contact-bench:end -->", 1)[0].strip()
    assert block, "docs/contact_benchmarks.md's block is empty: run `make bench-contact`"
    assert block in (REPO / "benchmarks" / "results" / "contact_peers.md").read_text()


@pytest.mark.bench
def test_peer_bodies_have_the_solid_shapes_inertia():
    from benchmarks import contact_engines as E

    sphere = E.Body("sphere", (0.1,), 1.0, (0.0, 0.0, 0.1), friction=0.3)
    cube = E.Body("box", (0.2, 0.2, 0.2), 1.0, (0.0, 0.0, 0.1), friction=0.5)
    for body, expected in ((sphere, 0.4 * 0.01), (cube, 1.0 / 12.0 * 0.08)):
        np.testing.assert_allclose(body.inertia, expected, rtol=1e-12)
        mj = E.MuJoCo(body, 1e-3, "pyramidal")
        np.testing.assert_allclose(mj.m.body_inertia[1], expected, rtol=1e-9)
        assert mj.m.body_mass[1] == pytest.approx(1.0, rel=1e-12)
        pb = E.PyBullet(body, 1e-3, "default")
        info = E.pybullet.getDynamicsInfo(pb.ids[0], -1, physicsClientId=pb.c)
        assert info[0] == pytest.approx(1.0, rel=1e-12)
        np.testing.assert_allclose(info[2], expected, rtol=1e-6)  # Bullet keeps float32-rounded inertia
        pb.close()


@pytest.mark.bench
def test_pybullet_damping_is_off():
    from benchmarks import contact_engines as E

    ball = E.Body("sphere", (0.1,), 1.0, (0.0, 0.0, 5.0), friction=0.5, velocity=(1.0, 0.0, 0.0),
                  angular_velocity=(0.0, 0.0, 2.0), gravity=(0.0, 0.0, 0.0))
    pb = E.PyBullet(ball, 1e-3, "default")
    pb.step(1000)
    _, w, v, _ = pb.sample()
    assert v[0] == pytest.approx(1.0, rel=1e-6) and w[2] == pytest.approx(2.0, rel=1e-6)
    pb.close()


@pytest.mark.bench
def test_mujoco_calibrated_solref_gives_the_first_apex_and_impacts_are_read_within_a_step():
    from benchmarks import contact_engines as E
    from benchmarks import contact_peers as C
    from rigid_body_sim.exact import contact as exact

    dt = 1e-3
    mj = E.MuJoCo(C.bounce_body(), dt, "calibrated", C.calibrate_dampratio(dt))
    r = C.run(mj, 1.2)
    impacts, flights = C._impacts(r, 3)
    assert C._apexes(r, flights, 1)[0] == pytest.approx(exact.bounce_apex(1, C.H0, C.E_BOUNCE), rel=1e-6)
    assert abs(impacts[0] - exact.bounce_impact_time(1, C.H0, C.E_BOUNCE, C.G)) <= dt


def test_the_rocking_box_reads_ours_at_housners_closed_form():
    """Ours (rk4, dt = 1 ms) read by the rocking case: landings 1 and 5 within 1e-9 s and the energy kept at them
    within 1e-9 of (1 − (3/2) sin²α)²: the reading itself adds no error (located impacts; the rocks' energy
    constant between landings)."""
    from benchmarks import contact_engines as E
    from benchmarks import contact_peers as C

    rows = C.case_rock(E.Ours(C.rock_body(), 1e-3, "rk4"))
    assert [r["quantity"] for r in rows] == ["landing 1", "energy kept at landing 1", "landing 5",
                                            "energy kept at landing 5"]
    for r in rows:
        assert abs(r["error"]) <= 1e-9, r


@pytest.mark.bench
def test_peers_start_the_rocking_box_tilted_and_read_its_first_landing():
    """The box's orientation reaches MuJoCo and PyBullet: each starts tilted as ours and lands on its other edge
    within 2 ms of the closed form's first landing (their own contact apart), with some of its rocking energy kept."""
    from benchmarks import contact_engines as E
    from benchmarks import contact_peers as C

    for engine in (E.MuJoCo(C.rock_body(), 1e-3, "pyramidal"), E.PyBullet(C.rock_body(), 1e-3, "default")):
        rows = {r["quantity"]: r for r in C.case_rock(engine)}
        assert abs(rows["landing 1"]["error"]) <= 2e-3, (engine.name, rows)
        assert 0.0 < rows["energy kept at landing 1"]["value"] < 1.0, (engine.name, rows)
        engine.close()


def _our_rows(case, items, dt, spins):
    from benchmarks import contact_bodies as B

    rows = B.case_impact(case, items, B.Ours(items, dt, "rk4"), dt, spins)
    for r in rows:
        r.update(engine="rigid_body_sim", setting="rk4", dt=dt)
    return rows


def test_two_body_cases_read_ours_at_the_closed_form_and_print():
    from benchmarks import contact_bodies as B
    from benchmarks import contact_peers as C

    rows = _our_rows("head-on, unequal", B.head_on(False), 1e-3, False)
    rows += _our_rows("oblique", B.oblique(False), 1e-3, True)
    rows += _our_rows("oblique", B.oblique(True), 1e-3, True)
    for r in rows:
        scale = 1e-9 if r["relative"] or r["unit"] != "s" else 1e-9 * r["exact"]
        assert abs(r["error"]) <= scale, r
    tunnels = []
    for case, items in (("wall", B.tunnel_wall()), ("pair", B.tunnel_pair())):
        row = B.case_tunnel(case, items, B.Ours(items, 1e-2, "rk4"), 1e-2)
        assert row["outcome"] == "held", row
        tunnels.append({**row, "engine": "rigid_body_sim", "setting": "rk4", "dt": 1e-2})
    text = C.bodies_text({"figures": rows, "tunnels": tunnels,
                          "costs": [{"case": "wall", "dt": 1e-2, "engine": "rigid_body_sim", "setting": "rk4",
                                     "us_per_step": 12.5}]})
    assert "| oblique | ω_b after" in text and "| wall | held / — / — |" in text and "12.5 / — / —" in text


def test_a_peers_impact_time_is_read_at_the_end_of_the_step_holding_the_first_velocity_change():
    """Synthetic samples: two spheres on straight lines whose velocities jump at a known t* inside
    a step; the reading is the end of that step."""
    from benchmarks import contact_bodies as B

    items = B.head_on(False)
    a, b = items
    t_star, dt = B.contact_time(a, b), 1e-2
    after = B.exact_after(a, b)[1]
    t = np.arange(40) * dt
    samples = np.zeros((len(t), 2, 9))
    for k, it in enumerate(items):
        before = np.add(it.position, np.outer(np.minimum(t, t_star), it.velocity))
        samples[:, k, 0:3] = before + np.outer(np.maximum(t - t_star, 0.0), after[2 * k])
        samples[:, k, 3:6] = np.where((t > t_star)[:, None], after[2 * k], it.velocity)
    assert B.sampled_impact_time(samples, dt) == t[np.argmax(t > t_star)]
    assert 0.0 < B.sampled_impact_time(samples, dt) - t_star <= dt
    assert np.isnan(B.sampled_impact_time(samples[:2], dt))


@pytest.mark.bench
def test_every_two_body_case_runs_on_every_engine_at_one_dt():
    from benchmarks import contact_bodies as B

    figures, tunnels, costs, settings = B.measure(True, lambda msg: None, dts=(1e-3,), min_seconds=1e-3)
    engines = {(r["engine"], r["setting"]) for r in figures}
    assert {("MuJoCo", "oscillator"), ("MuJoCo", "calibrated"), ("PyBullet", "default"),
            ("PyBullet", "tuned"), ("rigid_body_sim", "rk4")} <= engines
    assert {(r["engine"], r["setting"]) for r in tunnels} >= {("PyBullet", "ccd"), ("MuJoCo", "default")}
    assert all(r["outcome"] == "held" for r in tunnels if r["engine"] == "rigid_body_sim")
    assert {r["case"] for r in figures} >= {"oblique, spin, sticking", "oblique, spin, sliding"}
    assert len(costs) == len({(r["case"], r["engine"], r["setting"]) for r in figures + tunnels})
    assert "ccdSweptSphereRadius" in settings["PyBullet, ccd (tunnelling)"]
    pb = B.PyBullet(B.oblique(True), 1e-3, "default")
    info = B.pybullet.getDynamicsInfo(pb.ids[0], -1, physicsClientId=pb.c)
    assert info[1] == pytest.approx(B.MU_OBLIQUE ** 0.5) and info[5] == pytest.approx(B.E_PAIR ** 0.5)
    pb.close()
