"""Pictures of a mechanism: the assembled configuration and an animation of a simulation.

:func:`draw_scene` draws a scene as assembled at a time t (bodies, joints, slider guides,
ground, labels): what a user checks after writing a scene file and before simulating it.
:func:`animate` draws a simulated mechanism over its analysis span with its ideal counterpart
as a ghost, each clearance joint's journal orbit magnified inside its clearance circle, and an
output's error traced beside it; :func:`save_animation` writes it as GIF (Pillow), HTML
(matplotlib's ``to_jshtml``) or MP4 (needs ffmpeg). The CLI's ``mechrel draw`` and
``mechrel animate`` call these.

Conventions: a body with three or more points is drawn as the polygon through them (in angular
order about their centroid), a body with two points as a bar, a body with one point as a block
(a slider); ideal revolute joints are small open circles, clearance joints larger red circles,
the pin of a pin-in-slot joint a small open circle too; ground points of joints carry a hatched
ground symbol; a translational or pin-in-slot joint on a ground line draws that guide line, one
on a moving body's line draws the slot on that body (outlined in its colour, moving with it,
long enough for the point's travel along it). Coordinates are plotted in millimetres.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import AssemblyError, MechrelError
from ..scene.model import GROUND, Scene

__all__ = ["ANIMATION_FORMATS", "animate", "animation_output", "assembled_configuration",
           "draw_scene", "point_positions", "save_animation"]

ANIMATION_FORMATS = (".gif", ".html", ".mp4")
"""File types :func:`save_animation` writes (MP4 only where ffmpeg is installed)."""

MM = 1e3  # plotted in millimetres
# no red: red marks the clearance joints (the drawing's title says so)
_BODY_COLORS = ("#4C72B0", "#55A868", "#8172B2", "#CCB974", "#64B5CD", "#DD8452", "#937860",
                "#DA8BC3", "#8C8C8C")


def assembled_configuration(scene: Scene, t: float = 0.0) -> np.ndarray:
    """Coordinates q (x, y, θ per body; m, rad) of the scene assembled at time ``t``.

    Clearance joints are closed (as ideal joints) and drivers set their bodies' angles at
    ``t``, as in the start of a simulation. The mechanism is assembled at t = 0 and followed
    to ``t`` in steps that turn no driver by more than :data:`FOLLOW_STEP` (rad), each
    assembled from the last: the configuration a run reaches at ``t``. (Assembled at ``t``
    directly from the scene's guesses, a crank one turn later would have to turn by 2π in one
    linearised Newton step, which lands elsewhere or fails.)

    Parameters
    ----------
    scene : Scene
        A loaded scene.
    t : float, default 0.0
        Time (s) at which the drivers are evaluated.

    Returns
    -------
    numpy.ndarray, shape (3 n_bodies,)
        In the order of ``scene.bodies``.

    Raises
    ------
    mechrel.errors.AssemblyError
        The constraints cannot be satisfied at t = 0 or on the way to ``t`` (the message
        names the violated joints), or the drivers turn too far by ``t`` to be followed in at
        most :data:`FOLLOW_MAX_STEPS` steps.

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> q = assembled_configuration(load_scene("slider-crank"))
    >>> point_positions(load_scene("slider-crank"), q)["slider.B"].round(6).tolist()
    [0.17, 0.0]

    One crank turn later (12 ms at 5000 rpm) the slider-crank is where it started:

    >>> q1 = assembled_configuration(load_scene("slider-crank"), 0.012)
    >>> float(point_positions(load_scene("slider-crank"), q1)["slider.B"][0].round(6))
    0.17
    """
    from ..mechanics.drivers import driver_angles
    from ..mechanics.kinematics import assemble_positions
    from ..mechanics.system import compile_scene

    compiled = compile_scene(scene)
    system, labels = compiled.ideal, compiled.labels["ideal"]
    tol = scene.solver.assembly_tolerance
    q = assemble_positions(system, compiled.q_guess, 0.0, tol=tol, labels=labels)
    t = float(t)
    if t == 0.0 or system.dr_law.shape[0] == 0:
        return q  # without drivers nothing moves with t
    # how far the drivers turn on the way (the sum of |Δθ| on a fine grid, so that a harmonic
    # driver's swings count, not only where it ends)
    grid = np.linspace(0.0, t, 1025)
    turn = max(float(np.abs(np.diff(driver_angles(system.dr_law[k], system.dr_par[k],
                                                  grid))).sum())
               for k in range(system.dr_law.shape[0]))
    steps = max(math.ceil(turn / FOLLOW_STEP), 1)
    if not steps <= FOLLOW_MAX_STEPS:  # (a NaN or inf too)
        raise AssemblyError(
            f"t = {t:g} s: the drivers turn by {turn:.3g} rad from t = 0, {steps:.3g} steps of "
            f"{math.degrees(FOLLOW_STEP):g} degrees to follow, more than {FOLLOW_MAX_STEPS}; "
            f"allowed: |t| up to about {abs(t) * FOLLOW_MAX_STEPS / steps:.3g} s")
    for s in np.linspace(0.0, t, steps + 1)[1:]:
        q = assemble_positions(system, q, float(s), tol=tol, labels=labels)
    return q


FOLLOW_STEP = math.radians(5.0)
"""Largest driver rotation (rad) between two assemblies when :func:`assembled_configuration`
follows a mechanism from t = 0 (Newton from the last configuration converges in a few
iterations at this step)."""

FOLLOW_MAX_STEPS = 100_000
"""Most assemblies :func:`assembled_configuration` makes on the way to ``t`` (about 2–3 s)."""


def point_positions(scene: Scene, q: np.ndarray) -> dict[str, np.ndarray]:
    """World positions (m) of every named point, ``"body.point"`` → array (2,) or (n, 2).

    Parameters
    ----------
    scene : Scene
        The scene whose bodies ``q`` places.
    q : numpy.ndarray, shape (3 n_bodies,) or (n_times, 3 n_bodies)
        Coordinates in the order of ``scene.bodies``.

    Returns
    -------
    dict
        Also the ground points, as ``"ground.NAME"``.

    Examples
    --------
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank")
    >>> points = point_positions(scene, compile_scene(scene).q_guess)
    >>> points["crank.A"].tolist(), points["slider.B"].tolist()   # m
    ([0.05, 0.0], [0.17, 0.0])
    """
    q = np.asarray(q, dtype=float)
    out = {f"{GROUND}.{name}": np.broadcast_to(np.asarray(p, dtype=float), q.shape[:-1] + (2,))
           for name, p in scene.ground.items()}
    for k, body in enumerate(scene.bodies.values()):
        x, y, th = q[..., 3 * k], q[..., 3 * k + 1], q[..., 3 * k + 2]
        c, s = np.cos(th), np.sin(th)
        for name, (sx, sy) in body.points.items():
            out[f"{body.name}.{name}"] = np.stack([x + c * sx - s * sy, y + s * sx + c * sy],
                                                  axis=-1)
    return out


def _order(body) -> list[str]:
    """Point names of a body in angular order about their centroid (a simple polygon)."""
    names = list(body.points)
    if len(names) < 3:
        return names
    pts = np.array([body.points[n] for n in names])
    c = pts.mean(axis=0)
    ang = np.arctan2(pts[:, 1] - c[1], pts[:, 0] - c[0])
    return [names[i] for i in np.argsort(ang)]


class _Painter:
    """The artists of one drawn mechanism, updated in place for each frame."""

    def __init__(self, ax, scene: Scene, q: np.ndarray, *, ghost: bool = False,
                 labels: bool = True, extent: float = 1.0, travel: np.ndarray | None = None):
        from matplotlib.patches import Polygon

        self.scene = scene
        self.ax = ax
        self.order = {name: _order(b) for name, b in scene.bodies.items()}
        self.block = 0.035 * extent  # slider block half-size (m)
        pos = point_positions(scene, q)
        self.bodies = {}
        for k, (name, body) in enumerate(scene.bodies.items()):
            color = "0.6" if ghost else _BODY_COLORS[k % len(_BODY_COLORS)]
            xy = self._outline(name, body, pos, q)
            if len(body.points) >= 3 or len(body.points) == 1:
                patch = Polygon(xy * MM, closed=True, facecolor=color,
                                alpha=0.15 if ghost else 0.35, edgecolor=color,
                                lw=1.0 if ghost else 2.0, ls="--" if ghost else "-",
                                zorder=1 if ghost else 2)
                ax.add_patch(patch)
            else:
                (patch,) = ax.plot(*(xy * MM).T, color=color, lw=2 if ghost else 4,
                                   ls="--" if ghost else "-", alpha=0.5 if ghost else 0.9,
                                   solid_capstyle="round", zorder=1 if ghost else 2)
            self.bodies[name] = patch
        # slots: the lines of translational and pin-in-slot joints on moving bodies, over
        # the point's travel along them in ``travel`` (configurations, default q alone)
        self.slots = {}
        colors = {name: ("0.6" if ghost else _BODY_COLORS[k % len(_BODY_COLORS)])
                  for k, name in enumerate(scene.bodies)}
        for joint in scene.joints.values():
            if joint.type in ("translational", "pin-in-slot") and joint.points[1].body != GROUND:
                span = _slot_span(scene, joint, np.atleast_2d(q if travel is None else travel),
                                  0.1 * extent)
                patch = Polygon(np.zeros((4, 2)), closed=True, fill=False,
                                edgecolor=colors[joint.points[1].body], lw=1.0 if ghost else 1.5,
                                ls="--" if ghost else "-", zorder=1 if ghost else 3)
                ax.add_patch(patch)
                self.slots[joint.name] = (joint, span, 0.012 * extent, patch)
        self.joints = {}
        if ghost:
            self.update(q)
            return
        for joint in scene.joints.values():
            if joint.type not in ("revolute", "pin-in-slot"):
                continue
            where = str(joint.points[0])
            if joint.is_clearance:
                (m,) = ax.plot([], [], "o", ms=9, mfc="white", mec="tab:red", mew=2, zorder=5)
            else:
                (m,) = ax.plot([], [], "o", ms=5, mfc="white", mec="k", mew=1.2, zorder=5)
            self.joints[joint.name] = (where, m)
        self.labels = []
        if labels:
            for name in scene.bodies:
                self.labels.append((name, ax.text(0, 0, name, fontsize=8, ha="center",
                                                  va="center", zorder=4,
                                                  bbox={"boxstyle": "round,pad=0.15",
                                                        "fc": "white", "ec": "none",
                                                        "alpha": 0.7})))
        self.joint_labels = []
        if labels:
            # joints at one place (two rods pinned to one plate vertex) share one label
            at: dict[str, list] = {}
            first_q = point_positions(scene, q)
            for joint in scene.joints.values():
                if joint.type != "fixed-angle":  # at its (first) point: pin, sliding point
                    p = first_q[str(joint.points[0])]
                    key = f"{p[0]:.6f},{p[1]:.6f}"
                    at.setdefault(key, [str(joint.points[0]), [], False])
                    at[key][1].append(joint.name)
                    at[key][2] |= joint.is_clearance
            for where, names, clearance in at.values():
                self.joint_labels.append((where, ax.text(
                    0, 0, "/".join(names), fontsize=7, color="tab:red" if clearance else "0.2",
                    ha="left", va="bottom", zorder=6)))
        self.update(q)

    def _outline(self, name, body, pos, q):
        pts = np.array([pos[f"{name}.{p}"] for p in self.order[name]])
        if len(pts) == 1:  # a block around the point, turned with the body
            k = list(self.scene.bodies).index(name)
            th = q[3 * k + 2]
            c, s = math.cos(th), math.sin(th)
            h = self.block
            corners = np.array([[-1.6, -1.0], [1.6, -1.0], [1.6, 1.0], [-1.6, 1.0]]) * h
            rot = np.array([[c, -s], [s, c]])
            return pts[0] + corners @ rot.T
        return pts

    def update(self, q):
        pos = point_positions(self.scene, q)
        for name, body in self.scene.bodies.items():
            xy = self._outline(name, body, pos, q) * MM
            artist = self.bodies[name]
            if hasattr(artist, "set_xy"):
                artist.set_xy(xy)
            else:
                artist.set_data(xy[:, 0], xy[:, 1])
        for joint, span, half, patch in self.slots.values():
            patch.set_xy(_slot_outline(self.scene, joint, q, span, half) * MM)
        for where, m in self.joints.values():
            m.set_data([pos[where][0] * MM], [pos[where][1] * MM])
        for name, text in getattr(self, "labels", []):
            pts = np.array([pos[f"{name}.{p}"] for p in self.scene.bodies[name].points])
            c = pts.mean(axis=0) * MM
            text.set_position((c[0], c[1]))
        off = 0.35 * self.block * MM
        for where, text in getattr(self, "joint_labels", []):
            text.set_position((pos[where][0] * MM + off, pos[where][1] * MM + off))
        return [*self.bodies.values(), *(m for _, m in self.joints.values()),
                *(patch for *_, patch in self.slots.values())]


def _line_frame(scene: Scene, joint, q: np.ndarray):
    """World position (m) of the line's point ``points[1]`` and the line's unit direction, of a
    translational or pin-in-slot joint, at the configurations ``q`` (rows)."""
    from ..mechanics.system import _line_direction

    ref = joint.points[1]
    q = np.atleast_2d(q)
    origin = point_positions(scene, q)[str(ref)]
    u = _line_direction(scene, joint)
    if ref.body == GROUND:
        return origin, np.broadcast_to(u, origin.shape)
    th = q[:, 3 * list(scene.bodies).index(ref.body) + 2]
    c, s = np.cos(th), np.sin(th)
    return origin, np.stack([c * u[0] - s * u[1], s * u[0] + c * u[1]], axis=-1)


def _slot_span(scene: Scene, joint, Q: np.ndarray, margin: float) -> tuple[float, float]:
    """The stretch (m, along the line from its point ``points[1]``) a slot is drawn over: the
    line body's own points and the sliding point at every configuration in ``Q``, plus
    ``margin`` at each end."""
    origin, u = _line_frame(scene, joint, Q)
    pos = point_positions(scene, Q)
    body = joint.points[1].body
    points = [str(joint.points[0])] + [f"{body}.{name}" for name in scene.bodies[body].points]
    along = np.concatenate([np.einsum("ij,ij->i", pos[p] - origin, u) for p in points])
    return float(along.min()) - margin, float(along.max()) + margin


def _slot_outline(scene: Scene, joint, q: np.ndarray, span, half: float) -> np.ndarray:
    """The slot's rectangle (4 × 2, m) at the configuration ``q``: ``span`` along the line,
    ``half`` to either side."""
    origin, u = _line_frame(scene, joint, q)
    o, u = origin[0], u[0]
    n = np.array([-u[1], u[0]]) * half
    a, b = o + span[0] * u, o + span[1] * u
    return np.array([a - n, b - n, b + n, a + n])


def _ground_and_guides(ax, scene: Scene, pos: dict, extent: float, span=None):
    """Hatched ground symbols at the ground points of joints, and the ground lines of
    translational and pin-in-slot joints (guides)."""
    from matplotlib.patches import Polygon

    size = 0.02 * extent
    used = {str(p) for j in scene.joints.values() if j.type in ("revolute", "pin-in-slot")
            for p in j.points[:2 if j.type == "revolute" else 1] if p.body == GROUND}
    for joint in scene.joints.values():
        if joint.type not in ("translational", "pin-in-slot") \
                or joint.points[1].body != GROUND:
            continue
        g = np.asarray(scene.ground[joint.points[1].point], dtype=float)
        d = np.asarray(joint.direction, dtype=float)
        d = d / np.hypot(*d)
        s = np.asarray(pos[str(joint.points[0])], dtype=float).reshape(-1, 2)
        along = (s - g) @ d
        lo, hi = (along.min(), along.max()) if span is None else span(along)
        margin = 0.15 * extent
        a, b = g + (lo - margin) * d, g + (hi + margin) * d
        ax.plot([a[0] * MM, b[0] * MM], [a[1] * MM, b[1] * MM], color="0.3", lw=1, ls="-.",
                zorder=0)
    for where in sorted(used):
        x, y = scene.ground[where.split(".", 1)[1]]
        tri = np.array([[x, y], [x - size, y - 1.4 * size], [x + size, y - 1.4 * size]])
        ax.add_patch(Polygon(tri * MM, closed=True, fc="0.85", ec="0.3", lw=1, zorder=0))
        base = y - 1.4 * size
        ax.plot([(x - 1.4 * size) * MM, (x + 1.4 * size) * MM], [base * MM, base * MM],
                color="0.3", lw=1, zorder=0)
        for k in range(6):
            x0 = x - 1.4 * size + k * 2.8 * size / 5
            ax.plot([x0 * MM, (x0 - 0.5 * size) * MM], [base * MM, (base - 0.5 * size) * MM],
                    color="0.3", lw=0.8, zorder=0)


def _extent(pos: dict) -> float:
    pts = np.concatenate([np.asarray(v).reshape(-1, 2) for v in pos.values()])
    span = pts.max(axis=0) - pts.min(axis=0)
    return float(max(span.max(), 1e-3))


def draw_scene(scene: Scene, *, t: float = 0.0, ax=None, labels: bool = True):
    """Draw the scene assembled at time ``t``.

    Parameters
    ----------
    scene : Scene
        A loaded scene (:func:`mechrel.scene.load_scene`).
    t : float, default 0.0
        Time (s) at which the drivers place the mechanism.
    ax : matplotlib.axes.Axes, optional
        Where to draw; a new figure is made when omitted.
    labels : bool, default True
        Write the body and joint names.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    mechrel.errors.AssemblyError
        The mechanism cannot be assembled at ``t``.

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> fig = draw_scene(load_scene("nine-bar"))
    >>> fig.axes[0].get_xlabel()
    'x (mm)'
    """
    import matplotlib.pyplot as plt

    q = assembled_configuration(scene, t)
    if ax is None:
        fig, ax = plt.subplots(figsize=(7, 6), layout="constrained")
    else:
        fig = ax.figure
    pos = point_positions(scene, q)
    extent = _extent(pos)
    _ground_and_guides(ax, scene, pos, extent)
    _Painter(ax, scene, q, labels=labels, extent=extent)
    _finish_axes(ax, pos, extent)
    n_cl = sum(j.is_clearance for j in scene.joints.values())
    ax.set_title(f"{scene.name} at t = {t:g} s: {len(scene.bodies)} bodies, "
                 f"{len(scene.joints)} joints ({n_cl} with clearance, red)", fontsize=9)
    return fig


def _finish_axes(ax, pos, extent, pad=0.12):
    pts = np.concatenate([np.asarray(v).reshape(-1, 2) for v in pos.values()])
    lo, hi = pts.min(axis=0) - pad * extent, pts.max(axis=0) + pad * extent
    short = (hi - lo) < 0.4 * extent  # a flat configuration (e.g. a slider-crank at 0°)
    mid = (hi + lo) / 2
    lo = np.where(short, mid - 0.2 * extent, lo)
    hi = np.where(short, mid + 0.2 * extent, hi)
    ax.set_xlim(lo[0] * MM, hi[0] * MM)
    ax.set_ylim(lo[1] * MM, hi[1] * MM)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.grid(alpha=0.2)


def _ideal_coordinates(result) -> np.ndarray | None:
    """Coordinates of the ideal counterpart at the result's instants (driven scenes)."""
    from ..mechanics.kinematics import assemble_positions, kinematic_analysis
    from ..mechanics.system import compile_scene

    scene = result.scene
    compiled = compile_scene(scene)
    if compiled.ideal.n_constraints != compiled.q_guess.size:
        return None  # not fully driven: its ideal counterpart is itself a dynamic simulation
    tol = scene.solver.assembly_tolerance
    q0 = assemble_positions(compiled.ideal, compiled.q_guess, 0.0, tol=tol)
    Q, _, _, _ = kinematic_analysis(compiled.ideal, q0, result.time, tol=tol)
    return Q


def animate(result, *, output: str | None = None, quantity: str | None = None,
            frames: int = 120, magnify: float | None = None, interval: float = 50.0):
    """Animate a simulation: mechanism, ideal ghost, magnified orbits, output error.

    Parameters
    ----------
    result : mechrel.simulation.SimulationResult
        From :func:`mechrel.simulation.simulate`.
    output : str, optional
        Output whose error is traced (default: the scene's first output).
    quantity : str, optional
        Which error of ``output``: one of its kind's quantities
        (:data:`mechrel.outputs.OUTPUT_KINDS`; a point's ``displacement``, a body's
        ``angle``, ...). Default: the kind's first.
    frames : int, default 120
        Number of frames, spread evenly over the result's instants.
    magnify : float, optional
        Scale of the orbit drawings: the clearance circle (radius c) is drawn with radius
        ``magnify · c``. Default: a circle of 8 % of the mechanism's size.
    interval : float, default 50
        Milliseconds between frames.

    Returns
    -------
    matplotlib.animation.FuncAnimation

    Raises
    ------
    mechrel.errors.MechrelError
        An unknown output or quantity, fewer than 2 frames, or a ``magnify`` that draws a
        clearance circle wider than the mechanism.

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> from mechrel.simulation import simulate
    >>> anim = animate(simulate(load_scene("slider-crank")), frames=2)
    >>> type(anim).__name__, anim.to_jshtml().count("<script") > 0
    ('FuncAnimation', True)
    """
    import matplotlib.pyplot as plt
    from matplotlib.animation import FuncAnimation

    from ..outputs import display

    scene = result.scene
    output, quantity = animation_output(scene, output, quantity)
    if not (isinstance(frames, int) and frames >= 2):
        raise MechrelError(f"animate: frames = {frames!r}: too few; allowed: an integer >= 2")
    n = result.time.size
    idx = np.unique(np.linspace(0, n - 1, min(frames, n)).round().astype(int))
    Q = result.q
    Qi = _ideal_coordinates(result) if result.ideal is not None else None

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 5.2), layout="constrained",
                                  gridspec_kw={"width_ratios": [1.25, 1]})
    pos_all = point_positions(scene, Q)
    extent = _extent(pos_all)
    widest = max((scene.joints[name].clearance for name in result.orbits), default=0.0)
    if magnify is not None and magnify * widest > extent:
        plt.close(fig)
        raise MechrelError(
            f"animate: magnify = {magnify:g}: the clearance circle of radius {widest:g} m would "
            f"be drawn with a radius of {magnify * widest:.3g} m, more than the mechanism's "
            f"size ({extent:.3g} m), and the drawing collapses; allowed: magnify <= "
            f"{extent / widest:.4g} for this scene")
    _ground_and_guides(ax, scene, pos_all, extent)
    ghost = (_Painter(ax, scene, Qi[idx[0]], ghost=True, extent=extent, travel=Qi)
             if Qi is not None else None)
    # no name labels: they would hide the magnified orbits (mechrel draw shows the names)
    painter = _Painter(ax, scene, Q[idx[0]], extent=extent, labels=False, travel=Q)
    _finish_axes(ax, pos_all, extent, pad=0.2)

    # orbits: the clearance circle magnified to radius R on the drawing, at the bearing
    orbit_art, mags = [], []
    for name, orb in result.orbits.items():
        joint = scene.joints[name]
        c = joint.clearance
        R = (magnify * c) if magnify is not None else 0.08 * extent
        mags.append((name, f"×{R / c:.0f}"))
        theta = np.linspace(0, 2 * np.pi, 100)
        (circle,) = ax.plot([], [], color="tab:red", lw=1, zorder=7)
        (trace,) = ax.plot([], [], color="tab:red", lw=1.2, zorder=7)
        (dot,) = ax.plot([], [], "o", color="darkred", ms=4, zorder=8)
        orbit_art.append((str(joint.points[0]), orb["ex"] * R / c, orb["ey"] * R / c, R, theta,
                          circle, trace, dot))
    if orbit_art:
        # one factor for all joints, or each joint's own (their clearances differ)
        factors = {m for _, m in mags}
        which = (factors.pop() if len(factors) == 1 else
                 ", ".join(f"{m} ({name})" for name, m in mags))
        ax.plot([], [], color="tab:red", lw=1,
                label=f"journal orbits, clearance circle magnified {which}")
    if ghost is not None:
        ax.plot([], [], color="0.6", ls="--", lw=1.5, label="ideal mechanism (ghost)")
    if orbit_art or ghost is not None:
        ax.legend(fontsize=8, loc="upper left")

    unit, scale = display(quantity)
    x = result.crank_angle if result.crank_angle is not None else result.time
    xlabel = "crank angle (°)" if result.crank_angle is not None else "time (s)"
    if result.ideal is not None:
        y = result.error(output, quantity) * scale
        ylabel = f"{output} {quantity} error" + (f" ({unit})" if unit else "")
    else:
        y = result.outputs[output][quantity] * scale
        ylabel = f"{output} {quantity}" + (f" ({unit})" if unit else "")
    ax2.plot(x, y, color="0.8", lw=1)
    (line,) = ax2.plot([], [], color="tab:blue", lw=1.5)
    (mark,) = ax2.plot([], [], "o", color="tab:blue", ms=5)
    ax2.set_xlabel(xlabel)
    ax2.set_ylabel(ylabel)
    ax2.grid(alpha=0.3)
    title = ax.set_title("", fontsize=9)

    def frame(k):
        i = idx[k]
        artists = painter.update(Q[i])
        if ghost is not None:
            artists += ghost.update(Qi[i])
        pos = point_positions(scene, Q[i])
        for where, ex, ey, R, theta, circle, trace, dot in orbit_art:
            cx, cy = pos[where]
            circle.set_data((cx + R * np.cos(theta)) * MM, (cy + R * np.sin(theta)) * MM)
            trace.set_data((cx + ex[: i + 1]) * MM, (cy + ey[: i + 1]) * MM)
            dot.set_data([(cx + ex[i]) * MM], [(cy + ey[i]) * MM])
            artists += [circle, trace, dot]
        line.set_data(x[: i + 1], y[: i + 1])
        mark.set_data([x[i]], [y[i]])
        title.set_text(f"{scene.name}: t = {result.time[i]:.4f} s")
        return [*artists, line, mark, title]

    frame(0)
    return FuncAnimation(fig, frame, frames=len(idx), interval=interval, blit=False)


def animation_output(scene: Scene, output: str | None = None,
                     quantity: str | None = None) -> tuple[str, str]:
    """The output and quantity :func:`animate` traces, checked against the scene (before any
    simulation is run): the scene's first output and its kind's first quantity by default.

    Parameters
    ----------
    scene : Scene
        The scene to animate.
    output, quantity : str, optional
        As for :func:`animate`.

    Returns
    -------
    tuple of str
        ``(output, quantity)``.

    Raises
    ------
    mechrel.errors.MechrelError
        The scene has no such output, or the output's kind no such quantity.

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> animation_output(load_scene("four-bar"), "rocker")
    ('rocker', 'angle')
    """
    from ..outputs import quantities_of

    output = output if output is not None else next(iter(scene.outputs), None)
    if output is None or output not in scene.outputs:
        raise MechrelError(f"animate: output = {output!r}: not an output of scene "
                           f"{scene.name!r}; allowed: {', '.join(scene.outputs) or 'none'}")
    kinds = quantities_of(scene.outputs[output])
    quantity = kinds[0] if quantity is None else quantity
    if quantity not in kinds:
        raise MechrelError(f"animate: quantity = {quantity!r}: not a quantity of output "
                           f"{output!r} (kind '{scene.outputs[output].kind}'); allowed: "
                           f"{', '.join(kinds)}")
    return output, quantity


def check_animation_path(path: Any) -> Path:
    """The animation's file path, checked before any simulation is run.

    Raises
    ------
    mechrel.errors.MechrelError
        The suffix is not one of :data:`ANIMATION_FORMATS`, or MP4 is asked for and ffmpeg is
        not installed.
    """
    from matplotlib import animation

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in ANIMATION_FORMATS:
        raise MechrelError(f"animate: --out = {str(path)!r}: unknown file type "
                           f"{suffix or '(none)'!r}; allowed: {', '.join(ANIMATION_FORMATS)}")
    if suffix == ".mp4" and not animation.writers.is_available("ffmpeg"):
        raise MechrelError(f"animate: --out = {str(path)!r}: writing MP4 needs ffmpeg, which "
                           "is not installed; allowed: .gif or .html (or install ffmpeg)")
    return path


def save_animation(anim, path: Any, *, fps: int = 20) -> Path:
    """Write an animation from :func:`animate` as GIF, HTML or MP4 (by the file's suffix).

    Parameters
    ----------
    anim : matplotlib.animation.FuncAnimation
        From :func:`animate`.
    path : str or pathlib.Path
        Ends in ``.gif`` (Pillow), ``.html`` (a self-contained page with playback controls,
        matplotlib's ``to_jshtml``) or ``.mp4`` (ffmpeg).
    fps : int, default 20
        Frames per second, 1 to 100.

    Returns
    -------
    pathlib.Path
        The written file.

    Raises
    ------
    mechrel.errors.MechrelError
        See :func:`check_animation_path`; ``fps`` outside 1 to 100; or the file cannot be
        written (:class:`~mechrel.errors.OutputError`: the previous file, if any, is unchanged).

    Examples
    --------
    >>> import tempfile
    >>> from mechrel.scene import load_scene
    >>> from mechrel.simulation import simulate
    >>> anim = animate(simulate(load_scene("slider-crank")), frames=2)
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = save_animation(anim, Path(folder) / "crank.html", fps=5)
    ...     print(path.suffix, path.stat().st_size > 0)
    .html True
    """
    import matplotlib.pyplot as plt
    from matplotlib import animation

    from .._checks import ARGS
    from .tables import atomic_path

    path = check_animation_path(path)
    fps = ARGS.integer("fps", fps, ge=1, le=100,
                       what="frames per second; a GIF stores each frame's duration in 1/100 s")
    path.parent.mkdir(parents=True, exist_ok=True)
    suffix = path.suffix.lower()
    try:
        # into a temporary file renamed over path when complete: an interrupt or a full disk
        # leaves no truncated file that looks valid
        with atomic_path(path) as tmp:
            if suffix == ".gif":
                anim.save(tmp, writer=animation.PillowWriter(fps=fps), dpi=80)
            elif suffix == ".mp4":
                anim.save(tmp, writer=animation.FFMpegWriter(fps=fps), dpi=100)
            else:
                anim._interval = 1000.0 / fps
                tmp.write_text(anim.to_jshtml(fps=fps, default_mode="loop"), encoding="utf-8")
    finally:
        plt.close(anim._fig)
    return path
