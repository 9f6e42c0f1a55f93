"""The fast part of the right-hand side's Jacobian: what the clearance forces drive.

Owns :func:`clearance_jacobian`, the part of ``∂f/∂y`` that changes as fast as the clearance
forces (their derivatives through the joint kinematics, the lever arms and the constrained
response of multipliers and accelerations), which the stiff integrator
(:mod:`mechrel.integrate.radau`) refreshes after accepted steps while keeping the smooth rest
from finite differences; and :func:`_project_batch`, which carries a batch of generalised
forces through the constraints with the Schur factor that the last right-hand side left in
the workspace. ``@njit(cache=True)``.

Source: the derivation is in :func:`clearance_jacobian`'s docstring (the constrained
response ``P = M⁻¹ − M⁻¹ Φ_qᵀ S⁻¹ Φ_q M⁻¹`` of the equations of motion in
:mod:`mechrel.mechanics.dynamics`); it is checked against central differences of the whole
right-hand side in tests/test_jacobian.py.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..forces.joint import clearance_force
from ..forces.params import P_C
from .borrow import borrowed
from .dynamics import rhs_into
from .joints import joint_state


@njit(cache=True)
def _project_batch(sys, ws, G, E, X, PG, Z):
    """For each row c of ``G`` (K × n generalized forces) and ``E`` (K × m constraint-row
    changes): ``Z[c] = S⁻¹ (Φ_q M⁻¹ G[c] + E[c])`` (row order) and
    ``PG[c] = M⁻¹ (G[c] − Φ_qᵀ Z[c])``, with the factor of S left in ``ws`` by the last
    :func:`~mechrel.mechanics.dynamics.rhs_into`. With ``E = 0`` these are the responses of
    the multipliers (∂λ/∂Q) and of the constrained accelerations (∂q̈/∂Q) to the forces. All K
    right-hand sides go through the triangular solves together (``X``: m × K scratch, permuted
    order): independent columns overlap in the processor where one solve is a chain of
    dependent operations."""
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


@njit(cache=True, inline='always')
def force_law_derivatives(s, impact, p, F, dF):
    """A clearance joint's force law and its derivatives by forward differences.

    ``F = (F_x, F_y, M_S, M_B)`` of :func:`~mechrel.forces.joint.clearance_force` at the
    relative state ``s = (e_x, e_y, ė_x, ė_y, ω_B, ω_S)``, and ``dF[:, i] = ∂F/∂s_i`` with the
    increment ``δ = √u max(|s_i|, scale)``: scale c (the clearance) for the eccentricity, c
    per second for its rate, 1 rad/s for the angular velocities. Six evaluations of the force
    law, far cheaper than a right-hand side; both formulations' fast Jacobians use them
    (:func:`clearance_jacobian`, :func:`~mechrel.mechanics.reduced.reduced_fast_jacobian`).

    Parameters
    ----------
    s : ndarray, shape (6,)
        The relative state (m, m/s, rad/s); restored on return.
    impact : float
        The joint's impact speed (m/s; 0 outside contact or for a film).
    p : ndarray
        The joint's packed parameters (:mod:`mechrel.forces.params`).
    F : ndarray, shape (4,)
        Receives the force (N) and moments (N m).
    dF : ndarray, shape (4, 6)
        Receives ∂F/∂s (SI units).

    Examples
    --------
    A journal 0.3 mm off centre at +x, moving toward the wall at 10 mm/s: the squeeze film
    pushes it back (F_x < 0), harder the closer it is (∂F_x/∂e_x < 0) and the faster it
    comes (∂F_x/∂ė_x < 0: a damper):

    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> p = compile_scene(load_scene("slider-crank-lubricated")).dynamic.cl_p[0]
    >>> F, dF = np.empty(4), np.empty((4, 6))
    >>> force_law_derivatives(np.array([3e-4, 0.0, 0.01, 0.0, 0.0, 0.0]), 0.0, p, F, dF)
    >>> bool(F[0] < 0.0), bool(dF[0, 0] < 0.0), bool(dF[0, 2] < 0.0)
    (True, True, True)
    """
    F[0], F[1], F[2], F[3], _ = clearance_force(s[0], s[1], s[2], s[3], s[4], s[5], impact, p)
    c = p[P_C]
    for i in range(6):
        scale = c if i < 4 else 1.0
        si = s[i]
        sp = si + 1.4901161193847656e-08 * max(abs(si), scale)
        d = sp - si
        s[i] = sp
        f0_, f1_, f2_, f3_, _ = clearance_force(s[0], s[1], s[2], s[3], s[4], s[5], impact, p)
        s[i] = si
        dF[0, i] = (f0_ - F[0]) / d
        dF[1, i] = (f1_ - F[1]) / d
        dF[2, i] = (f2_ - F[2]) / d
        dF[3, i] = (f3_ - F[3]) / d


@njit(cache=True, inline='always')
def _line_geometry_share(sys, q, cs, sn, lam, acc, r0, g0, nb, G, E):
    """The constraint geometry's share (:func:`clearance_jacobian`) of the points on moving
    bodies' lines, rows ``r0 …`` of Φ_q: with ``n = A_j n̄``, ``a = A_i s_i`` and
    ``d = r_i + a − r_j``, the coefficients ``(n, n·(B_i s_i))`` on body i and
    ``(−n, n × d)`` on body j change with θ_i by ``(0, −n·a)`` and ``(0, n·a)``, with θ_j by
    ``(n⊥, n·a)`` and ``(−n⊥, −n·d)`` (``n⊥ = (−n_y, n_x)``), and the last one with x_i, y_i,
    x_j, y_j by ``−n_y, n_x, n_y, −n_x``. Each adds ``−δΦ_qᵀ λ`` to the response's
    generalized force (``G``) and ``δΦ_q q̈`` to its constraint change (``E``): the rows
    ``g0 + b`` (θ of body b) and ``g0 + nb + 2 b + {0, 1}`` (its x, y)."""
    ln_i = sys.ln_i
    ln_j = sys.ln_j
    ln_si = sys.ln_si
    ln_n = sys.ln_n
    for k in range(ln_i.shape[0]):
        r = r0 + k
        i = ln_i[k]
        j = ln_j[k]
        lr = lam[r]
        nx = ln_n[k, 0]
        ny = ln_n[k, 1]
        if j >= 0:
            bx = nx
            nx = cs[j] * bx - sn[j] * ny
            ny = sn[j] * bx + cs[j] * ny
        ax = 0.0
        ay = 0.0
        px = ln_si[k, 0]
        py = ln_si[k, 1]
        if i >= 0:
            ax = cs[i] * px - sn[i] * py
            ay = sn[i] * px + cs[i] * py
            px = q[3 * i] + ax
            py = q[3 * i + 1] + ay
        na = nx * ax + ny * ay
        if i >= 0:  # θ_i: (0, −n·a) on i, (0, n·a) on j
            row = g0 + i
            G[row, 3 * i + 2] += na * lr
            E[row, r] -= na * acc[3 * i + 2]
            if j >= 0:
                G[row, 3 * j + 2] -= na * lr
                E[row, r] += na * acc[3 * j + 2]
        if j >= 0:
            dx = px - q[3 * j]
            dy = py - q[3 * j + 1]
            nd_ = nx * dx + ny * dy
            row = g0 + j  # θ_j: (n⊥, n·a) on i, (−n⊥, −n·d) on j
            if i >= 0:
                G[row, 3 * i] += ny * lr
                G[row, 3 * i + 1] -= nx * lr
                G[row, 3 * i + 2] -= na * lr
                E[row, r] += -ny * acc[3 * i] + nx * acc[3 * i + 1] + na * acc[3 * i + 2]
            G[row, 3 * j] -= ny * lr
            G[row, 3 * j + 1] += nx * lr
            G[row, 3 * j + 2] += nd_ * lr
            E[row, r] += ny * acc[3 * j] - nx * acc[3 * j + 1] - nd_ * acc[3 * j + 2]
            # positions: only n × d, on θ_j, moves with them
            if i >= 0:
                row = g0 + nb + 2 * i
                G[row, 3 * j + 2] += ny * lr
                E[row, r] -= ny * acc[3 * j + 2]
                G[row + 1, 3 * j + 2] -= nx * lr
                E[row + 1, r] += nx * acc[3 * j + 2]
            row = g0 + nb + 2 * j
            G[row, 3 * j + 2] -= ny * lr
            E[row, r] += ny * acc[3 * j + 2]
            G[row + 1, 3 * j + 2] += nx * lr
            E[row + 1, r] -= nx * acc[3 * j + 2]


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
        History of the contact-capable joints (impact speed, m/s;
        :func:`~mechrel.mechanics.joints.n_contacts`).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).
    ws : Workspace
        The workspace (:func:`~mechrel.mechanics.dynamics.make_workspace`).
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
    >>> from mechrel.mechanics.dynamics import make_workspace, rhs
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
    ln_i = sys.ln_i
    nln = ln_i.shape[0]
    # responses: 4 per clearance joint, one per body's θ, and, where a point rides on a
    # moving body's line (whose Φ_q depends on positions too), one per body's x and y
    nxy = 2 * nb if nln > 0 else 0
    K = 4 * ncl + nb + nxy
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
        force_law_derivatives(s0, impact, p, F0[k], dF[k])
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
    if nln > 0:
        _line_geometry_share(sys, q, cs, sn, lam, acc_, m - nd - sys.ra_i.shape[0] - nln,
                             4 * ncl, nb, G, E)
    _project_batch(sys, ws, G, E, X, PG, Z)
    # --- assemble
    for bb in range(nb + nxy):
        row = 4 * ncl + bb
        col = 3 * bb + 2 if bb < nb else 3 * ((bb - nb) // 2) + (bb - nb) % 2
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
