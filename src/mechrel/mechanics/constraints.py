"""The ideal joints and drivers as constraint equations: Φ, Φ_t, Φ_q, γ and their violation.

Owns the constraint rows of a :class:`~mechrel.mechanics.system.System`, in the row order
revolute (2 rows), translational on a ground line (2), fixed angle (1), point on a line (1:
the on-line equation of a translational joint between moving bodies and of a pin-in-slot
joint), relative angle (1: the second equation of such a translational joint), driver (1):
:func:`n_constraints`;
``Φ(q, t)``, ``Φ_t`` and the Jacobian ``Φ_q`` as dense arrays for the assembly
(:func:`constraints`); the same terms and γ in the sparse, allocation-free form of the
right-hand side and the kinematic analysis (:func:`constraint_terms`: each row of Φ_q acts on
at most two bodies, with the Baumgarte combination formed there); and the violation of a state
(:func:`violation_from`).
All ``@njit(cache=True)``.

Formulation (Nikravesh 1988, *Computer-Aided Analysis of Mechanical Systems*, ch. 6; Baumgarte
1972): with ``q`` the absolute coordinates and ``Φ(q, t) = 0`` the constraints, the velocity
equations are ``Φ_q q̇ = −Φ_t`` and the acceleration equations ``Φ_q q̈ = γ`` with

    γ = −(Φ_q q̇)_q q̇ − 2 Φ_qt q̇ − Φ_tt,    Φ̇ = Φ_q q̇ + Φ_t;

the dynamics (:mod:`mechrel.mechanics.dynamics`) replaces ``γ`` by the stabilised
``c = γ − 2α Φ̇ − β² Φ``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .borrow import borrowed
from .drivers import driver_law
from .joints import _rot, body_trig


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
        2 per revolute and translational joint, 1 per fixed angle, pin-in-slot joint and
        driver.

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
            + sys.ln_i.shape[0] + sys.ra_i.shape[0] + sys.dr_i.shape[0])


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
    for k in range(sys.ln_i.shape[0]):
        # (A_j n̄)·(r_P − r_Q): P = r_i + A_i s_i on the line through Q = r_j + A_j s_j
        i = sys.ln_i[k]
        j = sys.ln_j[k]
        ax, ay, _, _ = _rot(q[3 * i + 2] if i >= 0 else 0.0, sys.ln_si[k, 0], sys.ln_si[k, 1])
        px = ax + (q[3 * i] if i >= 0 else 0.0)  # a ground point's s is global
        py = ay + (q[3 * i + 1] if i >= 0 else 0.0)
        th = q[3 * j + 2] if j >= 0 else 0.0
        qx, qy, _, _ = _rot(th, sys.ln_sj[k, 0], sys.ln_sj[k, 1])
        if j >= 0:
            qx += q[3 * j]
            qy += q[3 * j + 1]
        nx, ny, _, _ = _rot(th, sys.ln_n[k, 0], sys.ln_n[k, 1])
        phi[r] = nx * (px - qx) + ny * (py - qy)
        if i >= 0:
            J[r, 3 * i] = nx
            J[r, 3 * i + 1] = ny
            J[r, 3 * i + 2] = ny * ax - nx * ay  # n·(B_i s_i)
        if j >= 0:
            dx = px - q[3 * j]
            dy = py - q[3 * j + 1]
            J[r, 3 * j] = -nx
            J[r, 3 * j + 1] = -ny
            J[r, 3 * j + 2] = nx * dy - ny * dx  # n × (r_P − r_j)
        r += 1
    for k in range(sys.ra_i.shape[0]):
        i = sys.ra_i[k]
        j = sys.ra_j[k]
        phi[r] = -sys.ra_angle[k]
        if i >= 0:
            phi[r] += q[3 * i + 2]
            J[r, 3 * i + 2] = 1.0
        if j >= 0:
            phi[r] -= q[3 * j + 2]
            J[r, 3 * j + 2] = -1.0
        r += 1
    for k in range(sys.dr_i.shape[0]):
        i = sys.dr_i[k]
        th, w, _ = driver_law(sys.dr_law[k], sys.dr_par[k], t)
        phi[r] = q[3 * i + 2] - th
        phit[r] = -w
        J[r, 3 * i + 2] = 1.0
        r += 1
    return phi, phit, J


@njit(cache=True, inline='always')
def constraint_terms(t, q, v, sys, ws):
    """Φ, Φ̇ = Φ_q q̇ + Φ_t, the sparse rows of Φ_q and γ of the state, into ``ws``.

    One sine and cosine per body. Row r of Φ_q acts on at most two bodies
    (``sys.row_body[r]``) with the coefficients ``ws.coef[6 r:6 r + 6]``. With ``A s`` the
    body-fixed vector s in global axes, ``B s = ∂(A s)/∂θ = (−(A s)_y, (A s)_x)``, and
    ``γ = −(Φ_q q̇)_q q̇ − 2 Φ_qt q̇ − Φ_tt`` (Nikravesh 1988, §6.2): for a revolute joint
    ``(A_i s_i) ω_i² − (A_j s_j) ω_j²``, for a point on a ground line ``n·(A_i s_i) ω_i²``, for
    a point P of body i on the line of body j (normal ``n = A_j n̄``, ``d = r_P − r_j``)
    ``n·(A_i s_i) ω_i² − 2 ω_j n × ḋ + ω_j² n·d`` (docs/mechanics.md, "Joints between moving
    bodies"), for a driver its angular acceleration, zero for fixed and relative angles. The
    Baumgarte combination ``c = γ − 2α Φ̇ − β² Φ`` is formed here too.

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
        The workspace (:func:`~mechrel.mechanics.dynamics.make_workspace`).

    Examples
    --------
    At the assembled state Φ vanishes and Φ̇ to round-off:

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> from mechrel.mechanics.dynamics import make_workspace
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
    ln_i = sys.ln_i
    ln_j = sys.ln_j
    ln_n = sys.ln_n
    ln_si = sys.ln_si
    ln_sj = sys.ln_sj
    ra_angle = sys.ra_angle
    ra_i = sys.ra_i
    ra_j = sys.ra_j
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
    for k in range(ln_i.shape[0]):
        # P = r_i + A_i s_i on the line through Q = r_j + A_j s_j with normal n = A_j n̄:
        # Φ = n·(P − Q), Φ_q = (n, n·(B_i s_i)) on i and (−n, n × d) on j, d = P − r_j
        i = ln_i[k]
        j = ln_j[k]
        nx = ln_n[k, 0]
        ny = ln_n[k, 1]
        qx = ln_sj[k, 0]
        qy = ln_sj[k, 1]
        rjx = 0.0
        rjy = 0.0
        vjx = 0.0
        vjy = 0.0
        wj = 0.0
        if j >= 0:
            bx = nx
            nx = cs[j] * bx - sn[j] * ny
            ny = sn[j] * bx + cs[j] * ny
            rjx = q[3 * j]
            rjy = q[3 * j + 1]
            vjx = v[3 * j]
            vjy = v[3 * j + 1]
            wj = v[3 * j + 2]
            sx = qx
            qx = rjx + cs[j] * sx - sn[j] * qy
            qy = rjy + sn[j] * sx + cs[j] * qy
        px = ln_si[k, 0]
        py = ln_si[k, 1]
        ax = 0.0
        ay = 0.0
        wi = 0.0
        vpx = 0.0
        vpy = 0.0
        if i >= 0:
            ax = cs[i] * px - sn[i] * py
            ay = sn[i] * px + cs[i] * py
            wi = v[3 * i + 2]
            px = q[3 * i] + ax
            py = q[3 * i + 1] + ay
            vpx = v[3 * i] - ay * wi
            vpy = v[3 * i + 1] + ax * wi
        dx = px - rjx
        dy = py - rjy
        ddx = vpx - vjx
        ddy = vpy - vjy
        cross = nx * dy - ny * dx  # n × d
        phi[r] = nx * (px - qx) + ny * (py - qy)
        pd[r] = nx * ddx + ny * ddy + wj * cross
        g[r] = ((nx * ax + ny * ay) * wi * wi - 2.0 * wj * (nx * ddy - ny * ddx)
                + wj * wj * (nx * dx + ny * dy))
        o = 6 * r
        if i >= 0:
            co[o] = nx
            co[o + 1] = ny
            co[o + 2] = ny * ax - nx * ay  # n·(B_i s_i)
            o += 3
        co[o] = -nx
        co[o + 1] = -ny
        co[o + 2] = cross
        r += 1
    for k in range(ra_i.shape[0]):  # θ_i − θ_j − angle
        i = ra_i[k]
        j = ra_j[k]
        o = 6 * r
        phi[r] = -ra_angle[k]
        pd[r] = 0.0
        if i >= 0:
            phi[r] += q[3 * i + 2]
            pd[r] += v[3 * i + 2]
            co[o] = 0.0
            co[o + 1] = 0.0
            co[o + 2] = 1.0
            o += 3
        if j >= 0:
            phi[r] -= q[3 * j + 2]
            pd[r] -= v[3 * j + 2]
            co[o] = 0.0
            co[o + 1] = 0.0
            co[o + 2] = -1.0
        g[r] = 0.0
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


@njit(cache=True)
def violation_from(ws):
    """Max |Φ| and max |Φ_q q̇ + Φ_t| of the state whose constraint terms are in ``ws``.

    After :func:`constraint_terms` or :func:`~mechrel.mechanics.dynamics.rhs_into`.

    Parameters
    ----------
    ws : Workspace
        The workspace (:func:`~mechrel.mechanics.dynamics.make_workspace`).

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
    >>> from mechrel.mechanics.dynamics import make_workspace
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
def violations_at(Y, t, rows, sys):
    """Max |Φ| and max |Φ_q q̇ + Φ_t| over the states ``Y[k]`` (rows ``[q, q̇, ...]``) at the
    instants ``t[k]``, ``k`` in ``rows``, skipping a row with a non-finite entry: the
    constraint violation a run reports, in one compiled call.

    Parameters
    ----------
    Y : ndarray, shape (N, n) or (N, ≥ 2 n)
        States, coordinates then velocities (m, rad, m/s, rad/s); with coordinates only
        (n columns), the velocity violation is not computed (0).
    t : ndarray, shape (N,)
        Their instants (s).
    rows : ndarray of int64
        The rows to check.
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).

    Returns
    -------
    tuple of float
        max |Φ| (m or rad), max |Φ_q q̇ + Φ_t| (m/s or rad/s); 0 with no row checked.

    Examples
    --------
    The lubricated slider-crank's first and last output instants, as its run reports them:

    >>> from mechrel.scene import load_scene
    >>> from mechrel.simulation import simulate
    >>> from mechrel.mechanics.system import compile_scene
    >>> scene = load_scene("slider-crank-lubricated")
    >>> r = simulate(scene)
    >>> Y, rows = np.hstack([r.q, r.v]), np.array([0, r.time.size - 1])
    >>> pos, vel = violations_at(Y, r.time, rows, compile_scene(scene).dynamic)
    >>> bool(pos < 1e-12 and vel < 1e-9), r.stats["max_position_violation"] == pos
    (True, True)
    """
    n = sys.mass.shape[0]
    pos = 0.0
    vel = 0.0
    for k in rows:
        if not np.all(np.isfinite(Y[k])):
            continue
        phi, phit, J = constraints(Y[k, :n], t[k], sys)
        for r in range(phi.shape[0]):
            pos = max(pos, abs(phi[r]))
        if Y.shape[1] >= 2 * n:
            jv = J @ np.ascontiguousarray(Y[k, n:2 * n])  # BLAS, as NumPy's J @ v
            for r in range(phi.shape[0]):
                vel = max(vel, abs(jv[r] + phit[r]))
    return pos, vel
