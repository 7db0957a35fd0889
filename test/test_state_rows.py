"""Simulator.pose_twist_rows (one compiled pass, kernels/state_rows.py) against the numpy read-outs: bitwise.

Both compute the same IEEE operations in the same order (core/quaternion.py's formulas), so the
rows must equal positions_world, orientations_xyzw, linear_velocities_world,
angular_velocities_world and State.finite_bodies exactly, for bodies whose body frame differs
from their principal frame (a full inertia tensor) and for a body whose state is not finite.
"""

from __future__ import annotations

import numpy as np

from rigid_body_sim.core import Simulator, load_scene


def test_pose_twist_rows_are_bitwise_the_numpy_read_outs() -> None:
    rng = np.random.default_rng(7)
    bodies = {}
    for k in range(40):
        q = rng.normal(size=4)
        inertia = ({"tensor": [[2.0, 0.3, -0.1], [0.3, 1.5, 0.2], [-0.1, 0.2, 1.0]]} if k % 2
                   else {"box": (0.5 + rng.random(3)).tolist()})
        bodies[f"b{k}"] = {"mass": 1.0 + rng.random(), "inertia": inertia,
                           "pose": {"position": rng.normal(size=3).tolist(), "orientation": (q / np.linalg.norm(q)).tolist()},
                           "twist": {"linear": rng.normal(size=3).tolist(), "angular": (3.0 * rng.normal(size=3)).tolist()}}
    sim = Simulator(load_scene({"bodies": bodies}), integrator="rk4", dt=0.01)
    sim.step(7)
    n = len(bodies)
    poses, twists = np.empty((n, 7)), np.full((n, 7), 5.0)
    finite = sim.pose_twist_rows(poses, twists)
    assert finite.dtype == np.bool_ and finite.all()
    np.testing.assert_array_equal(poses[:, :3], sim.positions_world())
    np.testing.assert_array_equal(poses[:, 3:], sim.orientations_xyzw())
    np.testing.assert_array_equal(twists[:, :3], sim.linear_velocities_world())
    np.testing.assert_array_equal(twists[:, 3:6], sim.angular_velocities_world())
    assert (twists[:, 6] == 5.0).all()  # left as it was
    assert not np.array_equal(sim.orientations_xyzw(), sim.state.q_WP[:, [1, 2, 3, 0]])  # B is not P here
    state = sim.state.copy()
    state.v_WC_W[3, 1] = np.nan
    state.w_WP_P[8, 2] = np.inf
    sim.state = state
    finite = sim.pose_twist_rows(poses, twists)
    np.testing.assert_array_equal(finite, sim.state.finite_bodies())
    assert finite.sum() == n - 2
