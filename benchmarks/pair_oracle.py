"""Body–body narrow phase against MuJoCo's collision functions (the oracle), and its cost.

For every pair of sphere, box, cylinder and capsule: random dimensions (0.05–0.5 m), random
orientations (uniform), B's centre at a random direction from A's at a distance between 0.2
and 1.2 × the sum of their bounding radii (so about half the poses overlap). For each pose:

* ours: ``pairs.pair_contacts`` (one compiled call over all poses);
* MuJoCo: ``mujoco.mj_geomDistance(m, d, g1, g2, distmax, fromto)`` on the same geoms written
  into ``d.geom_xpos`` / ``d.geom_xmat``, with ``opt.ccd_tolerance`` = 1e-15 and
  ``opt.ccd_iterations`` = 10,000 (its convex method's settings, tightened; the defaults are
  1e-6 and 35). Its normal is fromto's direction (geom1 to geom2) where its points differ.

Reported per pair: the largest |Δ signed distance| (m), the largest angle between the
normals (rad), the fraction of poses within 1e-9 on each, split by apart/overlapping; and the
largest distance of our contact points from their surfaces (independent closed forms here).

For the pairs with a cylinder, where both sides run an iterative method on a curved rim, both
are also measured against the independent reference rigid_body_sim/exact/convex_distance.py
(sep(u) maximised over every stratum of its kinks to round-off; ~10–40 ms a pose in Python).

Cost: ns per pair of our compiled loop (median [min–max] of 5 runs over 20,000 poses) beside
one ``mj_geomDistance`` call from Python; then the broad phase's table (benchmarks/broadphase.py).

``python -m benchmarks.pair_oracle [--poses N] [--out DIR]`` writes DIR/pair_oracle.md (default
benchmarks/results) and prints it.
"""

from __future__ import annotations

import argparse
import itertools
import time
from pathlib import Path

import numpy as np

from benchmarks.machine import describe

try:
    import mujoco
except ImportError:  # the bench extra is not installed
    mujoco = None

KINDS = {"sphere": 1, "box": 2, "cylinder": 3, "capsule": 4}
MJ_TYPE = {"sphere": "sphere", "box": "box", "cylinder": "cylinder", "capsule": "capsule"}
PAIRS = list(itertools.combinations_with_replacement(KINDS, 2))
CYLINDER_PAIRS = [pair for pair in PAIRS if "cylinder" in pair]
TOL = 1e-9


def random_quats(rng, n):
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def quat_matrix(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def random_dims(rng, kind, n):
    """Shape dimensions as in a shape row: sphere r; box half extents; cylinder/capsule r, half length."""
    d = rng.uniform(0.05, 0.5, size=(n, 3))
    if kind == "sphere":
        d[:, 1:] = 0.0
    elif kind in ("cylinder", "capsule"):
        d[:, 2] = 0.0
    return d


def bounding_radius(kind, d):
    if kind == "sphere":
        return d[:, 0]
    if kind == "box":
        return np.linalg.norm(d, axis=1)
    if kind == "cylinder":
        return np.hypot(d[:, 0], d[:, 1])
    return d[:, 0] + d[:, 1]


def random_poses(rng, ka, kb, n):
    """(shapes (2n, 7), pos (2n, 3), quat (2n, 4), pairs (n, 2)): A at the origin, B around it."""
    from rigid_body_sim.core.kernels.contact.layout import DIMS, KIND, SHAPE_WIDTH
    da, db = random_dims(rng, ka, n), random_dims(rng, kb, n)
    reach = bounding_radius(ka, da) + bounding_radius(kb, db)
    direction = rng.normal(size=(n, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    pos = np.zeros((2 * n, 3))
    pos[1::2] = direction * (reach * rng.uniform(0.2, 1.2, size=n))[:, None]
    pos[0::2] = rng.uniform(-1.0, 1.0, size=(n, 3))
    pos[1::2] += pos[0::2]
    quat = random_quats(rng, 2 * n)
    shapes = np.zeros((2 * n, SHAPE_WIDTH))
    shapes[0::2, KIND], shapes[1::2, KIND] = KINDS[ka], KINDS[kb]
    shapes[0::2, DIMS:DIMS + 3], shapes[1::2, DIMS:DIMS + 3] = da, db
    pairs = np.stack((np.arange(0, 2 * n, 2), np.arange(1, 2 * n, 2)), axis=1).astype(np.int64)
    return shapes, pos, quat, pairs


def ours(shapes, pos, quat, pairs):
    from rigid_body_sim.core.kernels.contact.pairs import MAX_PAIR_POINTS, pair_contacts
    m = len(pairs)
    dist, normal = np.empty(m), np.empty((m, 3))
    count = np.zeros(m, np.int64)
    points, seps = np.full((m, MAX_PAIR_POINTS, 6), np.nan), np.full((m, MAX_PAIR_POINTS), np.nan)
    pair_contacts(pos, quat, shapes, pairs, dist, normal, count, points, seps)
    return dist, normal, count, points, seps


def mujoco_model(ka, kb, tolerance=1e-15, iterations=10_000):
    xml = (f'<mujoco><option ccd_tolerance="{tolerance:g}" ccd_iterations="{iterations}"/><worldbody>'
           f'<geom name="a" type="{MJ_TYPE[ka]}" size="0.1 0.1 0.1"/>'
           f'<geom name="b" type="{MJ_TYPE[kb]}" size="0.1 0.1 0.1" pos="1 0 0"/></worldbody></mujoco>')
    m = mujoco.MjModel.from_xml_string(xml)
    return m, mujoco.MjData(m)


def mj_size(kind, d):
    if kind == "sphere":
        return np.array([d[0], 0.0, 0.0])
    if kind in ("cylinder", "capsule"):
        return np.array([d[0], d[1], 0.0])
    return d.copy()


def theirs(ka, kb, shapes, pos, quat, pairs):
    """MuJoCo's signed distance and normal (geom a to geom b) for each pose."""
    from rigid_body_sim.core.kernels.contact.layout import DIMS
    m, d = mujoco_model(ka, kb)
    n = len(pairs)
    dist, normal = np.empty(n), np.full((n, 3), np.nan)
    fromto = np.zeros(6)
    for k, (a, b) in enumerate(pairs):
        for g, (body, kind) in enumerate(((a, ka), (b, kb))):
            m.geom_size[g] = mj_size(kind, shapes[body, DIMS:DIMS + 3])
            m.geom_rbound[g] = bounding_radius(kind, shapes[body:body + 1, DIMS:DIMS + 3])[0]
            d.geom_xpos[g] = pos[body]
            d.geom_xmat[g] = quat_matrix(quat[body]).ravel()
        fromto[:] = 0.0
        dist[k] = mujoco.mj_geomDistance(m, d, 0, 1, 100.0, fromto)
        v = fromto[3:] - fromto[:3]
        norm = np.linalg.norm(v)
        if norm > 0.0:
            normal[k] = np.sign(dist[k]) * v / norm if dist[k] != 0.0 else v / norm
    return dist, normal


def surface_distance(kind, d, c, q, p):
    """|distance of the point p from the shape's surface| (m), closed forms in the shape's frame."""
    x = quat_matrix(q).T @ (p - c)
    if kind == "sphere":
        return abs(np.linalg.norm(x) - d[0])
    if kind == "capsule":
        z = np.clip(x[2], -d[1], d[1])
        return abs(np.linalg.norm(x - np.array([0, 0, z])) - d[0])
    if kind == "box":
        outside = np.maximum(np.abs(x) - d, 0.0)
        if np.any(outside > 0):
            return np.linalg.norm(outside)
        return np.min(d - np.abs(x))
    rho = np.hypot(x[0], x[1])
    out_r, out_z = max(rho - d[0], 0.0), max(abs(x[2]) - d[1], 0.0)
    if out_r > 0 or out_z > 0:
        return np.hypot(out_r, out_z)
    return min(d[0] - rho, d[1] - abs(x[2]))


def reference(ka, kb, shapes, pos, quat, pairs):
    """The independent reference (rigid_body_sim/exact/convex_distance.py): (sd (n,), normal (n, 3), certified (n,))."""
    from rigid_body_sim.core.kernels.contact.layout import DIMS
    from rigid_body_sim.exact.convex_distance import signed_distance
    n = len(pairs)
    sd, normal, certified = np.empty(n), np.empty((n, 3)), np.empty(n, bool)
    for k, (a, b) in enumerate(pairs):
        sd[k], normal[k], certified[k] = signed_distance((ka, shapes[a, DIMS:DIMS + 3], pos[a], quat_matrix(quat[a])),
                                                         (kb, shapes[b, DIMS:DIMS + 3], pos[b], quat_matrix(quat[b])))
    return sd, normal, certified


def angle(n1, n2):
    """Angle (rad) between the rows of n1 and n2; 0 where one has no direction (NaN)."""
    a = np.arctan2(np.linalg.norm(np.cross(n1, n2), axis=1), np.einsum("ij,ij->i", n1, n2))
    return np.where(np.isnan(a), 0.0, a)


def against_reference(ka, kb, n, seed=0):
    """Ours and MuJoCo against the reference on the poses of :func:`compare`, split apart/overlapping.

    Returns (rows {label: {n, ours_dist, ours_angle, ours_within, mj_dist, mj_angle, mj_within}},
    uncertified count, arrays (dist, normal, mj_dist, mj_normal, ref_dist, ref_normal)).
    """
    rng = np.random.default_rng(seed)
    shapes, pos, quat, pairs = random_poses(rng, ka, kb, n)
    dist, normal, _, _, _ = ours(shapes, pos, quat, pairs)
    mj_dist, mj_normal = theirs(ka, kb, shapes, pos, quat, pairs)
    ref_dist, ref_normal, certified = reference(ka, kb, shapes, pos, quat, pairs)
    rows = {}
    for label, mask in (("apart", ref_dist > 0), ("overlapping", ref_dist <= 0)):
        if mask.any():
            row = dict(n=int(mask.sum()))
            for who, d, nn in (("ours", dist, normal), ("mj", mj_dist, mj_normal)):
                e_d, e_n = np.abs(d - ref_dist)[mask], angle(nn, ref_normal)[mask]
                row[f"{who}_dist"], row[f"{who}_angle"] = float(e_d.max()), float(e_n.max())
                row[f"{who}_within"] = float(np.mean((e_d <= TOL) & (e_n <= TOL)))
            rows[label] = row
    return rows, int(np.sum(~certified)), (dist, normal, mj_dist, mj_normal, ref_dist, ref_normal)


def compare(ka, kb, n, seed=0):
    rng = np.random.default_rng(seed)
    shapes, pos, quat, pairs = random_poses(rng, ka, kb, n)
    dist, normal, count, points, _ = ours(shapes, pos, quat, pairs)
    mj_dist, mj_normal = theirs(ka, kb, shapes, pos, quat, pairs)
    err_d = np.abs(dist - mj_dist)
    err_n = angle(normal, mj_normal)  # 0 where MuJoCo gives no direction (touching exactly)
    on_surface = 0.0
    from rigid_body_sim.core.kernels.contact.layout import DIMS
    for k in range(n):
        a, b = pairs[k]
        for j in range(count[k]):
            on_surface = max(on_surface, surface_distance(ka, shapes[a, DIMS:DIMS + 3], pos[a], quat[a], points[k, j, :3]),
                             surface_distance(kb, shapes[b, DIMS:DIMS + 3], pos[b], quat[b], points[k, j, 3:]))
    overlap = mj_dist < 0
    rows = {}
    for label, mask in (("apart", ~overlap), ("overlapping", overlap)):
        if mask.any():
            rows[label] = dict(n=int(mask.sum()), max_dist=float(err_d[mask].max()),
                               frac_dist=float(np.mean(err_d[mask] <= TOL)), max_angle=float(err_n[mask].max()),
                               frac_angle=float(np.mean(err_n[mask] <= TOL)))
    return rows, on_surface, (shapes, pos, quat, pairs, dist, normal, mj_dist, mj_normal)


def cost(ka, kb, n=20_000, repeats=5):
    """(our ns per pair in the compiled loop (median, min, max), MuJoCo's µs per mj_geomDistance call from Python)."""
    rng = np.random.default_rng(1)
    shapes, pos, quat, pairs = random_poses(rng, ka, kb, n)
    ours(shapes, pos, quat, pairs)
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        ours(shapes, pos, quat, pairs)
        times.append((time.perf_counter() - t) / n * 1e9)
    # MuJoCo: the call alone, on one overlapping pose written once (median of 5 × 2000 calls)
    from rigid_body_sim.core.kernels.contact.layout import DIMS
    m, d = mujoco_model(ka, kb)
    k = int(np.argmin(np.linalg.norm(pos[pairs[:, 1]] - pos[pairs[:, 0]], axis=1)))
    for g, (body, kind) in enumerate(((pairs[k, 0], ka), (pairs[k, 1], kb))):
        m.geom_size[g] = mj_size(kind, shapes[body, DIMS:DIMS + 3])
        m.geom_rbound[g] = bounding_radius(kind, shapes[body:body + 1, DIMS:DIMS + 3])[0]
        d.geom_xpos[g] = pos[body]
        d.geom_xmat[g] = quat_matrix(quat[body]).ravel()
    fromto = np.zeros(6)
    mj_times = []
    for _ in range(repeats):
        t = time.perf_counter()
        for _ in range(2000):
            mujoco.mj_geomDistance(m, d, 0, 1, 100.0, fromto)
        mj_times.append((time.perf_counter() - t) / 2000 * 1e6)
    return (float(np.median(times)), float(min(times)), float(max(times))), float(np.median(mj_times))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--poses", type=int, default=10_000)
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = parser.parse_args(argv)
    if mujoco is None:
        raise SystemExit("MuJoCo is not installed: pip install -r requirements-bench.txt")
    machine = describe()
    lines = ["# Body–body narrow phase against MuJoCo", "",
             f"Machine: {machine}", "",
             f"MuJoCo {mujoco.__version__}, mj_geomDistance with ccd_tolerance 1e-15, ccd_iterations 10000; "
             f"{args.poses} random poses per pair (seed 0); tolerance {TOL:g}.", "",
             "| pair | case | poses | max abs Δ distance (m) | within 1e-9 | max normal angle (rad) | within 1e-9 |"
             " points off surface (m) |",
             "|---|---|---|---|---|---|---|---|"]
    lines += ["", "The box–capsule rows with deep overlaps (the capsule's axis inside the box) differ because "
              "MuJoCo's box–capsule function does not return the shortest separating translation there; ours "
              "equals max over u of sep(u) evaluated independently (test/test_contact_pairs.py).", ""]
    for ka, kb in PAIRS:
        rows, on_surface, _ = compare(ka, kb, args.poses)
        for label, r in rows.items():
            lines.append(f"| {ka}–{kb} | {label} | {r['n']} | {r['max_dist']:.1e} | {100 * r['frac_dist']:.2f} % | "
                         f"{r['max_angle']:.1e} | {100 * r['frac_angle']:.2f} % | {on_surface:.1e} |")
        print(lines[-1], flush=True)
    lines += ["", "Pairs with a cylinder against the independent reference (rigid_body_sim/exact/convex_distance.py: "
              "sep(u) maximised over every stratum of its kinks, Newton and scipy brentq to round-off; "
              f"the same {args.poses} poses):", "",
              "| pair | case | poses | ours: max abs Δ distance (m) | ours: max normal angle (rad) | ours: both within 1e-9 "
              "| MuJoCo: max abs Δ distance (m) | MuJoCo: max normal angle (rad) | MuJoCo: both within 1e-9 |",
              "|---|---|---|---|---|---|---|---|---|"]
    for ka, kb in CYLINDER_PAIRS:
        rows, uncertified, _ = against_reference(ka, kb, args.poses)
        for label, r in rows.items():
            lines.append(f"| {ka}–{kb} | {label} | {r['n']} | {r['ours_dist']:.1e} | {r['ours_angle']:.1e} | "
                         f"{100 * r['ours_within']:.2f} % | {r['mj_dist']:.1e} | {r['mj_angle']:.1e} | "
                         f"{100 * r['mj_within']:.2f} % |")
        print(lines[-1], flush=True)
        if uncertified:
            lines.append(f"| {ka}–{kb} | reference not locally certified on {uncertified} poses | | | | | | | |")
    lines += ["", "| pair | ours: ns per pair, compiled loop (median [min–max] of 5) | MuJoCo mj_geomDistance from Python, one call on an overlapping pose (µs, median of 5 × 2000) |",
              "|---|---|---|"]
    for ka, kb in PAIRS:
        (med, lo, hi), mj = cost(ka, kb)
        lines.append(f"| {ka}–{kb} | {med:.0f} [{lo:.0f}–{hi:.0f}] | {mj:.2f} |")
        print(lines[-1], flush=True)
    from benchmarks.broadphase import table
    lines += [""] + table()
    print("\n".join(lines[-8:]), flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "pair_oracle.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
