"""Model reduction, measured fairly: per body kind and on a mixed scene, against a baseline that skips static bodies.

Scenes of N bodies, no gravity, nothing applied, each moving body with a random twist (seeded):

* ``sphere``: r = 0.2 m — isotropic, exact exp-map rotation with reduction;
* ``crate``: a 1.0 × 0.5 × 0.5 m box — symmetric, the exact symmetric-top flow;
* ``box``: a 1.0 × 0.6 × 0.4 m box — full: the integrator either way;
* ``cart``: the same box, ``motion: translation_only`` — the exact constant-force flow;
* ``wall``: 1.0 × 1.0 × 0.1 m, ``motion: static`` — never stepped;
* ``mixed``: sphere, box, wall repeating.

Under ``euler``, whose step costs about as much as the exact isotropic and symmetric models,
those models are kept for their exactness, not for speed (core/reduction.py); their rows say so.

For each scene and integrator, seconds per ``sim.step(k)`` (batched), median of ≥ 5 interleaved
samples (min–max), of:

* ``reduced``: ``model_reduction=True``, every body of the scene;
* ``full``: ``model_reduction=False`` on the scene **without its static bodies** — the fair
  baseline: any engine skips a body that cannot move, reduction or not;
* ``full, statics stepped``: ``model_reduction=False`` on the whole scene, which integrates the
  walls too (an unfair baseline, shown beside the fair one for comparison).

The gain is full / reduced (time per step of the same scene's moving bodies). A scene of walls
only has no fair baseline (nothing to step); its row gives the cost of skipping them.
"""

from __future__ import annotations

import numpy as np

from rigid_body_sim.core import Simulator, load_scene

from .timing import Case, interleaved

INTEGRATORS = ("euler", "semi_implicit_euler", "implicit_gyroscopic", "splitting", "symmetric_splitting", "rk4")
KINDS = ("sphere", "crate", "box", "cart", "wall")
MIXED_PATTERN = ("sphere", "box", "wall")
DT = 1e-3
_SPEC = {"sphere": {"inertia": {"sphere": 0.2}}, "crate": {"inertia": {"box": [1.0, 0.5, 0.5]}},
         "box": {"inertia": {"box": [1.0, 0.6, 0.4]}},
         "cart": {"inertia": {"box": [1.0, 0.6, 0.4]}, "motion": "translation_only"},
         "wall": {"inertia": {"box": [1.0, 1.0, 0.1]}, "motion": "static"}}


def scene_of(kinds: list[str], seed: int = 0, skip_static: bool = False):
    """A scene with one body per entry of ``kinds`` (2 m apart), random twists; statics dropped if asked."""
    rng = np.random.default_rng(seed)
    bodies = {}
    for i, kind in enumerate(kinds):
        twist = {"linear": rng.normal(size=3).tolist(), "angular": rng.normal(size=3).tolist()}
        if kind == "cart":
            twist["angular"] = [0.0, 0.0, 0.0]
        if kind == "wall":
            if skip_static:
                continue
            spec = {"mass": 1.0, "pose": {"position": [2.0 * i, 0.0, 0.0]}, **_SPEC[kind]}
        else:
            spec = {"mass": 1.0, "pose": {"position": [2.0 * i, 0.0, 0.0]}, "twist": twist, **_SPEC[kind]}
        bodies[f"{kind}{i}"] = spec
    return load_scene({"bodies": bodies})


def kinds_of(scene_name: str, count: int) -> list[str]:
    if scene_name == "mixed":
        return [MIXED_PATTERN[i % len(MIXED_PATTERN)] for i in range(count)]
    return [scene_name] * count


def _note(kinds: list[str], integrator: str) -> str:
    """What a row's gain means where it is not a speed-up by design."""
    if integrator == "euler" and {"sphere", "crate"} & set(kinds):
        return "exact models kept for exactness: they cost about as much as euler's step"
    if set(kinds) <= {"box", "wall"} and "box" in kinds:
        return "the integrator either way"
    return ""


def _case(key, sim: Simulator) -> Case:
    return Case(key, sim.step, sim.reset, 100_000)


def sweep(count: int, repeats: int, min_seconds: float, integrators=INTEGRATORS, kind_integrators=("rk4",),
          log=print) -> list[dict]:
    """Rows per (scene, integrator): reduced / full (fair) / full with statics, µs per step and the gains."""
    jobs = [("mixed", name) for name in integrators] + [(kind, name) for kind in KINDS for name in kind_integrators]
    rows = []
    for scene_name, name in jobs:
        kinds = kinds_of(scene_name, count)
        whole = scene_of(kinds)
        reduced_sim = Simulator(whole, integrator=name, dt=DT, model_reduction=True, threads=1)
        cases = [_case("reduced", reduced_sim)]
        moving = [k for k in kinds if k != "wall"]
        if moving:
            cases.append(_case("full", Simulator(scene_of(kinds, skip_static=True), integrator=name, dt=DT, threads=1,
                                                 model_reduction=False)))
        if len(moving) < len(kinds):
            cases.append(_case("full, statics stepped", Simulator(whole, integrator=name, dt=DT, model_reduction=False,
                                                threads=1)))
        stats = interleaved(cases, repeats, min_seconds)
        models: dict[str, int] = {}
        for plan in reduced_sim.body_models():
            models[plan.model] = models.get(plan.model, 0) + 1
        row = {"scene": scene_name, "integrator": name, "bodies": count, "moving": len(moving),
               "models": ", ".join(f"{k} {v}" for k, v in sorted(models.items())), "note": _note(kinds, name)}
        for key, s in stats.items():
            row.update(s.scaled(1e6).as_row(f"{key.replace(', ', '_').replace(' ', '_')}_us"))
        reduced = stats["reduced"].median
        if "full" in stats:
            row["gain"] = stats["full"].median / reduced
        if "full, statics stepped" in stats:
            row["gain_vs_statics_stepped"] = stats["full, statics stepped"].median / reduced
        rows.append(row)
        log(f"  reduction {scene_name} {name}: gain {row.get('gain', float('nan')):.3g}")
    return rows
