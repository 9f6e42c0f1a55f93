"""The output kinds' evaluators: the values of a scene's outputs at the mechanism's states.

The catalogue of output kinds (names, scene fields, quantities and units) is
:data:`mechrel.outputs.OUTPUT_KINDS`, on the ground floor, where the scene's schema and
validation read it; the function that computes a kind's values needs the mechanism
(:mod:`mechrel.mechanics`, the force laws) and lives here, registered for its kind by
:func:`evaluator`: a new kind is its row in the catalogue plus one function here
(docs/scenes.md, "How to add an output kind"; ``tests/test_output_kinds.py`` checks that
every kind of the catalogue has exactly one evaluator).

Every evaluator ``f(scene, compiled, output, st, ideal, actual, counterpart)`` gets the
states :class:`States` (instants ``T``, coordinates ``Q`` (m, rad), their rates ``V`` and
accelerations ``A``, one row per instant, and the history state ``H`` of the contact joints or
None) and returns ``{quantity: array}`` in SI units, the value at each row a function of that
row's state alone (the cycle extremes take the values at the output instants from the run's
outputs and compute only those at the solution log's rows; ``tests/test_output_kinds.py``
checks every kind on a subset of rows); ``ideal`` says whether the state
is the ideal mechanism's (for kinds whose ideal value is not the same formula on the ideal
state), ``actual`` is the simulated scene (``scene`` may be a reference design) and
``counterpart`` the scene whose ideal mechanism the errors are measured against.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
from numba import njit

from ..outputs import OUTPUT_KINDS, PATH_POINTS

__all__ = ["States", "EVALUATORS", "evaluator", "values", "ideal_path", "distance_to_path"]

_EVALUATORS: dict[str, Callable] = {}
#: The evaluator of each output kind, by the kind's name (read-only view).
EVALUATORS: Mapping[str, Callable] = MappingProxyType(_EVALUATORS)


def evaluator(kind: str) -> Callable[[Callable], Callable]:
    """Register the decorated function as the evaluator of output kind ``kind``.

    Parameters
    ----------
    kind : str
        A key of :data:`mechrel.outputs.OUTPUT_KINDS` without an evaluator yet.

    Returns
    -------
    callable
        The decorator; it returns the function unchanged.

    Raises
    ------
    ValueError
        ``kind`` is not in the catalogue, or already has an evaluator.

    Examples
    --------
    >>> EVALUATORS["body"].__name__
    '_body_values'
    >>> evaluator("no-such-kind")
    Traceback (most recent call last):
    ...
    ValueError: output kind 'no-such-kind' is not in mechrel.outputs.OUTPUT_KINDS
    """
    if kind not in OUTPUT_KINDS:
        raise ValueError(f"output kind {kind!r} is not in mechrel.outputs.OUTPUT_KINDS")
    if kind in _EVALUATORS:
        raise ValueError(f"output kind {kind!r} has an evaluator already: "
                         f"{_EVALUATORS[kind].__name__}")

    def register(function: Callable) -> Callable:
        _EVALUATORS[kind] = function
        return function

    return register


@dataclass(frozen=True)
class States:
    """The mechanism's states at some instants (rows): ``T`` (s), ``Q`` (m, rad), ``V``,
    ``A``, and ``H`` the contact joints' history state (impact speeds, m/s) or None (the ideal
    mechanism has none).

    Parameters
    ----------
    T : numpy.ndarray
        Instants (s).
    Q : numpy.ndarray
        Coordinates at each instant (m, rad), one row each.
    V, A : numpy.ndarray
        Their first and second time derivatives (m/s, rad/s; m/s², rad/s²).
    H : numpy.ndarray, optional
        History state of the contact joints (impact speeds, m/s), one row per instant.

    Examples
    --------
    >>> z = np.zeros((2, 3))
    >>> States(np.array([0.0, 0.1]), z, z, z).H is None
    True
    """

    T: np.ndarray
    Q: np.ndarray
    V: np.ndarray
    A: np.ndarray
    H: np.ndarray | None = None


def _body(compiled, name):
    return compiled.body_index[name]


@evaluator("point")
def _point_values(scene, compiled, output, st, ideal, actual, counterpart):
    """A body point's position, velocity and acceleration projected on the unit ``axis``."""
    Q, V, A = st.Q, st.V, st.A
    b = _body(compiled, output.point.body)
    sx, sy = scene.bodies[output.point.body].points[output.point.point]
    ux, uy = output.axis
    th = Q[:, 3 * b + 2]
    # cos and sin by NumPy (its SIMD routines are not libm's, which compiled code would call:
    # the same bits as every earlier release); the rest in one compiled pass
    x, v, a = _point_motion(Q, V, A, b, float(sx), float(sy), float(ux), float(uy),
                            np.cos(th), np.sin(th))
    return {"displacement": x, "velocity": v, "acceleration": a}


@njit(cache=True)
def _point_motion(Q, V, A, b, sx, sy, ux, uy, c, s):
    """Position, velocity and acceleration of the point ``(sx, sy)`` of body ``b`` along the
    unit axis ``(ux, uy)``, per row, given ``c, s`` = cos and sin of the body's angle: with
    ``a = A(θ) s``, ``r + a``, ``ṙ + ω × a`` and ``r̈ + α × a − ω² a``. The operations are
    those, in the order, of the NumPy expressions the values were first computed with (no
    fused multiply–add without ``fastmath``), so the bits are theirs."""
    N = Q.shape[0]
    x = np.empty(N)
    v = np.empty(N)
    a = np.empty(N)
    i, j, k = 3 * b, 3 * b + 1, 3 * b + 2
    for r in range(N):
        ax = c[r] * sx - s[r] * sy
        ay = s[r] * sx + c[r] * sy
        w = V[r, k]
        al = A[r, k]
        x[r] = (Q[r, i] + ax) * ux + (Q[r, j] + ay) * uy
        v[r] = (V[r, i] - ay * w) * ux + (V[r, j] + ax * w) * uy
        a[r] = (A[r, i] - ay * al - ax * w * w) * ux + (A[r, j] + ax * al - ay * w * w) * uy
    return x, v, a


@evaluator("body")
def _body_values(scene, compiled, output, st, ideal, actual, counterpart):
    """A body's absolute angle, angular velocity and angular acceleration."""
    Q, V, A = st.Q, st.V, st.A
    b = _body(compiled, output.body)
    return {"angle": Q[:, 3 * b + 2], "angular_velocity": V[:, 3 * b + 2],
            "angular_acceleration": A[:, 3 * b + 2]}


def _global_point(scene, compiled, ref, Q):
    if ref.body == "ground":
        x, y = scene.ground[ref.point]
        return np.full(Q.shape[0], float(x)), np.full(Q.shape[0], float(y))
    b = _body(compiled, ref.body)
    sx, sy = scene.bodies[ref.body].points[ref.point]
    th = Q[:, 3 * b + 2]
    c, s = np.cos(th), np.sin(th)
    return Q[:, 3 * b] + c * sx - s * sy, Q[:, 3 * b + 1] + s * sx + c * sy


@evaluator("joint")
def _joint_values(scene, compiled, output, st, ideal, actual, counterpart):
    """Eccentricity ratio ε = |e|/c, minimum film thickness h_min = c (1 − ε) (rigid
    surfaces; negative while a dry journal penetrates) and penetration max(|e| − c, 0) of a
    clearance joint, e = journal point − bearing point. The ideal joint is concentric:
    ε = 0, h_min = c (the clearance of the simulated scene ``actual``), no penetration."""
    Q = st.Q
    joint = scene.joints[output.joint]
    c = joint.clearance
    if ideal:
        c = actual.joints[output.joint].clearance
        n = Q.shape[0]
        return {"eccentricity_ratio": np.zeros(n), "min_film_thickness": np.full(n, c),
                "penetration": np.zeros(n),
                "reaction_force": _multiplier_force(compiled, "ideal", output.joint, st)}
    bx, by = _global_point(scene, compiled, joint.points[0], Q)
    jx, jy = _global_point(scene, compiled, joint.points[1], Q)
    e = np.hypot(jx - bx, jy - by)
    if joint.is_clearance:
        force = _clearance_force(scene, compiled, joint, st)
    else:
        force = _multiplier_force(compiled, "dynamic", output.joint, st)
    return {"eccentricity_ratio": e / c, "min_film_thickness": c - e,
            "penetration": np.maximum(e - c, 0.0), "reaction_force": force}


def _global_velocity(scene, compiled, ref, Q, V):
    if ref.body == "ground":
        return np.zeros(Q.shape[0]), np.zeros(Q.shape[0]), np.zeros(Q.shape[0])
    b = _body(compiled, ref.body)
    sx, sy = scene.bodies[ref.body].points[ref.point]
    th, w = Q[:, 3 * b + 2], V[:, 3 * b + 2]
    c, s = np.cos(th), np.sin(th)
    ax, ay = c * sx - s * sy, s * sx + c * sy
    return V[:, 3 * b] - ay * w, V[:, 3 * b + 1] + ax * w, w


def _clearance_force(scene, compiled, joint, st):
    """|F| (N) of a clearance joint's force law (contact and friction, film, or both) at the
    states, with the impact speeds of ``st.H`` (the force law of the simulation itself)."""
    from ..forces.joint import clearance_force

    k = compiled.clearance_names.index(joint.name)
    sys = compiled.dynamic
    h = int(sys.cl_hist[k])
    p = sys.cl_p[k]
    bx, by = _global_point(scene, compiled, joint.points[0], st.Q)
    jx, jy = _global_point(scene, compiled, joint.points[1], st.Q)
    bvx, bvy, wb = _global_velocity(scene, compiled, joint.points[0], st.Q, st.V)
    jvx, jvy, wj = _global_velocity(scene, compiled, joint.points[1], st.Q, st.V)
    if h >= 0 and st.H is None:
        raise ValueError("the history state is needed for a dry joint's force")
    out = np.empty(st.Q.shape[0])
    for i in range(out.size):
        impact = float(st.H[i, h]) if h >= 0 else 0.0
        fx, fy, _, _, _ = clearance_force(jx[i] - bx[i], jy[i] - by[i], jvx[i] - bvx[i],
                                          jvy[i] - bvy[i], wb[i], wj[i], impact, p)
        out[i] = math.hypot(fx, fy)
    return out


def _multiplier_force(compiled, which, name, st):
    """|λ| (N) of the two constraint rows of revolute joint ``name`` in system ``which``
    (``"ideal"`` or ``"dynamic"``): the force the joint transmits, from the equations of
    motion at the states (for the driven ideal mechanism, its inverse dynamics)."""
    from ..mechanics.dynamics import N_WORK, accelerations_into, make_workspace

    sys = getattr(compiled, which)
    labels = compiled.labels[which]
    r0, r1 = [i for i, lbl in enumerate(labels) if lbl.startswith(f"joints.{name} (")]
    n = st.Q.shape[1]
    ws = make_workspace(sys)
    lam = ws.lam
    Y = np.zeros((st.Q.shape[0], 2 * n + N_WORK))
    Y[:, :n], Y[:, n:2 * n] = st.Q, st.V
    use_h = st.H is not None and which == "dynamic" and st.H.shape[1] > 0
    H = np.ascontiguousarray(st.H) if use_h else np.zeros((st.Q.shape[0], sys.n_contacts))
    out = np.empty(st.Q.shape[0])
    for i in range(out.size):
        accelerations_into(float(st.T[i]), Y[i], H[i], sys, ws)
        out[i] = math.hypot(lam[r0], lam[r1])
    return out


_PATHS: dict = {}


def ideal_path(counterpart, ref) -> np.ndarray:
    """The path (PATH_POINTS + 1, 2) (m) of point ``ref`` on the ideal mechanism of
    ``counterpart`` over one cycle of its cycle driver, from kinematic analysis (cached).

    Parameters
    ----------
    counterpart : Scene
        A fully driven scene with a cycle driver.
    ref : PointRef
        The point whose path is traced.

    Returns
    -------
    ndarray, shape (PATH_POINTS + 1, 2)
        Global coordinates (m), first and last rows the same point.

    Raises
    ------
    SimulationError
        A scene that is not fully driven or has no cycle driver.

    Examples
    --------
    The slider of the slider-crank moves on a straight guide: its path is a segment of
    twice the crank radius (0.05 m):

    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank")
    >>> path = ideal_path(scene, scene.outputs["slider"].point)
    >>> round(float(np.ptp(path[:, 0])), 9), round(float(np.ptp(path[:, 1])), 9)
    (0.1, 0.0)
    """
    from ..errors import SimulationError
    from ..mechanics.kinematics import assemble_positions, kinematic_analysis
    from ..mechanics.system import compile_scene
    from ..scene import scene_hash

    key = (scene_hash(counterpart), str(ref))
    if key in _PATHS:
        return _PATHS[key]
    compiled = compile_scene(counterpart)
    if compiled.period is None or compiled.ideal.n_constraints != compiled.q_guess.size:
        raise SimulationError(f"a path output ({ref}) needs a fully driven mechanism with "
                              "analysis.cycle_driver (its ideal path is one cycle of it); "
                              "allowed: kind = 'point' on other scenes")
    tol = counterpart.solver.assembly_tolerance
    q0 = assemble_positions(compiled.ideal, compiled.q_guess, 0.0, tol=tol,
                            labels=compiled.labels["ideal"])
    T = np.linspace(0.0, compiled.period, PATH_POINTS + 1)
    Q, _, _, _ = kinematic_analysis(compiled.ideal, q0, T, tol=tol,
                                    labels=compiled.labels["ideal"])
    x, y = _global_point(counterpart, compiled, ref, Q)
    if len(_PATHS) > 16:
        _PATHS.clear()
    _PATHS[key] = np.column_stack([x, y])
    return _PATHS[key]


def distance_to_path(px, py, path) -> np.ndarray:
    """Distance (m) of the points (px, py) from the polyline ``path``: the smallest distance
    to the segments next to the 8 nearest vertices (the nearest point of a finely sampled
    smooth curve lies on one of them).

    Parameters
    ----------
    px, py : array_like
        Coordinates of the points (m).
    path : ndarray, shape (m, 2)
        The polyline's vertices (m), m >= 2.

    Returns
    -------
    ndarray
        One distance (m) per point.

    Examples
    --------
    >>> path = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    >>> distance_to_path(np.array([0.5, 2.5]), np.array([0.3, 0.0]), path).tolist()
    [0.3, 0.5]
    """
    from scipy.spatial import cKDTree

    P = np.column_stack([px, py])
    m = path.shape[0]
    _, idx = cKDTree(path).query(P, k=min(8, m))
    idx = np.atleast_2d(idx.T).T
    best = np.full(P.shape[0], np.inf)
    for col in range(idx.shape[1]):
        for shift in (-1, 0):
            i0 = np.clip(idx[:, col] + shift, 0, m - 2)
            a, b = path[i0], path[i0 + 1]
            ab = b - a
            den = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
            t = np.clip(np.einsum("ij,ij->i", P - a, ab) / den, 0.0, 1.0)
            d = np.hypot(*(P - a - t[:, None] * ab).T)
            best = np.minimum(best, d)
    return best


@evaluator("path")
def _path_values(scene, compiled, output, st, ideal, actual, counterpart):
    """The distance of a point from the ideal mechanism's path of the same point (the coupler
    curve), not from the same-time ideal point: a timing difference along the path is no
    deviation. The ideal point is on its path: 0."""
    Q = st.Q
    if ideal:
        return {"path_deviation": np.zeros(Q.shape[0])}
    px, py = _global_point(scene, compiled, output.point, Q)
    return {"path_deviation": distance_to_path(px, py, ideal_path(counterpart, output.point))}


def values(scene, compiled, T, Q, V, A, *, H=None, ideal: bool = False, actual=None,
           counterpart=None) -> dict:
    """``{output: {quantity: array}}`` of every output of ``scene`` at the states (rows of
    ``Q``, ``V``, ``A``); ``actual``: the simulated scene when ``scene`` is a reference
    design, ``counterpart``: the scene whose ideal mechanism is the reference (both default
    ``scene``).

    Parameters
    ----------
    scene : Scene
        Whose outputs are computed.
    compiled : CompiledScene
        ``scene`` compiled.
    T : ndarray
        Instants (s).
    Q, V, A : ndarray, shape (len(T), n)
        Coordinates (m, rad) and their derivatives.
    H : ndarray, optional
        The contact joints' history state (impact speeds, m/s).
    ideal : bool
        The states are of the ideal mechanism.
    actual, counterpart : Scene, optional
        See above.

    Returns
    -------
    dict
        ``{output: {quantity: ndarray}}`` in SI units.

    Examples
    --------
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> from mechrel.simulation import simulate
    >>> scene = load_scene("slider-crank")
    >>> r = simulate(scene)
    >>> out = values(scene, compile_scene(scene), r.time, r.q, r.v, r.a, ideal=True)
    >>> bool(np.array_equal(out["slider"]["displacement"], r.outputs["slider"]["displacement"]))
    True
    """
    actual = scene if actual is None else actual
    counterpart = scene if counterpart is None else counterpart
    st = States(np.asarray(T, dtype=float), Q, V, A, H)
    return {name: EVALUATORS[o.kind](scene, compiled, o, st, ideal, actual, counterpart)
            for name, o in scene.outputs.items()}
