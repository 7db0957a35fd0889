"""Compiled gap functions against closed forms and brute force.

Sphere: gap n·c − r − offset exactly. Box: the lowest of the 8 corners computed independently
with numpy (rotation matrices, not the kernel's quaternion rotation), the points returned are
the corners within the band (4 on a face, 2 on an edge). Capsule and cylinder: the closed-form
gap against the minimum over a dense sampling of their surfaces (the sampled minimum is above
the exact one by at most the sampling's chord error).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from helpers import random_rotation_matrix
from rigid_body_sim.core.kernels.contact.layout import MAX_POINTS
from rigid_body_sim.core.kernels.contact.shapes import box_points, capsule_points, cylinder_points, sphere_points
from rigid_body_sim.core.quaternion import quat_from_matrix


def random_normal(rng):
    n = rng.normal(size=3)
    return n / np.linalg.norm(n)


def buffers():
    return np.full((MAX_POINTS, 3), np.nan), np.full(MAX_POINTS, np.nan)


def test_sphere_gap_and_point():
    rng = np.random.default_rng(0)
    for _ in range(50):
        c, n, r, offset = rng.normal(size=3), random_normal(rng), rng.uniform(0.01, 1.0), rng.normal()
        points, gaps = buffers()
        assert sphere_points(*c, r, *n, offset, points, gaps) == 1
        assert gaps[0] == pytest.approx(n @ c - r - offset, abs=1e-15)
        assert points[0] == pytest.approx(c - r * n, abs=1e-15)


def test_box_lowest_corner_matches_brute_force():
    rng = np.random.default_rng(1)
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    for _ in range(200):
        R = random_rotation_matrix(rng)
        q = quat_from_matrix(R)
        half = rng.uniform(0.01, 1.0, size=3)
        c, n, offset = rng.normal(size=3), random_normal(rng), rng.normal()
        corners = c + (signs * half) @ R.T
        exact = corners @ n - offset
        points, gaps = buffers()
        count = box_points(*c, *q, *half, *n, offset, points, gaps)
        assert count == 1  # a random orientation touches with one corner
        assert gaps[0] == pytest.approx(exact.min(), abs=1e-14)
        assert points[0] == pytest.approx(corners[np.argmin(exact)], abs=1e-14)


@pytest.mark.parametrize("q, expected", [
    ((1.0, 0.0, 0.0, 0.0), 4),  # flat on its face
    ((math.cos(math.pi / 8), math.sin(math.pi / 8), 0.0, 0.0), 2),  # 45° about x: on an edge
])
def test_box_face_and_edge_give_their_corners(q, expected):
    points, gaps = buffers()
    half = (0.2, 0.1, 0.05)
    count = box_points(0.0, 0.0, 1.0, *q, *half, 0.0, 0.0, 1.0, 0.0, points, gaps)
    assert count == expected
    lowest = 1.0 - (0.05 if expected == 4 else math.hypot(0.1, 0.05) * math.sin(math.pi / 4 + math.atan2(0.05, 0.1)))
    assert gaps[:count] == pytest.approx(np.full(count, lowest), abs=1e-15)
    assert points[:count, 2] == pytest.approx(np.full(count, lowest), abs=1e-15)  # n = z, offset 0: height = gap


def axis_frame(R):
    return R[:, 0], R[:, 1], R[:, 2]


def test_capsule_gap_against_sampled_surface():
    rng = np.random.default_rng(2)
    for _ in range(50):
        R = random_rotation_matrix(rng)
        q = quat_from_matrix(R)
        r, half = rng.uniform(0.01, 0.5), rng.uniform(0.01, 1.0)
        c, n, offset = rng.normal(size=3), random_normal(rng), rng.normal()
        points, gaps = buffers()
        count = capsule_points(*c, *q, r, half, *n, offset, points, gaps)
        axis = R[:, 2]
        ends = np.array([c - half * axis, c + half * axis])
        exact = (ends @ n).min() - r - offset
        assert gaps[:count].min() == pytest.approx(exact, abs=1e-14)
        # the points lie on the surface: at distance r from the segment
        for k in range(count):
            s = np.clip((points[k] - c) @ axis, -half, half)
            assert np.linalg.norm(points[k] - (c + s * axis)) == pytest.approx(r, abs=1e-14)


def test_cylinder_gap_against_sampled_rims():
    rng = np.random.default_rng(3)
    theta = np.linspace(0.0, 2 * np.pi, 20001)
    for _ in range(50):
        R = random_rotation_matrix(rng)
        q = quat_from_matrix(R)
        r, half = rng.uniform(0.01, 0.5), rng.uniform(0.01, 1.0)
        c, n, offset = rng.normal(size=3), random_normal(rng), rng.normal()
        e1, e2, axis = axis_frame(R)
        rim = (np.cos(theta)[:, None] * e1 + np.sin(theta)[:, None] * e2) * r
        sampled = min(((c + side * half * axis + rim) @ n).min() for side in (-1, 1)) - offset
        points, gaps = buffers()
        count = cylinder_points(*c, *q, r, half, *n, offset, points, gaps)
        chord = r * (theta[1] - theta[0]) ** 2  # how far the samples can sit above the true rim minimum
        assert gaps[:count].min() <= sampled + 1e-14
        assert gaps[:count].min() >= sampled - chord
        # each returned point is on a rim: |axial| = half, radial distance r
        for k in range(count):
            rel = points[k] - c
            assert abs(rel @ axis) == pytest.approx(half, abs=1e-14)
            assert np.linalg.norm(rel - (rel @ axis) * axis) == pytest.approx(r, abs=1e-14)
            assert n @ points[k] - offset == pytest.approx(gaps[k], abs=1e-14)


def test_cylinder_standing_and_lying():
    points, gaps = buffers()
    assert cylinder_points(0.0, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0, 0.1, 0.3, 0.0, 0.0, 1.0, 0.0, points, gaps) == 4
    assert gaps[:4] == pytest.approx(np.full(4, 0.2), abs=1e-15)
    lying = (math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0)  # axis along −y
    assert cylinder_points(0.0, 0.0, 0.5, *lying, 0.1, 0.3, 0.0, 0.0, 1.0, 0.0, points, gaps) == 2
    assert gaps[:2] == pytest.approx(np.full(2, 0.4), abs=1e-15)
    assert sorted(points[:2, 1].tolist()) == pytest.approx([-0.3, 0.3], abs=1e-15)

