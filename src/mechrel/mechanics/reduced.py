"""The equations of motion in the clearance joints' eccentricities (and the free coordinates).

When a mechanism's ideal degrees of freedom are all driven, the motion that clearance adds has
exactly two degrees of freedom per clearance joint: its eccentricity ``e = r_S − r_B`` (journal
point minus bearing point, m). A degree of freedom that no driver sets adds a *free
coordinate* of the construction: the angle ``φ`` of an undriven link (a pendulum's swing, a
crank turned by a torque) or the position ``s`` of an undriven slider along its line (a cart on
a rail). With the bodies placed in closed form for any ``e`` and free coordinates
(:mod:`~mechrel.mechanics.construction`, whose steps treat each clearance joint as two nodes
``e`` apart and pose an undriven body at its free angle or position), the positions
``q(z, t)`` of all bodies are a function of the reduced coordinates
``z = (e_1, …, e_nc, φ_1 or s_1, …)`` (``nz = 2 nc + nf`` of them, ``nf`` free coordinates)
and time, and

    q̇ = R ż + q̇₀,     q̈ = R z̈ + q̈₀,     R = ∂q/∂z (n × nz),

where ``q̇₀`` is the velocity with ``ż = 0`` (the drivers alone) and ``q̈₀`` the acceleration
with ``z̈ = 0`` (the drivers' accelerations and every velocity-quadratic term). Each column of
``R`` is the construction's velocity pass with a unit rate of one component of ``z`` and
the drivers at rest; ``q̈₀`` is its acceleration pass with ``z̈ = 0``. Projecting
``M q̈ = Q + Φ_qᵀ λ`` onto the admissible motions (the columns of ``R``, which satisfy
``Φ_q R = 0``) removes the multipliers (the principle of virtual work; Nikravesh 1988, §6.5,
"embedding"; Haug 1989, ch. 6):

    (Rᵀ M R) z̈ = Rᵀ (Q(q, q̇, t) − M q̈₀).

``Q`` is the same gravity and clearance-joint forces as in the absolute formulation
(:func:`~mechrel.mechanics.applied.applied_forces_trig`), evaluated at the placed ``q`` and
``q̇``. The constraints hold exactly (to round-off) at every evaluation, with no Baumgarte
terms, and the state has ``2 nz + 2`` entries (10 for the nine-bar) instead of ``2 n + 2``
(50).

State ``y = (z, ż, W_in, W_cl)``: the eccentricities (m), clearance joint by joint, then the
free coordinates (rad for an angle, m for a position), their rates, and the drivers' and
clearance joints' work (J), as the absolute state ends with them. The clearance power
``P_cl`` is the force laws' (the same as the absolute formulation's); the drivers' power is
that of the constraint forces,
``P_in = q̇ᵀ (M q̈ − Q)``: ideal joints do no work, so the drivers' reactions are all of it (the
absolute formulation computes the same quantity as ``−Σ λ_d θ̇_d``; the two agree to round-off
at a state that satisfies the constraints, which a test checks). The layout ``(coordinates,
velocities, two work integrals)`` is the absolute state's with ``z`` for ``q``, so the
integrators' second-order structure (Radau's condensed iteration matrices) applies unchanged.
The assembly branch of each square root of the construction is the one of the configuration
the work arrays are made from (:func:`make_reduced_work`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit
from numba.extending import register_jitable

from .applied import applied_forces_trig
from .borrow import borrowed
from .construction import (ANGLE_FREE, POSE_ANGLE, SLIDE, _accelerations, _branch_signs,
                           _ground_nodes, _place, _velocities)
from .construction import construction  # noqa: F401  (the docstring examples use it)
from ..forces.params import P_C
from .jacobian import force_law_derivatives
from .joints import body_trig, gap_of, joint_state, n_contacts

__all__ = ["ReducedSystem", "ReducedWork", "expand", "expand_rows", "make_reduced_work",
           "n_reduced", "output_row", "reduced_coordinates", "reduced_fast_jacobian",
           "reduced_gaps_into", "reduced_rhs_into"]


class ReducedSystem(NamedTuple):
    """A mechanism in its reduced coordinates: what the integrators take in place of a
    :class:`~mechrel.mechanics.system.System` to integrate the reduced equations
    (:mod:`mechrel.mechanics.formulation` dispatches on the type).

    Parameters
    ----------
    sys : System
        The mechanism with its clearance joints as force elements (``compiled.dynamic``).
    con : Construction
        ``construction(sys)``.
    q_ref : ndarray, shape (n,)
        The configuration whose assembly branch and angles the evaluations continue (m, rad;
        :func:`make_reduced_work`).

    Examples
    --------
    >>> ReducedSystem._fields
    ('sys', 'con', 'q_ref')
    """

    sys: object
    con: object
    q_ref: np.ndarray


class ReducedWork(NamedTuple):
    """Preallocated arrays of one reduced evaluation (:func:`make_reduced_work`).

    Parameters
    ----------
    N, Nv, Na : ndarray, shape (n_nodes, 2)
        The nodes' positions (m), velocities (m/s) and accelerations (m/s²).
    Vc : ndarray, shape (nz + 1, n_nodes, 2)
        The velocity pass's columns (:func:`~mechrel.mechanics.construction._velocities`):
        the nodes' velocities for a unit rate of each eccentricity component and free
        coordinate, then the drivers' motion.
    q, v, a : ndarray, shape (n,)
        The bodies' coordinates, velocities and accelerations (SI).
    vc : ndarray, shape (nz + 1, n)
        The bodies' velocities of the same columns: its first ``nz`` rows are ``Rᵀ``,
        ``R = ∂q/∂z``, and its last one ``q̇₀``.
    E, Ed, Edd : ndarray, shape (nc, 2)
        The eccentricities (m), their rates (m/s) and accelerations (m/s²).
    Q : ndarray, shape (n,)
        The applied generalised forces (N, N·m).
    cs, sn : ndarray, shape (nb,)
        cos θ, sin θ of every body (the construction computes them).
    gap, gaprate : ndarray, shape (nh,)
        The contact-capable joints' penetration (m) and its rate (m/s).
    th, th_ref : ndarray, shape (nb,)
        Body angles found from two nodes (or by turning a line through a point) continue
        ``th_ref`` (rad): the reference configuration's, then those of each output row
        (:func:`output_row`, :func:`expand_rows`), so that a body that turns fully keeps a
        continuous angle; ``th`` is the copy an evaluation updates. Only the multiple of 2π
        of these angles depends on it, never their sine and cosine (so never a force).
    Mr : ndarray, shape (nz, nz)
        Rᵀ M R (kg, kg m, kg m²), factorised in place.
    b : ndarray, shape (nz,)
        Rᵀ (Q − M q̈₀) (N), solved in place for z̈.
    sign : ndarray, shape (n_branches,)
        The assembly branch of each square root of the construction.
    drv : ndarray, shape (nd + nf, 3)
        Each driver's θ (rad), θ̇ (rad/s), θ̈ (rad/s²) at the evaluation's time, then each
        free coordinate's value, rate and acceleration (from the state; the acceleration
        zero but in an expansion).
    D : ndarray, shape (nz,)
        Scratch of :func:`reduced_fast_jacobian`: one column of ∂z̈/∂s (m/s² per unit of s).
    w : ndarray, shape (nz,)
        Scratch of :func:`reduced_fast_jacobian`: ``Rᵀ M q̇`` (kg m/s).

    Examples
    --------
    Made by :func:`make_reduced_work`, filled by :func:`reduced_rhs_into` (whose example
    reads ``R`` from ``vc``):

    >>> ReducedWork._fields[:3], ReducedWork._fields[7]
    (('N', 'Nv', 'Na'), 'vc')
    """

    N: np.ndarray
    Nv: np.ndarray
    Na: np.ndarray
    Vc: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    vc: np.ndarray
    E: np.ndarray
    Ed: np.ndarray
    Edd: np.ndarray
    Q: np.ndarray
    cs: np.ndarray
    sn: np.ndarray
    gap: np.ndarray
    gaprate: np.ndarray
    th: np.ndarray
    th_ref: np.ndarray
    Mr: np.ndarray
    b: np.ndarray
    sign: np.ndarray
    drv: np.ndarray
    D: np.ndarray
    w: np.ndarray


@register_jitable
def n_reduced(con):
    """The number of reduced coordinates ``nz = 2 nc + nf`` of a construction: two per
    clearance joint (its eccentricity), one per free coordinate (a link's angle or a slider's
    position). The reduced state has ``2 nz + 2`` entries. Plain Python where called from
    Python, compiled inline in compiled code.

    Parameters
    ----------
    con : Construction
        ``construction(sys)``.

    Returns
    -------
    int

    Examples
    --------
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> n_reduced(construction(compile_scene(load_scene("nine-bar-lubricated")).dynamic))
    4
    >>> n_reduced(construction(compile_scene(load_scene("double-pendulum")).dynamic))
    2
    """
    return 2 * con.cl_nodes.shape[0] + con.n_free


@njit(cache=True)
def make_reduced_work(sys, con, q_ref):
    """The :class:`ReducedWork` of ``sys`` placed by ``con``, on the assembly branch and with
    the angles of the configuration ``q_ref`` (an assembled ``q``, m and rad).

    Parameters
    ----------
    sys : System
        The mechanism with its clearance joints as force elements (``compiled.dynamic``).
    con : Construction
        ``construction(sys)``.
    q_ref : ndarray, shape (n,)
        The reference configuration.

    Returns
    -------
    ReducedWork

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("nine-bar-lubricated"))
    >>> q0, _ = assemble(c.assembly, c.q_guess, 0.0)
    >>> rw = make_reduced_work(c.dynamic, construction(c.dynamic), q0)
    >>> rw.vc.shape, rw.Mr.shape  # R transposed, then q̇₀; Rᵀ M R
    ((5, 24), (4, 4))
    """
    n = q_ref.shape[0]
    nb = n // 3
    nn = con.node_body.shape[0]
    nc = con.cl_nodes.shape[0]
    nz = n_reduced(con)
    nh = n_contacts(sys)
    N = np.zeros((nn, 2))
    _ground_nodes(con, N)
    th_ref = np.empty(nb)
    for i in range(nb):
        th_ref[i] = q_ref[3 * i + 2]
    return ReducedWork(N, np.zeros((nn, 2)), np.zeros((nn, 2)), np.zeros((nz + 1, nn, 2)),
                       np.empty(n), np.empty(n), np.empty(n), np.zeros((nz + 1, n)),
                       np.empty((nc, 2)), np.empty((nc, 2)),
                       np.zeros((nc, 2)), np.empty(n), np.empty(nb), np.empty(nb),
                       np.empty(nh), np.empty(nh), np.empty(nb), th_ref,
                       np.empty((nz, nz)), np.empty(nz), _branch_signs(q_ref, con),
                       np.zeros((sys.dr_i.shape[0] + con.n_free, 3)), np.empty(nz),
                       np.empty(nz))


@njit(cache=True, inline='always')
def _kinematics_of(t, y, sys, con, rw):
    """Positions, velocities and accelerations of the reduced state ``y`` into ``rw``, the
    eccentricities and the free coordinates accelerating at ``rw.Edd`` and the free
    coordinates' rows of ``rw.drv`` (zero: ``q̈₀``); False where the construction has no real
    solution or a toggle."""
    nc = rw.E.shape[0]
    nz = rw.b.shape[0]
    for c in range(nc):
        rw.E[c, 0] = y[2 * c]
        rw.E[c, 1] = y[2 * c + 1]
        rw.Ed[c, 0] = y[nz + 2 * c]
        rw.Ed[c, 1] = y[nz + 2 * c + 1]
    nd = rw.drv.shape[0] - (nz - 2 * nc)  # the free coordinates' rows follow the drivers'
    for f in range(nz - 2 * nc):
        rw.drv[nd + f, 0] = y[2 * nc + f]
        rw.drv[nd + f, 1] = y[nz + 2 * nc + f]
    for i in range(rw.th.shape[0]):
        rw.th[i] = rw.th_ref[i]
    if not _place(con, rw.sign, sys, t, rw.E, rw.N, rw.q, rw.cs, rw.sn, rw.drv, rw.th):
        return False
    if not _velocities(con, rw.drv, rw.E, rw.N, rw.q, rw.Vc, rw.vc):
        return False
    # q̇ = R ż + q̇₀ (vc holds Rᵀ, then q̇₀) and the nodes' velocities likewise
    vc = rw.vc
    Vc = rw.Vc
    n = rw.q.shape[0]
    for i in range(n):
        s = vc[nz, i]
        for c in range(nz):
            s += vc[c, i] * y[nz + c]
        rw.v[i] = s
    for k in range(rw.Nv.shape[0]):
        sx = Vc[nz, k, 0]
        sy = Vc[nz, k, 1]
        for c in range(nz):
            sx += Vc[c, k, 0] * y[nz + c]
            sy += Vc[c, k, 1] * y[nz + c]
        rw.Nv[k, 0] = sx
        rw.Nv[k, 1] = sy
    _accelerations(con, rw.drv, rw.E, rw.Ed, rw.Edd, rw.N, rw.q, rw.Nv, rw.v, rw.Na, rw.a)
    return True


@njit(cache=True)
def reduced_rhs_into(t, y, hist, sys, con, rw, out):
    """``dy/dt = (ż, z̈, P_in, P_cl)`` of the reduced state ``y = (z, ż, W_in, W_cl)`` into
    ``out`` (module docstring).

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray, shape (2 nz + 2,)
        Eccentricities (m), clearance joint by joint, and free coordinates (rad or m), their
        rates (m/s, rad/s), and the two work integrals (J).
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (impact speed, m/s).
    sys : System
        The mechanism with its clearance joints as force elements.
    con : Construction
        ``construction(sys)``.
    rw : ReducedWork
        Work arrays (:func:`make_reduced_work`); on return they hold this state's ``q``,
        ``q̇`` (``rw.q``, ``rw.v``), ``q̈₀`` (``rw.a``), ``Rᵀ`` (``rw.vc[:2 nc]``),
        ``Q − M q̈₀`` (``rw.Q``) and
        the contact joints' gaps.
    out : ndarray, shape (2 nz + 2,)
        Receives ``(ż, z̈, P_in, P_cl)`` (m/s and rad/s, m/s² and rad/s², W, W); NaN where
        the mechanism cannot be placed at ``y`` (an eccentricity that breaks a group's
        assembly, a toggle).

    Returns
    -------
    bool
        False where ``out`` is NaN.

    Examples
    --------
    The lubricated nine-bar centred and at rest relative to its ideal motion: the film
    carries no load yet, so the journals fall behind the drivers' motion (z̈ ≠ 0):

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("nine-bar-lubricated"))
    >>> q0, _ = assemble(c.assembly, c.q_guess, 0.0)
    >>> con = construction(c.dynamic)
    >>> rw = make_reduced_work(c.dynamic, con, q0)
    >>> out = np.empty(10)
    >>> reduced_rhs_into(0.0, np.zeros(10), np.zeros(0), c.dynamic, con, rw, out)
    True
    >>> bool(np.all(out[:4] == 0.0) and np.abs(out[4:8]).max() > 1.0)
    True

    ``rw.vc[:4]`` now holds ``Rᵀ = (∂q/∂z)ᵀ``: the first joint's eccentricity moves its
    bearing body (rod 3, body 2) and the rest of the chain, not the crank that carries its
    journal (body 0):

    >>> bool(np.all(rw.vc[:4, 0:3] == 0.0)), bool(np.abs(rw.vc[0, 6:9]).max() > 0.1)
    (True, True)
    """
    y, hist, sys, con, rw, out = borrowed((y, hist, sys, con, rw, out))  # mechanics/borrow.py
    nz = rw.b.shape[0]
    n = rw.q.shape[0]
    if not _kinematics_of(t, y, sys, con, rw):
        for i in range(out.shape[0]):
            out[i] = math.nan
        return False
    Rt = rw.vc  # Rᵀ in its first nz rows
    Q = rw.Q
    for i in range(n):
        Q[i] = 0.0
    pcl, _ = applied_forces_trig(t, rw.q, rw.v, hist, sys, Q, rw.cs, rw.sn, rw.gap, rw.gaprate)
    mass = sys.mass
    for i in range(n):
        Q[i] -= mass[i] * rw.a[i]  # Q − M q̈₀
    Mr = rw.Mr
    b = rw.b
    for r in range(nz):
        s = 0.0
        for i in range(n):
            s += Rt[r, i] * Q[i]
        b[r] = s
        for c in range(r + 1):
            s = 0.0
            for i in range(n):
                s += Rt[r, i] * mass[i] * Rt[c, i]
            Mr[r, c] = s
    # Cholesky of the symmetric positive definite Rᵀ M R (lower triangle), then z̈
    for j in range(nz):
        d = Mr[j, j]
        for k in range(j):
            d -= Mr[j, k] * Mr[j, k]
        d = math.sqrt(d)
        Mr[j, j] = d
        for i in range(j + 1, nz):
            s = Mr[i, j]
            for k in range(j):
                s -= Mr[i, k] * Mr[j, k]
            Mr[i, j] = s / d
    _cholesky_solve(Mr, b, nz)
    # the drivers' power q̇ᵀ (M q̈ − Q) = q̇ᵀ (M R z̈ − (Q − M q̈₀)) (module docstring)
    pin = 0.0
    for i in range(n):
        s = 0.0
        for c in range(nz):
            s += Rt[c, i] * b[c]
        pin += rw.v[i] * (mass[i] * s - Q[i])
    for i in range(nz):
        out[i] = y[nz + i]
        out[nz + i] = b[i]
    out[2 * nz] = pin
    out[2 * nz + 1] = pcl
    return True


@njit(cache=True)
def reduced_fast_jacobian(t, y, hist, sys, con, rw, f, JS):
    """The fast part of ``∂f/∂y`` of the reduced equations, the one the clearance forces drive,
    into ``JS``; ``f`` receives ``f(t, y)`` (:func:`reduced_rhs_into`).

    Joint k's force law (:func:`~mechrel.forces.joint.clearance_force`) maps
    ``s = (e_x, e_y, ė_x, ė_y, ω_B, ω_S)`` to ``F = (F_x, F_y, M_S, M_B)``, whose virtual
    power is ``F_x δė_x + F_y δė_y + M_S δω_S + M_B δω_B``. The eccentricity is a pair of the
    coordinates, ``e_k = z_k``, so its generalized force on ``z`` is ``F`` itself in joint k's
    two entries, plus the moments through ``∂ω/∂ż``, the θ rows of ``R``:
    ``Rᵀ Q_k = S_kᵀ (F_x, F_y) + R_{θS}ᵀ M_S + R_{θB}ᵀ M_B``. Holding ``R`` and
    ``Rᵀ M R`` (smooth in z) fixed,

        ∂z̈/∂y ⊃ (Rᵀ M R)⁻¹ Σ_k (S_kᵀ ∂F_xy/∂s + R_{θS}ᵀ ∂M_S/∂s + R_{θB}ᵀ ∂M_B/∂s) ∂s/∂y,

    with ``∂s/∂y``: unit entries for ``e = z_k`` and ``ė = ż_k``, and ``∂ω/∂ż = R_θ``; ``∂F/∂s``
    by forward differences of the force law alone
    (:func:`~mechrel.mechanics.jacobian.force_law_derivatives`, as for the absolute
    formulation). The work rows get
    ``∂P_in/∂s = q̇ᵀ M R ∂z̈/∂s − q̇ᵀ ∂Q/∂s`` (``P_in = q̇ᵀ (M q̈ − Q)``, the dependence
    through ``q̇`` vanishing with ``Rᵀ (M q̈ − Q) = 0``) and
    ``∂P_cl/∂s = ∂(F·ė + M_S ω_S + M_B ω_B)/∂s``. What is left out (the derivatives of R, of
    Rᵀ M R, of q̈₀ and of gravity's share) is smooth: the integrator takes it from finite
    differences of the mechanism without clearance forces, as for the absolute formulation
    (:func:`mechrel.integrate.radau._update_jacobian`). Rows ``2 nc … ny − 1``, columns
    ``0 … 2 nz − 1`` of ``JS`` are written (zero where ``f`` is NaN).

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray, shape (2 nz + 2,)
        The reduced state (module docstring).
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (impact speed, m/s).
    sys : System
        The mechanism with its clearance joints as force elements.
    con : Construction
        ``construction(sys)``.
    rw : ReducedWork
        Work arrays (:func:`make_reduced_work`).
    f : ndarray, shape (2 nz + 2,)
        Receives ``f(t, y)``.
    JS : ndarray, shape (2 nz + 2, 2 nz + 2)
        Receives the clearance forces' part of the Jacobian (SI units of ``f`` over those of
        ``y``).

    Examples
    --------
    The lubricated slider-crank's journal 0.3 mm off centre and moving: the film's stiffness
    and damping are the large entries of ∂ë/∂(e, ė) (m/s² per m, per m/s):

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q0, _ = assemble(c.assembly, c.q_guess, 0.0)
    >>> con = construction(c.dynamic)
    >>> rw = make_reduced_work(c.dynamic, con, q0)
    >>> y = np.array([3e-4, 0.0, 0.0, 0.01, 0.0, 0.0])
    >>> f, JS = np.empty(6), np.zeros((6, 6))
    >>> reduced_fast_jacobian(0.0, y, np.zeros(0), c.dynamic, con, rw, f, JS)
    >>> bool(np.abs(JS[2:4, 0:4]).max() > 1e6), bool(np.all(JS[:2] == 0.0))
    (True, True)
    """
    y, hist, sys, con, rw, f, JS = borrowed((y, hist, sys, con, rw, f, JS))
    nz = rw.b.shape[0]
    ny = y.shape[0]
    n = rw.q.shape[0]
    for i in range(nz, ny):
        for c in range(2 * nz):
            JS[i, c] = 0.0
    if not reduced_rhs_into(t, y, hist, sys, con, rw, f):
        return
    Rt = rw.vc  # Rᵀ in its first nz rows
    L = rw.Mr  # the Cholesky factor of Rᵀ M R that reduced_rhs_into left (lower triangle)
    mass = sys.mass
    v = rw.v
    D = rw.D
    w = rw.w
    for r in range(nz):  # Rᵀ M q̇
        s = 0.0
        for i in range(n):
            s += Rt[r, i] * mass[i] * v[i]
        w[r] = s
    cl_b = sys.cl_b
    cl_j = sys.cl_j
    cl_p = sys.cl_p
    cl_hist = sys.cl_hist
    s0 = np.empty(6)
    F = np.empty(4)
    dF = np.empty((4, 6))
    for k in range(cl_b.shape[0]):
        b = cl_b[k]
        j = cl_j[k]
        p = cl_p[k]
        ex, ey, evx, evy, wb, wj, rjx, rjy, rbx, rby = joint_state(
            rw.q, v, b, j, sys.cl_sb[k, 0], sys.cl_sb[k, 1], sys.cl_sj[k, 0], sys.cl_sj[k, 1],
            rw.cs, rw.sn)
        h = cl_hist[k]
        impact = hist[h] if h >= 0 else 0.0
        s0[0], s0[1], s0[2], s0[3], s0[4], s0[5] = ex, ey, evx, evy, wb, wj
        force_law_derivatives(s0, impact, p, F, dF)
        fx, fy, ms, mb = F[0], F[1], F[2], F[3]
        for i in range(6):
            d0 = dF[0, i]
            d1 = dF[1, i]
            d2 = dF[2, i]
            d3 = dF[3, i]
            for r in range(nz):  # ∂(Rᵀ Q)/∂s_i
                D[r] = 0.0
            D[2 * k] += d0
            D[2 * k + 1] += d1
            if j >= 0:
                for r in range(nz):
                    D[r] += Rt[r, 3 * j + 2] * d2
            if b >= 0:
                for r in range(nz):
                    D[r] += Rt[r, 3 * b + 2] * d3
            pin = 0.0  # − q̇ᵀ ∂Q/∂s_i, with ∂Q on the journal's and the bearing's body
            if j >= 0:
                pin -= v[3 * j] * d0 + v[3 * j + 1] * d1 + v[3 * j + 2] * (rjx * d1 - rjy * d0
                                                                           + d2)
            if b >= 0:
                pin += v[3 * b] * d0 + v[3 * b + 1] * d1 + v[3 * b + 2] * (rbx * d1 - rby * d0
                                                                           - d3)
            _cholesky_solve(L, D, nz)
            for r in range(nz):
                pin += w[r] * D[r]
            pcl = d0 * evx + d1 * evy + d2 * wj + d3 * wb
            if i == 2:
                pcl += fx
            elif i == 3:
                pcl += fy
            elif i == 4:
                pcl += mb
            elif i == 5:
                pcl += ms
            # ∂s_i/∂y: e = z_k, ė = ż_k, ω = R_θ ż + …
            if i < 4:
                col = 2 * k + i if i < 2 else nz + 2 * k + i - 2
                for r in range(nz):
                    JS[nz + r, col] += D[r]
                JS[2 * nz, col] += pin
                JS[2 * nz + 1, col] += pcl
            else:
                body = b if i == 4 else j
                if body >= 0:
                    for c in range(nz):
                        wgt = Rt[c, 3 * body + 2]
                        col = nz + c
                        for r in range(nz):
                            JS[nz + r, col] += wgt * D[r]
                        JS[2 * nz, col] += wgt * pin
                        JS[2 * nz + 1, col] += wgt * pcl


@njit(cache=True, inline='always')
def _cholesky_solve(L, x, nz):
    """``x ← (L Lᵀ)⁻¹ x`` with the lower triangle of ``L``."""
    for i in range(nz):
        s = x[i]
        for k in range(i):
            s -= L[i, k] * x[k]
        x[i] = s / L[i, i]
    for i in range(nz - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, nz):
            s -= L[k, i] * x[k]
        x[i] = s / L[i, i]


@njit(cache=True)
def reduced_gaps_into(y, sys, g, gd):
    """Penetration δ = |e| − c (m) and its rate δ̇ (m/s) of every contact-capable joint, read
    from the reduced state (the eccentricities are its coordinates).

    The reduced counterpart of :func:`~mechrel.mechanics.joints.gaps_into` (the same
    :func:`~mechrel.mechanics.joints.gap_of`), indexed like ``hist``.

    Parameters
    ----------
    y : ndarray, shape (2 nz + 2,)
        The reduced state (module docstring).
    sys : System
        The mechanism with its clearance joints as force elements.
    g, gd : ndarray, shape (nh,)
        Receive δ (m) and δ̇ (m/s).

    Examples
    --------
    The dry slider-crank's joint 0.2 mm off centre, closing at 0.1 m/s: 0.3 mm from contact:

    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> sys = compile_scene(load_scene("slider-crank-dry")).dynamic
    >>> g, gd = np.empty(1), np.empty(1)
    >>> reduced_gaps_into(np.array([2e-4, 0.0, 0.1, 0.0, 0.0, 0.0]), sys, g, gd)
    >>> round(float(g[0]), 12), float(gd[0])
    (-0.0003, 0.1)
    """
    nz = (y.shape[0] - 2) // 2  # the eccentricities first, then any free coordinates
    for k in range(sys.cl_hist.shape[0]):
        h = sys.cl_hist[k]
        if h >= 0:
            g[h], gd[h] = gap_of(y[2 * k], y[2 * k + 1], y[nz + 2 * k], y[nz + 2 * k + 1],
                                 sys.cl_p[k, P_C])


@njit(cache=True, inline='always')
def _expand_into(t, y, zdd, sys, con, rw):
    """:func:`_kinematics_of` with the eccentricities and free coordinates accelerating at
    ``zdd``."""
    nc = rw.E.shape[0]
    nf = rw.b.shape[0] - 2 * nc
    nd = rw.drv.shape[0] - nf
    for c in range(nc):
        rw.Edd[c, 0] = zdd[2 * c]
        rw.Edd[c, 1] = zdd[2 * c + 1]
    for f in range(nf):
        rw.drv[nd + f, 2] = zdd[2 * nc + f]
    ok = _kinematics_of(t, y, sys, con, rw)
    for c in range(nc):  # back to zero, for reduced_rhs_into's q̈₀
        rw.Edd[c, 0] = 0.0
        rw.Edd[c, 1] = 0.0
    for f in range(nf):
        rw.drv[nd + f, 2] = 0.0
    return ok


@njit(cache=True, inline='always')
def _continue_angles(rw):
    """The angles of the row just placed in ``rw`` become the ones the next evaluations
    continue (``rw.th_ref``): a body that turns fully by the rows' steps keeps a continuous
    angle (its 2π multiple; a body turning by less than π between rows keeps the same one)."""
    th_ref = rw.th_ref
    q = rw.q
    for b in range(th_ref.shape[0]):
        th_ref[b] = q[3 * b + 2]


@njit(cache=True)
def output_row(y, f, rw, Ya, YDa):
    """The absolute row of the reduced state ``y`` right after its evaluation: what the
    evaluation left in ``rw`` gives ``q``, ``q̇`` and ``q̈ = q̈₀ + R z̈`` without placing the
    mechanism again (an integrator's outputs and its log; :func:`expand_rows` for rows it
    has not just evaluated).

    Parameters
    ----------
    y, f : ndarray, shape (2 nz + 2,)
        The reduced state and ``reduced_rhs_into(t, y, …)``, which must be the last
        evaluation into ``rw``.
    rw : ReducedWork
        The work arrays of that evaluation.
    Ya, YDa : ndarray, shape (2 n + 2,)
        Receive ``(q, q̇, W_in, W_cl)`` and ``(q̇, q̈, P_in, P_cl)`` (SI units); NaN where ``y``
        or ``f`` is not finite (a state the mechanism cannot take).

    Examples
    --------
    The same row as :func:`expand_rows` gives, to round-off (``q̈`` here is ``q̈₀ + R z̈``,
    there the acceleration pass with ``z̈``):

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("nine-bar-lubricated"))
    >>> q0, _ = assemble(c.assembly, c.q_guess, 0.0)
    >>> con = construction(c.dynamic)
    >>> rw = make_reduced_work(c.dynamic, con, q0)
    >>> y, f = np.array([1e-4, 0, 0, -2e-4, 0.01, 0, 0, 0, 0, 0]), np.empty(10)
    >>> reduced_rhs_into(0.1, y, np.zeros(0), c.dynamic, con, rw, f)
    True
    >>> Ya, YDa, Ye, YDe = np.empty(50), np.empty(50), np.empty((1, 50)), np.empty((1, 50))
    >>> output_row(y, f, rw, Ya, YDa)
    >>> expand_rows(np.array([0.1]), y[None], f[None], c.dynamic, con, rw, Ye, YDe)
    0
    >>> bool(np.array_equal(Ya, Ye[0])), bool(np.allclose(YDa, YDe[0], rtol=1e-12, atol=1e-9))
    (True, True)
    """
    y, f, rw, Ya, YDa = borrowed((y, f, rw, Ya, YDa))
    nz = rw.b.shape[0]
    n = rw.q.shape[0]
    ok = True
    for i in range(y.shape[0]):
        if not (math.isfinite(y[i]) and math.isfinite(f[i])):
            ok = False
    if not ok:
        for i in range(2 * n + 2):
            Ya[i] = math.nan
            YDa[i] = math.nan
        return
    Rt = rw.vc  # Rᵀ in its first nz rows
    for i in range(n):
        s = rw.a[i]  # q̈₀
        for c in range(nz):
            s += Rt[c, i] * f[nz + c]
        Ya[i] = rw.q[i]
        Ya[n + i] = rw.v[i]
        YDa[i] = rw.v[i]
        YDa[n + i] = s
    for i in range(2):
        Ya[2 * n + i] = y[2 * nz + i]
        YDa[2 * n + i] = f[2 * nz + i]
    _continue_angles(rw)


@njit(cache=True)
def expand_rows(T, Y, YD, sys, con, rw, Ya, YDa):
    """The absolute states and their derivatives of reduced ones, row by row (an
    integration's outputs or its log).

    Parameters
    ----------
    T : ndarray, shape (N,)
        The rows' instants (s).
    Y, YD : ndarray, shape (N, 2 nz + 2)
        Reduced states ``(z, ż, W_in, W_cl)`` and their derivatives ``(ż, z̈, P_in, P_cl)``.
    sys : System
        The mechanism with its clearance joints as force elements.
    con : Construction
        ``construction(sys)``.
    rw : ReducedWork
        Work arrays (:func:`make_reduced_work`).
    Ya, YDa : ndarray, shape (N, 2 n + 2)
        Receive ``(q, q̇, W_in, W_cl)`` and ``(q̇, q̈, P_in, P_cl)`` (SI units): the layout of
        :func:`~mechrel.mechanics.dynamics.rhs_into`. A row that is not finite, or where the
        mechanism cannot be placed, is NaN.

    Returns
    -------
    int
        The rows that are NaN.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("nine-bar-lubricated"))
    >>> q0, _ = assemble(c.assembly, c.q_guess, 0.0)
    >>> con = construction(c.dynamic)
    >>> rw = make_reduced_work(c.dynamic, con, q0)
    >>> Y, YD = np.zeros((2, 10)), np.zeros((2, 10))
    >>> Y[1] = np.nan
    >>> Ya, YDa = np.empty((2, 50)), np.empty((2, 50))
    >>> expand_rows(np.zeros(2), Y, YD, c.dynamic, con, rw, Ya, YDa)
    1
    >>> q, v, a = expand(0.0, Y[0], YD[0, 4:8], c.dynamic, con, rw)
    >>> bool(np.array_equal(Ya[0, :24], q)), bool(np.isnan(YDa[1]).all())
    (True, True)
    """
    T, Y, YD, sys, con, rw, Ya, YDa = borrowed((T, Y, YD, sys, con, rw, Ya, YDa))
    nz = rw.b.shape[0]
    n = rw.q.shape[0]
    bad = 0
    for k in range(T.shape[0]):
        ok = True
        for i in range(Y.shape[1]):
            if not (math.isfinite(Y[k, i]) and math.isfinite(YD[k, i])):
                ok = False
        if ok:
            ok = _expand_into(T[k], Y[k], YD[k, nz:2 * nz], sys, con, rw)
        if not ok:
            bad += 1
            for i in range(2 * n + 2):
                Ya[k, i] = math.nan
                YDa[k, i] = math.nan
            continue
        for i in range(n):
            Ya[k, i] = rw.q[i]
            Ya[k, n + i] = rw.v[i]
            YDa[k, i] = rw.v[i]
            YDa[k, n + i] = rw.a[i]
        for i in range(2):
            Ya[k, 2 * n + i] = Y[k, 2 * nz + i]
            YDa[k, 2 * n + i] = YD[k, 2 * nz + i]
        _continue_angles(rw)
    return bad


def expand(t, y, zdd, sys, con, rw):
    """The absolute coordinates, velocities and accelerations of a reduced state.

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray, shape (2 nz + 2,)
        The reduced state (m and rad, m/s and rad/s, J; only ``(z, ż)`` is read).
    zdd : ndarray, shape (nz,)
        The accelerations z̈ (m/s², rad/s²), e.g. ``reduced_rhs_into``'s second half.
    sys : System
        The mechanism with its clearance joints as force elements.
    con : Construction
        ``construction(sys)``.
    rw : ReducedWork
        Work arrays (:func:`make_reduced_work`).

    Returns
    -------
    q, v, a : ndarray, shape (n,)
        Positions (m, rad), velocities (m/s, rad/s), accelerations (m/s², rad/s²).

    Raises
    ------
    ValueError
        Where the mechanism cannot be placed at ``y``.

    Examples
    --------
    The nine-bar with both joints centred is the ideal mechanism: the slider (body 8)
    starts 0.575769 m below the ground's origin, as the scene says:

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("nine-bar-lubricated"))
    >>> q0, _ = assemble(c.assembly, c.q_guess, 0.0)
    >>> con = construction(c.dynamic)
    >>> q, v, a = expand(0.0, np.zeros(10), np.zeros(4), c.dynamic, con,
    ...                  make_reduced_work(c.dynamic, con, q0))
    >>> round(float(q[22]), 6)
    -0.575769
    """
    nz = n_reduced(con)
    n = sys.mass.shape[0]
    Y, YD = np.zeros((1, 2 * nz + 2)), np.zeros((1, 2 * nz + 2))
    Y[0, :2 * nz] = np.asarray(y, dtype=float)[:2 * nz]
    YD[0, nz:2 * nz] = zdd
    Ya, YDa = np.empty((1, 2 * n + 2)), np.empty((1, 2 * n + 2))
    if expand_rows(np.array([float(t)]), Y, YD, sys, con, rw, Ya, YDa):
        raise ValueError(f"the mechanism cannot be placed at the reduced state {y!r} "
                         f"(t = {t:g} s)")
    return Ya[0, :n].copy(), Ya[0, n:2 * n].copy(), YDa[0, n:2 * n].copy()


def reduced_coordinates(sys, con, q, v, work=(0.0, 0.0)):
    """The reduced state ``(z, ż, W_in, W_cl)`` of an absolute state: each clearance joint's
    eccentricity ``e = r_S − r_B`` (m) and each free coordinate (a free angle: the angle of its
    body, rad; a free position: the slider's node along its line from ``P₀``, m), their rates
    (m/s, rad/s), then the two work integrals (J).

    Parameters
    ----------
    sys : System
        The mechanism with its clearance joints as force elements.
    con : Construction
        ``construction(sys)`` (the order of the clearance joints and free coordinates).
    q, v : ndarray, shape (n,)
        Coordinates (m, rad) and velocities (m/s, rad/s).
    work : pair of float, optional
        The drivers' and the clearance joints' work so far (J). Default zero.

    Returns
    -------
    ndarray, shape (2 nz + 2,)

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("nine-bar-lubricated"))
    >>> q0, v0 = assemble(c.assembly, c.q_guess, 0.0)
    >>> y = reduced_coordinates(c.dynamic, construction(c.dynamic), q0, v0)
    >>> y.shape, bool(np.abs(y).max() < 1e-12)  # centred, at rest relative to the ideal motion
    ((10,), True)

    The double pendulum has no driver: its two links' angles are its coordinates

    >>> d = compile_scene(load_scene("double-pendulum"))
    >>> q0, v0 = assemble(d.assembly, d.q_guess, 0.0)
    >>> v0[[2, 5]] = 1.5, -0.5
    >>> reduced_coordinates(d.dynamic, construction(d.dynamic), q0, v0).tolist()
    [0.0, 0.0, 1.5, -0.5, 0.0, 0.0]
    """
    return _reduced_state(sys, con, np.ascontiguousarray(q, dtype=float),
                          np.ascontiguousarray(v, dtype=float), float(work[0]), float(work[1]))


@njit(cache=True)
def _reduced_state(sys, con, q, v, w_in, w_cl):
    """:func:`reduced_coordinates` compiled (contiguous ``q``, ``v``; the two work integrals)."""
    nc = con.cl_nodes.shape[0]
    nz = n_reduced(con)
    cs, sn = np.empty(q.size // 3), np.empty(q.size // 3)
    body_trig(q, cs, sn)
    y = np.empty(2 * nz + 2)
    y[2 * nz] = w_in
    y[2 * nz + 1] = w_cl
    for k in range(nc):  # the relative state the force laws see
        ex, ey, evx, evy = joint_state(q, v, sys.cl_b[k], sys.cl_j[k], sys.cl_sb[k, 0],
                                       sys.cl_sb[k, 1], sys.cl_sj[k, 0], sys.cl_sj[k, 1],
                                       cs, sn)[:4]
        y[2 * k] = ex
        y[2 * k + 1] = ey
        y[nz + 2 * k] = evx
        y[nz + 2 * k + 1] = evy
    for o in range(con.op.shape[0]):
        if con.op[o, 0] == POSE_ANGLE and con.op[o, 3] == ANGLE_FREE:
            b, f = con.op[o, 1], con.op[o, 5]  # a free angle is its body's angle
            y[2 * nc + f] = q[3 * b + 2]
            y[nz + 2 * nc + f] = v[3 * b + 2]
    for o in range(con.op.shape[0]):
        if con.op[o, 0] != SLIDE:
            continue
        k, f = con.op[o, 1], con.op[o, 5]  # a free position: N = P0 + s u
        b, sx, sy = con.node_body[k], con.node_s[k, 0], con.node_s[k, 1]  # the node on a body
        px, py = cs[b] * sx - sn[b] * sy, sn[b] * sx + cs[b] * sy
        ux, uy = con.par[o, 2], con.par[o, 3]
        y[2 * nc + f] = (q[3 * b] + px - con.par[o, 0]) * ux + (q[3 * b + 1] + py
                                                                 - con.par[o, 1]) * uy
        w = v[3 * b + 2]
        y[nz + 2 * nc + f] = (v[3 * b] - w * py) * ux + (v[3 * b + 1] + w * px) * uy
    return y
