"""The compiled problem: constraints, their Jacobian and γ terms, the forward-dynamics
right-hand side, contact gaps and energy.

Every function is ``@njit(cache=True)`` and reads the scene only through a
:class:`~mechrel.mechanics.system.System`. The integrator kernels in :mod:`mechrel.integrate`
call these functions by module-global reference (see docs/architecture.md for why).

Formulation (Nikravesh 1988, *Computer-Aided Analysis of Mechanical Systems*, ch. 6 and 13;
Baumgarte 1972): with ``q`` the absolute coordinates, ``Φ(q, t) = 0`` the constraints,

    [ M    Φ_qᵀ ] [ q̈ ]   [ Q                        ]
    [ Φ_q  0    ] [ λ  ] = [ γ − 2α Φ̇ − β² Φ          ]     (paper eq. 24, corrected)

with ``γ = −(Φ_q q̇)_q q̇ − 2 Φ_qt q̇ − Φ_tt`` and ``Φ̇ = Φ_q q̇ + Φ_t``. ``M`` is diagonal, so the
system is solved through the Schur complement ``S = Φ_q M⁻¹ Φ_qᵀ`` (m × m, symmetric positive
definite while the constraints are independent):
``S λ = Φ_q M⁻¹ Q − c``, ``q̈ = M⁻¹ (Q − Φ_qᵀ λ)``.

State vector ``y = [q (n), q̇ (n), W_in, W_cl]``: the last two entries integrate the power of the
drivers (input work, J) and of the clearance-joint forces (J), for energy balances.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from ..forces.joint import clearance_force
from ..forces.params import P_C
from .borrow import borrowed
from .system import (D_ACCEL, D_AMPLITUDE, D_ANGLE0, D_FREQUENCY, D_PHASE, D_RAMP, D_SPEED,
                     LAW_CONSTANT_ACCELERATION, LAW_CONSTANT_SPEED, LAW_HARMONIC)

N_WORK = 2  # extra states: driver work, clearance-force work


@njit(cache=True)
def driver_law(law, par, t):
    """Angle (rad), angular velocity (rad/s) and angular acceleration (rad/s²) of a driver.

    Parameters
    ----------
    law : int
        The driver law code (``System.dr_law``: constant speed, constant acceleration, harmonic).
    par : ndarray
        Its parameters (a row of ``System.dr_par``: rad, rad/s, rad/s², Hz, s).
    t : float
        Time (s).

    Returns
    -------
    tuple of float
        ``(θ, θ̇, θ̈)`` at ``t``.

    Examples
    --------
    The slider-crank's crank turns at a constant 5000 rpm = 523.599 rad/s:

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> th, om, al = driver_law(dyn.dr_law[0], dyn.dr_par[0], 0.1)
    >>> round(th, 4), round(om, 4), al
    (52.3599, 523.5988, 0.0)
    """
    th0 = par[D_ANGLE0]
    w = par[D_SPEED]
    if law == LAW_CONSTANT_SPEED:
        return th0 + w * t, w, 0.0
    if law == LAW_CONSTANT_ACCELERATION:
        a = par[D_ACCEL]
        return th0 + w * t + 0.5 * a * t * t, w + a * t, a
    if law == LAW_HARMONIC:
        amp = par[D_AMPLITUDE]
        om = par[D_FREQUENCY]
        ph = om * t + par[D_PHASE]
        return th0 + amp * math.sin(ph), amp * om * math.cos(ph), -amp * om * om * math.sin(ph)
    # smooth start: the speed follows w * s(t/T), s the quintic smoothstep 10τ³ − 15τ⁴ + 6τ⁵,
    # so the acceleration is zero at both ends of the ramp.
    T = par[D_RAMP]
    if t >= T:
        return th0 + w * (t - 0.5 * T), w, 0.0
    tau = t / T
    t2 = tau * tau
    t3 = t2 * tau
    S = t2 * t2 * (2.5 - 3.0 * tau + t2)  # ∫ s dτ
    s = t3 * (10.0 - 15.0 * tau + 6.0 * t2)
    ds = 30.0 * t2 * (1.0 - 2.0 * tau + t2)
    return th0 + w * T * S, w * s, w * ds / T


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


@njit(cache=True)
def n_constraints(sys):
    """Number of constraint equations m of ``sys``.

    Parameters
    ----------
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).

    Returns
    -------
    int
        2 per revolute and translational joint, 1 per fixed angle and driver.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> n_constraints(dyn), c.ideal.n_constraints
    (7, 9)
    """
    return (2 * sys.rev_i.shape[0] + 2 * sys.tr_i.shape[0] + sys.fa_i.shape[0]
            + sys.dr_i.shape[0])


@njit(cache=True)
def constraints(q, t, sys):
    """Φ(q, t) (m, rad), Φ_t (m/s, rad/s) and the Jacobian Φ_q.

    Parameters
    ----------
    q : ndarray, shape (n,)
        Coordinates (m, rad).
    t : float
        Time (s).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).

    Returns
    -------
    tuple of ndarray
        ``(Φ, Φ_t, Φ_q)`` of shapes (m,), (m,), (m, n).

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> phi, phi_t, jac = constraints(q, 0.0, dyn)
    >>> float(np.abs(phi).max()), jac.shape
    (0.0, (7, 9))
    """
    m = n_constraints(sys)
    n = q.shape[0]
    phi = np.zeros(m)
    phit = np.zeros(m)
    J = np.zeros((m, n))
    r = 0
    for k in range(sys.rev_i.shape[0]):
        i = sys.rev_i[k]
        j = sys.rev_j[k]
        th = q[3 * i + 2]
        axi, ayi, bxi, byi = _rot(th, sys.rev_si[k, 0], sys.rev_si[k, 1])
        phi[r] = q[3 * i] + axi - sys.rev_off[k, 0]
        phi[r + 1] = q[3 * i + 1] + ayi - sys.rev_off[k, 1]
        phit[r] = -sys.rev_offdot[k, 0]
        phit[r + 1] = -sys.rev_offdot[k, 1]
        J[r, 3 * i] = 1.0
        J[r + 1, 3 * i + 1] = 1.0
        J[r, 3 * i + 2] = bxi
        J[r + 1, 3 * i + 2] = byi
        if j < 0:
            phi[r] -= sys.rev_sj[k, 0]
            phi[r + 1] -= sys.rev_sj[k, 1]
        else:
            axj, ayj, bxj, byj = _rot(q[3 * j + 2], sys.rev_sj[k, 0], sys.rev_sj[k, 1])
            phi[r] -= q[3 * j] + axj
            phi[r + 1] -= q[3 * j + 1] + ayj
            J[r, 3 * j] = -1.0
            J[r + 1, 3 * j + 1] = -1.0
            J[r, 3 * j + 2] = -bxj
            J[r + 1, 3 * j + 2] = -byj
        r += 2
    for k in range(sys.tr_i.shape[0]):
        i = sys.tr_i[k]
        nx = sys.tr_n[k, 0]
        ny = sys.tr_n[k, 1]
        ax, ay, bx, by = _rot(q[3 * i + 2], sys.tr_si[k, 0], sys.tr_si[k, 1])
        phi[r] = nx * (q[3 * i] + ax - sys.tr_p0[k, 0]) + ny * (q[3 * i + 1] + ay - sys.tr_p0[k, 1])
        J[r, 3 * i] = nx
        J[r, 3 * i + 1] = ny
        J[r, 3 * i + 2] = nx * bx + ny * by
        phi[r + 1] = q[3 * i + 2] - sys.tr_angle[k]
        J[r + 1, 3 * i + 2] = 1.0
        r += 2
    for k in range(sys.fa_i.shape[0]):
        i = sys.fa_i[k]
        phi[r] = q[3 * i + 2] - sys.fa_angle[k]
        J[r, 3 * i + 2] = 1.0
        r += 1
    for k in range(sys.dr_i.shape[0]):
        i = sys.dr_i[k]
        th, w, _ = driver_law(sys.dr_law[k], sys.dr_par[k], t)
        phi[r] = q[3 * i + 2] - th
        phit[r] = -w
        J[r, 3 * i + 2] = 1.0
        r += 1
    return phi, phit, J


@njit(cache=True)
def gamma(q, v, t, sys):
    """γ = −(Φ_q q̇)_q q̇ − 2Φ_qt q̇ − Φ_tt, the right-hand side of Φ_q q̈ = γ (m/s², rad/s²).

    Parameters
    ----------
    q : ndarray, shape (n,)
        Coordinates ``(x, y, θ)`` of each body (m, m, rad).
    v : ndarray, shape (n,)
        Their velocities (m/s, m/s, rad/s).
    t : float
        Time (s).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).

    Returns
    -------
    ndarray, shape (m,)
        γ.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> gamma(q, v, 0.0, dyn).shape
    (7,)
    """
    m = n_constraints(sys)
    g = np.zeros(m)
    r = 0
    for k in range(sys.rev_i.shape[0]):
        i = sys.rev_i[k]
        j = sys.rev_j[k]
        ax, ay, _, _ = _rot(q[3 * i + 2], sys.rev_si[k, 0], sys.rev_si[k, 1])
        w2 = v[3 * i + 2] ** 2
        g[r] = ax * w2
        g[r + 1] = ay * w2
        if j >= 0:
            ax, ay, _, _ = _rot(q[3 * j + 2], sys.rev_sj[k, 0], sys.rev_sj[k, 1])
            w2 = v[3 * j + 2] ** 2
            g[r] -= ax * w2
            g[r + 1] -= ay * w2
        r += 2
    for k in range(sys.tr_i.shape[0]):
        i = sys.tr_i[k]
        ax, ay, _, _ = _rot(q[3 * i + 2], sys.tr_si[k, 0], sys.tr_si[k, 1])
        g[r] = (sys.tr_n[k, 0] * ax + sys.tr_n[k, 1] * ay) * v[3 * i + 2] ** 2
        r += 2
    r += sys.fa_i.shape[0]
    for k in range(sys.dr_i.shape[0]):
        _, _, acc = driver_law(sys.dr_law[k], sys.dr_par[k], t)
        g[r] = acc
        r += 1
    return g


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


@njit(cache=True, inline='always')
def applied_forces_trig(t, q, v, hist, sys, Q, cs, sn, gap, gaprate):
    """Add gravity and clearance-joint forces to Q (N, N·m).

    The penetration δ = |e| − c (m) and its rate (m/s) of the contact-capable joints go to
    ``gap`` and ``gaprate`` (as :func:`gaps_into` computes them), so that a kernel that
    evaluates the right-hand side at a step's end has the gaps for its onset check.

    Parameters
    ----------
    t : float
        Time (s).
    q : ndarray, shape (n,)
        Coordinates ``(x, y, θ)`` of each body (m, m, rad).
    v : ndarray, shape (n,)
        Their velocities (m/s, m/s, rad/s).
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (impact speed, m/s; :func:`n_contacts`).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).
    Q : ndarray, shape (n,)
        Generalised forces (N, N, N·m), added to.
    cs, sn : ndarray, shape (nb,)
        cos θ and sin θ of every body (:func:`body_trig`).
    gap, gaprate : ndarray, shape (nh,)
        Receive the penetration δ (m) and its rate (m/s) of the contact-capable joints.

    Returns
    -------
    tuple of float
        ``(clearance power (W), elastic contact energy (J))``.

    Examples
    --------
    At the centred start the film carries nothing: Q is gravity, ``−m g`` on each body:

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> cs, sn = np.empty(3), np.empty(3)
    >>> body_trig(q, cs, sn)
    >>> Q = np.zeros(9)
    >>> p, e = applied_forces_trig(0.0, q, v, np.zeros(0), dyn, Q, cs, sn, np.empty(0),
    ...                            np.empty(0))
    >>> round(float(Q[1]), 6), round(-0.3 * 9.81, 6)
    (-2.943, -2.943)
    """
    nb = q.shape[0] // 3
    cl_b = sys.cl_b
    cl_hist = sys.cl_hist
    cl_j = sys.cl_j
    cl_p = sys.cl_p
    cl_sb = sys.cl_sb
    cl_sj = sys.cl_sj
    gravity = sys.gravity
    mass = sys.mass
    for b in range(nb):
        Q[3 * b] += mass[3 * b] * gravity[0]
        Q[3 * b + 1] += mass[3 * b] * gravity[1]
    power = 0.0
    elastic = 0.0
    for k in range(cl_b.shape[0]):
        b = cl_b[k]
        j = cl_j[k]
        ex, ey, evx, evy, wb, wj, rjx, rjy, rbx, rby = joint_state(
            q, v, b, j, cl_sb[k, 0], cl_sb[k, 1], cl_sj[k, 0], cl_sj[k, 1], cs, sn)
        h = cl_hist[k]
        impact = hist[h] if h >= 0 else 0.0
        if h >= 0:
            gap[h], gaprate[h] = gap_of(ex, ey, evx, evy, cl_p[k, P_C])
        fx, fy, ms, mb, eel = clearance_force(ex, ey, evx, evy, wb, wj, impact, cl_p[k])
        power += fx * evx + fy * evy + ms * wj + mb * wb
        elastic += eel
        if j >= 0:
            Q[3 * j] += fx
            Q[3 * j + 1] += fy
            Q[3 * j + 2] += rjx * fy - rjy * fx + ms
        if b >= 0:
            Q[3 * b] -= fx
            Q[3 * b + 1] -= fy
            Q[3 * b + 2] += -(rbx * fy - rby * fx) + mb
    return power, elastic


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


@njit(cache=True)
def applied_forces(t, q, v, hist, sys, Q):
    """:func:`applied_forces_trig` for callers outside the right-hand side.

    Parameters
    ----------
    t : float
        Time (s).
    q : ndarray, shape (n,)
        Coordinates ``(x, y, θ)`` of each body (m, m, rad).
    v : ndarray, shape (n,)
        Their velocities (m/s, m/s, rad/s).
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (impact speed, m/s; :func:`n_contacts`).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).
    Q : ndarray, shape (n,)
        Generalised forces (N, N, N·m), added to.

    Returns
    -------
    tuple of float
        ``(clearance power (W), elastic contact energy (J))``.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> Q = np.zeros(9)
    >>> p, e = applied_forces(0.0, q, v, np.zeros(0), dyn, Q)
    >>> round(float(Q[4]), 6), e
    (-2.0601, 0.0)
    """
    nb = q.shape[0] // 3
    cs = np.empty(nb)
    sn = np.empty(nb)
    body_trig(q, cs, sn)
    nh = n_contacts(sys)
    return applied_forces_trig(t, q, v, hist, sys, Q, cs, sn, np.empty(nh), np.empty(nh))


class Workspace(NamedTuple):
    """Preallocated arrays of one right-hand-side evaluation (:func:`make_workspace`).

    An evaluation allocates nothing: on the slider-crank a dozen small temporaries per call
    were a third of its cost. After :func:`rhs_into` the constraint terms of the evaluated
    state are left in ``phi`` and ``phidot`` (read by the kernels' violation records) and the
    multipliers in ``lam``. One workspace per kernel call; not shared between threads.

    Parameters
    ----------
    cs, sn : ndarray, shape (nb,)
        cos θ, sin θ of each body.
    minv : ndarray, shape (n,)
        Diagonal of M⁻¹ (1/kg, 1/(kg m²)).
    Q : ndarray, shape (n,)
        Applied generalised forces (N, N·m).
    acc : ndarray, shape (n,)
        q̈ (m/s², rad/s²).
    phi : ndarray, shape (m,)
        Φ (m, rad).
    phidot : ndarray, shape (m,)
        Φ̇ = Φ_q q̇ + Φ_t (m/s, rad/s).
    c : ndarray, shape (m,)
        γ − 2α Φ̇ − β² Φ (m/s², rad/s²).
    coef : ndarray, shape (6 m,)
        Φ_q's row r at 6 r: (∂/∂x, ∂/∂y, ∂/∂θ) of body ``row_body[r, 0]``, then of
        ``row_body[r, 1]``.
    L : ndarray, shape (m²,)
        Cholesky factor of S, row-major, permuted (structural entries only).
    dinv : ndarray, shape (m,)
        1 / L[j, j].
    x : ndarray, shape (m,)
        Right-hand side / solution of S λ = …, permuted.
    lam : ndarray, shape (m,)
        Lagrange multipliers λ in row order.
    gap, gaprate : ndarray, shape (nh,)
        Penetration δ (m) and its rate δ̇ (m/s) of each contact-capable joint, as :func:`gaps`.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> ws = make_workspace(dyn)
    >>> ws.minv.shape, ws.lam.shape, ws.L.shape
    ((9,), (7,), (49,))
    """

    cs: np.ndarray  # (nb,) cos θ of each body
    sn: np.ndarray  # (nb,) sin θ
    minv: np.ndarray  # (n,) diagonal of M⁻¹ (1/kg, 1/(kg m²))
    Q: np.ndarray  # (n,) applied generalized forces (N, N m)
    acc: np.ndarray  # (n,) q̈
    phi: np.ndarray  # (m,) Φ (m, rad)
    phidot: np.ndarray  # (m,) Φ̇ = Φ_q q̇ + Φ_t (m/s, rad/s)
    c: np.ndarray  # (m,) γ − 2α Φ̇ − β² Φ (m/s², rad/s²)
    coef: np.ndarray  # (6 m,) Φ_q row r at 6r: (∂/∂x, ∂/∂y, ∂/∂θ) of body row_body[r, 0],
    #                   then of row_body[r, 1]
    L: np.ndarray  # (m², ) Cholesky factor of S, row-major, permuted (structural entries only)
    dinv: np.ndarray  # (m,) 1 / L[j, j]
    x: np.ndarray  # (m,) right-hand side / solution of S λ = …, permuted
    lam: np.ndarray  # (m,) Lagrange multipliers λ in row order
    gap: np.ndarray  # (nh,) penetration δ (m) of each contact-capable joint, as ``gaps``
    gaprate: np.ndarray  # (nh,) its rate δ̇ (m/s)


@njit(cache=True)
def make_workspace(sys):
    """A :class:`Workspace` for ``sys``.

    Parameters
    ----------
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).

    Returns
    -------
    Workspace
        Fresh arrays sized for ``sys``.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> ws = make_workspace(dyn)
    >>> round(float(ws.minv[0]), 6), 1 / 0.3
    (3.333333, 3.3333333333333335)
    """
    n = sys.mass.shape[0]
    m = n_constraints(sys)
    return Workspace(np.empty(n // 3), np.empty(n // 3), 1.0 / sys.mass, np.empty(n),
                     np.empty(n), np.empty(m), np.empty(m), np.empty(m), np.zeros(6 * m),
                     np.zeros(m * m), np.empty(m), np.empty(m), np.empty(m),
                     np.empty(n_contacts(sys)), np.empty(n_contacts(sys)))


@njit(cache=True, inline='always')
def constraint_terms(t, q, v, sys, ws):
    """Φ, Φ̇ = Φ_q q̇ + Φ_t, the sparse rows of Φ_q and γ of the state, into ``ws``.

    One sine and cosine per body. Row r of Φ_q acts on at most two bodies
    (``sys.row_body[r]``) with the coefficients ``ws.coef[6 r:6 r + 6]``. With ``A s`` the
    body-fixed vector s in global axes, ``B s = ∂(A s)/∂θ = (−(A s)_y, (A s)_x)``, and
    ``γ = −(Φ_q q̇)_q q̇ − 2 Φ_qt q̇ − Φ_tt`` (Nikravesh 1988, §6.2): for a revolute joint
    ``(A_i s_i) ω_i² − (A_j s_j) ω_j²``, for a point on a line ``n·(A_i s_i) ω_i²``, for a driver
    its angular acceleration, zero for fixed angles. The Baumgarte combination
    ``c = γ − 2α Φ̇ − β² Φ`` is formed here too.

    Parameters
    ----------
    t : float
        Time (s).
    q : ndarray, shape (n,)
        Coordinates ``(x, y, θ)`` of each body (m, m, rad).
    v : ndarray, shape (n,)
        Their velocities (m/s, m/s, rad/s).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).
    ws : Workspace
        The workspace (:func:`make_workspace`).

    Examples
    --------
    At the assembled state Φ vanishes and Φ̇ to round-off:

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> ws = make_workspace(dyn)
    >>> constraint_terms(0.0, q, v, dyn, ws)
    >>> float(np.abs(ws.phi).max()), bool(np.abs(ws.phidot).max() < 1e-11)
    (0.0, True)
    """
    # Arrays are taken out of the tuples once: each attribute access inside a loop would
    # cost a reference-count increment and decrement (a null test and a call when the caller
    # borrowed the tuples, mechanics/borrow.py).
    baumgarte = sys.baumgarte
    dr_i = sys.dr_i
    dr_law = sys.dr_law
    dr_par = sys.dr_par
    fa_angle = sys.fa_angle
    fa_i = sys.fa_i
    rev_i = sys.rev_i
    rev_j = sys.rev_j
    rev_off = sys.rev_off
    rev_offdot = sys.rev_offdot
    rev_si = sys.rev_si
    rev_sj = sys.rev_sj
    tr_angle = sys.tr_angle
    tr_i = sys.tr_i
    tr_n = sys.tr_n
    tr_p0 = sys.tr_p0
    tr_si = sys.tr_si
    cs = ws.cs
    sn = ws.sn
    body_trig(q, cs, sn)
    phi = ws.phi
    pd = ws.phidot
    g = ws.c
    co = ws.coef
    r = 0
    for k in range(rev_i.shape[0]):
        i = rev_i[k]
        j = rev_j[k]
        sx = rev_si[k, 0]
        sy = rev_si[k, 1]
        axi = cs[i] * sx - sn[i] * sy
        ayi = sn[i] * sx + cs[i] * sy
        wi = v[3 * i + 2]
        phi[r] = q[3 * i] + axi - rev_off[k, 0]
        phi[r + 1] = q[3 * i + 1] + ayi - rev_off[k, 1]
        pd[r] = v[3 * i] - ayi * wi - rev_offdot[k, 0]
        pd[r + 1] = v[3 * i + 1] + axi * wi - rev_offdot[k, 1]
        g[r] = axi * wi * wi
        g[r + 1] = ayi * wi * wi
        co[6 * r] = 1.0
        co[6 * r + 1] = 0.0
        co[6 * r + 2] = -ayi
        co[6 * r + 6] = 0.0
        co[6 * r + 7] = 1.0
        co[6 * r + 8] = axi
        if j < 0:
            phi[r] -= rev_sj[k, 0]
            phi[r + 1] -= rev_sj[k, 1]
        else:
            sx = rev_sj[k, 0]
            sy = rev_sj[k, 1]
            axj = cs[j] * sx - sn[j] * sy
            ayj = sn[j] * sx + cs[j] * sy
            wj = v[3 * j + 2]
            phi[r] -= q[3 * j] + axj
            phi[r + 1] -= q[3 * j + 1] + ayj
            pd[r] -= v[3 * j] - ayj * wj
            pd[r + 1] -= v[3 * j + 1] + axj * wj
            g[r] -= axj * wj * wj
            g[r + 1] -= ayj * wj * wj
            co[6 * r + 3] = -1.0
            co[6 * r + 4] = 0.0
            co[6 * r + 5] = ayj
            co[6 * r + 9] = 0.0
            co[6 * r + 10] = -1.0
            co[6 * r + 11] = -axj
        r += 2
    for k in range(tr_i.shape[0]):
        i = tr_i[k]
        nx = tr_n[k, 0]
        ny = tr_n[k, 1]
        sx = tr_si[k, 0]
        sy = tr_si[k, 1]
        ax = cs[i] * sx - sn[i] * sy
        ay = sn[i] * sx + cs[i] * sy
        wi = v[3 * i + 2]
        cth = ny * ax - nx * ay  # n·(B s)
        phi[r] = nx * (q[3 * i] + ax - tr_p0[k, 0]) + ny * (q[3 * i + 1] + ay - tr_p0[k, 1])
        pd[r] = nx * v[3 * i] + ny * v[3 * i + 1] + cth * wi
        g[r] = (nx * ax + ny * ay) * wi * wi
        co[6 * r] = nx
        co[6 * r + 1] = ny
        co[6 * r + 2] = cth
        phi[r + 1] = q[3 * i + 2] - tr_angle[k]
        pd[r + 1] = wi
        g[r + 1] = 0.0
        co[6 * r + 6] = 0.0
        co[6 * r + 7] = 0.0
        co[6 * r + 8] = 1.0
        r += 2
    for k in range(fa_i.shape[0]):
        i = fa_i[k]
        phi[r] = q[3 * i + 2] - fa_angle[k]
        pd[r] = v[3 * i + 2]
        g[r] = 0.0
        co[6 * r] = 0.0
        co[6 * r + 1] = 0.0
        co[6 * r + 2] = 1.0
        r += 1
    for k in range(dr_i.shape[0]):
        i = dr_i[k]
        th, w, acc = driver_law(dr_law[k], dr_par[k], t)
        phi[r] = q[3 * i + 2] - th
        pd[r] = v[3 * i + 2] - w
        g[r] = acc
        co[6 * r] = 0.0
        co[6 * r + 1] = 0.0
        co[6 * r + 2] = 1.0
        r += 1
    alpha2 = 2.0 * baumgarte[0]
    beta2 = baumgarte[1] * baumgarte[1]
    for r in range(phi.shape[0]):
        g[r] -= alpha2 * pd[r] + beta2 * phi[r]


@njit(cache=True, inline='always')
def _solve_multipliers(sys, ws):
    """λ from ``S λ = Φ_q M⁻¹ Q − c`` with ``S = Φ_q M⁻¹ Φ_qᵀ``, by a Cholesky factorisation
    ``S = L Lᵀ`` that visits only the structural entries of
    :func:`~mechrel.mechanics.system.schur_structure`, through precomputed flat indices. The
    work is a chain of dependent scalar operations, so its cost is latency: divisions are
    replaced by products with the reciprocal pivots. A non-positive pivot (dependent
    constraints) raises ``np.linalg.LinAlgError``, like ``np.linalg.solve`` for a singular
    matrix."""
    m = ws.phi.shape[0]
    co = ws.coef
    rb = sys.row_body
    perm = sys.ch_perm
    minv = ws.minv
    Q = ws.Q
    L = ws.L
    x = ws.x
    dinv = ws.dinv
    c = ws.c
    lam = ws.lam
    ent = sys.ch_ent
    for e in range(ent.shape[0]):
        L[ent[e, 0]] = 0.0
    sc = sys.sc_idx
    for e in range(sc.shape[0]):
        a = sc[e, 1]
        b = sc[e, 2]
        body = sc[e, 3]
        L[sc[e, 0]] += ((co[a] * co[b] + co[a + 1] * co[b + 1]) * minv[body]
                        + co[a + 2] * co[b + 2] * minv[body + 2])
    for p in range(m):
        r = perm[p]
        acc = -c[r]
        for s in range(2):
            body = rb[r, s]
            if body >= 0:
                o = 6 * r + 3 * s
                b3 = 3 * body
                acc += (co[o] * Q[b3] * minv[b3] + co[o + 1] * Q[b3 + 1] * minv[b3 + 1]
                        + co[o + 2] * Q[b3 + 2] * minv[b3 + 2])
        x[p] = acc
    ptr = sys.ch_ptr
    kk = sys.ch_kk
    for e in range(ent.shape[0]):
        ij = ent[e, 0]
        j = ent[e, 1]
        s = L[ij]
        for u in range(ptr[e], ptr[e + 1]):
            s -= L[kk[u, 0]] * L[kk[u, 1]]
        if ij == j * (m + 1):  # diagonal
            if not s > 0.0:
                raise np.linalg.LinAlgError("constraint Jacobian is rank deficient")
            d = math.sqrt(s)
            L[ij] = d
            dinv[j] = 1.0 / d
        else:
            L[ij] = s * dinv[j]
    _cholesky_solve(sys, L, dinv, x)
    for p in range(m):
        lam[perm[p]] = x[p]


@njit(cache=True, inline='always')
def _cholesky_solve(sys, L, dinv, x):
    """Solve ``L Lᵀ u = x`` in place (permuted order) with the factor of
    :func:`_solve_multipliers`."""
    m = x.shape[0]
    rp = sys.ch_row_ptr
    ri = sys.ch_row_idx
    for i in range(m):  # forward: L z = x
        s = x[i]
        for u in range(rp[i], rp[i + 1]):
            k = ri[u]
            s -= L[i * m + k] * x[k]
        x[i] = s * dinv[i]
    for i in range(m - 1, -1, -1):  # backward: Lᵀ u = z, scattering each solved u_i
        xi = x[i] * dinv[i]
        x[i] = xi
        for u in range(rp[i], rp[i + 1]):
            k = ri[u]
            x[k] -= L[i * m + k] * xi


@njit(cache=True, inline='always')
def accelerations_into(t, y, hist, sys, ws):
    """q̈ into ``ws.acc`` and λ into ``ws.lam``.

    Solves the corrected eq. 24 through the Schur complement (module docstring):
    ``S λ = Φ_q M⁻¹ Q − c``, ``q̈ = M⁻¹ (Q − Φ_qᵀ λ)``, with Φ_q's sparse rows
    (:func:`constraint_terms`). The drivers' generalized force is ``−Φ_q,dᵀ λ_d``, so their
    power is ``−Σ λ_d θ̇_d``.

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray, shape (2 n + 2,)
        The state ``(q, q̇, W_in, W_cl)``: coordinates (m, rad), velocities (m/s, rad/s), input
        and clearance work (J).
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (impact speed, m/s; :func:`n_contacts`).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).
    ws : Workspace
        The workspace (:func:`make_workspace`).

    Returns
    -------
    tuple of float
        ``(driver power, clearance power)`` (W).

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> ws = make_workspace(dyn)
    >>> p_in, p_cl = accelerations_into(0.0, y, np.zeros(0), dyn, ws)
    >>> round(p_in, 4), round(float(ws.acc[0]), 3)
    (51.9267, -6853.892)
    """
    sys = borrowed(sys)
    ws = borrowed(ws)
    n = sys.mass.shape[0]
    q = y[:n]
    v = y[n:2 * n]
    Q = ws.Q
    for k in range(n):
        Q[k] = 0.0
    constraint_terms(t, q, v, sys, ws)
    pcl, _ = applied_forces_trig(t, q, v, hist, sys, Q, ws.cs, ws.sn, ws.gap, ws.gaprate)
    m = ws.phi.shape[0]
    a = ws.acc
    lam = ws.lam
    minv = ws.minv
    dr_i = sys.dr_i
    for k in range(n):
        a[k] = Q[k]
    if m > 0:
        _solve_multipliers(sys, ws)
        co = ws.coef
        rb = sys.row_body
        for r in range(m):
            lr = lam[r]
            for s in range(2):
                body = rb[r, s]
                if body >= 0:
                    o = 6 * r + 3 * s
                    a[3 * body] -= co[o] * lr
                    a[3 * body + 1] -= co[o + 1] * lr
                    a[3 * body + 2] -= co[o + 2] * lr
    for k in range(n):
        a[k] *= minv[k]
    pin = 0.0
    r = m - dr_i.shape[0]
    for k in range(dr_i.shape[0]):
        pin -= lam[r + k] * v[3 * dr_i[k] + 2]
    return pin, pcl


@njit(cache=True)
def rhs_into(t, y, hist, sys, ws, out):
    """dy/dt for ``y = [q, q̇, W_in, W_cl]`` into ``out``, allocation-free (the kernels' form).

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray, shape (2 n + 2,)
        The state ``(q, q̇, W_in, W_cl)``: coordinates (m, rad), velocities (m/s, rad/s), input
        and clearance work (J).
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (impact speed, m/s; :func:`n_contacts`).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).
    ws : Workspace
        The workspace (:func:`make_workspace`).
    out : ndarray, shape (2 n + 2,)
        Receives ``dy/dt = (q̇, q̈, P_in, P_cl)`` (SI units).

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> out = np.empty_like(y)
    >>> rhs_into(0.0, y, np.zeros(0), dyn, make_workspace(dyn), out)
    >>> bool(np.array_equal(out[:9], v)), round(float(out[18]), 4)
    (True, 51.9267)
    """
    rhs_inline(t, y, hist, sys, ws, out)


@njit(cache=True, inline='always')
def rhs_inline(t, y, hist, sys, ws, out):
    """:func:`rhs_into`'s body, inlined where a kernel calls it once per stage in a tight loop.

    In RK4 a call passes the System and Workspace tuples as some 400 scalar arguments, 5–8 %
    of an evaluation of the slider-crank. Use it at one call site per kernel only (each site
    compiles the whole right-hand side again).

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray, shape (2 n + 2,)
        The state ``(q, q̇, W_in, W_cl)``: coordinates (m, rad), velocities (m/s, rad/s), input
        and clearance work (J).
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (impact speed, m/s; :func:`n_contacts`).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).
    ws : Workspace
        The workspace (:func:`make_workspace`).
    out : ndarray, shape (2 n + 2,)
        Receives ``dy/dt = (q̇, q̈, P_in, P_cl)`` (SI units).

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> out = np.empty_like(y)
    >>> rhs_inline(0.0, y, np.zeros(0), dyn, make_workspace(dyn), out)
    >>> bool(np.array_equal(out[:9], v)), round(float(out[18]), 4)
    (True, 51.9267)
    """
    n = sys.mass.shape[0]
    pin, pcl = accelerations_into(t, y, hist, sys, ws)
    acc = ws.acc
    for k in range(n):
        out[k] = y[n + k]
        out[n + k] = acc[k]
    out[2 * n] = pin
    out[2 * n + 1] = pcl


@njit(cache=True)
def accelerations(t, y, hist, sys):
    """q̈, the Lagrange multipliers λ, driver power and clearance power, as fresh values.

    A convenience form of :func:`accelerations_into`.

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray, shape (2 n + 2,)
        The state ``(q, q̇, W_in, W_cl)``: coordinates (m, rad), velocities (m/s, rad/s), input
        and clearance work (J).
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (impact speed, m/s; :func:`n_contacts`).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).

    Returns
    -------
    tuple
        ``(q̈ (n,) (m/s², rad/s²), λ (m,), driver power (W), clearance power (W))``.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> a, lam, p_in, p_cl = accelerations(0.0, y, np.zeros(0), dyn)
    >>> a.shape, lam.shape, round(p_in, 4)
    ((9,), (7,), 51.9267)
    """
    ws = make_workspace(sys)
    pin, pcl = accelerations_into(t, y, hist, sys, ws)
    return ws.acc.copy(), ws.lam.copy(), pin, pcl


@njit(cache=True)
def rhs(t, y, hist, sys):
    """dy/dt for y = [q, q̇, W_in, W_cl] as a fresh array.

    For Python callers such as SciPy's integrators; the compiled kernels use :func:`rhs_into`
    with one workspace.

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray, shape (2 n + 2,)
        The state ``(q, q̇, W_in, W_cl)``: coordinates (m, rad), velocities (m/s, rad/s), input
        and clearance work (J).
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (impact speed, m/s; :func:`n_contacts`).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).

    Returns
    -------
    ndarray, shape (2 n + 2,)
        ``(q̇, q̈, P_in, P_cl)`` (SI units).

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> f = rhs(0.0, y, np.zeros(0), dyn)
    >>> bool(np.array_equal(f[:9], v)), f.shape
    (True, (20,))
    """
    out = np.empty_like(y)
    rhs_into(t, y, hist, sys, make_workspace(sys), out)
    return out


@njit(cache=True)
def _project_batch(sys, ws, G, E, X, PG, Z):
    """For each row c of ``G`` (K × n generalized forces) and ``E`` (K × m constraint-row
    changes): ``Z[c] = S⁻¹ (Φ_q M⁻¹ G[c] + E[c])`` (row order) and
    ``PG[c] = M⁻¹ (G[c] − Φ_qᵀ Z[c])``, with the factor of S left in ``ws`` by the last
    :func:`rhs_into`. With ``E = 0`` these are the responses of the multipliers (∂λ/∂Q) and of
    the constrained accelerations (∂q̈/∂Q) to the forces. All K right-hand sides go through the
    triangular solves together (``X``: m × K scratch, permuted order): independent columns
    overlap in the processor where one solve is a chain of dependent operations."""
    sys, ws, G, E, X, PG, Z = borrowed((sys, ws, G, E, X, PG, Z))
    K = G.shape[0]
    n = G.shape[1]
    m = Z.shape[1]
    co = ws.coef
    rb = sys.row_body
    perm = sys.ch_perm
    minv = ws.minv
    L = ws.L
    dinv = ws.dinv
    for p in range(m):
        r = perm[p]
        for c in range(K):
            X[p, c] = E[c, r]
        for s in range(2):
            body = rb[r, s]
            if body >= 0:
                o = 6 * r + 3 * s
                b3 = 3 * body
                w0 = co[o] * minv[b3]
                w1 = co[o + 1] * minv[b3 + 1]
                w2 = co[o + 2] * minv[b3 + 2]
                for c in range(K):
                    X[p, c] += w0 * G[c, b3] + w1 * G[c, b3 + 1] + w2 * G[c, b3 + 2]
    rp = sys.ch_row_ptr
    ri = sys.ch_row_idx
    for i in range(m):  # forward: L U = X
        for u in range(rp[i], rp[i + 1]):
            k = ri[u]
            lik = L[i * m + k]
            for c in range(K):
                X[i, c] -= lik * X[k, c]
        d = dinv[i]
        for c in range(K):
            X[i, c] *= d
    for i in range(m - 1, -1, -1):  # backward: Lᵀ Z = U
        d = dinv[i]
        for c in range(K):
            X[i, c] *= d
        for u in range(rp[i], rp[i + 1]):
            k = ri[u]
            lik = L[i * m + k]
            for c in range(K):
                X[k, c] -= lik * X[i, c]
    for p in range(m):
        r = perm[p]
        for c in range(K):
            Z[c, r] = X[p, c]
    for c in range(K):
        for k in range(n):
            PG[c, k] = G[c, k]
    for r in range(m):
        for s in range(2):
            body = rb[r, s]
            if body >= 0:
                o = 6 * r + 3 * s
                b3 = 3 * body
                for c in range(K):
                    zr = Z[c, r]
                    PG[c, b3] -= co[o] * zr
                    PG[c, b3 + 1] -= co[o + 1] * zr
                    PG[c, b3 + 2] -= co[o + 2] * zr
    for c in range(K):
        for k in range(n):
            PG[c, k] *= minv[k]


@njit(cache=True)
def clearance_jacobian(t, y, hist, sys, ws, f, JS):
    """The fast part of ``∂f/∂y``, the one the clearance forces drive, into ``JS``.

    For joint k with bearing body b and journal body j, the force law
    (:func:`~mechrel.forces.joint.clearance_force`) maps the relative state
    ``s = (e_x, e_y, ė_x, ė_y, ω_B, ω_S)`` to ``F = (F_x, F_y, M_S, M_B)``, which enters the
    generalized forces through the lever arms ``r_j = A_j s_j``, ``r_b = A_b s_b``:
    ``Q = G F`` with ``G``'s columns ``(+1, 0, −r_jy)`` on j and ``(−1, 0, +r_by)`` on b for
    ``F_x``, ``(0, +1, r_jx)`` / ``(0, −1, −r_bx)`` for ``F_y``, and the unit moments of M_S on j
    and M_B on b. Then

        ∂q̈/∂y ⊃ P (G ∂F/∂s ∂s/∂y + ∂G/∂y F),   P = ∂q̈/∂Q = M⁻¹ − M⁻¹ Φ_qᵀ S⁻¹ Φ_q M⁻¹,

    with ``∂s/∂y`` the (analytic) kinematics of the two points, ``∂F/∂s`` by forward
    differences of the force law alone (6 evaluations per joint, far cheaper than a
    right-hand side) and ``∂G/∂θ F`` the turning of the lever arms (``−r_j·F`` on θ_j,
    ``+r_b·F`` on θ_b). The multipliers and accelerations carry the forces into the
    constraints, so the constraint geometry's share of ∂q̈/∂θ changes as fast as the forces:
    with Q and c held, δθ_b changes only the θ-coefficients of Φ_q (``d(A s)/dθ = B s``,
    ``d(B s)/dθ = −A s``), and ``M δq̈ + δΦ_qᵀ λ + Φ_qᵀ δλ = 0``, ``Φ_q δq̈ + δΦ_q q̈ = 0``
    give ``δq̈ = M⁻¹ (w − Φ_qᵀ δλ)``, ``S δλ = Φ_q M⁻¹ w + δΦ_q q̈`` with ``w = −δΦ_qᵀ λ``.
    All these responses (4 per joint, 1 per body) are solved together with the Cholesky
    factor of S at ``y`` (:func:`_project_batch`). The work rows get
    ``∂W_in/∂y = −Σ_d θ̇_d ∂λ_d/∂y`` and ``∂W_cl/∂y = ∂(F·ė + M_S ω_S + M_B ω_B)/∂y``.

    Everything proportional to the clearance forces is included, so at a fixed state the
    result is linear in them (tested: ``tests/test_jacobian.py``). What is left out — the
    derivatives of γ, the Baumgarte terms and gravity, and the constraint geometry's share of
    the force-free multipliers — is smooth; the integrator takes it from finite differences
    of the mechanism without clearance forces (``mechrel.integrate.radau``). Rows
    ``n … ny − 1``, columns ``0 … 2n − 1`` of ``JS`` are written. ``f`` receives ``f(t, y)``.

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray, shape (2 n + 2,)
        The state ``(q, q̇, W_in, W_cl)``: coordinates (m, rad), velocities (m/s, rad/s), input
        and clearance work (J).
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (impact speed, m/s; :func:`n_contacts`).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).
    ws : Workspace
        The workspace (:func:`make_workspace`).
    f : ndarray, shape (2 n + 2,)
        Receives ``f(t, y)``.
    JS : ndarray, shape (2 n + 2, 2 n + 2)
        Receives the clearance forces' part of the Jacobian (SI units of ``f`` over those of
        ``y``).

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> f, JS = np.empty(20), np.zeros((20, 20))
    >>> clearance_jacobian(0.0, y, np.zeros(0), dyn, make_workspace(dyn), f, JS)
    >>> bool(np.array_equal(f, rhs(0.0, y, np.zeros(0), dyn))), bool(np.abs(JS).max() > 0)
    (True, True)
    """
    y, hist, sys, ws, f, JS = borrowed((y, hist, sys, ws, f, JS))
    n = sys.mass.shape[0]
    ny = y.shape[0]
    m = ws.phi.shape[0]
    nb = n // 3
    rhs_into(t, y, hist, sys, ws, f)  # leaves S's factor at y, and cos/sin, in ws
    for i in range(n, ny):
        for c in range(2 * n):
            JS[i, c] = 0.0
    q = y[:n]
    v = y[n:2 * n]
    cs = ws.cs
    sn = ws.sn
    co = ws.coef
    lam = ws.lam
    acc_ = ws.acc
    cl_b = sys.cl_b
    cl_j = sys.cl_j
    cl_sb = sys.cl_sb
    cl_sj = sys.cl_sj
    cl_p = sys.cl_p
    cl_hist = sys.cl_hist
    dr_i = sys.dr_i
    nd = dr_i.shape[0]
    ncl = cl_b.shape[0]
    K = 4 * ncl + nb
    G = np.zeros((K, n))
    E = np.zeros((K, m))
    X = np.empty((m, K))
    PG = np.empty((K, n))
    Z = np.empty((K, m))
    dF = np.empty((ncl, 4, 6))
    F0 = np.empty((ncl, 4))
    S0 = np.empty((ncl, 6))
    lever = np.empty((ncl, 4))  # r_jx, r_jy, r_bx, r_by
    s0 = np.empty(6)
    # --- per joint: state, force, ∂F/∂s, and G's four columns
    for k in range(ncl):
        b = cl_b[k]
        j = cl_j[k]
        p = cl_p[k]
        (s0[0], s0[1], s0[2], s0[3], s0[4], s0[5],
         rjx, rjy, rbx, rby) = joint_state(q, v, b, j, cl_sb[k, 0], cl_sb[k, 1], cl_sj[k, 0],
                                           cl_sj[k, 1], cs, sn)
        lever[k, 0] = rjx
        lever[k, 1] = rjy
        lever[k, 2] = rbx
        lever[k, 3] = rby
        h = cl_hist[k]
        impact = hist[h] if h >= 0 else 0.0
        for i in range(6):
            S0[k, i] = s0[i]
        F0[k, 0], F0[k, 1], F0[k, 2], F0[k, 3], _ = clearance_force(
            s0[0], s0[1], s0[2], s0[3], s0[4], s0[5], impact, p)
        # ∂F/∂s by forward differences, δ = √u max(|s_i|, scale): scale c for the
        # eccentricity, c per second for its rate, 1 rad/s for the angular velocities
        c = p[P_C]
        for i in range(6):
            scale = c if i < 4 else 1.0
            si = s0[i]
            sp = si + 1.4901161193847656e-08 * max(abs(si), scale)
            d = sp - si
            s0[i] = sp
            f0_, f1_, f2_, f3_, _ = clearance_force(s0[0], s0[1], s0[2], s0[3], s0[4], s0[5],
                                                    impact, p)
            s0[i] = si
            dF[k, 0, i] = (f0_ - F0[k, 0]) / d
            dF[k, 1, i] = (f1_ - F0[k, 1]) / d
            dF[k, 2, i] = (f2_ - F0[k, 2]) / d
            dF[k, 3, i] = (f3_ - F0[k, 3]) / d
        row = 4 * k
        if j >= 0:
            G[row, 3 * j] = 1.0
            G[row, 3 * j + 2] = -rjy
            G[row + 1, 3 * j + 1] = 1.0
            G[row + 1, 3 * j + 2] = rjx
            G[row + 2, 3 * j + 2] = 1.0
        if b >= 0:
            G[row, 3 * b] = -1.0
            G[row, 3 * b + 2] = rby
            G[row + 1, 3 * b + 1] = -1.0
            G[row + 1, 3 * b + 2] = -rbx
            G[row + 3, 3 * b + 2] = 1.0
    # --- per body: the constraint geometry's share, w = −δΦ_qᵀ λ on θ_b, E = δΦ_q q̈
    rev_i = sys.rev_i
    rev_j = sys.rev_j
    tr_i = sys.tr_i
    tr_n = sys.tr_n
    tr_si = sys.tr_si
    r = 0
    for k in range(rev_i.shape[0]):  # co[2] = −a_y, co[8] = a_x; co[5] = a_y, co[11] = −a_x
        bi = rev_i[k]
        E[4 * ncl + bi, r] += -co[6 * r + 8]
        E[4 * ncl + bi, r + 1] += co[6 * r + 2]
        bj = rev_j[k]
        if bj >= 0:
            E[4 * ncl + bj, r] += -co[6 * r + 11]
            E[4 * ncl + bj, r + 1] += co[6 * r + 5]
        r += 2
    for k in range(tr_i.shape[0]):  # co[2] = n·(B s): its derivative is −n·(A s)
        bi = tr_i[k]
        ax = cs[bi] * tr_si[k, 0] - sn[bi] * tr_si[k, 1]
        ay = sn[bi] * tr_si[k, 0] + cs[bi] * tr_si[k, 1]
        E[4 * ncl + bi, r] += -(tr_n[k, 0] * ax + tr_n[k, 1] * ay)
        r += 2
    for bb in range(nb):
        row = 4 * ncl + bb  # E[row] holds ∂(θ-coefficients)/∂θ_bb for now
        wsum = 0.0
        for r in range(m):
            dco = E[row, r]
            wsum -= dco * lam[r]
            E[row, r] = dco * acc_[3 * bb + 2]
        G[row, 3 * bb + 2] = wsum
    _project_batch(sys, ws, G, E, X, PG, Z)
    # --- assemble
    for bb in range(nb):
        row = 4 * ncl + bb
        col = 3 * bb + 2
        for i in range(n):
            JS[n + i, col] += PG[row, i]
        a_ = 0.0
        for d_ in range(nd):
            a_ -= v[3 * dr_i[d_] + 2] * Z[row, m - nd + d_]
        JS[2 * n, col] += a_
    pin_row = np.empty(4)
    ds = np.zeros((6, 12))  # ∂s/∂(local columns): x, y, θ, v_x, v_y, ω of j, then of b
    cols = np.empty(12, dtype=np.int64)
    for k in range(ncl):
        b = cl_b[k]
        j = cl_j[k]
        rjx = lever[k, 0]
        rjy = lever[k, 1]
        rbx = lever[k, 2]
        rby = lever[k, 3]
        wb = S0[k, 4]
        wj = S0[k, 5]
        for comp in range(4):
            a_ = 0.0
            for d_ in range(nd):
                a_ -= v[3 * dr_i[d_] + 2] * Z[4 * k + comp, m - nd + d_]
            pin_row[comp] = a_
        # ∂s/∂y on the 12 local columns (e = r_S − r_B, module docstring of forces.joint)
        for a in range(6):
            for u in range(12):
                ds[a, u] = 0.0
        for side in range(2):
            body = j if side == 0 else b
            sg = 1.0 if side == 0 else -1.0
            rx = rjx if side == 0 else rbx
            ry = rjy if side == 0 else rby
            w = wj if side == 0 else wb
            o = 6 * side
            for c6 in range(3):
                cols[o + c6] = 3 * body + c6 if body >= 0 else -1
                cols[o + 3 + c6] = n + 3 * body + c6 if body >= 0 else -1
            ds[0, o + 0] = sg  # e_x / x
            ds[0, o + 2] = -sg * ry  # e_x / θ
            ds[1, o + 1] = sg
            ds[1, o + 2] = sg * rx
            ds[2, o + 2] = -sg * rx * w  # ė_x = … − r_y ω
            ds[2, o + 3] = sg
            ds[2, o + 5] = -sg * ry
            ds[3, o + 2] = -sg * ry * w  # ė_y = … + r_x ω
            ds[3, o + 4] = sg
            ds[3, o + 5] = sg * rx
            ds[5 if side == 0 else 4, o + 5] = 1.0  # ω_S, ω_B
        sv0 = S0[k, 2]  # velocities paired with F_x, F_y, M_S, M_B
        sv1 = S0[k, 3]
        sv2 = wj
        sv3 = wb
        for u in range(12):
            col = cols[u]
            if col < 0:
                continue
            # H[:, u] = ∂F/∂s ∂s/∂y_u, plus the lever-arm turning on the θ columns
            h0 = 0.0
            h1 = 0.0
            h2 = 0.0
            h3 = 0.0
            for a in range(6):
                dsa = ds[a, u]
                if dsa != 0.0:
                    h0 += dF[k, 0, a] * dsa
                    h1 += dF[k, 1, a] * dsa
                    h2 += dF[k, 2, a] * dsa
                    h3 += dF[k, 3, a] * dsa
            # ∂W_cl/∂y_u: F·∂(ė, ω_S, ω_B)/∂y_u + (ė, ω_S, ω_B)·∂F/∂y_u
            JS[2 * n + 1, col] += (sv0 * h0 + sv1 * h1 + sv2 * h2 + sv3 * h3
                                   + F0[k, 0] * ds[2, u] + F0[k, 1] * ds[3, u]
                                   + F0[k, 2] * ds[5, u] + F0[k, 3] * ds[4, u])
            if u == 2:  # θ_j: the moment arm of (F_x, F_y) on j turns
                h2 += -(rjx * F0[k, 0] + rjy * F0[k, 1])
            elif u == 8:  # θ_b
                h3 += rbx * F0[k, 0] + rby * F0[k, 1]
            r0 = 4 * k
            for i in range(n):
                JS[n + i, col] += (PG[r0, i] * h0 + PG[r0 + 1, i] * h1 + PG[r0 + 2, i] * h2
                                   + PG[r0 + 3, i] * h3)
            JS[2 * n, col] += pin_row[0] * h0 + pin_row[1] * h1 + pin_row[2] * h2 \
                + pin_row[3] * h3


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


@njit(cache=True)
def violation_from(ws):
    """Max |Φ| and max |Φ_q q̇ + Φ_t| of the state whose constraint terms are in ``ws``.

    After :func:`constraint_terms` or :func:`rhs_into`.

    Parameters
    ----------
    ws : Workspace
        The workspace (:func:`make_workspace`).

    Returns
    -------
    tuple of float
        max |Φ| (m or rad), max |Φ̇| (m/s or rad/s).

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> ws = make_workspace(dyn)
    >>> constraint_terms(0.0, q, v, dyn, ws)
    >>> pos, vel = violation_from(ws)
    >>> pos, bool(vel < 1e-11)
    (0.0, True)
    """
    ws = borrowed(ws)
    phi = ws.phi
    phidot = ws.phidot
    p = 0.0
    v = 0.0
    for r in range(phi.shape[0]):
        p = max(p, abs(phi[r]))
        v = max(v, abs(phidot[r]))
    return p, v


@njit(cache=True)
def constraint_violation(t, y, sys):
    """Max |Φ| (m or rad) and max |Φ_q q̇ + Φ_t| (m/s or rad/s) of the state ``y``.

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
    tuple of float
        max |Φ|, max |Φ̇|.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> pos, vel = constraint_violation(0.0, y, dyn)
    >>> pos, bool(vel < 1e-11)
    (0.0, True)
    """
    n = sys.mass.shape[0]
    ws = make_workspace(sys)
    constraint_terms(t, y[:n], y[n:2 * n], sys, ws)
    return violation_from(ws)


@njit(cache=True)
def mechanical_energy(y, sys):
    """Kinetic energy ½ q̇ᵀ M q̇ and gravitational potential −Σ m g·r (J).

    Parameters
    ----------
    y : ndarray, shape (2 n + 2,)
        The state ``(q, q̇, W_in, W_cl)``: coordinates (m, rad), velocities (m/s, rad/s), input
        and clearance work (J).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).

    Returns
    -------
    tuple of float
        ``(T, V)`` (J).

    Examples
    --------
    All bodies at y = 0, so V = 0; T is ½ q̇ᵀ M q̇:

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> T, V = mechanical_energy(y, dyn)
    >>> round(T, 6), round(float(0.5 * (dyn.mass * v**2).sum()), 6), V
    (63.350904, 63.350904, 0.0)
    """
    n = sys.mass.shape[0]
    T = 0.0
    V = 0.0
    for k in range(n):
        T += 0.5 * sys.mass[k] * y[n + k] ** 2
    for b in range(n // 3):
        V -= sys.mass[3 * b] * (sys.gravity[0] * y[3 * b] + sys.gravity[1] * y[3 * b + 1])
    return T, V


@njit(cache=True)
def post_process(times, Y, sys):
    """Per output instant, the clearance joints' eccentricities and the energies.

    In one compiled call: the eccentricity (e_x, e_y) (m) of every clearance joint, kinetic
    and gravitational energy and the elastic contact energy (J).

    Parameters
    ----------
    times : ndarray, shape (N,)
        The output instants (s).
    Y : ndarray, shape (N, 2 n + 2)
        The states at those instants.
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).

    Returns
    -------
    tuple of ndarray
        ``(EX, EY, T, V, E)``: EX, EY of shape (N, n_clearance) (m), T, V, E of shape (N,)
        (J).

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> EX, EY, T, V, E = post_process(np.zeros(1), y[None], dyn)
    >>> EX.shape, round(float(T[0]), 6), float(E[0])
    ((1, 1), 63.350904, 0.0)
    """
    N = Y.shape[0]
    n = sys.mass.shape[0]
    nc = sys.cl_b.shape[0]
    EX = np.empty((N, nc))
    EY = np.empty((N, nc))
    T = np.empty(N)
    V = np.empty(N)
    E = np.empty(N)
    no_hist = np.zeros(n_contacts(sys))  # the stored elastic energy does not depend on history
    cl_b = sys.cl_b
    cl_j = sys.cl_j
    cl_sb = sys.cl_sb
    cl_sj = sys.cl_sj
    Q = np.zeros(n)
    cs = np.empty(n // 3)
    sn = np.empty(n // 3)
    for r in range(N):
        y = Y[r]
        q = y[:n]
        v = y[n:2 * n]
        body_trig(q, cs, sn)
        for k in range(nc):
            EX[r, k], EY[r, k], _, _, _, _, _, _, _, _ = joint_state(
                q, v, cl_b[k], cl_j[k], cl_sb[k, 0], cl_sb[k, 1], cl_sj[k, 0], cl_sj[k, 1],
                cs, sn)
        T[r], V[r] = mechanical_energy(y, sys)
        Q[:] = 0.0
        _, E[r] = applied_forces(times[r], q, v, no_hist, sys, Q)
    return EX, EY, T, V, E


@njit(cache=True)
def driver_angles(law, par, times):
    """Angle (rad) of one driver at each instant.

    Parameters
    ----------
    law : int
        The driver law code (``System.dr_law``: constant speed, constant acceleration, harmonic).
    par : ndarray
        Its parameters (a row of ``System.dr_par``: rad, rad/s, rad/s², Hz, s).
    times : ndarray, shape (N,)
        The instants (s).

    Returns
    -------
    ndarray, shape (N,)
        θ (rad).

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> driver_angles(dyn.dr_law[0], dyn.dr_par[0], np.array([0.0, 0.01])).round(6).tolist()
    [0.0, 5.235988]
    """
    out = np.empty(times.shape[0])
    for r in range(times.shape[0]):
        out[r] = driver_law(law, par, times[r])[0]
    return out
