"""Points on bodies and the relative state of clearance joints.

Owns the planar kinematics of body-fixed points (``r = R + A(θ) s``, ``ṙ = Ṙ + B(θ) s θ̇``
with ``A`` the rotation matrix and ``B = dA/dθ``): :func:`point_state`, :func:`body_trig`
(one cosine and sine per body, shared by every point of an evaluation); the relative state of
a clearance joint (eccentricity ``e = r_S − r_B`` of the journal S in the bearing B, its rate,
the angular velocities and lever arms the force laws and their Jacobian need):
:func:`joint_state`; and the contact gaps of the contact-capable (dry, transition) joints,
``δ = |e| − c`` and ``δ̇ = n·ė``: :func:`gap_of`, :func:`n_contacts`, :func:`gaps_into`,
:func:`gaps`, which the integrators' contact-onset location reads. All ``@njit(cache=True)``;
the kernels' inner-loop forms (``joint_state``, ``gap_of``, ``body_trig``) are
``inline='always'`` and take plain values, not the System tuple.

Source: Nikravesh 1988, *Computer-Aided Analysis of Mechanical Systems*, ch. 4 (a point on a
planar body); the clearance joint's eccentricity and its use by the force laws are written out
in docs/mechanics.md ("Coordinates and bodies", "Clearance joints") and docs/forces.md.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..forces.params import P_C
from .borrow import borrowed


@njit(cache=True)
def _rot(th, sx, sy):
    """A(θ) s and B(θ) s = dA/dθ s."""
    c = math.cos(th)
    s = math.sin(th)
    return c * sx - s * sy, s * sx + c * sy, -s * sx - c * sy, c * sx - s * sy


@njit(cache=True)
def point_state(q, v, i, sx, sy):
    """Global position and velocity of the body-frame point s on body i (i = −1: ground point).

    Parameters
    ----------
    q : ndarray, shape (n,)
        Coordinates ``(x, y, θ)`` of each body (m, m, rad).
    v : ndarray, shape (n,)
        Their velocities (m/s, m/s, rad/s).
    i : int
        The body (−1: the ground, ``(sx, sy)`` then global).
    sx, sy : float
        The point in body axes (m).

    Returns
    -------
    tuple of float
        ``(x, y, ẋ, ẏ)`` (m, m/s).

    Examples
    --------
    The crank (body 0, centre at x = 0.025 m, ω = 523.6 rad/s) at 0.05 m from its centre:
    ``ẏ = ẏ_0 + ω · 0.05``.

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> x, yy, vx, vy = point_state(q, v, 0, 0.05, 0.0)
    >>> round(x, 9), round(vy, 4), round(float(v[1] + v[2] * 0.05), 4)
    (0.075, 39.2699, 39.2699)
    """
    if i < 0:
        return sx, sy, 0.0, 0.0
    th = q[3 * i + 2]
    ax, ay, bx, by = _rot(th, sx, sy)
    w = v[3 * i + 2]
    return (q[3 * i] + ax, q[3 * i + 1] + ay,
            v[3 * i] + bx * w, v[3 * i + 1] + by * w)


@njit(cache=True, inline='always')
def _point_state_trig(q, v, i, sx, sy, cs, sn):
    """:func:`point_state` with the body's cos θ, sin θ given."""
    if i < 0:
        return sx, sy, 0.0, 0.0
    ax = cs[i] * sx - sn[i] * sy
    ay = sn[i] * sx + cs[i] * sy
    w = v[3 * i + 2]
    return q[3 * i] + ax, q[3 * i + 1] + ay, v[3 * i] - ay * w, v[3 * i + 1] + ax * w


@njit(cache=True, inline='always')
def body_trig(q, cs, sn):
    """Cos θ and sin θ of every body into ``cs``, ``sn``.

    Parameters
    ----------
    q : ndarray, shape (n,)
        Coordinates (m, rad).
    cs, sn : ndarray, shape (n // 3,)
        Receive cos θ and sin θ.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> cs, sn = np.empty(3), np.empty(3)
    >>> body_trig(q, cs, sn)
    >>> cs.tolist(), sn.tolist()
    ([1.0, 1.0, 1.0], [0.0, 0.0, 0.0])
    """
    for b in range(cs.shape[0]):
        th = q[3 * b + 2]
        cs[b] = math.cos(th)
        sn[b] = math.sin(th)


@njit(cache=True, inline='always')
def joint_state(q, v, b, j, sbx, sby, sjx, sjy, cs, sn):
    """Relative state of a clearance joint between a bearing point and a journal point.

    The bearing point ``(sbx, sby)`` is on body b and the journal point ``(sjx, sjy)`` on body
    j (−1: ground, the point then global). One place for what the force assembly, the gaps,
    the fast Jacobian and the post-processing need; it takes plain values, not the System
    tuple, because it runs in the right-hand side's joint loop (a tuple attribute there costs
    a reference-count pair per joint, or its null test when the tuple is borrowed).

    Parameters
    ----------
    q : ndarray, shape (n,)
        Coordinates ``(x, y, θ)`` of each body (m, m, rad).
    v : ndarray, shape (n,)
        Their velocities (m/s, m/s, rad/s).
    b, j : int
        The bearing's and the journal's body (−1: ground).
    sbx, sby, sjx, sjy : float
        The bearing and journal points in their bodies' axes (m).
    cs, sn : ndarray, shape (nb,)
        cos θ and sin θ of every body (:func:`body_trig`).

    Returns
    -------
    tuple of float
        ``(e_x, e_y, ė_x, ė_y, ω_B, ω_S, r_jx, r_jy, r_bx, r_by)``: eccentricity
        e = r_S − r_B (m) and its rate (m/s), the angular velocities ω_B, ω_S (rad/s), and the
        lever arms r_j = A_j s_j, r_b = A_b s_b (m) from the bodies' centres (zero for the
        ground).

    Examples
    --------
    At assembly the slider-crank's lubricated joint is centred (e = 0):

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> cs, sn = np.empty(3), np.empty(3)
    >>> body_trig(q, cs, sn)
    >>> s = joint_state(q, v, dyn.cl_b[0], dyn.cl_j[0], *dyn.cl_sb[0], *dyn.cl_sj[0], cs, sn)
    >>> bool(abs(s[0]) < 1e-15), round(s[4], 4), round(float(v[5]), 4)
    (True, -218.1662, -218.1662)
    """
    bx, by, bvx, bvy = _point_state_trig(q, v, b, sbx, sby, cs, sn)
    jx, jy, jvx, jvy = _point_state_trig(q, v, j, sjx, sjy, cs, sn)
    wb = v[3 * b + 2] if b >= 0 else 0.0
    wj = v[3 * j + 2] if j >= 0 else 0.0
    rjx = jx - q[3 * j] if j >= 0 else 0.0
    rjy = jy - q[3 * j + 1] if j >= 0 else 0.0
    rbx = bx - q[3 * b] if b >= 0 else 0.0
    rby = by - q[3 * b + 1] if b >= 0 else 0.0
    return jx - bx, jy - by, jvx - bvx, jvy - bvy, wb, wj, rjx, rjy, rbx, rby


@njit(cache=True, inline='always')
def gap_of(ex, ey, evx, evy, c):
    """Penetration δ = |e| − c (m) and its rate δ̇ = n·ė (m/s) of one joint.

    At e = 0 the direction is undefined and the joint is far from contact, so δ̇ = 0 there.

    Parameters
    ----------
    ex, ey : float
        Eccentricity (m).
    evx, evy : float
        Its rate (m/s).
    c : float
        Radial clearance (m).

    Returns
    -------
    tuple of float
        ``(δ, δ̇)``.

    Examples
    --------
    |e| = 5e-5 m along (0.6, 0.8):

    >>> gap_of(3e-5, 4e-5, 1.0, 0.0, 1e-4)
    (-5e-05, 0.6)
    """
    e = math.hypot(ex, ey)
    return e - c, ((evx * ex + evy * ey) / e if e > 0.0 else 0.0)


@njit(cache=True)
def n_contacts(sys):
    """Number of contact-capable clearance joints (the length of ``hist``).

    Parameters
    ----------
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).

    Returns
    -------
    int
        The dry and transition clearance joints.

    Examples
    --------
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> n_contacts(compile_scene(load_scene("slider-crank-dry")).dynamic)
    1
    """
    nh = 0
    for k in range(sys.cl_hist.shape[0]):
        if sys.cl_hist[k] >= 0:
            nh += 1
    return nh


@njit(cache=True)
def gaps_into(t, y, sys, g, gd):
    """Penetration δ = |e| − c (m) and its rate δ̇ (m/s) of every contact-capable joint.

    Into ``g`` and ``gd`` (indexed like ``hist``); the same values the right-hand side leaves
    in ``Workspace.gap``/``gaprate``.

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray, shape (2 n + 2,)
        The state ``(q, q̇, W_in, W_cl)``: coordinates (m, rad), velocities (m/s, rad/s), input
        and clearance work (J).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).
    g, gd : ndarray, shape (nh,)
        Receive δ (m) and δ̇ (m/s).

    Examples
    --------
    The dry slider-crank's joint assembled centred: δ = −c = −0.5 mm:

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-dry"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> y = np.concatenate([q, v, np.zeros(2)])
    >>> g, gd = np.empty(1), np.empty(1)
    >>> gaps_into(0.0, y, c.dynamic, g, gd)
    >>> g.round(12).tolist(), gd.tolist()
    ([-0.0005], [0.0])
    """
    y, sys, g, gd = borrowed((y, sys, g, gd))
    n = sys.mass.shape[0]
    q = y[:n]
    v = y[n:2 * n]
    cs = np.empty(n // 3)
    sn = np.empty(n // 3)
    body_trig(q, cs, sn)
    cl_b = sys.cl_b
    cl_j = sys.cl_j
    cl_sb = sys.cl_sb
    cl_sj = sys.cl_sj
    cl_hist = sys.cl_hist
    cl_p = sys.cl_p
    for k in range(cl_hist.shape[0]):
        h = cl_hist[k]
        if h >= 0:
            ex, ey, evx, evy, _, _, _, _, _, _ = joint_state(
                q, v, cl_b[k], cl_j[k], cl_sb[k, 0], cl_sb[k, 1], cl_sj[k, 0], cl_sj[k, 1],
                cs, sn)
            g[h], gd[h] = gap_of(ex, ey, evx, evy, cl_p[k, P_C])


@njit(cache=True)
def gaps(t, y, sys):
    """:func:`gaps_into` returning fresh arrays ``(δ, δ̇)``.

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray, shape (2 n + 2,)
        The state ``(q, q̇, W_in, W_cl)``: coordinates (m, rad), velocities (m/s, rad/s), input
        and clearance work (J).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).

    Returns
    -------
    tuple of ndarray
        δ (m) and δ̇ (m/s), each of shape (nh,).

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-dry"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> y = np.concatenate([q, v, np.zeros(2)])
    >>> g, gd = gaps(0.0, y, c.dynamic)
    >>> g.round(12).tolist(), gd.tolist()
    ([-0.0005], [0.0])
    """
    nh = n_contacts(sys)
    g = np.empty(nh)
    gd = np.empty(nh)
    gaps_into(t, y, sys, g, gd)
    return g, gd
