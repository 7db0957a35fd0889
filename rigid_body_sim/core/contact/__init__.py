"""Contact with static ground half-spaces: scene keys, compiled gap functions, events, impact laws.

The package sits *around* the integrator step, never inside one (STYLE.md, "Contact code we
learn from"): after each step of the chosen integrator the gaps are checked (compiled,
:mod:`.shapes`); where one became negative the impact time is located by root finding on the
integrator's own step map (:mod:`.solver`), the impact law (:mod:`.impacts`) changes the
velocities, and the rest of the step is taken. Bodies that come to rest are held by a
persistent contact (:mod:`.persistent`): the contact force that holds them is a wrench of the
step, and gap and normal velocity are projected back to zero after it.

Modules
-------
scene_keys
    The scene keys ``ground``, ``bodies.<b>.material`` and ``bodies.<b>.collision`` (pure Python).
layout
    Column names of the shape, ground and contact rows.
shapes
    Compiled gap functions: sphere, box, cylinder, capsule against a half-space.
impacts
    Compiled impact law for one or several simultaneous contacts, with Coulomb friction.
persistent
    Compiled holding force of a persistent contact and the projection onto the contact manifold.
batch
    The compiled passes over every body in persistent contact (holding forces, projection).
solver
    :class:`~rigid_body_sim.core.contact.solver.ContactSolver`, the driver a Simulator holds when its
    scene has collision geometry.

scene.py imports :mod:`.scene_keys` (pure Python); the compiled modules are loaded when a
scene has a ``ground`` (or a test imports them).

numba checks a cached function against its own file only, and the compiled functions here
inline the core's (dynamics.derivative, the rotations, the layouts): so, like core/jit.py
does for the core, the cache of this package is dropped at import whenever any source of the
core or of this package changed since it was compiled (:func:`invalidate_stale_cache`).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

__all__ = ["invalidate_stale_cache"]

PACKAGE_DIR = Path(__file__).resolve().parent
CACHE_DIR = PACKAGE_DIR / "__pycache__"
STAMP_NAME = "numba-sources.sha256"


def invalidate_stale_cache(source_dirs: tuple[Path, ...] = (PACKAGE_DIR.parent, PACKAGE_DIR),
                           cache_dir: Path = CACHE_DIR) -> bool:
    """Drop this package's cached machine code if any source in ``source_dirs`` changed since it was compiled.

    Returns True when it was dropped. A read-only install is left alone (numba then caches
    elsewhere, per file, as it does).
    """
    sources = [path for directory in source_dirs for path in sorted(directory.glob("*.py"))]
    digest = hashlib.sha256(b"".join(p.name.encode() + p.read_bytes() for p in sources)).hexdigest()
    stamp = cache_dir / STAMP_NAME
    try:
        if stamp.read_text() == digest:
            return False
    except OSError:
        pass
    try:
        for stale in (*cache_dir.glob("*.nbi"), *cache_dir.glob("*.nbc")):
            stale.unlink(missing_ok=True)
        cache_dir.mkdir(exist_ok=True)
        partial = stamp.with_name(f"{STAMP_NAME}.{os.getpid()}")
        partial.write_text(digest)
        os.replace(partial, stamp)
    except OSError:
        return False
    return True


invalidate_stale_cache()
