"""benchmarks/contact_peers.py: the peers are set up as docs/contact_benchmarks.md says, and the docs block is one run's.

* The generated block of docs/contact_benchmarks.md is text of benchmarks/results/contact_peers.md
  (``make bench-contact`` writes both from one run).
* (bench: needs MuJoCo and PyBullet) Each peer's body has the inertia of the solid shape (2/5 m r²
  for the sphere, m (b² + c²)/12 for the cube), as ours; PyBullet's default damping is switched off
  (a free sphere keeps its speed over 1 s, the damping PyBullet applies by default would take
  7.5 % of it); MuJoCo's calibrated solref gives the first apex of the closed form; and the
  sampled-impact reading finds a peer's first impact within one step of the closed form.
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
