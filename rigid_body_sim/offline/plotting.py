"""Figures of a run: one PNG per body, for ``rigid-body-sim plot``.

Six panels over sim time: position and linear velocity (world), orientation (the quaternion
x, y, z, w, kept sign-continuous: for display only), angular velocity in body axes (where an
intermediate-axis flip shows as the rate about that axis changing sign), the relative drift
of energy and |L|, and the error against the closed form where the scene has one
(:mod:`~rigid_body_sim.offline.reference`). A body the ground can touch (a collision shape in a
scene with ``ground``, docs/contact.md) gets instead its energy E(t) − E(0) in J (kinetic plus
potential: it drops at impacts and with friction, and must never rise) and the lowest gap of its
collision shape to the ground over time (from the sampled poses; zero while it rests, never
negative beyond round-off). matplotlib's Agg canvas is used directly, so no
GUI backend or global pyplot state is involved.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..core import Scene
from ..core.quaternion import quat_angle_between, quat_to_matrix, quat_wxyz_from_xyzw
from .reference import closed_form_reference
from .rundata import BodyTrack, RunData

__all__ = ["plot_body", "continuous_quaternions"]

_XYZ = ("x", "y", "z")
_COLOURS = ("tab:red", "tab:green", "tab:blue", "0.35")


def continuous_quaternions(q: np.ndarray) -> np.ndarray:
    """Quaternions (T, 4) with signs flipped so that consecutive ones have a positive dot product."""
    q = np.array(q, dtype=float, copy=True)
    for i in range(1, len(q)):
        if np.dot(q[i], q[i - 1]) < 0.0:
            q[i] = -q[i]
    return q


def plot_body(data: RunData, body: str, out: str | os.PathLike[str], *, scene: Scene | None = None,
              title: str | None = None, dpi: int = 120) -> Path:
    """Draw ``body``'s run into the PNG ``out`` and return its path.

    Parameters
    ----------
    data : RunData
    body : str
        A key of ``data.bodies``.
    out : str or Path
        PNG file to write.
    scene : Scene, optional
        The run's scene: enables the closed-form error panel where the body has a closed form.
    title : str, optional
        Figure title; default names the body, the scene and the integrator.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    if body not in data.bodies:
        raise ValueError(f"unknown body {body!r}; the run has {list(data.bodies)}")
    track: BodyTrack = data.bodies[body]
    t = data.time
    fig = Figure(figsize=(13, 10.5), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(3, 2, sharex=True)

    for ax, values in ((axes[0, 0], track.position_world), (axes[0, 1], track.linear_velocity_world)):
        if not np.any(values):
            _note(ax, "0 at every sample")
    _lines(axes[0, 0], t, track.position_world, [f"$p_{c}$" for c in _XYZ], "position, world (m)")
    axes[0, 0].set_title("Centre of mass position (world frame)")
    _lines(axes[0, 1], t, track.linear_velocity_world, [f"$v_{c}$" for c in _XYZ], "velocity, world axes (m/s)")
    axes[0, 1].set_title("Centre of mass velocity (world axes)")
    _lines(axes[1, 0], t, continuous_quaternions(track.orientation_xyzw), ["$q_x$", "$q_y$", "$q_z$", "$q_w$"],
           "quaternion component (1)")
    axes[1, 0].set_title("Orientation $q_{WB}$ (x, y, z, w; sign kept continuous; display only)")
    _lines(axes[1, 1], t, track.angular_velocity_body, [rf"$\omega_{c}$" for c in _XYZ],
           "angular velocity, body axes (rad/s)")

    reference = None
    if scene is not None and body in scene.body_names:
        reference = closed_form_reference(scene, body, t)
    axes[1, 1].set_title("Angular velocity (body axes)")
    if reference is not None and reference.flip_period is not None and scene is not None:
        _mark_flips(axes[1, 1], t, scene, body, reference)

    touches = scene is not None and body in scene.body_names and scene.contact is not None and \
        scene.body_names.index(body) in np.asarray(scene.contact.bodies).tolist()
    if touches:
        _contact_panels(axes[2, 0], axes[2, 1], t, track, scene, body)
    else:
        _conservation_panel(axes[2, 0], t, track)
        _error_panel(axes[2, 1], t, track, reference, scene)
    for ax in axes[2]:
        ax.set_xlabel("sim time t (s)")
    for ax in axes.ravel():
        ax.grid(True, alpha=0.3)

    meta = data.meta
    if title is None:
        parts = [f"{body}"]
        if meta.get("scene"):
            parts.append(Path(meta["scene"]).name)
        if meta.get("integrator"):
            parts.append(f"integrator {meta['integrator']}")
        if meta.get("dt"):
            parts.append(f"dt = {float(meta['dt']):g} s")
        title = " — ".join(parts[:2]) + ("  (" + ", ".join(parts[2:]) + ")" if parts[2:] else "")
    fig.suptitle(title, fontsize="x-large")
    out = Path(out)
    _save_whole(fig, out, dpi)
    return out


def _conservation_panel(ax, t: np.ndarray, track: BodyTrack) -> None:
    """Relative drift of energy and |L|."""
    drawn = False
    if track.energy is not None:
        drawn |= _drift(ax, t, track.energy, "energy $E$", "tab:purple")
    if track.angular_momentum_norm is not None:
        drawn |= _drift(ax, t, track.angular_momentum_norm, "$|L|$ about the COM", "tab:orange")
    ax.set_ylabel(r"relative drift $(X(t) - X(0))\,/\,|X(0)|$ (1)")
    ax.set_title("Conservation: energy and |angular momentum|")
    if drawn:
        ax.legend(loc="upper left", fontsize="small")
    else:
        _note(ax, "energy and |L| unknown: pass --scene to compute them")


def _contact_panels(energy_ax, gap_ax, t: np.ndarray, track: BodyTrack, scene: Scene, body: str) -> None:
    """Energy E(t) − E(0) (J) and the lowest gap to the ground (m) of a body the ground can touch."""
    from ..core import Simulator
    from ..core.contact.query import lowest_gaps_along

    energy_ax.set_title("Energy: kinetic + potential, E(t) − E(0) (lost at impacts and to friction)")
    if track.energy is not None:
        energy_ax.plot(t, track.energy - track.energy[0], color="tab:purple", lw=1.2, label="$E - E(0)$")
        energy_ax.legend(loc="upper right", fontsize="small")
        energy_ax.set_ylabel("energy change (J)")
    else:
        _note(energy_ax, "energy unknown: pass --scene to compute it")
    gaps = lowest_gaps_along(Simulator(scene), body, track.position_world, track.orientation_xyzw)
    gap_ax.set_title("Lowest gap of the collision shape to the ground")
    gap_ax.plot(t, gaps, color="tab:brown", lw=1.2, label="gap (m)")
    gap_ax.axhline(0.0, color="0.5", lw=0.8, ls=":")
    gap_ax.set_ylabel("gap (m)")
    gap_ax.text(0.99, 0.98, f"lowest: {gaps.min():.3g} m", transform=gap_ax.transAxes, ha="right", va="top",
                fontsize="small", color="0.25")


def _save_whole(fig, out: Path, dpi: int) -> None:
    """Write the PNG to a new file beside ``out``, then rename it over ``out``: an interrupted
    plot leaves the old file or none, never half a PNG (and never writes into a FIFO or device)."""
    import secrets

    temporary = out.with_name(f".{out.name}.{secrets.token_hex(6)}.tmp")
    fd = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o666)  # the umask applies
    try:
        with os.fdopen(fd, "wb") as handle:
            fig.savefig(handle, dpi=dpi, format="png")
        os.replace(temporary, out)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def _lines(ax, t: np.ndarray, values: np.ndarray, labels: list[str], ylabel: str) -> None:
    for k, label in enumerate(labels):
        ax.plot(t, values[:, k], color=_COLOURS[k], lw=1.2, label=label)
    ax.set_ylabel(ylabel)
    low, high = ax.get_ylim()
    ax.set_ylim(low, high + 0.22 * (high - low))  # head room for the legend
    ax.legend(loc="upper right", fontsize="small", ncol=len(labels))


def _mark_flips(ax, t: np.ndarray, scene: Scene, body: str, reference) -> None:
    """Dotted lines where the closed-form rate about the intermediate axis changes sign, and a note."""
    b = scene.body_names.index(body)
    intermediate = int(np.argsort(scene.model.inertia_P[b])[1])
    axis_B = quat_to_matrix(scene.model.q_BP[b])[:, intermediate]
    named = [k for k in range(3) if abs(abs(axis_B[k]) - 1.0) < 1e-12]
    what = rf"$\omega_{_XYZ[named[0]]}$ (intermediate axis)" if named else "the rate about the intermediate axis"
    rate = reference.angular_velocity_body @ axis_B
    crossings = np.flatnonzero(np.sign(rate[1:]) * np.sign(rate[:-1]) < 0)
    for i in crossings:
        t_cross = t[i] + (t[i + 1] - t[i]) * rate[i] / (rate[i] - rate[i + 1])
        ax.axvline(t_cross, color="0.5", lw=0.8, ls=":")
    low, high = ax.get_ylim()
    ax.set_ylim(low - 0.18 * (high - low), high)  # room for the note below the curves
    ax.text(0.01, 0.02, f"{what} changes sign every {reference.flip_period:.3g} s\n"
            "(closed form; dotted lines: its sign changes)", transform=ax.transAxes, ha="left", va="bottom",
            fontsize="small", color="0.25", bbox={"facecolor": "white", "edgecolor": "none", "alpha": 0.8})


def _drift(ax, t: np.ndarray, values: np.ndarray, label: str, colour: str) -> bool:
    scale = abs(values[0])
    if scale == 0.0:
        return False
    ax.plot(t, (values - values[0]) / scale, color=colour, lw=1.2, label=label)
    return True


def _note(ax, text: str) -> None:
    ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center", fontsize="medium", color="0.3")


def _error_panel(ax, t: np.ndarray, track: BodyTrack, reference, scene: Scene | None) -> None:
    ax.set_title("Error against the closed form")
    if reference is None:
        _note(ax, "no scene given: no closed form to compare with" if scene is None else "body not in the scene")
        return
    drawn = False
    if reference.orientation_xyzw is not None:
        angle = quat_angle_between(quat_wxyz_from_xyzw(track.orientation_xyzw),
                                   quat_wxyz_from_xyzw(reference.orientation_xyzw))
        drawn |= _semilog(ax, t, angle, "orientation error angle (rad)", "tab:blue")
        rate = np.linalg.norm(track.angular_velocity_body - reference.angular_velocity_body, axis=1)
        drawn |= _semilog(ax, t, rate, r"$|\omega_B - \omega_B^{exact}|$ (rad/s)", "tab:green")
    translation = f"translation: {reference.translation}"
    if reference.position_world is not None:
        position = np.linalg.norm(track.position_world - reference.position_world, axis=1)
        if _semilog(ax, t, position, "$|p - p^{exact}|$ (m)", "tab:red"):
            drawn = True
        else:
            translation += " (position error exactly 0)"
    ax.set_ylabel("error (rad, rad/s, m; log scale)")
    if drawn:
        ax.set_yscale("log")
        low, high = ax.get_ylim()
        ax.set_ylim(max(low, 1e-6 * high), high * 10.0)  # not down to a lone round-off sample at t ≈ 0
        ax.legend(loc="lower right", fontsize="small")
    notes = [f"rotation: {reference.rotation}", translation]
    ax.text(0.01, 0.98, "\n".join(notes), transform=ax.transAxes, ha="left", va="top", fontsize="small",
            color="0.25")
    if not drawn:
        _note(ax, "no closed form for this body")


def _semilog(ax, t: np.ndarray, error: np.ndarray, label: str, colour: str) -> bool:
    """Plot ``error`` where it is > 0 (a log axis cannot show exact zeros); False if none is."""
    positive = error > 0.0
    if not positive.any():
        return False
    ax.plot(t, np.where(positive, error, np.nan), color=colour, lw=1.2, label=label)
    return True
