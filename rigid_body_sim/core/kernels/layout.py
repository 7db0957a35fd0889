"""Named layouts of the core's buffers: which column of a row holds what.

The compiled code (``forces.py``, ``dynamics.py``, ``integrators.py``, ``reduced_models.py``,
``stepping.py``) keeps every body in fixed-width float64 rows, one row per body, so that a
step is a loop over rows with no allocation. This module is the one place that says what each
column is; everything else uses these names, never a bare number. Module-level ints are
compile-time constants to numba.

State row (``STATE_WIDTH`` + 1 floats per body; ``Simulator`` holds two buffers of them)
    ``P`` p_WC_W (3, m), ``Q`` q_WP (4, w x y z), ``V`` v_WC_W (3, m/s), ``W`` w_WP_P (3, rad/s,
    principal axes), then ``BOUND``: √J, the energy bound of the blow-up check
    (simulator.DivergenceError), carried with the state so a rejected step rolls it back too.

Wrench row (``WRENCH_WIDTH`` floats per body)
    Applied wrenches kept in the terms of the frame they were given in (forces.py):

    ``F_WORLD``, ``T_WORLD``   force and torque about the world origin, world axes (frame
                               ``world``): the torque about the COM is T − p × F, so it
                               depends on where the COM is at each stage.
    ``F_COM_W``, ``T_COM_W``   force at the COM and torque, world axes (``B/world_aligned``,
                               and world-axes sites).
    ``F_COM_P``, ``T_COM_P``   force at the COM and torque, principal axes P (body frame ``B``
                               and body-axes sites, whose moment r × f is added in P): they
                               turn with the body.
    ``SITE_MOMENT``            Σ f_W ⊗ r_P (3 × 3, row-major) over world-axes sites: the
                               moment Σ (R r_P) × f_W of forces fixed in world axes at
                               body-fixed points, which turns with the body.
    ``HELD`` …                 a persistent contact whose force is found at every stage
                               (kernels/contact/stage.py): ``HELD`` its mode (0 none, else
                               persistent.STICK or SLIDE), ``HELD_SHAPE`` the body's shape
                               (kind, 3 dims: contact/layout.py's shape row), ``HELD_GROUND``
                               the plane (normal, offset), ``HELD_FEATURES`` the tracked
                               features (bits), ``HELD_MU`` the friction, ``HELD_SLIDE`` each
                               contact point's slip direction (t1, t2) at the step's start;
                               ``HELD_OTHER`` a second plane held on at the same time (normal,
                               offset; zero: none) and ``HELD_OTHER_FEATURES`` its features
                               (a body in a corner, contact/two_grounds.py).
    ``ACTIVE``                 non-zero if anything was added to the row (the last column).

Parameter row (``PRM_WIDTH`` floats per body, ``core/stepping.pack_parameters``)
    Mass properties, damping, gravity as the body's motion allows it, the energy-bound
    constants, the body's reduced model and projection, its plane (planar), its constant twist
    (kinematic), q_PB (principal → body frame) and a cache of the last rotation increment.

Step controls (``CONTROL_WIDTH`` int64) and step inputs (``INPUT_WIDTH`` float64)
    What ``stepping.advance`` reads and reports besides the buffers: which buffer is current,
    the method, the steps done and the outcome; dt, the blow-up limit, and one pending wrench
    (the single-wrench fast path of ``Simulator.apply_*``).
"""

from __future__ import annotations

__all__ = [
    "P", "Q", "V", "W", "STATE_WIDTH", "BOUND", "ROW_WIDTH",
    "F_WORLD", "T_WORLD", "F_COM_W", "T_COM_W", "F_COM_P", "T_COM_P", "SITE_MOMENT", "HELD", "HELD_SHAPE", "HELD_GROUND",
    "HELD_FEATURES", "HELD_MU", "HELD_SLIDE", "HELD_OTHER", "HELD_OTHER_FEATURES", "ACTIVE",
    "WRENCH_WIDTH",
    "FRAME_WORLD", "FRAME_BODY", "FRAME_WORLD_ALIGNED", "FRAME_SITE_BODY_AXES", "FRAME_SITE_WORLD_AXES",
]

# ----------------------------------------------------------------------------- state rows
P, Q, V, W = 0, 3, 7, 10
STATE_WIDTH = 13
BOUND = 13  # √J: the blow-up check's energy bound, advanced and rolled back with the state
ROW_WIDTH = 14

# ----------------------------------------------------------------------------- wrench rows
F_WORLD = 0
T_WORLD = 3
F_COM_W = 6
T_COM_W = 9
F_COM_P = 12
T_COM_P = 15
SITE_MOMENT = 18  # 9 columns, M[j, l] at SITE_MOMENT + 3 j + l
HELD = 27  # 0: no held contact; else persistent.STICK or SLIDE
HELD_SHAPE = 28  # 4 columns: KIND, DIMS (3) of the body's shape row (kernels/contact/layout.py)
HELD_GROUND = 32  # 4 columns: the plane's unit normal (world axes) and offset (m)
HELD_FEATURES = 36  # the tracked features (shapes.feature_points' mask), as bits
HELD_MU = 37  # Coulomb friction coefficient
HELD_SLIDE = 38  # 2 × 4 columns (contact/layout.MAX_POINTS): each contact's slip direction (t1, t2), step start
HELD_OTHER = 46  # 4 columns: a second plane held on at once (normal, offset); all zero: none
HELD_OTHER_FEATURES = 50  # the tracked features on the second plane, as bits
ACTIVE = 51
WRENCH_WIDTH = 52

#: How a frame's origin and axes relate to its body (core/frames.parse_frame; forces.add_wrench).
FRAME_WORLD = 0  # world origin, world axes
FRAME_BODY = 1  # centre of mass, body axes
FRAME_WORLD_ALIGNED = 2  # centre of mass, world axes
FRAME_SITE_BODY_AXES = 3  # body-fixed point, body axes
FRAME_SITE_WORLD_AXES = 4  # body-fixed point, world axes

# ----------------------------------------------------------------------------- parameter rows
MASS, INV_MASS = 0, 1
INERTIA = 2  # 3 columns: I1, I2, I3 (kg·m²)
DAMP_LIN, DAMP_ANG = 5, 6  # c_v (N·s/m), c_w (N·m·s/rad)
GRAVITY = 7  # 3 columns, m/s², projected onto the body's motion
GRAVITY_BUDGET_RATE = 10  # |m g| / √(2m): the energy bound's growth rate under gravity alone
INV_INERTIA = 11  # 3 columns
# Columns 0–13 are what a step with no wrench reads of every body (fewer cache lines a row).
BUDGET_FORCE, BUDGET_TORQUE = 14, 15  # 1/√(2m), 1/√(2 I_min)
MODEL = 16  # MODEL_* below
PROJECT = 17  # PROJECT_* below
Q_PB = 18  # 4 columns: q_PB (w, x, y, z), principal frame → the user's body frame B
# The rotation increment of a constant-rate step, kept for the next step with the same rate
# and dt (kinematic bodies, undamped isotropic ones): the same numbers without sin and cos.
CACHE_RATE = 22  # 3 columns
CACHE_DT = 25  # NaN: nothing cached
CACHE_Q = 26  # 4 columns
AXIS_S, AXIS_K = 30, 31  # symmetric splitting: symmetry and remainder axes (0, 1, 2)
INV_I_T, C_S, C_K = 32, 33, 34  # 1/I_t, 1/I_s − 1/I_t, 1/I_k − 1/I_t
NORMAL = 35  # 3 columns: unit plane normal, world axes (planar)
PLANE_OFFSET = 38  # n·p of the plane (planar), m
INERTIA_NORMAL = 39  # nᵀ I_W n, the moment about the plane normal (planar), kg·m²
KINEMATIC_W = 40  # 3 columns: constant angular velocity of a kinematic body, world axes, rad/s
# The torque-free symmetric top's increments q ← A ⊗ q ⊗ B (reduced_models.symmetric_free): constant
# along its motion, kept with the state (q, w) and dt they lead to; NaN in TOP_DT: nothing cached.
TOP_KEY = 43  # 7 columns: q (w, x, y, z) then w_P the last step left
TOP_DT = 50
TOP_A = 51  # 4 columns: exp(dt L_W / I_t), world side
TOP_B = 55  # 4 columns: exp(dt λ e_s), body side
PRM_WIDTH = 59

#: Per-body models (reduction.py says which body gets which, and why).
MODEL_FULL = 0  # the integrator
MODEL_STATIC = 1  # never stepped
MODEL_KINEMATIC = 2  # constant twist, exact
MODEL_TRANSLATION = 3  # exact flow of the COM; orientation fixed
MODEL_PLANAR = 4  # x, y, yaw in a plane
MODEL_ISOTROPIC = 5  # exact while no torque acts and the force is fixed in world axes, else the integrator
MODEL_SYMMETRIC = 6  # likewise, with the exact symmetric-top flow
MODEL_COUNT = 7

#: Wrench components a motion lets through (the rest is projected out, also of impulses).
PROJECT_NONE = 0  # free
PROJECT_FORCE = 1  # rotation_only: no force
PROJECT_TORQUE = 2  # translation_only: no torque
PROJECT_PLANE = 3  # planar: force in the plane, torque along its normal
PROJECT_ALL = 4  # static, kinematic: nothing

# ----------------------------------------------------------------------------- step controls
CUR = 0  # which of the two state buffers holds the state
METHOD = 1  # integrators.Method.code of the integrator
DONE = 2  # out: steps done by the last advance
OUTCOME = 3  # out: OK, NON_FINITE or DIVERGED
GROUPS = 4  # 2 × MODEL_COUNT: [start, end) in ``members`` of each model's bodies
CONTROL_WIDTH = GROUPS + 2 * MODEL_COUNT

DT = 0  # s
LIMIT = 1  # energy_growth_limit
SPENT = 2  # 1.0: the wrench rows hold the last step's wrenches, dropped before anything is added or stepped
PENDING = 3  # 1.0 when a pending wrench waits in the next columns
PENDING_BODY = 4
PENDING_FRAME = 5  # FRAME_*
PENDING_ARM = 6  # 3 columns: the site's position from the COM, P axes (site frames)
PENDING_FORCE = 9  # 3 columns, N, the frame's axes
PENDING_TORQUE = 12  # 3 columns, N·m about the frame's origin, the frame's axes
INPUT_WIDTH = 15

#: Step outcomes (and per-body status).
OK, NON_FINITE, DIVERGED = 0, 1, 2
