"""Body–body narrow and broad phase against closed forms and the definition of the signed distance.

* Closed forms: sphere–sphere; sphere–box in the face, edge and corner regions (distance to the
  face plane, the edge line, the corner); capsule–capsule parallel (two points, the axes'
  distance) and crossed (the common normal); box–box stacked face on face (depth, normal, the
  four corners of the overlap rectangle).
* The definition, for every pair over random poses: the signed distance is
  max over unit u of sep(u) = min_B u·x − max_A u·x, computed here from the shapes' support
  functions in numpy (rotation matrices, not the kernels' code): sep(n) along the reported
  normal equals the reported distance, and no sampled direction separates more. Every
  reported point lies on its shape's surface (independent closed forms), within 1e-9 m.
  Swapping a and b gives the same distance and the opposite normal.
* Pairs with a cylinder against the reference of exact/convex_distance.py (an independent
  maximisation of sep over the strata of its kinks): distance and normal within 1e-9.
* Two boxes' face-normal separation (the bound that lets a step skip their narrow phase): the
  best of their six face normals, never above the signed distance.
  After the bodies move and turn, the islands' projection keeps a pair apart without a look only
  while that separation at the new poses (numpy) exceeds its bound.
* Broad phase: the grid and the sweep find exactly the overlapping bounding boxes of a brute
  force over all pairs. MuJoCo's collision functions are the oracle of the bench test
  (benchmarks/pair_oracle.py, test_bench_pairs below, ``pytest -m bench``).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from rigid_body_sim.core.kernels.contact.broadphase import grid_pairs, shape_aabbs, sweep_pairs
from rigid_body_sim.core.kernels.contact.layout import DIMS, KIND, SHAPE_BOX, SHAPE_WIDTH
from rigid_body_sim.core.kernels.contact.convex import POSE_WIDTH
from rigid_body_sim.core.kernels.contact.pairs import MAX_PAIR_POINTS, apart_bounds, face_patch, pair_contacts

KINDS = {"sphere": 1, "box": 2, "cylinder": 3, "capsule": 4}
IDENTITY = (1.0, 0.0, 0.0, 0.0)


def row(kind, *dims):
    r = np.zeros(SHAPE_WIDTH)
    r[KIND] = KINDS[kind]
    r[DIMS:DIMS + len(dims)] = dims
    return r


def matrix(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def contacts(shapes, pos, quat, pairs):
    m = len(pairs)
    dist, normal = np.full(m, np.nan), np.full((m, 3), np.nan)
    count = np.zeros(m, np.int64)
    points, seps = np.full((m, MAX_PAIR_POINTS, 6), np.nan), np.full((m, MAX_PAIR_POINTS), np.nan)
    pair_contacts(np.asarray(pos, float), np.asarray(quat, float), np.asarray(shapes, float),
                  np.asarray(pairs, np.int64), dist, normal, count, points, seps)
    return dist, normal, count, points, seps


def one(a, b, pos_a, pos_b, q_a=IDENTITY, q_b=IDENTITY):
    dist, normal, count, points, seps = contacts([a, b], [pos_a, pos_b], [q_a, q_b], [[0, 1]])
    return dist[0], normal[0], count[0], points[0, :count[0]], seps[0, :count[0]]


def support_value(kind, d, c, r, u):
    """h(u) = max over the shape of u·x (numpy; u (k, 3) unit)."""
    local = u @ r
    base = u @ c
    if kind == "sphere":
        return base + d[0]
    if kind == "capsule":
        return base + d[0] + d[1] * np.abs(local[:, 2])
    if kind == "box":
        return base + np.abs(local) @ d
    return base + d[0] * np.hypot(local[:, 0], local[:, 1]) + d[1] * np.abs(local[:, 2])


def surface_distance(kind, d, c, r, p):
    x = r.T @ (p - c)
    if kind == "sphere":
        return abs(np.linalg.norm(x) - d[0])
    if kind == "capsule":
        return abs(np.linalg.norm(x - np.array([0.0, 0.0, np.clip(x[2], -d[1], d[1])])) - d[0])
    if kind == "box":
        outside = np.maximum(np.abs(x) - d, 0.0)
        return np.linalg.norm(outside) if np.any(outside > 0) else np.min(d - np.abs(x))
    rho = np.hypot(x[0], x[1])
    out_r, out_z = max(rho - d[0], 0.0), max(abs(x[2]) - d[1], 0.0)
    return np.hypot(out_r, out_z) if out_r > 0 or out_z > 0 else min(d[0] - rho, d[1] - abs(x[2]))


# ----------------------------------------------------------------------------- closed forms

def test_sphere_sphere_closed_form():
    rng = np.random.default_rng(0)
    for _ in range(50):
        ra, rb = rng.uniform(0.05, 0.5, 2)
        ca, cb = rng.normal(size=3), rng.normal(size=3)
        d = cb - ca
        dist, normal, count, points, _ = one(row("sphere", ra), row("sphere", rb), ca, cb)
        assert dist == pytest.approx(np.linalg.norm(d) - ra - rb, abs=1e-14)
        assert normal == pytest.approx(d / np.linalg.norm(d), abs=1e-14)
        assert count == 1
        assert points[0, :3] == pytest.approx(ca + ra * normal, abs=1e-14)
        assert points[0, 3:] == pytest.approx(cb - rb * normal, abs=1e-14)


@pytest.mark.parametrize("region", ["face", "edge", "corner"])
@pytest.mark.parametrize("inside", [False, True])
def test_sphere_box_regions(region, inside):
    """A sphere near the box (half extents a) at a face, an edge or a corner: distance to that feature."""
    rng = np.random.default_rng(1)
    a = np.array([0.3, 0.2, 0.1])
    for _ in range(20):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        r_wb = matrix(q)
        c_box = rng.normal(size=3)
        r = 0.05
        gap = rng.uniform(-0.04, 0.04)
        if region == "face":
            local = np.array([rng.uniform(-0.25, 0.25), rng.uniform(-0.15, 0.15), a[2] + r + gap])
            expect_dist, expect_n = gap, np.array([0.0, 0.0, -1.0])
            if inside:  # centre inside the box, nearest face +z
                local[2] = a[2] - 0.02
                expect_dist = -0.02 - r
        elif region == "edge":  # beyond x and z, within y: distance to the edge line
            off = rng.uniform(0.01, 0.2, 2)
            local = np.array([a[0] + off[0], rng.uniform(-0.15, 0.15), a[2] + off[1]])
            expect_dist = np.hypot(*off) - r
            expect_n = -np.array([off[0], 0.0, off[1]]) / np.hypot(*off)
            if inside:
                continue
        else:
            off = rng.uniform(0.01, 0.2, 3)
            local = a + off
            expect_dist, expect_n = np.linalg.norm(off) - r, -off / np.linalg.norm(off)
            if inside:
                continue
        c = c_box + r_wb @ local
        dist, normal, count, points, _ = one(row("sphere", r), row("box", *a), c, c_box, IDENTITY, q)
        assert dist == pytest.approx(expect_dist, abs=1e-13)
        assert normal == pytest.approx(r_wb @ expect_n, abs=1e-12)
        assert count == 1


def test_capsule_capsule_parallel_and_crossed():
    rng = np.random.default_rng(2)
    for _ in range(20):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        r_w = matrix(q)
        c = rng.normal(size=3)
        ra, rb, h = 0.05, 0.07, 0.3
        offset = rng.uniform(0.05, 0.2)
        shift = rng.uniform(-0.2, 0.2)
        # parallel: B beside A along local x, shifted along the axis
        cb = c + r_w @ np.array([offset, 0.0, shift])
        dist, normal, count, points, seps = one(row("capsule", ra, h), row("capsule", rb, h), c, cb, q, q)
        assert dist == pytest.approx(offset - ra - rb, abs=1e-13)
        assert normal == pytest.approx(r_w[:, 0], abs=1e-12)
        assert count == 2
        assert seps == pytest.approx([offset - ra - rb] * 2, abs=1e-13)
        ends = sorted(r_w[:, 2] @ (points[:, 0:3] - c).T)  # the overlap interval of the two axes
        assert ends == pytest.approx([max(-h, shift - h), min(h, shift + h)], abs=1e-12)
        # crossed: B's axis along A's local x, offset along A's local y
        q_b = np.array([np.cos(np.pi / 4), 0.0, np.sin(np.pi / 4), 0.0])  # body z → x
        rot_b = r_w @ matrix(q_b)
        from rigid_body_sim.core.quaternion import quat_from_matrix
        qb_w = np.asarray(quat_from_matrix(rot_b), float)
        cb = c + r_w @ np.array([0.0, offset, 0.0])
        dist, normal, count, points, _ = one(row("capsule", ra, h), row("capsule", rb, h), c, cb, q, qb_w)
        assert dist == pytest.approx(offset - ra - rb, abs=1e-13)
        assert normal == pytest.approx(r_w[:, 1], abs=1e-12)
        assert count == 1
        assert points[0, :3] == pytest.approx(c + (ra) * r_w[:, 1], abs=1e-12)


def test_box_box_stacked_face_on_face():
    """B (cube 0.2 m) on A (0.4 × 0.4 × 0.2 m), sunk by 1 mm and shifted: depth, normal, 4 overlap corners."""
    a, b = np.array([0.2, 0.2, 0.1]), np.array([0.1, 0.1, 0.1])
    shift = np.array([0.15, -0.05])
    cb = np.array([shift[0], shift[1], a[2] + b[2] - 1e-3])
    dist, normal, count, points, seps = one(row("box", *a), row("box", *b), [0.0, 0.0, 0.0], cb)
    assert dist == pytest.approx(-1e-3, abs=1e-15)
    assert normal == pytest.approx([0.0, 0.0, 1.0], abs=1e-15)
    assert count == 4
    assert seps == pytest.approx([-1e-3] * 4, abs=1e-15)
    lo = np.maximum(-a[:2], shift - b[:2])
    hi = np.minimum(a[:2], shift + b[:2])
    corners = {(x, y) for x in (lo[0], hi[0]) for y in (lo[1], hi[1])}
    got = {tuple(np.round(p[:2], 12)) for p in points}
    assert got == {tuple(np.round(c, 12)) for c in corners}
    assert points[:, 2] == pytest.approx([a[2]] * 4, abs=1e-15)  # on A's top face
    assert points[:, 5] == pytest.approx([a[2] - 1e-3] * 4, abs=1e-15)  # on B's bottom face
    # apart by 2 mm: the same patch, positive distance
    dist, normal, count, _, _ = one(row("box", *a), row("box", *b), [0.0, 0.0, 0.0], cb + [0.0, 0.0, 3e-3])
    assert (dist, count) == (pytest.approx(2e-3, abs=1e-15), 4)


@pytest.mark.parametrize("swap", [False, True])
def test_box_corner_touching_a_box_face_within_round_off(swap):
    """A tilted box's lowest corner over an upright box's top face, apart by δ from 0 to 1e-10 m (a pile's
    resting contacts): the normal is the face's, +z (closed form), within 1e-9; the distance δ within 1e-14 m;
    every point separates by at least the distance. A direction from the nearest points' difference over δ
    is round-off there."""
    rng = np.random.default_rng(11)
    a = np.array([0.05, 0.05, 0.05])
    for k in range(300):  # every pose asserted
        b = rng.uniform(0.03, 0.08, size=3)
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * b @ matrix(q).T
        low = corners[np.argmin(corners[:, 2])]
        delta = [0.0, 1e-16, 1e-14, 1e-12, 1e-10][k % 5] * rng.uniform(0.5, 1.0)
        foot = rng.uniform(-0.8, 0.8, size=2) * a[:2]  # where the corner comes down, inside the face
        cb = np.array([foot[0], foot[1], a[2] + delta]) - low
        if swap:
            dist, normal, count, points, seps = one(row("box", *b), row("box", *a), cb, [0.0, 0.0, 0.0], q, IDENTITY)
            up = [0.0, 0.0, -1.0]
        else:
            dist, normal, count, points, seps = one(row("box", *a), row("box", *b), [0.0, 0.0, 0.0], cb, IDENTITY, q)
            up = [0.0, 0.0, 1.0]
        assert np.max(np.abs(normal - up)) <= 1e-9, (k, delta, normal)
        assert abs(dist - delta) <= 1e-14, (k, delta, dist)
        assert np.all(seps >= dist - 1e-14)


# ----------------------------------------------------------------------------- definition and properties

def random_pair_poses(rng, ka, kb, n):
    d = rng.uniform(0.05, 0.5, size=(2 * n, 3))
    shapes = np.zeros((2 * n, SHAPE_WIDTH))
    shapes[0::2, KIND], shapes[1::2, KIND] = KINDS[ka], KINDS[kb]
    shapes[:, DIMS:DIMS + 3] = d
    reach = np.linalg.norm(d[0::2], axis=1) + np.linalg.norm(d[1::2], axis=1)
    direction = rng.normal(size=(n, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    pos = np.zeros((2 * n, 3))
    pos[1::2] = direction * (reach * rng.uniform(0.1, 1.1, size=n))[:, None]
    quat = rng.normal(size=(2 * n, 4))
    quat /= np.linalg.norm(quat, axis=1, keepdims=True)
    pairs = np.stack((np.arange(0, 2 * n, 2), np.arange(1, 2 * n, 2)), axis=1)
    return shapes, pos, quat, pairs


@pytest.mark.parametrize("ka,kb", list(itertools.combinations_with_replacement(KINDS, 2)))
def test_signed_distance_is_the_largest_separation(ka, kb):
    """sd = max_u sep(u): attained along the reported normal, never beaten by a sampled direction (1e-12 m).

    Pairs with a cylinder go through GJK/EPA on its curved rim, whose direction is then refined
    by Newton's method on the support functions (refine.py); point 0 is on both support sets, so
    its separation is the distance.
    """
    rng = np.random.default_rng(3)
    n = 60
    shapes, pos, quat, pairs = random_pair_poses(rng, ka, kb, n)
    dist, normal, count, points, seps = contacts(shapes, pos, quat, pairs)
    u = rng.normal(size=(4000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    tol = 1e-12
    for m, (a, b) in enumerate(pairs):
        da, db = shapes[a, DIMS:DIMS + 3], shapes[b, DIMS:DIMS + 3]
        ra, rb = matrix(quat[a]), matrix(quat[b])

        def sep(v):
            return -(support_value(ka, da, pos[a], ra, v) + support_value(kb, db, pos[b], rb, -v))

        assert np.linalg.norm(normal[m]) == pytest.approx(1.0, abs=1e-14)
        assert sep(normal[m][None])[0] == pytest.approx(dist[m], abs=tol)
        assert np.max(sep(u)) <= dist[m] + tol
        assert 1 <= count[m] <= MAX_PAIR_POINTS
        assert seps[m, 0] == pytest.approx(dist[m], abs=1e-12)
        for k in range(count[m]):
            assert surface_distance(ka, da, pos[a], ra, points[m, k, :3]) <= 1e-9
            assert surface_distance(kb, db, pos[b], rb, points[m, k, 3:]) <= 1e-9
            assert seps[m, k] >= dist[m] - tol
    # swapping a and b: the same distance, the opposite normal
    swapped = pairs[:, ::-1]
    dist2, normal2, _, _, _ = contacts(shapes, pos, quat, swapped)
    assert dist2 == pytest.approx(dist, abs=tol)
    assert np.max(np.linalg.norm(normal2 + normal, axis=1)) <= 1e-9


def test_two_boxes_apart_bound_is_their_best_face_separation_and_at_most_their_distance():
    """apart_bounds (the cut that lets a step skip two boxes' narrow phase): for two boxes, the largest
    sep(u) over their six face normals (numpy support functions, 1e-12 m), so never more than the
    signed distance max_u sep(u) the narrow phase reports (over apart and overlapping poses); −1 (no
    bound) for a pair that is not two boxes."""
    rng = np.random.default_rng(5)
    shapes, pos, quat, pairs = random_pair_poses(rng, "box", "box", 400)
    out = np.empty(len(pairs))
    apart_bounds(pos, quat, shapes, pairs, out)
    dist = contacts(shapes, pos, quat, pairs)[0]
    assert (dist > 0).sum() > 100 and (dist < 0).sum() > 100  # both kinds of pose
    assert np.all(out <= dist + 1e-12)
    for m, (a, b) in enumerate(pairs):
        da, db = shapes[a, DIMS:DIMS + 3], shapes[b, DIMS:DIMS + 3]
        ra, rb = matrix(quat[a]), matrix(quat[b])
        u = np.concatenate((ra.T, rb.T))  # the face normals (rows): each box's axes
        u = np.concatenate((u, -u))
        sep = -(support_value("box", da, pos[a], ra, u) + support_value("box", db, pos[b], rb, -u))
        assert out[m] == pytest.approx(sep.max(), abs=1e-12)
    shapes, pos, quat, pairs = random_pair_poses(rng, "box", "sphere", 5)
    apart_bounds(pos, quat, shapes, pairs, out[:5])
    assert np.all(out[:5] == -1.0)



def _face_separation(shapes, pos, quat, a, b):
    """The largest sep(u) of boxes a and b over their six face normals (numpy support functions)."""
    da, db = shapes[a, DIMS:DIMS + 3], shapes[b, DIMS:DIMS + 3]
    ra, rb = matrix(quat[a]), matrix(quat[b])
    u = np.concatenate((ra.T, rb.T))
    u = np.concatenate((u, -u))
    return (-(support_value("box", da, pos[a], ra, u) + support_value("box", db, pos[b], rb, -u))).max()


def _turned(q, rotvec):
    """exp(rotvec) ⊗ q (w, x, y, z): q turned by |rotvec| rad about world axis rotvec."""
    angle = np.linalg.norm(rotvec)
    w, v = np.cos(angle / 2), np.sin(angle / 2) * rotvec / angle
    return np.array([w * q[0] - v @ q[1:], *(w * q[1:] + q[0] * v + np.cross(v, q[1:]))])


def test_a_pair_kept_apart_without_a_look_is_still_apart_by_more_than_its_bound():
    """island._still_apart (the projection's rounds leave two boxes found apart unlooked-at while it holds): over
    random apart box pairs moved and turned at random (each body by a few steps, the steps' lengths and angles
    summed as the projection sums them; some mostly translating, some mostly turning), it never says a pair is
    still apart by more than a bound that the boxes' face-normal separation at the new poses (numpy) does not
    exceed (checked at the sharpest such bound, that separation itself); and it keeps over 100 of the pairs
    apart for a bound drawn below their first separation (the cut is not vacuous)."""
    from rigid_body_sim.core.kernels.contact.island import _still_apart
    from rigid_body_sim.core.kernels.layout import P, STATE_WIDTH

    rng = np.random.default_rng(11)
    shapes, pos, quat, pairs = random_pair_poses(rng, "box", "box", 600)
    kept = 0
    for a, b in pairs:
        lower = _face_separation(shapes, pos, quat, a, b)
        if lower <= 0.0:
            continue
        size = shapes[[a, b], DIMS:DIMS + 3].max()
        new_pos, new_quat, path = pos.copy(), quat.copy(), np.zeros((len(pos), 2))
        scale = lower * 10.0 ** rng.uniform(-4, 0)  # from far below the margin to about it
        turning = 10.0 ** rng.uniform(-2, 2)  # the turns' share against the translations'
        for i in (a, b):
            for _ in range(rng.integers(1, 4)):
                step, turn = rng.normal(size=3) * scale / 2, rng.normal(size=3) * turning * scale / (4 * size)
                new_pos[i] += step
                new_quat[i] = _turned(new_quat[i], turn)
                path[i] += np.linalg.norm(step), np.linalg.norm(turn)
        Y = np.zeros((len(pos), STATE_WIDTH))
        Y[:, P:P + 3] = new_pos
        assert not _still_apart(Y, shapes, path, lower, _face_separation(shapes, new_pos, new_quat, a, b), a, b)
        kept += _still_apart(Y, shapes, path, lower, lower * rng.uniform(0.0, 1.0), a, b)
    assert kept > 100


def _patch(half_a, half_b, pos_b, quat_b, normal, flat=np.cos(0.1), band=1.0):
    """face_patch of box a (half extents half_a, at the origin, unturned) and box b; its points sorted."""
    shapes = np.zeros((2, SHAPE_WIDTH))
    shapes[:, KIND] = SHAPE_BOX
    shapes[0, DIMS:DIMS + 3], shapes[1, DIMS:DIMS + 3] = half_a, half_b
    pos, quat = np.array([[0.0, 0.0, 0.0], pos_b]), np.array([[1.0, 0.0, 0.0, 0.0], quat_b])
    res, seps = np.empty((MAX_PAIR_POINTS, 6)), np.empty(MAX_PAIR_POINTS)
    count, *ref = face_patch(pos, quat, shapes, 0, 1, *normal, flat, band, np.zeros((2, POSE_WIDTH)),
                            np.empty((2, 16, 3)), res, seps)
    order = np.lexsort(np.round(res[:count, 3:5], 9).T)
    return count, np.array(ref), res[:count][order], seps[:count][order]


def test_a_box_face_on_a_box_face_touches_by_the_clipped_patch():
    """face_patch (the islands' rows of two boxes face on face, kernels/contact/island.py), against closed forms:
    a cube tilted 0.02 rad on a larger box touches by its four bottom corners, each at its own height above the
    top face (numpy rotation, 1e-15 m), its foot straight below; a cube turned 45° about z on an equal cube, a
    gap 1e-3 m above it, by the regular octagon of the two squares' crossing (1e-15 m); a pair normal 0.3 rad
    from every face: no patch."""
    h = 0.05
    angle = 0.02
    R = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(angle), -np.sin(angle)], [0.0, np.sin(angle), np.cos(angle)]])
    centre = np.array([0.01, -0.02, 0.1 + h * (np.cos(angle) + np.sin(angle)) + 1e-4])  # lowest corner 1e-4 above
    q = [np.cos(angle / 2), np.sin(angle / 2), 0.0, 0.0]
    count, ref, res, seps = _patch([0.5, 0.5, 0.1], [h, h, h], centre, q, [0.0, np.sin(0.01), np.cos(0.01)])
    corners = centre + np.array([[sx * h, sy * h, -h] for sx in (-1, 1) for sy in (-1, 1)]) @ R.T
    corners = corners[np.lexsort(np.round(corners[:, :2], 9).T)]
    assert count == 4
    np.testing.assert_allclose(ref, [0.0, 0.0, 1.0], atol=0.0)
    np.testing.assert_allclose(res[:, 3:6], corners, rtol=0.0, atol=1e-15)
    np.testing.assert_allclose(res[:, 0:3], np.c_[corners[:, :2], np.full(4, 0.1)], rtol=0.0, atol=1e-15)
    np.testing.assert_allclose(seps, corners[:, 2] - 0.1, rtol=0.0, atol=1e-15)
    assert seps.min() == pytest.approx(1e-4, abs=1e-15)

    t = np.tan(np.pi / 8) * h  # the octagon: (±h, ±t) and (±t, ±h)
    octagon = np.array([[sx * h, sy * t] for sx in (-1, 1) for sy in (-1, 1)] + [[sx * t, sy * h] for sx in (-1, 1) for sy in (-1, 1)])
    octagon = octagon[np.lexsort(np.round(octagon, 9).T)]
    yaw = [np.cos(np.pi / 8), 0.0, 0.0, np.sin(np.pi / 8)]
    count, ref, res, seps = _patch([h, h, h], [h, h, h], [0.0, 0.0, 2 * h + 1e-3], yaw, [0.0, 0.0, 1.0])
    assert count == 8
    np.testing.assert_allclose(res[:, 0:2], octagon, rtol=0.0, atol=1e-15)
    np.testing.assert_allclose(res[:, 3:5], octagon, rtol=0.0, atol=1e-15)
    np.testing.assert_allclose(res[:, 2], h, rtol=0.0, atol=1e-15)
    np.testing.assert_allclose(seps, 1e-3, rtol=0.0, atol=1e-15)

    assert _patch([h, h, h], [h, h, h], [0.0, 0.0, 2 * h], [1.0, 0.0, 0.0, 0.0], [0.0, np.sin(0.3), np.cos(0.3)])[0] == 0


def test_distance_sign():
    """Apart (centres far) is positive, nested (one centre inside the other) negative, for every pair."""
    for ka, kb in itertools.combinations_with_replacement(KINDS, 2):
        a, b = row(ka, 0.2, 0.3, 0.25), row(kb, 0.1, 0.15, 0.2)
        assert one(a, b, [0, 0, 0], [2.0, 0.5, 0.1])[0] > 0.0
        assert one(a, b, [0, 0, 0], [0.01, 0.02, 0.03])[0] < 0.0


# ----------------------------------------------------------------------------- broad phase

@pytest.mark.parametrize("margin", [0.0, 0.05])
def test_broad_phase_finds_exactly_the_overlapping_boxes(margin):
    rng = np.random.default_rng(4)
    n = 400
    shapes = np.zeros((n, SHAPE_WIDTH))
    shapes[:, KIND] = rng.integers(0, 5, size=n)  # SHAPE_NONE included: never paired
    shapes[:, DIMS:DIMS + 3] = rng.uniform(0.05, 0.3, size=(n, 3))
    pos = rng.uniform(0.0, 3.0, size=(n, 3))
    quat = rng.normal(size=(n, 4))
    quat /= np.linalg.norm(quat, axis=1, keepdims=True)
    lo, hi = np.empty((n, 3)), np.empty((n, 3))
    shape_aabbs(pos, quat, shapes, lo, hi)
    # the boxes are the shapes' exact extents along the world axes (support function along ±e_k)
    for i in np.flatnonzero(shapes[:, KIND] > 0):
        kind = [k for k, v in KINDS.items() if v == shapes[i, KIND]][0]
        e = np.eye(3)
        r = matrix(quat[i])
        assert hi[i] == pytest.approx(support_value(kind, shapes[i, DIMS:DIMS + 3], pos[i], r, e), abs=1e-14)
        assert lo[i] == pytest.approx(-support_value(kind, shapes[i, DIMS:DIMS + 3], pos[i], r, -e), abs=1e-14)
    brute = set()
    for i in range(n):
        for j in range(i + 1, n):
            if shapes[i, KIND] > 0 and shapes[j, KIND] > 0 and np.all(lo[j] <= hi[i] + 2 * margin) \
                    and np.all(lo[i] <= hi[j] + 2 * margin):
                brute.add((i, j))
    assert len(brute) > 50
    for method in (grid_pairs, sweep_pairs):
        pairs = np.empty((20 * n, 2), np.int64)
        count = method(lo, hi, margin, pairs)
        assert count == len(brute)
        assert {tuple(p) for p in pairs[:count]} == brute
        small = np.empty((10, 2), np.int64)
        assert method(lo, hi, margin, small) == len(brute)  # the count says how much room is needed


def test_cylinder_on_a_box_face_standing_and_lying():
    """A cylinder (r 0.1, half length 0.2) sunk 1 mm into a box's top face: standing, its 4 rim points and the
    one toward the box's centre (the last on the −x point when the box's centre is along −x); lying, 2."""
    a = np.array([0.3, 0.3, 0.1])
    r, h = 0.1, 0.2
    toward = np.array([0.05, 0.02]) - r * np.array([0.05, 0.02]) / np.hypot(0.05, 0.02)
    for shift, expect in (((0.05, 0.02), [(0.15, 0.02), (-0.05, 0.02), (0.05, 0.12), (0.05, -0.08), tuple(toward)]),
                          ((0.35, 0.0), [(0.25, 0.0), (0.3, 0.05), (0.3, -0.05)])):  # over the edge: clipped
        c = np.array([shift[0], shift[1], a[2] + h - 1e-3])
        dist, normal, count, points, seps = one(row("box", *a), row("cylinder", r, h), [0.0, 0.0, 0.0], c)
        assert dist == pytest.approx(-1e-3, abs=1e-12)
        assert normal == pytest.approx([0.0, 0.0, 1.0], abs=1e-12)
        assert seps == pytest.approx([-1e-3] * count, abs=1e-12)
        assert {tuple(np.round(p[:2], 9)) for p in points} == {tuple(np.round(e, 9)) for e in expect}
        assert points[:, 2] == pytest.approx([a[2]] * count, abs=1e-12)
        assert points[:, 5] == pytest.approx([a[2] - 1e-3] * count, abs=1e-12)
    q = (np.cos(np.pi / 4), np.sin(np.pi / 4), 0.0, 0.0)  # the axis along world −y
    c = np.array([0.0, 0.1, a[2] + r - 1e-3])
    dist, normal, count, points, seps = one(row("box", *a), row("cylinder", r, h), [0.0, 0.0, 0.0], c, IDENTITY, q)
    assert dist == pytest.approx(-1e-3, abs=1e-12)
    assert count == 2
    assert sorted(points[:, 1]) == pytest.approx([-0.1, 0.3], abs=1e-12)  # clipped at the face's edge y = 0.3
    assert seps == pytest.approx([-1e-3] * 2, abs=1e-12)



def test_a_cylinder_standing_tilted_within_the_face_alignment_touches_at_its_deepest_rim_point():
    """A cylinder (r 0.1, half length 0.2) standing on a box's top face, tilted 5e-7 rad (within FACE_ALIGNMENT,
    so its rim is clipped as standing) toward 30° from x, its lowest rim point 1 mm deep: that point (closed form:
    the end's centre less r along the face normal's part across the axis) is one of the points, at the signed
    distance, so the manifold is as deep as the pair; the square's points are shallower by up to
    r sin θ (1 − cos 30°), 6.7e-9 m."""
    a = np.array([0.3, 0.3, 0.1])
    r, h, tilt = 0.1, 0.2, 5e-7
    k = np.array([np.cos(np.radians(120.0)), np.sin(np.radians(120.0)), 0.0])  # the turn's axis
    q = (np.cos(tilt / 2), *(np.sin(tilt / 2) * k))
    u = matrix(q) @ [0.0, 0.0, 1.0]
    c = np.array([0.05, 0.02, a[2] - 1e-3 + h * u[2] + r * np.sin(tilt)])
    end = c - h * u
    across = np.array([0.0, 0.0, 1.0]) - u[2] * u
    deepest = end - r * across / np.linalg.norm(across)
    dist, normal, count, points, seps = one(row("box", *a), row("cylinder", r, h), [0.0, 0.0, 0.0], c, IDENTITY, q)
    assert dist == pytest.approx(-1e-3, abs=1e-12)
    assert normal == pytest.approx([0.0, 0.0, 1.0], abs=1e-12)
    assert seps.min() == pytest.approx(-1e-3, abs=1e-12)
    # where along the rim: its direction across the axis is known to ~1e-16 / θ rad, so to ~r × 2e-10 m
    assert np.min(np.linalg.norm(points[:, 3:] - deepest, axis=1)) <= 1e-9
    assert count == 6  # the square's 4, the point toward the box's centre and the deepest
    on_both("box", a, np.zeros(3), IDENTITY, "cylinder", np.array([r, h, 0.0]), c, q, points)

#: A box and a thin can lying on its face, end on face (two bodies of a mixed pile): the end 3.7e-8 rad off the
#: face, sunk 2.6e-10 m below the face's plane at its lowest rim point, which is 11.6 mm beyond the face's edge.
CAN_END_OVER_AN_EDGE = (
    row("box", 0.07773482225249503, 0.08640051186020783, 0.09385453290184612),
    row("cylinder", 0.07283314984857345, 0.014193023298215831),
    [(0.33795162727972283, -0.6198536327078117, 0.07773510843959801),
     (0.3206009410049598, -0.6521668277484056, 0.16966303589283574)],
    [(0.7067378149494463, 0.022856919323420193, -0.706736678544643, 0.022858026144244876),
     (0.5530751129991458, 2.0589275611430137e-07, 1.0839873391914898e-06, 0.8331313938267868)])


def test_a_can_end_overhanging_a_box_faces_edge_overlaps_by_the_reference_depth():
    """The pair above overlaps by 1.24e-10 m (exact/convex_distance.py), along a direction 1.8e-8 rad off the
    face's normal: what is sunk over the face, where the rim crosses the face's edge. Along the face's normal
    the supports overlap by 2.57e-10 m, which is what EPA reported, and the rim polygon's points, on chords,
    said 0. The distance is the reference's within 1e-12 m, and point 0 is at it."""
    from rigid_body_sim.exact.convex_distance import signed_distance
    box, can, pos, quat = CAN_END_OVER_AN_EDGE
    dist, normal, count, points, seps = contacts([box, can], pos, quat, [[0, 1]])
    sd, n, certified = signed_distance(("box", box[DIMS:DIMS + 3], np.array(pos[0]), matrix(quat[0])),
                                       ("cylinder", can[DIMS:DIMS + 3], np.array(pos[1]), matrix(quat[1])))
    assert certified and -1.3e-10 < sd < -1.2e-10
    assert abs(dist[0] - sd) <= 1e-12
    assert seps[0, 0] == dist[0] and np.all(seps[0, :count[0]] >= dist[0])
    on_both("box", box[DIMS:DIMS + 3], np.array(pos[0]), quat[0], "cylinder", can[DIMS:DIMS + 3], np.array(pos[1]),
            quat[1], points[0, :count[0]])


def test_a_can_standing_on_a_box_face_over_its_edge_or_corner_is_as_deep_as_its_deepest_point():
    """Cans standing on a box's top face within the face alignment (tilt 0 to 1e-6 rad about a random horizontal
    axis), their end's centre within 0.9 r of the face's edge (even poses) or corner (odd), sunk 0 to 1e-7 m, the
    pair turned at random: the distance is exact/convex_distance.py's within 1e-12 m, and point 0 is at it (the
    rim polygon's points lie on chords, up to 2.6e-9 m shallower where the rim crosses the face's side)."""
    from scipy.spatial.transform import Rotation
    from rigid_body_sim.exact.convex_distance import signed_distance
    rng = np.random.default_rng(5)
    for t in range(12):
        d, r, h = rng.uniform(0.05, 0.2, 3), rng.uniform(0.03, 0.1), rng.uniform(0.01, 0.1)
        across = d[0] + rng.uniform(-0.9, 0.9) * r
        along = d[1] + rng.uniform(-0.9, 0.9) * r if t % 2 else rng.uniform(-d[1], d[1])
        turn = rng.uniform(0.0, 2.0 * np.pi)
        tilt = Rotation.from_rotvec(rng.uniform(0.0, 1e-6) * np.array([np.cos(turn), np.sin(turn), 0.0]))
        end = np.array([across, along, d[2] - rng.uniform(0.0, 1e-7)])
        world = Rotation.random(random_state=rng.integers(1 << 31))
        pos = np.array([[0.3, 0.3, 0.3], world.apply(end + h * tilt.apply([0.0, 0.0, 1.0])) + 0.3])
        quat = [_quat(world.as_matrix()), _quat((world * tilt).as_matrix())]
        box, can = row("box", *d), row("cylinder", r, h)
        dist, normal, count, points, seps = contacts([box, can], pos, quat, [[0, 1]])
        sd, _, certified = signed_distance(("box", d, pos[0], world.as_matrix()),
                                           ("cylinder", can[DIMS:DIMS + 3], pos[1], (world * tilt).as_matrix()))
        assert certified
        assert abs(dist[0] - sd) <= 1e-12, (t, dist[0], sd)
        assert abs(seps[0, 0] - dist[0]) <= 1e-12 and np.all(seps[0, :count[0]] >= dist[0] - 1e-12), (t, seps[0])
        on_both("box", d, pos[0], quat[0], "cylinder", can[DIMS:DIMS + 3], pos[1], quat[1], points[0, :count[0]])


ALONG_X = (np.cos(np.pi / 4), 0.0, np.sin(np.pi / 4), 0.0)  # the body's z axis along world x


def on_both(ka, da, ca, qa, kb, db, cb, qb, points):
    """Every point pair lies on its shape's surface (surface_distance), within 1e-12 m."""
    for p in points:
        assert surface_distance(ka, da, np.asarray(ca), matrix(qa), p[:3]) <= 1e-12
        assert surface_distance(kb, db, np.asarray(cb), matrix(qb), p[3:]) <= 1e-12


@pytest.mark.parametrize("ra,rb,offset", [(0.1, 0.1, (0.0, 0.0)), (0.1, 0.1, (0.06, 0.02)), (0.1, 0.04, (0.03, 0.0)),
                                          (0.04, 0.1, (0.03, -0.01)), (0.1, 0.06, (0.09, 0.0))])
def test_two_cylinders_end_on_end_touch_where_their_disks_overlap(ra, rb, offset):
    """B (radius rb) sunk 1 mm on A's top end, its axis offset: the points are each rim's four points (local ±x,
    ±y) and its point toward the other's centre inside the other disk, and the two points where the rims cross
    (closed form); every one is within both disks, 1 mm deep, on both surfaces, and their hull holds B's centre
    when it lies over both disks."""
    h = 0.15
    ca, cb = np.zeros(3), np.array([offset[0], offset[1], 2 * h - 1e-3])
    da, db = np.array([ra, h, 0.0]), np.array([rb, h, 0.0])
    dist, normal, count, points, seps = one(row("cylinder", ra, h), row("cylinder", rb, h), ca, cb)
    assert dist == pytest.approx(-1e-3, abs=1e-12)
    assert normal == pytest.approx([0.0, 0.0, 1.0], abs=1e-12)
    assert seps == pytest.approx([-1e-3] * count, abs=1e-12)
    on_both("cylinder", da, ca, IDENTITY, "cylinder", db, cb, IDENTITY, points)
    expect = []
    for centre, r, other, r_other in ((ca[:2], ra, cb[:2], rb), (cb[:2], rb, ca[:2], ra)):
        ways = [(1, 0), (0, 1), (-1, 0), (0, -1)]
        if np.linalg.norm(other - centre) > 0:
            ways.append((other - centre) / np.linalg.norm(other - centre))
        for u in ways:
            p = centre + r * np.array(u)
            if np.linalg.norm(p - other) <= r_other + 1e-12:
                expect.append(p)
    d = np.linalg.norm(cb[:2])
    if abs(ra - rb) < d < ra + rb:
        e = cb[:2] / d
        along = (d * d + ra * ra - rb * rb) / (2 * d)
        across = np.sqrt(ra * ra - along * along)
        expect += [along * e + s * across * np.array([-e[1], e[0]]) for s in (-1, 1)]
    distinct = {tuple(np.round(p, 9)) for p in expect}
    assert count == len(distinct)
    assert {tuple(np.round(p[:2], 9)) for p in points} == distinct
    if np.linalg.norm(cb[:2]) < ra:  # B's centre over A's disk: inside the points' hull
        from scipy.spatial import Delaunay
        assert Delaunay(points[:, :2]).find_simplex(cb[:2]) >= 0


@pytest.mark.parametrize("ka", ["capsule", "cylinder"])
def test_a_side_lying_on_an_end_face_touches_along_the_chord_over_the_disk(ka):
    """A capsule or a cylinder (radius 0.03, half length 0.2, along x, 0.02 off the disk's centre in y) lying 1 mm
    deep on a cylinder's top end (radius 0.1): two points, at the chord's ends x = ±√(0.1² − 0.02²); a cylinder
    standing on a lying one's side: the chord of its end along the side's line."""
    R, h, r, half = 0.1, 0.15, 0.03, 0.2
    ca, cb = np.zeros(3), np.array([0.01, 0.02, h + r - 1e-3])
    db = np.array([r, half, 0.0])
    dist, normal, count, points, seps = one(row("cylinder", R, h), row(ka, r, half), ca, cb, IDENTITY, ALONG_X)
    assert dist == pytest.approx(-1e-3, abs=1e-12)
    assert count == 2
    assert seps == pytest.approx([-1e-3] * 2, abs=1e-12)
    chord = np.sqrt(R * R - 0.02 ** 2)
    assert sorted(points[:, 0]) == pytest.approx([-chord, chord], abs=1e-12)
    assert points[:, 1] == pytest.approx([0.02, 0.02], abs=1e-12)
    on_both("cylinder", np.array([R, h, 0.0]), ca, IDENTITY, ka, db, cb, ALONG_X, points)
    # a cylinder (radius 0.05) standing on the side of one lying along x: its end's chord along the top line
    ca, cb = np.zeros(3), np.array([0.01, 0.03, R + h - 1e-3])
    dist, normal, count, points, seps = one(row("cylinder", R, half), row("cylinder", 0.05, h), ca, cb, ALONG_X)
    assert count == 2
    assert seps == pytest.approx([-1e-3] * 2, abs=1e-12)
    chord = np.sqrt(0.05 ** 2 - 0.03 ** 2)
    assert sorted(points[:, 0]) == pytest.approx([0.01 - chord, 0.01 + chord], abs=1e-12)
    on_both("cylinder", np.array([R, half, 0.0]), ca, ALONG_X, "cylinder", np.array([0.05, h, 0.0]), cb, IDENTITY,
            points)


@pytest.mark.parametrize("ka", ["capsule", "cylinder"])
def test_two_sides_lying_along_parallel_axes_touch_along_their_overlap(ka):
    """A capsule or a cylinder (radius 0.03, half length 0.2) lying 1 mm deep along the top of a cylinder lying
    (radius 0.1, half length 0.15) parallel to it, 0.1 along: two points, at the overlap's ends x = −0.1, 0.15."""
    R, h, r, half = 0.1, 0.15, 0.03, 0.2
    ca, cb = np.zeros(3), np.array([0.1, 0.0, R + r - 1e-3])
    dist, normal, count, points, seps = one(row(ka, r, half), row("cylinder", R, h), cb, ca, ALONG_X, ALONG_X)
    assert dist == pytest.approx(-1e-3, abs=1e-12)
    assert normal == pytest.approx([0.0, 0.0, -1.0], abs=1e-12)
    assert count == 2
    assert seps == pytest.approx([-1e-3] * 2, abs=1e-12)
    assert sorted(points[:, 0]) == pytest.approx([-0.1, 0.15], abs=1e-12)
    on_both(ka, np.array([r, half, 0.0]), cb, ALONG_X, "cylinder", np.array([R, h, 0.0]), ca, ALONG_X, points)


@pytest.mark.parametrize("ka,kb", [("sphere", "cylinder"), ("box", "cylinder"), ("cylinder", "cylinder"),
                                   ("cylinder", "capsule")])
def test_cylinder_pairs_match_the_reference(ka, kb):
    """Distance and normal within 1e-9 of exact/convex_distance.py (an independent maximisation of sep) on random poses.

    10 poses per pair here (the reference costs ~0.1 s a pose); 10,000 in the bench
    (benchmarks/pair_oracle.py, ``make bench-oracle``).
    """
    from rigid_body_sim.exact.convex_distance import signed_distance
    rng = np.random.default_rng(11)
    shapes, pos, quat, pairs = random_pair_poses(rng, ka, kb, 10)
    dist, normal, _, _, _ = contacts(shapes, pos, quat, pairs)
    for m, (a, b) in enumerate(pairs):
        sd, n, certified = signed_distance((ka, shapes[a, DIMS:DIMS + 3], pos[a], matrix(quat[a])),
                                           (kb, shapes[b, DIMS:DIMS + 3], pos[b], matrix(quat[b])))
        assert certified
        assert dist[m] == pytest.approx(sd, abs=1e-9)
        assert np.linalg.norm(normal[m] - n) <= 1e-9


#: A box's edge 2.7e-7 m from a can's rim (two tumbling bodies of a mixed pile just after their impact), at two
#: poses 1e-16 apart (quaternions w, x, y, z): GJK's witnesses, 2.7e-7 m apart, gave the second a direction
#: 1.3e-2 rad off the normal, beyond the refinement's reach, which stopped at −1.07e-3 m (a false overlap).
BOX_EDGE_BY_A_RIM = (
    row("box", 0.09710430543171569, 0.04912776605995227, 0.067302732997678),
    row("cylinder", 0.07851380886012613, 0.024094824278060686),
    [(0.3123144841104977, 0.008347967160762628, 0.4660518882297356),
     (0.5023752639569996, 0.028430061782855655, 0.4793073376548937)],
    [[(0.03678209339683501, -0.16142246334443336, -0.9839971201293303, -0.06587513575201198),
      (0.24800474936280892, 0.9130326536201004, -0.19578744857203406, 0.2579385444220805)],
     [(0.036782093396835, -0.16142246334443336, -0.9839971201293303, -0.06587513575201198),
      (0.24800474936280892, 0.9130326536201004, -0.19578744857203412, 0.2579385444220805)]])


@pytest.mark.parametrize("pose", [0, 1])
def test_a_box_edge_near_a_can_rim_is_apart_by_the_reference_distance(pose):
    """The pair above: distance and normal within 1e-12 m and 1e-9 rad of exact/convex_distance.py at both poses
    (MuJoCo's mj_geomDistance gives 2.73704603e-07 m at both)."""
    from rigid_body_sim.exact.convex_distance import signed_distance
    box, can, pos, quats = BOX_EDGE_BY_A_RIM
    quat = quats[pose]
    dist, normal, _, _, _ = contacts([box, can], pos, quat, [[0, 1]])
    sd, n, certified = signed_distance(("box", box[DIMS:DIMS + 3], np.array(pos[0]), matrix(quat[0])),
                                       ("cylinder", can[DIMS:DIMS + 3], np.array(pos[1]), matrix(quat[1])))
    assert certified and sd > 2.7e-7
    assert abs(dist[0] - sd) <= 1e-12
    assert np.linalg.norm(normal[0] - n) <= 1e-9


def _quat(rotation):
    """(w, x, y, z) of a rotation matrix (scipy)."""
    from scipy.spatial.transform import Rotation
    x, y, z, w = Rotation.from_matrix(rotation).as_quat()
    return (w, x, y, z)


def test_a_box_edge_on_a_can_rim_is_apart_by_the_gap_it_was_put_at():
    """A box's edge put across a can's rim at a gap g (−1 µm to 1 µm, 0 included) along a normal n in the rim's cone
    (between the side's and the end's normals): the can lies below the plane through the rim point across n, the
    box above the one g beyond it, with its edge on it, so the signed distance is g and the normal n exactly.
    300 random rims, edges and gaps, each pair turned and moved at random: distance within 1e-12 m, normal within
    1e-9, both points on their surfaces within 1e-12 m. Touching, GJK's witnesses are a hair apart and their
    direction is round-off: a box face's normal taken from there stopped the refinement up to 14 mm short."""
    rng = np.random.default_rng(17)
    for _ in range(300):
        r, h, half = rng.uniform(0.02, 0.1), rng.uniform(0.02, 0.15), rng.uniform(0.02, 0.1, 3)
        phi, psi, chi = rng.uniform(0.0, 2 * np.pi), rng.uniform(0.05, 1.5), rng.uniform(0.2, np.pi - 0.2)
        g = float(rng.choice([-1e-6, -1e-8, -1e-10, 0.0, 1e-10, 1e-8, 1e-6]))
        radial, up = np.array([np.cos(phi), np.sin(phi), 0.0]), np.array([0.0, 0.0, rng.choice([-1.0, 1.0])])
        rim_point = r * radial + h * up
        n = np.cos(psi) * radial + np.sin(psi) * up  # in the rim's normal cone
        tangent = np.cross(up, radial)
        edge = np.cos(chi) * tangent + np.sin(chi) * np.cross(n, tangent)  # across n, not along the rim
        across = np.cross(edge, n)
        u, w = (n + across) / np.sqrt(2), (n - across) / np.sqrt(2)  # the box's axes by the edge: n = (u + w)/√2
        box_centre = rim_point + g * n + half[1] * w + half[2] * u + rng.uniform(-0.9, 0.9) * half[0] * edge
        turn = matrix(_unit4(rng))
        offset = rng.normal(size=3)
        can_q, box_q = _quat(turn), _quat(turn @ np.column_stack([edge, w, u]))
        can_c, box_c = offset, turn @ box_centre + offset
        dist, normal, count, points, _ = one(row("cylinder", r, h), row("box", *half), can_c, box_c, can_q, box_q)
        assert abs(dist - g) <= 1e-12
        assert np.linalg.norm(normal - turn @ n) <= 1e-9
        on_both("cylinder", (r, h), can_c, can_q, "box", half, box_c, box_q, points)


def _unit4(rng):
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)
