"""The reference signed distance of convex pairs (rigid_body_sim/exact/convex_distance.py) against hand-derived values.

Cylinder (A, radius r, half length h, axis z unless rotated) against a sphere, another cylinder,
a box and a capsule, apart and overlapping, where the answer is a closed form: side against side
(parallel axes, crossed axes), an end face flat on a face, a capsule or cylinder lying across an
end face, a box edge against the side, a tilted cylinder's rim on a face (lowest point
c_z − h cos θ − r sin θ), a sphere at the rim (the distance to the rim circle) and inside.
Distances within 1e-12 m, normals within 1e-12 (unit vectors). Plus its bad-input errors and
its agreement with the definition on random poses (no sampled direction separates more).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rigid_body_sim.exact.convex_distance import sep, signed_distance

I3 = np.eye(3)
ABOUT_Y_90 = Rotation.from_euler("y", 90, degrees=True).as_matrix()  # local z → world x


def shape(kind, dims, centre=(0.0, 0.0, 0.0), rot=I3):
    return kind, np.asarray(dims, float), np.asarray(centre, float), np.asarray(rot, float)


CYL = shape("cylinder", (0.3, 0.5))
S2 = math.sqrt(2.0)
TILT = 0.37
R_TILT = Rotation.from_euler("y", TILT).as_matrix()

CASES = {
    # cylinder–sphere
    "sphere at the side": (CYL, shape("sphere", (0.1,), (0.6, 0.0, 0.1)), 0.2, (1, 0, 0)),
    "sphere above the end face": (CYL, shape("sphere", (0.1,), (0.05, 0.1, 0.9)), 0.3, (0, 0, 1)),
    "sphere at the rim": (CYL, shape("sphere", (0.1,), (0.6, 0.0, 0.9)), 0.4, (0.6, 0, 0.8)),
    "sphere inside near the side": (CYL, shape("sphere", (0.1,), (0.0, -0.25, 0.0)), -0.15, (0, -1, 0)),
    # cylinder–cylinder
    "parallel side by side": (CYL, shape("cylinder", (0.2, 0.4), (0.6, 0.0, 0.1)), 0.1, (1, 0, 0)),
    "parallel overlapping": (CYL, shape("cylinder", (0.2, 0.4), (0.0, 0.45, 0.1)), -0.05, (0, 1, 0)),
    "end on end": (CYL, shape("cylinder", (0.2, 0.4), (0.05, 0.0, 1.0)), 0.1, (0, 0, 1)),
    "end on end sunk": (CYL, shape("cylinder", (0.2, 0.4), (0.05, 0.0, -0.88)), -0.02, (0, 0, -1)),
    "crossed sides": (CYL, shape("cylinder", (0.2, 0.4), (0.0, 0.7, 0.0), ABOUT_Y_90), 0.2, (0, 1, 0)),
    "lying across the end face": (CYL, shape("cylinder", (0.2, 0.4), (0.0, 0.05, 0.73), ABOUT_Y_90), 0.03,
                                  (0, 0, 1)),
    "tilted rim on a wide end face": (shape("cylinder", (2.0, 0.1)),
                                      shape("cylinder", (0.2, 0.4), (0.3, 0.2, 0.62), R_TILT),
                                      0.62 - 0.4 * math.cos(TILT) - 0.2 * math.sin(TILT) - 0.1, (0, 0, 1)),
    "tilted rim sunk in a wide end face": (shape("cylinder", (2.0, 0.1)),
                                           shape("cylinder", (0.2, 0.4), (0.3, 0.2, 0.45), R_TILT),
                                           0.45 - 0.4 * math.cos(TILT) - 0.2 * math.sin(TILT) - 0.1, (0, 0, 1)),
    # cylinder–box
    "end face flat on a box face": (shape("box", (1.0, 1.0, 0.2)), shape("cylinder", (0.3, 0.5), (0.1, 0.2, 0.75)),
                                    0.05, (0, 0, 1)),
    "end face sunk in a box face": (shape("box", (1.0, 1.0, 0.2)), shape("cylinder", (0.3, 0.5), (0.1, 0.2, 0.69)),
                                    -0.01, (0, 0, 1)),
    "lying on a box face": (shape("box", (1.0, 1.0, 0.2)), shape("cylinder", (0.3, 0.5), (0.1, 0.2, 0.55), ABOUT_Y_90),
                            0.05, (0, 0, 1)),
    "tilted rim on a box face": (shape("box", (1.0, 1.0, 0.2)), shape("cylinder", (0.3, 0.5), (0.1, 0.2, 0.9), R_TILT),
                                 0.9 - 0.5 * math.cos(TILT) - 0.3 * math.sin(TILT) - 0.2, (0, 0, 1)),
    "box edge against the side": (shape("box", (0.2, 0.2, 0.2), rot=Rotation.from_euler("z", 45, degrees=True).as_matrix()),
                                  shape("cylinder", (0.3, 0.5), (0.2 * S2 + 0.35, 0.0, 0.0)), 0.05, (1, 0, 0)),
    # cylinder–capsule
    "capsule parallel to the side": (CYL, shape("capsule", (0.1, 0.4), (0.0, 0.5, 0.0)), 0.1, (0, 1, 0)),
    "capsule end on the end face": (CYL, shape("capsule", (0.1, 0.4), (0.1, 0.0, 1.05)), 0.05, (0, 0, 1)),
    "capsule lying across the end face, sunk": (CYL, shape("capsule", (0.1, 0.4), (0.0, 0.1, 0.58), ABOUT_Y_90),
                                               -0.02, (0, 0, 1)),
}


@pytest.mark.parametrize("name", list(CASES))
def test_hand_derived(name):
    a, b, sd_expected, n_expected = CASES[name]
    sd, n, certified = signed_distance(a, b)
    n_expected = np.asarray(n_expected, float) / np.linalg.norm(n_expected)
    assert sd == pytest.approx(sd_expected, abs=1e-12)
    assert np.max(np.abs(n - n_expected)) <= 1e-12
    assert certified
    # swapped: the same distance, the opposite normal
    sd2, n2, _ = signed_distance(b, a)
    assert sd2 == pytest.approx(sd_expected, abs=1e-12)
    assert np.max(np.abs(n2 + n_expected)) <= 1e-12


@pytest.mark.parametrize("kb", ["sphere", "box", "cylinder", "capsule"])
def test_no_sampled_direction_separates_more(kb):
    """Random poses (apart and overlapping): sd is attained along n and beats 20,000 random directions."""
    rng = np.random.default_rng(7)
    u = rng.normal(size=(20_000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    dims = {"sphere": (0.2,), "box": (0.3, 0.15, 0.25), "cylinder": (0.2, 0.35), "capsule": (0.12, 0.3)}[kb]
    for _ in range(6):
        a = shape("cylinder", (0.25, 0.3), rng.normal(size=3) * 0.1, Rotation.random(random_state=rng).as_matrix())
        b = shape(kb, dims, rng.normal(size=3) * 0.4, Rotation.random(random_state=rng).as_matrix())
        sd, n, certified = signed_distance(a, b)
        assert certified
        assert sep(a, b, n[None])[0] == pytest.approx(sd, abs=1e-15)
        assert np.max(sep(a, b, u)) <= sd + 1e-13


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="a: expected a kind in"):
        signed_distance(("cone", (1.0,), (0, 0, 0), I3), CYL)
    with pytest.raises(ValueError, match="b: expected a rotation matrix"):
        signed_distance(CYL, shape("sphere", (0.1,), rot=2 * I3))
    with pytest.raises(ValueError, match="b: expected finite dimensions"):
        signed_distance(CYL, shape("sphere", (-0.1,)))
