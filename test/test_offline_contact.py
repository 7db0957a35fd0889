"""``rigid-body-sim run`` and ``plot`` with a contact scene, against the closed form of the dropped ball.

config/contact_bouncing_ball.yaml: r = 0.1 m, m = 1 kg, lowest point at h = 1 m, e = 0.5,
g = 9.81. Impacts at t1 = √(2h/g), t_{k+1} = t_k + 2 e^k v1 / g (v1 = √(2gh)); the k-th impact
(from 0) loses ½ m (e^k v1)² (1 − e²) of kinetic energy; between impacts the lowest gap is the
parabola e^k v1 (t − t_k) − g (t − t_k)²/2. Over 1.2 s there are three impacts.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from rigid_body_sim.cli import main
from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.core.contact.query import lowest_gaps_along
from rigid_body_sim.offline.csv_io import read_csv
from rigid_body_sim.offline.reference import closed_form_reference
from rigid_body_sim.offline.run import run_offline
from rigid_body_sim.offline.rundata import with_derived_quantities

BALL = Path(__file__).resolve().parents[1] / "config" / "contact_bouncing_ball.yaml"
G, E, R, H, M = 9.81, 0.5, 0.1, 1.0, 1.0
T1, V1 = math.sqrt(2.0 * H / G), math.sqrt(2.0 * G * H)
IMPACTS = [T1, T1 + 2 * E * V1 / G, T1 + 2 * E * V1 / G + 2 * E**2 * V1 / G]


def gap(t: float) -> float:
    """Closed-form lowest gap of the ball at t (before the fourth impact)."""
    if t <= T1:
        return H - 0.5 * G * t * t
    k = max(k for k, tk in enumerate(IMPACTS) if tk <= t)
    s = t - IMPACTS[k]
    return E ** (k + 1) * V1 * s - 0.5 * G * s * s


def test_run_offline_reports_the_impacts_their_energy_and_the_lowest_gap() -> None:
    sim = Simulator(load_scene(BALL), "rk4", 0.001)
    summary = run_offline(sim, 1.2, sample_every=10)
    contact = summary.contact
    assert contact is not None
    assert contact["impacts"] == 3 and contact["events"] == 3 and contact["resting"] == 0
    lost = -sum(0.5 * M * (E**k * V1) ** 2 * (1 - E**2) for k in range(3))
    assert abs(contact["impact_energy"] - lost) < 1e-9
    samples = np.arange(0, 121) * 0.01
    assert abs(contact["lowest_gap"] - min(gap(t) for t in samples)) < 1e-9
    assert run_offline(Simulator(load_scene(BALL.parent / "default_scene.yaml")), 0.01).contact is None


def test_cli_run_and_plot_draw_energy_and_gap_of_a_contact_scene(tmp_path: Path, capsys) -> None:
    csv = tmp_path / "ball.csv"
    assert main(["run", str(BALL), "--duration", "1.2", "--dt", "0.001", "--rate", "100", "--csv", str(csv)]) == 0
    out = capsys.readouterr().out
    assert "contact: 3 impacts (3 events)" in out and "0 bodies resting at the end" in out
    scene = load_scene(BALL)
    data = with_derived_quantities(read_csv(csv), scene)
    ball = data.bodies["ball"]
    # the gap over time, from the sampled poses: the closed form's parabolas
    gaps = lowest_gaps_along(Simulator(scene), "ball", ball.position_world, ball.orientation_xyzw)
    np.testing.assert_allclose(gaps, [gap(t) for t in data.time], rtol=0, atol=1e-9)
    # energy: drops by the impacts' losses, never rises
    energy = ball.energy - ball.energy[0]
    assert np.all(np.diff(energy) <= 1e-9)
    assert abs(energy[-1] + sum(0.5 * M * (E**k * V1) ** 2 * (1 - E**2) for k in range(3))) < 1e-9
    # no free-flight "closed form" for a body the ground touches
    reference = closed_form_reference(scene, "ball", data.time)
    assert reference.position_world is None and reference.translation == "none: ground contact"
    assert main(["plot", str(csv), "--output", str(tmp_path / "cli.png")]) == 0  # plot_body with its contact panels
    assert (tmp_path / "cli.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_gaps_are_of_the_body_frame_pose_also_when_principal_axes_differ() -> None:
    """A box (edges 0.4, 0.2, 0.1 m along B's axes) whose inertia tensor is not diagonal in B (so its
    principal axes P are turned away from B): at position z and B level its lowest gap is z − 0.05, and
    with B turned a quarter about x it is z − 0.1 (the 0.2 m edge vertical)."""
    from rigid_body_sim.core.scene import load_scene_text

    scene = load_scene_text("""
gravity: [0.0, 0.0, -9.81]
ground:
  - {normal: [0, 0, 1], offset: 0.0}
bodies:
  plate:
    mass: 1.0
    inertia: {tensor: [[0.02, 0.005, 0.0], [0.005, 0.03, 0.0], [0.0, 0.0, 0.04]]}
    collision: {box: [0.4, 0.2, 0.1]}
    pose: {position: [0.0, 0.0, 1.0]}
""", "plate")
    assert abs(scene.model.q_BP[0][0]) < 1.0 - 1e-6  # P is turned away from B
    sim = Simulator(scene)
    s = math.sqrt(0.5)
    gaps = lowest_gaps_along(sim, "plate", [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]], [[0, 0, 0, 1], [s, 0, 0, s]])
    np.testing.assert_allclose(gaps, [0.95, 0.9], rtol=0, atol=1e-12)
