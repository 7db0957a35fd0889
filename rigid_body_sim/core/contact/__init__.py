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
kernels/contact/layout
    Column names of the shape, ground and contact rows.
kernels/contact/shapes
    Compiled gap functions: sphere, box, cylinder, capsule against a half-space.
kernels/contact/impacts
    Compiled impact law for one or several simultaneous contacts, with Coulomb friction.
kernels/contact/persistent
    Compiled holding force of a persistent contact and the projection onto the contact manifold.
kernels/contact/batch
    The compiled passes over every body in persistent contact (holding forces, projection).
kernels/contact/swept
    The compiled swept broad phase of the body–body pass (boxes over the step, a hashed grid).
body_pairs
    Impacts between moving bodies, located on both step maps; no tunnelling through thin shapes.
solver
    :class:`~rigid_body_sim.core.contact.solver.ContactSolver`, the driver a Simulator holds when its
    scene has collision geometry.

scene.py imports :mod:`.scene_keys` (pure Python); the compiled modules live in
core/kernels/contact (like every compiled module of the core, so that the kernels' cache guard
covers them) and are loaded when a scene has a ``ground``.
"""
