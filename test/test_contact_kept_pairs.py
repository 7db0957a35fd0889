"""The broad phase keeps the pairs of bodies whose paths did not change (core/contact/swept_pairs.py).

Its pairs are those of the hashed grid and the spheres' test it replaces (kernels/contact/swept.py:
grid_swept_pairs then spheres_may_meet, each tested against the brute force in test_contact_tunnelling.py),
pair for pair and in their order, which the islands' solve depends on; and a scene stepped with them is the same,
to the bit, as one whose broad phase lists every body again at every step.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigid_body_sim.core import Simulator, load_scene
from rigid_body_sim.core.contact.swept_pairs import SweptPairs
from rigid_body_sim.core.kernels.contact.layout import GROUND_WIDTH, NORMAL, OFFSET
from rigid_body_sim.core.kernels.contact.swept import grid_swept_pairs, spheres_may_meet, swept_bounds
from rigid_body_sim.core.kernels.layout import P, STATE_WIDTH, V

G = 9.81


def grid_then_spheres(Y0, Y1, members, movable, radius, h, grounds):
    """grid_swept_pairs then spheres_may_meet on their own arrays: (pairs kept, cells, heads, chain)."""
    n = len(members)
    lo, hi = np.empty((n, 3)), np.empty((n, 3))
    swept_bounds(Y0, Y1, members, radius, h, lo, hi)
    cells, chain = np.empty((n, 3), dtype=np.int64), np.empty(n, dtype=np.int64)
    heads = np.empty(1 << max(4, int(2 * n - 1).bit_length()), dtype=np.int64)
    pairs = np.empty((n * n, 2), dtype=np.int64)
    found = grid_swept_pairs(lo, hi, movable, cells, heads, chain, pairs)
    kept = spheres_may_meet(Y0, Y1, members, radius, h, grounds, pairs, found)
    return pairs[:kept], cells, heads, chain


def test_kept_pairs_are_the_grids_pairs_in_its_order_step_after_step():
    """120 movable bodies and 3 fixed ones (up to 10 times larger) with the ground z ≥ 0, over 80 steps: at most
    steps a few bodies move (some set across cells, some by a bit, one's radius shrinks), at others every body,
    the step's h or the ground. After each, SweptPairs' pairs are grid_then_spheres', in the same order, and the grid
    is filed the same; where the few moved, far fewer members are listed again than there are. Its room, too
    small at first (a dense start), grows."""
    rng = np.random.default_rng(11)
    n, n_fixed = 123, 3
    members = np.arange(n, dtype=np.int64)
    movable = np.ones(n, dtype=np.bool_)
    movable[rng.choice(n, n_fixed, replace=False)] = False
    radius = np.where(movable, rng.uniform(0.03, 0.07, n), rng.uniform(0.1, 0.8, n))
    largest = np.flatnonzero(movable)[0]
    radius[largest] = 0.075  # the cell: 0.15 m and a few mm rounded up to 2^(−43/16) = 0.1555 m (grid_cell)
    Y0 = np.zeros((n, STATE_WIDTH + 1))
    Y0[:, P:P + 3] = rng.uniform(-0.15, 0.15, (n, 3)) + [0.0, 0.0, 0.1]  # dense: more pairs than the room
    Y1 = Y0.copy()
    grounds = np.zeros((1, GROUND_WIDTH))
    grounds[0, NORMAL + 2] = 1.0
    lo, hi, cells = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3), dtype=np.int64)
    heads, chain = np.empty(1 << max(4, int(2 * n - 1).bit_length()), dtype=np.int64), np.empty(n, dtype=np.int64)
    kept = SweptPairs(members, movable, lo, hi, cells, heads, chain)
    room = len(kept.pairs)
    h = 1e-3
    few_listed = []
    for step in range(80):
        Y0 = Y1.copy()
        Y1 = Y0.copy()
        if step == 1:  # spread out
            Y0[:, P:P + 3] = Y1[:, P:P + 3] = rng.uniform(-1.0, 1.0, (n, 3)) + [0.0, 0.0, 1.0]
            Y0[:, V:V + 3] = Y1[:, V:V + 3] = 0.0
        kind = step % 10
        if kind == 0:  # every body
            Y1[:, V:V + 3] += rng.normal(0.0, 0.3, (n, 3))
            Y1[:, P:P + 3] += h * Y1[:, V:V + 3]
        elif kind == 5:
            h = 2e-3 if h == 1e-3 else 1e-3
        elif kind == 7:
            grounds[0, OFFSET] = -0.5 if grounds[0, OFFSET] == 0.0 else 0.0
        else:
            moved = rng.choice(np.flatnonzero(movable), int(rng.integers(0, 5)), replace=False)
            for i in moved:
                if rng.random() < 0.3:  # set elsewhere (across cells), now and then
                    Y0[i, P:P + 3] = Y1[i, P:P + 3] = Y1[i, P:P + 3] + rng.uniform(-0.4, 0.4, 3)
                Y1[i, V:V + 3] = rng.normal(0.0, 0.2, 3)
                Y1[i, P:P + 3] += h * Y1[i, V:V + 3]
            if kind == 3:
                radius[rng.choice(np.flatnonzero(movable)[1:])] *= 0.9  # not the largest: the same cell
        swept_bounds(Y0, Y1, members, radius, h, lo, hi)
        found = kept.find(Y0, Y1, radius, h, grounds)
        pairs, ref_cells, ref_heads, ref_chain = grid_then_spheres(Y0, Y1, members, movable, radius, h, grounds)
        assert np.array_equal(kept.pairs[:found], pairs), step
        assert np.array_equal(cells[movable], ref_cells[movable]) and np.array_equal(heads, ref_heads)
        assert np.array_equal(chain[movable], ref_chain[movable])
        if step == 0:
            assert found > room  # the dense start did not fit: the room grew
        if kind in (2, 3, 4, 6, 8, 9) and step > 10:  # the step before moved a few bodies too, or none
            few_listed.append(kept.listed)
    assert max(few_listed) < n // 4, few_listed


def scene(sleeping: bool) -> Simulator:
    """A 10 × 10 grid of 0.1 m cubes resting on the ground, 0.12 m apart, and a ball (r 50 mm, 1 kg) 0.3 m above
    one of the middle four (c4_4), falling."""
    box = {"box": [0.1] * 3}
    material = {"restitution": 0.0, "friction": 0.5}
    bodies = {f"c{i}_{j}": {"mass": 1.0, "inertia": box, "collision": box, "material": material,
                            "pose": {"position": [0.12 * i, 0.12 * j, 0.05]}} for i in range(10) for j in range(10)}
    ball = {"sphere": 0.05}
    bodies["ball"] = {"mass": 1.0, "inertia": ball, "collision": ball, "material": material,
                      "pose": {"position": [0.48, 0.48, 0.45]}}
    sim = Simulator(load_scene({"gravity": [0.0, 0.0, -G], "bodies": bodies,
                                "ground": [{"normal": [0, 0, 1], "offset": 0.0, "material": material}]}),
                    integrator="rk4", dt=1e-3, threads=1)
    sim.contact.sleeping = sleeping
    return sim


@pytest.mark.parametrize("sleeping", [True, False])
def test_a_scene_steps_the_same_to_the_bit_whether_the_pairs_are_kept_or_listed_again(sleeping):
    """The grid of cubes (asleep, with sleeping on) and the ball falling onto them, landing and coming to rest
    (0.4 s): every state row and contact the same, to the bit, as the same scene whose broad phase lists every
    body again at each step (the pairs found anew). Sleeping on, while the ball falls onto the cubes asleep, fewer
    than a quarter of the 101 bodies are listed again at any step (those whose 14 cells it is in)."""
    kept, anew = scene(sleeping), scene(sleeping)
    swept = (anew.contact.pairs._swept, anew.contact.pairs._swept_grown)
    listed = []
    for step in range(400):
        for s in swept:
            s._state[0] = 0.0  # nothing kept: every member listed again
        kept.step(1)
        anew.step(1)
        assert np.array_equal(kept.state.rows(), anew.state.rows()), step
        if 5 < step < 250:
            listed.append(kept.contact.pairs._swept.listed)
    for x, y in zip(kept.contact.pairs.islands.contacts(), anew.contact.pairs.islands.contacts()):
        assert np.array_equal(x, y)
    assert kept.state.rows()[100, P + 2] < 0.2  # the ball came down onto the cubes
    if sleeping:
        assert max(listed) < 101 // 4, listed
