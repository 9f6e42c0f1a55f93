"""The reduced formulation: integrate only the relative coordinates that clearance adds.

For a scene whose ideal degrees of freedom are all driven, replacing every clearance joint by
a revolute joint *held at a prescribed eccentricity* ``e_k`` leaves a square constraint system
``Φ(q, t; z) = 0`` (``n`` equations for the ``n`` absolute coordinates), with
``z = (e_1, …, e_nc)`` the ``2 nc`` eccentricity components. Given ``(t, z, ż)`` the bodies'
motion follows from the constraints alone, and only ``z`` carries dynamics: the state is
``x = (z, ż, W_in, W_cl)`` (4 nc + 2 entries; the nine-bar with two clearance joints: 10 in
place of 50). docs/mechanics.md ("The reduced formulation") derives it; in short:

* position: ``Φ(q, t; z) = 0`` by Newton from a second-order predictor of the previous solution
  (a cache: the result depends on it only through the Newton residual, ≤ ``NEWTON_TOL``
  times the mechanism's size, near round-off);
* velocity: ``Φ_q q̇ = b`` with ``b`` the drivers' angular velocities on their rows and
  ``±ż`` on the clearance rows, so ``q̇ = q̇₀ + R ż`` with ``R = ∂q/∂z = Φ_q⁻¹ P``
  (``P``: ±1 on the clearance rows);
* acceleration: ``Φ_q q̈ = γ + P z̈``, so ``q̈ = q̈₀ + R z̈`` with ``q̈₀ = Φ_q⁻¹ γ``;
* dynamics: the virtual displacements the ideal joints and the drivers allow are
  ``δq = R δz``; projecting ``M q̈ = Q + (ideal constraint forces)`` onto them removes the
  constraint forces: ``(Rᵀ M R) z̈ = Rᵀ (Q − M q̈₀)`` (Kane's equations / the embedding
  method; Wehage & Haug 1982, Nikravesh 1988 §13).

``Q`` is gravity plus the clearance forces, assembled by the same
:func:`~mechrel.mechanics.problem.applied_forces_trig` as the absolute formulation, so the
physics is the same function of ``(q, q̇)``. The constraints hold to the Newton residual at
every evaluation: there are no Baumgarte terms. The driver power is
``q̇ᵀ (M q̈ − Q)`` (the ideal joints do no work, and the clearance rows' multipliers vanish
by the projected equation), the clearance power is the force law's.

The functions here are the problem interface of :mod:`mechrel.mechanics.formulation` for a
:class:`ReducedSystem`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from ..forces.joint import clearance_force
from ..forces.params import P_C
from .borrow import borrowed
from .kinematics import LUFactors, _lu_factor, _lu_solve, _lu_workspace
from .problem import (Workspace, applied_forces_trig, constraint_terms, driver_law, gap_of,
                      joint_state, make_workspace, n_contacts)
from .system import System

# the public entry points; the ``*_inline`` variants and ``expand_rows`` are building blocks
# of the functions below
__all__ = ["NEWTON_TOL", "NEWTON_ACCEPT", "NEWTON_MAX_ITER", "N_SLOTS", "PIVOT_THRESHOLD",
           "ReducedSystem", "ReducedWorkspace", "make_reduced_workspace", "solve_positions",
           "reduced_rhs_into", "reduced_gaps_into", "reduced_fd_jacobian", "reduced_system",
           "initial_state", "expand_solution", "reduced_clearance_jacobian"]

NEWTON_TOL = 64 * 2.220446049250313e-16
"""Newton tolerance on max |Φ|, relative to the mechanism's size ``ReducedSystem.length`` (-):
a few hundred units of round-off, so that the eccentricity the force laws see differs from
``z`` by far less than the finite-difference increments of the Jacobian (√u c)."""
NEWTON_ACCEPT = 1e-10
"""A Newton iteration that stops contracting (round-off) is accepted below this residual,
relative to ``length`` (-)."""
NEWTON_MAX_ITER = 12
N_SLOTS = 4
"""Solutions kept for the Newton predictor: Radau evaluates three stage times per iteration
and the step's end, each warm-started from its own last solution."""


class ReducedSystem(NamedTuple):
    """A fully driven mechanism with clearance joints in the reduced formulation.

    ``dyn`` is the dynamic :class:`~mechrel.mechanics.system.System` (masses, gravity, the
    clearance joints as force elements); ``con`` the square constraint system: the ideal
    joints, the drivers and every clearance joint as a revolute joint at zero offset, without
    Baumgarte terms. Clearance joint k (in ``dyn``'s order) is the pair of rows
    ``cl_row[k], cl_row[k] + 1`` of ``con``, which read ``sign_k (r_S − r_B)``.

    Parameters
    ----------
    dyn : System
        The dynamic system (its fields: :class:`~mechrel.mechanics.system.System`).
    con : System
        The square constraint system described above.
    cl_row : ndarray of int, shape (nc,)
        First row of each clearance joint in ``con``.
    cl_sign : ndarray, shape (nc,)
        ±1.0: the sign that makes those rows the eccentricity ``r_S − r_B`` (m).
    q_guess : ndarray, shape (n,)
        A configuration near the start (m, rad): the first Newton predictor.
    jac_floor : ndarray, shape (4 nc,)
        Floors of the finite-difference increments: the clearance ``c`` (m) for ``z``,
        ``c`` × the fastest driver speed (m/s) for ``ż``.
    length : float
        The mechanism's size (m): largest |x|, |y| of a body at the start, at least 1e-3 m.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-lubricated")
    >>> c = compile_scene(scene)
    >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    >>> qa, _ = assemble(c.assembly, q0, 0.0)
    >>> rs = reduced_system(scene, c, qa)
    >>> rs.cl_row.shape, rs.n_states, rs.length
    ((1,), 6, 0.17)
    """

    dyn: System
    con: System
    cl_row: np.ndarray  # (nc,) int
    cl_sign: np.ndarray  # (nc,) ±1.0
    q_guess: np.ndarray  # (n,) m, rad: a configuration near the start (the first predictor)
    jac_floor: np.ndarray  # (4 nc,) floors of the finite-difference increments: c, c ω (m, m/s)
    length: float  # m: the mechanism's size (largest |x|, |y| of a body at the start, ≥ 1e-3)

    @property
    def cl_p(self):  # the force-law parameters, as System.cl_p (for the integrators' advice)
        """The clearance joints' force-law parameters, as ``System.cl_p`` of ``dyn``.

        Returns
        -------
        ndarray, shape (nc, N_PARAMS)
            The packed parameters (:mod:`mechrel.forces.params`), read by the integrators' advice.

        Examples
        --------
        >>> from mechrel.mechanics.kinematics import assemble
        >>> from mechrel.mechanics.system import compile_scene
        >>> from mechrel.scene import load_scene
        >>> scene = load_scene("slider-crank-lubricated")
        >>> c = compile_scene(scene)
        >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
        >>> qa, _ = assemble(c.assembly, q0, 0.0)
        >>> rs = reduced_system(scene, c, qa)
        >>> rs.cl_p is rs.dyn.cl_p
        True
        """
        return self.dyn.cl_p

    @property
    def n_states(self) -> int:
        """Length of the reduced state ``x = (z, ż, W_in, W_cl)``: ``4 nc + 2``.

        Returns
        -------
        int
            The number of states.

        Examples
        --------
        >>> from mechrel.mechanics.kinematics import assemble
        >>> from mechrel.mechanics.system import compile_scene
        >>> from mechrel.scene import load_scene
        >>> scene = load_scene("slider-crank-lubricated")
        >>> c = compile_scene(scene)
        >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
        >>> qa, _ = assemble(c.assembly, q0, 0.0)
        >>> rs = reduced_system(scene, c, qa)
        >>> rs.n_states
        6
        """
        return 4 * self.cl_row.shape[0] + 2


class ReducedWorkspace(NamedTuple):
    """Arrays of one reduced right-hand-side evaluation and the Newton predictor's cache.

    After :func:`reduced_rhs_into` ``q``, ``v``, ``a`` hold the bodies' coordinates,
    velocities and accelerations and ``res[0]`` the Newton residual max |Φ|. Built by
    :func:`make_reduced_workspace`; one per kernel call, not shared between threads. ``n``
    is the number of coordinates (3 per body), ``nz = 2 nc``, ``nh`` the number of
    contact-capable joints, ``N_SLOTS`` the predictor's cache size.

    Parameters
    ----------
    cws : Workspace
        Constraint terms of ``con`` (:class:`~mechrel.mechanics.problem.Workspace`).
    lu : LUFactors
        Sparse LU factors of Φ_q (:mod:`mechrel.mechanics.kinematics`).
    A : ndarray, shape (n, n)
        Φ_q, dense (overwritten by the factorisation).
    q, v, a : ndarray, shape (n,)
        The bodies' coordinates (m, rad), velocities (m/s, rad/s), accelerations (m/s², rad/s²).
    R : ndarray, shape (n, nz)
        ∂q/∂z (-, rad/m).
    v0 : ndarray, shape (n,)
        q̇ at ż = 0 (m/s, rad/s).
    b : ndarray, shape (n,)
        Work array.
    Q : ndarray, shape (n,)
        Applied generalised forces (N, N·m).
    Mr : ndarray, shape (nz, nz)
        Rᵀ M R (kg).
    fr : ndarray, shape (nz,)
        Rᵀ (Q − M q̈₀) (N).
    gap, gaprate : ndarray, shape (nh,)
        Penetration (m) and its rate (m/s) of each contact-capable joint.
    qc, vc, ac : ndarray, shape (N_SLOTS, n)
        The cached solutions q, q̇, q̈ of the last distinct times.
    Rc : ndarray, shape (N_SLOTS, n, nz)
        The cached ∂q/∂z.
    zc : ndarray, shape (N_SLOTS, 3, nz)
        The cached z (m), ż (m/s), z̈ (m/s²).
    tc : ndarray, shape (N_SLOTS,)
        Time of each slot (s).
    ok : ndarray, shape (N_SLOTS,)
        1.0 once a slot is written.
    slot : ndarray of int, shape (2,)
        The slot read by the last solve, the next slot to replace.
    res : ndarray, shape (2,)
        Newton residual of the last evaluation (m), residual of its velocity solve (m/s).

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-lubricated")
    >>> c = compile_scene(scene)
    >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    >>> qa, _ = assemble(c.assembly, q0, 0.0)
    >>> rs = reduced_system(scene, c, qa)
    >>> rw = make_reduced_workspace(rs)
    >>> rw.q.shape, rw.R.shape, rw.zc.shape[1:]
    ((9,), (9, 2), (3, 2))
    """

    cws: Workspace  # constraint terms of ``con`` (cos/sin, Φ, Φ̇, γ, Φ_q's rows)
    lu: LUFactors  # sparse LU of Φ_q
    A: np.ndarray  # (n, n) Φ_q, dense (overwritten by the factorisation)
    q: np.ndarray  # (n,)
    v: np.ndarray  # (n,)
    a: np.ndarray  # (n,)
    R: np.ndarray  # (n, nz) ∂q/∂z
    v0: np.ndarray  # (n,) q̇ at ż = 0
    b: np.ndarray  # (n,) work
    Q: np.ndarray  # (n,) applied forces
    Mr: np.ndarray  # (nz, nz) Rᵀ M R
    fr: np.ndarray  # (nz,) Rᵀ (Q − M q̈₀)
    gap: np.ndarray  # (nh,)
    gaprate: np.ndarray  # (nh,)
    # the predictor's cache: the last solutions at N_SLOTS distinct times (a stiff integrator
    # evaluates its stages at a few fixed times while it iterates), slot s valid if ok[s]
    qc: np.ndarray  # (N_SLOTS, n)
    Rc: np.ndarray  # (N_SLOTS, n, nz)
    vc: np.ndarray  # (N_SLOTS, n) q̇
    ac: np.ndarray  # (N_SLOTS, n) q̈
    zc: np.ndarray  # (N_SLOTS, 3, nz) z, ż, z̈
    tc: np.ndarray  # (N_SLOTS,) time of each slot
    ok: np.ndarray  # (N_SLOTS,) 1.0 once written
    slot: np.ndarray  # (2,) int: the slot read by the last solve, the next slot to replace
    res: np.ndarray  # (2,) Newton residual of the last evaluation (m), velocity residual (m/s)


@njit(cache=True)
def make_reduced_workspace(rs):
    """A :class:`ReducedWorkspace` for ``rs``, its predictor cache filled with ``rs.q_guess``.

    Parameters
    ----------
    rs : ReducedSystem
        The reduced system.

    Returns
    -------
    ReducedWorkspace
        Fresh arrays for :func:`reduced_rhs_into` and its callers.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-lubricated")
    >>> c = compile_scene(scene)
    >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    >>> qa, _ = assemble(c.assembly, q0, 0.0)
    >>> rs = reduced_system(scene, c, qa)
    >>> rw = make_reduced_workspace(rs)
    >>> bool((rw.q == rs.q_guess).all()), rw.Mr.shape
    (True, (2, 2))
    """
    n = rs.con.mass.shape[0]
    nz = 2 * rs.cl_row.shape[0]
    nh = n_contacts(rs.dyn)
    qc = np.empty((N_SLOTS, n))
    for s in range(N_SLOTS):
        qc[s] = rs.q_guess
    return ReducedWorkspace(make_workspace(rs.con), _lu_workspace(n), np.zeros((n, n)),
                            rs.q_guess.copy(), np.zeros(n), np.zeros(n), np.zeros((n, nz)),
                            np.zeros(n), np.zeros(n), np.zeros(n), np.zeros((nz, nz)),
                            np.zeros(nz), np.zeros(nh), np.zeros(nh), qc,
                            np.zeros((N_SLOTS, n, nz)), np.zeros((N_SLOTS, n)),
                            np.zeros((N_SLOTS, n)), np.zeros((N_SLOTS, 3, nz)),
                            np.zeros(N_SLOTS), np.zeros(N_SLOTS),
                            np.zeros(2, dtype=np.int64), np.zeros(2))


PIVOT_THRESHOLD = 0.1
"""Threshold pivoting: the factorisation keeps its recorded pivot order while each planned
pivot is at least this fraction of the largest candidate in its column (the bound on the
multipliers, 1 / 0.1, keeps the growth of the elimination bounded, as threshold partial
pivoting in sparse direct solvers does); otherwise it pivots afresh. Strict partial pivoting
re-planned the factorisation whenever two candidates swapped order as the mechanism moved."""


@njit(cache=True, inline='always')
def _lu_refactor_threshold(A, f):
    """:func:`mechrel.mechanics.kinematics._lu_refactor` with threshold pivoting
    (:data:`PIVOT_THRESHOLD`): returns False (factors unusable) when ``A`` has a non-zero
    outside the planned pattern or a planned pivot falls below the threshold."""
    n = A.shape[0]
    lp, lr, lv, up, ui, uv, ur, ud, pp, pr, pat, perm, wk, y, off, valid = f
    if not valid[0]:
        return False
    bits = np.ascontiguousarray(A).reshape(n * n).view(np.int64)
    outside = 0
    for i in range(n * n):
        outside |= bits[i] & off[i]
    if outside != 0:
        return False
    for k in range(n):
        prow = ur[k]
        amax = 0.0
        for r in range(pp[k], pp[k + 1]):
            a = abs(A[pr[r], k])
            if a > amax:
                amax = a
        piv = A[prow, k]
        if not abs(piv) >= PIVOT_THRESHOLD * amax or piv == 0.0:
            return False
        rd = 1.0 / piv
        ud[k] = rd
        u0 = up[k]
        u1 = up[k + 1]
        for c in range(u0, u1):
            uv[c] = A[prow, ui[c]]
        for r in range(lp[k], lp[k + 1]):
            i = lr[r]
            el = A[i, k] * rd
            lv[r] = el
            for c in range(u0, u1):
                A[i, ui[c]] -= el * uv[c]
    return True


@njit(cache=True, inline='always')
def _factor_jacobian(rs, rw):
    """Φ_q from the sparse rows in ``rw.cws.coef`` into the dense ``rw.A``, factored into
    ``rw.lu`` (by the previous factorisation's plan when it still applies)."""
    A = rw.A
    co = rw.cws.coef
    rb = rs.con.row_body
    n = A.shape[0]
    for i in range(n):
        for j in range(n):
            A[i, j] = 0.0
    for r in range(n):
        for s in range(2):
            body = rb[r, s]
            if body >= 0:
                o = 6 * r + 3 * s
                A[r, 3 * body] += co[o]
                A[r, 3 * body + 1] += co[o + 1]
                A[r, 3 * body + 2] += co[o + 2]
    if not _lu_refactor_threshold(A, rw.lu):
        for i in range(n):
            for j in range(n):
                A[i, j] = 0.0
        for r in range(n):
            for s in range(2):
                body = rb[r, s]
                if body >= 0:
                    o = 6 * r + 3 * s
                    A[r, 3 * body] += co[o]
                    A[r, 3 * body + 1] += co[o + 1]
                    A[r, 3 * body + 2] += co[o + 2]
        _lu_factor(A, rw.lu)


@njit(cache=True, inline='always')
def solve_positions_inline(t, z, rs, rw):
    """``q`` with ``Φ(q, t; z) = 0`` into ``rw.q`` (Newton from the cache's predictor), with
    Φ_q factored at it and its constraint terms in ``rw.cws``. Returns max |Φ| (m), NaN when
    Newton fails. (The arrays are borrowed: docs/architecture.md.)"""
    z, rs, rw = borrowed((z, rs, rw))
    n = rw.q.shape[0]
    nc = rs.cl_row.shape[0]
    q = rw.q
    # the slot nearest in time (a never-written slot holds q_guess with R = 0, q̇ = q̈ = 0);
    # second order: q ≈ q_c + q̇_c Δt + q̈_c Δt²/2 + R (z − z_c(t)) with z_c(t) the slot's z
    # continued to second order, so the error is O(Δt³, Δt |z − z_c(t)|, |z − z_c(t)|²)
    tc = rw.tc
    ok = rw.ok
    best = 0
    dbest = math.inf
    for sl in range(N_SLOTS):
        d = abs(t - tc[sl]) if ok[sl] != 0.0 else math.inf
        if d < dbest:
            dbest = d
            best = sl
    rw.slot[0] = best
    qc = rw.qc[best]
    zc = rw.zc[best]
    Rc = rw.Rc[best]
    vc = rw.vc[best]
    ac = rw.ac[best]
    dt = t - tc[best] if ok[best] != 0.0 else 0.0
    hdt2 = 0.5 * dt * dt
    dz = rw.fr  # work (overwritten later by the projected equations)
    for c in range(2 * nc):
        dz[c] = z[c] - (zc[0, c] + zc[1, c] * dt + zc[2, c] * hdt2)
    for i in range(n):
        s = qc[i] + vc[i] * dt + ac[i] * hdt2
        for c in range(2 * nc):
            s += Rc[i, c] * dz[c]
        q[i] = s
    cws = rw.cws
    phi = cws.phi
    b = rw.b
    cl_row = rs.cl_row
    cl_sign = rs.cl_sign
    tol = NEWTON_TOL * rs.length
    accept = NEWTON_ACCEPT * rs.length
    prev = math.inf
    it = 0
    while True:
        constraint_terms(t, q, rw.v, rs.con, cws)
        for k in range(nc):
            r = cl_row[k]
            phi[r] -= cl_sign[k] * z[2 * k]
            phi[r + 1] -= cl_sign[k] * z[2 * k + 1]
        res = 0.0
        for i in range(n):
            a = abs(phi[i])
            if a > res or a != a:
                res = a
        if res != res:
            return math.nan
        _factor_jacobian(rs, rw)
        # converged, or stopped contracting at round-off level
        if res <= tol or (it > 0 and res > 0.5 * prev and res <= accept):
            return res
        if it >= NEWTON_MAX_ITER:
            return math.nan
        for i in range(n):
            b[i] = phi[i]
        _lu_solve(rw.lu, b)
        for i in range(n):
            q[i] -= b[i]
        prev = res
        it += 1


@njit(cache=True)
def solve_positions(t, z, rs, rw):
    """``q`` with ``Φ(q, t; z) = 0`` into ``rw.q`` (Newton from the cache's predictor).

    Φ_q is left factored at the solution and its constraint terms in ``rw.cws``. The arrays
    are borrowed (docs/architecture.md).

    Parameters
    ----------
    t : float
        Time (s).
    z : ndarray, shape (2 nc,)
        The clearance joints' eccentricities (m), in ``rs.dyn``'s order.
    rs : ReducedSystem
        The reduced system.
    rw : ReducedWorkspace
        Its workspace; ``q`` receives the solution.

    Returns
    -------
    float
        max |Φ| at the solution (m), NaN when Newton fails.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-lubricated")
    >>> c = compile_scene(scene)
    >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    >>> qa, _ = assemble(c.assembly, q0, 0.0)
    >>> rs = reduced_system(scene, c, qa)
    >>> rw = make_reduced_workspace(rs)
    >>> bool(solve_positions(0.0, np.zeros(2), rs, rw) < 1e-12)
    True
    """
    return solve_positions_inline(t, z, rs, rw)


@njit(cache=True, inline='always')
def reduced_rhs_inline(t, x, hist, rs, rw, out):
    """``dx/dt`` for ``x = (z, ż, W_in, W_cl)`` into ``out``; the bodies' ``q, q̇, q̈`` into
    ``rw``. A failed position solve gives NaN (the integrator then shrinks its step)."""
    x, hist, rs, rw, out = borrowed((x, hist, rs, rw, out))
    dyn = rs.dyn
    nc = rs.cl_row.shape[0]
    nz = 2 * nc
    n = rw.q.shape[0]
    z = x[:nz]
    zd = x[nz:2 * nz]
    res = solve_positions_inline(t, z, rs, rw)
    rw.res[0] = res
    if res != res:
        for i in range(out.shape[0]):
            out[i] = math.nan
        return
    lu = rw.lu
    R = rw.R
    b = rw.b
    v0 = rw.v0
    cl_row = rs.cl_row
    cl_sign = rs.cl_sign
    con = rs.con
    dr_i = con.dr_i
    nd = dr_i.shape[0]
    # R = Φ_q⁻¹ P
    for c in range(nz):
        for i in range(n):
            b[i] = 0.0
        b[cl_row[c // 2] + (c % 2)] = cl_sign[c // 2]
        _lu_solve(lu, b)
        for i in range(n):
            R[i, c] = b[i]
    # q̇₀ (drivers only), q̇ = q̇₀ + R ż
    for i in range(n):
        v0[i] = 0.0
    for d in range(nd):
        _, w, _ = driver_law(con.dr_law[d], con.dr_par[d], t)
        v0[n - nd + d] = w
    _lu_solve(lu, v0)
    v = rw.v
    q = rw.q
    for i in range(n):
        s = v0[i]
        for c in range(nz):
            s += R[i, c] * zd[c]
        v[i] = s
    # γ at (q, q̇), then q̈₀ = Φ_q⁻¹ γ
    cws = rw.cws
    constraint_terms(t, q, v, con, cws)
    a = rw.a
    gam = cws.c
    for i in range(n):
        a[i] = gam[i]
    _lu_solve(lu, a)
    # applied forces at (q, q̇)
    Q = rw.Q
    for i in range(n):
        Q[i] = 0.0
    pcl, _ = applied_forces_trig(t, q, v, hist, dyn, Q, cws.cs, cws.sn, rw.gap, rw.gaprate)
    mass = dyn.mass
    Mr = rw.Mr
    fr = rw.fr
    for c in range(nz):
        s = 0.0
        for i in range(n):
            s += R[i, c] * (Q[i] - mass[i] * a[i])
        fr[c] = s
        for d in range(c + 1):
            s = 0.0
            for i in range(n):
                s += R[i, c] * mass[i] * R[i, d]
            Mr[c, d] = s
            Mr[d, c] = s
    # (Rᵀ M R) z̈ = fr by Cholesky (symmetric positive definite: M > 0, R of full rank)
    for j in range(nz):
        s = Mr[j, j]
        for k in range(j):
            s -= Mr[j, k] * Mr[j, k]
        if not s > 0.0:
            for i in range(out.shape[0]):
                out[i] = math.nan
            return
        d = math.sqrt(s)
        Mr[j, j] = d
        for i in range(j + 1, nz):
            s = Mr[i, j]
            for k in range(j):
                s -= Mr[i, k] * Mr[j, k]
            Mr[i, j] = s / d
    for i in range(nz):
        s = fr[i]
        for k in range(i):
            s -= Mr[i, k] * fr[k]
        fr[i] = s / Mr[i, i]
    for i in range(nz - 1, -1, -1):
        s = fr[i]
        for k in range(i + 1, nz):
            s -= Mr[k, i] * fr[k]
        fr[i] = s / Mr[i, i]
    pin = 0.0
    for i in range(n):
        s = a[i]
        for c in range(nz):
            s += R[i, c] * fr[c]
        a[i] = s
        pin += v[i] * (mass[i] * s - Q[i])
    for c in range(nz):
        out[c] = zd[c]
        out[nz + c] = fr[c]
    out[2 * nz] = pin
    out[2 * nz + 1] = pcl
    # velocity residual of Φ_q q̇ = b (round-off of the solve), for the statistics
    pd = cws.phidot
    vres = 0.0
    for k in range(nc):
        r = cl_row[k]
        pd[r] -= cl_sign[k] * zd[2 * k]
        pd[r + 1] -= cl_sign[k] * zd[2 * k + 1]
    for i in range(n):
        vres = max(vres, abs(pd[i]))
    rw.res[1] = vres
    # the predictor's cache: the slot read if it is at this time, else the next in turn
    sl = rw.slot[0]
    if rw.ok[sl] == 0.0 or rw.tc[sl] != t:
        sl = rw.slot[1]
        rw.slot[1] = (sl + 1) % N_SLOTS
    qc = rw.qc[sl]
    vc = rw.vc[sl]
    ac = rw.ac[sl]
    Rc = rw.Rc[sl]
    zc = rw.zc[sl]
    for i in range(n):
        qc[i] = q[i]
        vc[i] = v[i]
        ac[i] = a[i]
        for c in range(nz):
            Rc[i, c] = R[i, c]
    for c in range(nz):
        zc[0, c] = z[c]
        zc[1, c] = zd[c]
        zc[2, c] = out[nz + c]
    rw.tc[sl] = t
    rw.ok[sl] = 1.0


@njit(cache=True)
def reduced_rhs_into(t, x, hist, rs, rw, out):
    """``dx/dt`` for ``x = (z, ż, W_in, W_cl)`` into ``out``; the bodies' ``q, q̇, q̈`` into ``rw``.

    A failed position solve gives NaN (the integrator then shrinks its step).

    Parameters
    ----------
    t : float
        Time (s).
    x : ndarray, shape (4 nc + 2,)
        Eccentricities ``z`` (m), their rates ``ż`` (m/s), the input and clearance work (J).
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (the impact speed, m/s).
    rs : ReducedSystem
        The reduced system.
    rw : ReducedWorkspace
        Its workspace; receives ``q``, ``v``, ``a`` and the residuals ``res``.
    out : ndarray, shape (4 nc + 2,)
        Receives ``(ż, z̈, P_in, P_cl)`` (m/s, m/s², W, W).

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-lubricated")
    >>> c = compile_scene(scene)
    >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    >>> qa, _ = assemble(c.assembly, q0, 0.0)
    >>> rs = reduced_system(scene, c, qa)
    >>> rw = make_reduced_workspace(rs)
    >>> x = initial_state(scene, rs)
    >>> out = np.empty_like(x)
    >>> reduced_rhs_into(0.0, x, np.zeros(0), rs, rw, out)
    >>> out[:2].tolist(), bool(rw.res[0] < 1e-12)
    ([0.0, 0.0], True)
    """
    reduced_rhs_inline(t, x, hist, rs, rw, out)


@njit(cache=True)
def reduced_gaps_into(t, x, rs, g, gd):
    """Penetration δ = |e| − c (m) and its rate (m/s) of the contact-capable joints.

    Straight from ``z`` and ``ż``: no position solve is needed, ``z`` holds the eccentricities.

    Parameters
    ----------
    t : float
        Time (s).
    x : ndarray, shape (4 nc + 2,)
        The reduced state (:func:`reduced_rhs_into`).
    rs : ReducedSystem
        The reduced system.
    g, gd : ndarray, shape (nh,)
        Receive δ (m) and δ̇ (m/s), in ``hist`` order.

    Examples
    --------
    The lubricated slider-crank has no contact-capable joint (``nh = 0``):

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-lubricated")
    >>> c = compile_scene(scene)
    >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    >>> qa, _ = assemble(c.assembly, q0, 0.0)
    >>> rs = reduced_system(scene, c, qa)
    >>> g, gd = np.empty(0), np.empty(0)
    >>> reduced_gaps_into(0.0, initial_state(scene, rs), rs, g, gd)
    >>> g.shape
    (0,)
    """
    x, rs, g, gd = borrowed((x, rs, g, gd))
    dyn = rs.dyn
    nc = rs.cl_row.shape[0]
    for k in range(nc):
        h = dyn.cl_hist[k]
        if h >= 0:
            g[h], gd[h] = gap_of(x[2 * k], x[2 * k + 1], x[2 * nc + 2 * k],
                                 x[2 * nc + 2 * k + 1], dyn.cl_p[k, P_C])


@njit(cache=True)
def reduced_fd_jacobian(t, x, f0, hist, rs, rw, J, xp, fp):
    """``J = ∂f/∂x`` by forward differences of :func:`reduced_rhs_into`.

    The increments are ``√u max(|x_j|, floor_j)`` (``floor``: ``ReducedSystem.jac_floor``),
    the rows ``dz/dt = ż`` are exact and the work integrals' columns zero.

    Parameters
    ----------
    t : float
        Time (s).
    x : ndarray, shape (ny,)
        The reduced state, ``ny = 4 nc + 2``.
    f0 : ndarray, shape (ny,)
        ``f(t, x)``.
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (m/s).
    rs : ReducedSystem
        The reduced system.
    rw : ReducedWorkspace
        Its workspace.
    J : ndarray, shape (ny, ny)
        Receives the Jacobian (SI units of ``f`` over those of ``x``).
    xp, fp : ndarray, shape (ny,)
        Work arrays.

    Returns
    -------
    int
        The number of right-hand-side evaluations, ``4 nc``.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-lubricated")
    >>> c = compile_scene(scene)
    >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    >>> qa, _ = assemble(c.assembly, q0, 0.0)
    >>> rs = reduced_system(scene, c, qa)
    >>> rw = make_reduced_workspace(rs)
    >>> x = initial_state(scene, rs)
    >>> f0 = np.empty_like(x)
    >>> reduced_rhs_into(0.0, x, np.zeros(0), rs, rw, f0)
    >>> J = np.zeros((6, 6))
    >>> reduced_fd_jacobian(0.0, x, f0, np.zeros(0), rs, rw, J, np.empty(6), np.empty(6))
    4
    >>> J[:2].tolist()
    [[0.0, 0.0, 1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0, 0.0, 0.0]]
    """
    x, f0, hist, rs, rw, J, xp, fp = borrowed((x, f0, hist, rs, rw, J, xp, fp))
    nz = 2 * rs.cl_row.shape[0]
    ny = x.shape[0]
    floor = rs.jac_floor
    for i in range(nz):
        for j in range(ny):
            J[i, j] = 0.0
        J[i, nz + i] = 1.0
    for i in range(nz, ny):
        for j in range(2 * nz, ny):
            J[i, j] = 0.0
    for j in range(ny):
        xp[j] = x[j]
    for j in range(2 * nz):
        xj = x[j]
        xp[j] = xj + 1.4901161193847656e-08 * max(abs(xj), floor[j])
        d = xp[j] - xj
        reduced_rhs_into(t, xp, hist, rs, rw, fp)
        for i in range(nz, ny):
            J[i, j] = (fp[i] - f0[i]) / d
        xp[j] = xj
    return 2 * nz


@njit(cache=True)
def expand_rows(times, X, H, rs):
    """The absolute state ``y = (q, q̇, W_in, W_cl)`` and its derivative
    ``(q̇, q̈, P_in, P_cl)`` at each row ``(t, x, hist)`` of a reduced solution, in order
    (each row's position solve starts from the previous row's solution). Returns
    ``(Y, YD, max Newton residual)``; rows whose position solve fails are NaN."""
    N = X.shape[0]
    n = rs.con.mass.shape[0]
    nx = X.shape[1]
    Y = np.empty((N, 2 * n + 2))
    YD = np.empty((N, 2 * n + 2))
    rw = make_reduced_workspace(rs)
    f = np.empty(nx)
    res = 0.0
    for r in range(N):
        reduced_rhs_into(times[r], X[r], H[r], rs, rw, f)
        res = max(res, rw.res[0])
        for i in range(n):
            Y[r, i] = rw.q[i]
            Y[r, n + i] = rw.v[i]
            YD[r, i] = rw.v[i]
            YD[r, n + i] = rw.a[i]
        Y[r, 2 * n] = X[r, nx - 2]
        Y[r, 2 * n + 1] = X[r, nx - 1]
        YD[r, 2 * n] = f[nx - 2]
        YD[r, 2 * n + 1] = f[nx - 1]
    return Y, YD, res


def reduced_system(scene, compiled, q0) -> ReducedSystem:
    """The :class:`ReducedSystem` of a compiled scene.

    Parameters
    ----------
    scene : Scene
        The scene (its clearance joints' order and drivers).
    compiled : CompiledScene
        ``compile_scene(scene)``.
    q0 : ndarray, shape (n,)
        The assembled coordinates at the start (m, rad): the first Newton predictor and the
        mechanism's size.

    Returns
    -------
    ReducedSystem
        The reduced formulation of the scene.

    Raises
    ------
    SimulationError
        No clearance joint (nothing to integrate), or an ideal degree of freedom that no
        driver fixes (the constraints with every clearance joint held would not be square),
        or a constraint Jacobian that is singular at the start.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-lubricated")
    >>> c = compile_scene(scene)
    >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    >>> qa, _ = assemble(c.assembly, q0, 0.0)
    >>> rs = reduced_system(scene, c, qa)
    >>> rs.con.mass.shape, rs.cl_row.shape
    ((9,), (1,))
    """
    from ..errors import SimulationError
    from ..scene.model import GROUND

    where = scene.source or scene.name
    n = compiled.q_guess.size
    asm = compiled.assembly
    if not compiled.clearance_names:
        raise SimulationError(
            f"{where}: formulation = 'reduced': the scene has no clearance joint, so there is "
            "nothing to integrate in the reduced coordinates; allowed: 'absolute' (or the "
            "kinematic analysis of a fully driven scene)")
    if asm.n_constraints != n:
        raise SimulationError(
            f"{where}: formulation = 'reduced': with every clearance joint held the mechanism "
            f"has {asm.n_constraints} constraint equations for {n} coordinates, so "
            f"{n - asm.n_constraints} ideal degree(s) of freedom are not driven; allowed: "
            "'reduced' for scenes whose ideal degrees of freedom are all driven, 'absolute' "
            "for any scene")
    rows, signs = [], []
    r = 0
    for joint in scene.joints.values():
        if joint.type != "revolute":
            continue
        if joint.is_clearance:
            rows.append(2 * r)
            # rows read r_i − r_j with i the journal's body, unless that is the ground
            signs.append(-1.0 if joint.points[1].body == GROUND else 1.0)
        r += 1
    zeros = np.zeros_like(asm.rev_off)
    con = asm._replace(rev_off=zeros, rev_offdot=zeros.copy(), baumgarte=np.zeros(2))
    dyn = compiled.dynamic
    q0 = np.ascontiguousarray(q0, dtype=float)
    from .problem import constraints
    _, _, Jq = constraints(q0, 0.0, con)
    if np.linalg.matrix_rank(Jq) < n:
        raise SimulationError(
            f"{where}: formulation = 'reduced': the constraints with every clearance joint "
            "held are singular at the start (a dead-centre position); allowed: 'absolute'")
    speeds = [abs(float(p[1])) for p in con.dr_par]  # D_SPEED
    omega = max(speeds + [1.0])
    c = dyn.cl_p[:, P_C]
    floor = np.concatenate([np.repeat(c, 2), np.repeat(c * omega, 2)])
    xy = np.concatenate([q0[0::3], q0[1::3]])
    length = max(float(np.max(np.abs(xy))), 1e-3)
    return ReducedSystem(dyn=dyn, con=con, cl_row=np.asarray(rows, dtype=np.int64),
                         cl_sign=np.asarray(signs, dtype=float), q_guess=q0.copy(),
                         jac_floor=floor, length=length)


def initial_state(scene, rs: ReducedSystem) -> np.ndarray:
    """``x0 = (e0, ė0, 0, 0)``: the clearance joints' initial eccentricities and rates, zero work.

    Parameters
    ----------
    scene : Scene
        The scene (its joints' ``initial_eccentricity`` and ``initial_eccentricity_rate``).
    rs : ReducedSystem
        Its reduced system.

    Returns
    -------
    ndarray, shape (4 nc + 2,)
        ``(z, ż, W_in, W_cl)`` (m, m/s, J, J), in ``dyn``'s order of the clearance joints.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-lubricated")
    >>> c = compile_scene(scene)
    >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    >>> qa, _ = assemble(c.assembly, q0, 0.0)
    >>> rs = reduced_system(scene, c, qa)
    >>> initial_state(scene, rs).tolist()
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    """
    z = [scene.joints[name].initial_eccentricity for name in _clearance_order(scene)]
    zd = [scene.joints[name].initial_eccentricity_rate for name in _clearance_order(scene)]
    return np.concatenate([np.asarray(z, dtype=float).reshape(-1),
                           np.asarray(zd, dtype=float).reshape(-1), np.zeros(2)])


def _clearance_order(scene):
    return [j.name for j in scene.joints.values() if j.type == "revolute" and j.is_clearance]


def expand_solution(rs: ReducedSystem, t_out, out):
    """A kernel's result on the reduced state, turned into the absolute one.

    The result ``(X, XD, hist, stats, t, x, log, H)`` at the output instants ``t_out``
    becomes ``(Y, YD, hist, stats, t, y, log, H)`` (the log's rows ``(t, x, dx/dt, hist)``
    too), so that everything after the integration reads the same arrays as with the
    absolute formulation. The largest Newton residual of these rows joins the statistics'
    position violation. Rows the kernel did not reach (NaN) stay NaN.

    Parameters
    ----------
    rs : ReducedSystem
        The reduced system.
    t_out : ndarray, shape (N,)
        The output instants (s).
    out : tuple
        The kernel's result ``(X, XD, hist, stats, t, x, log, H)``: ``X``, ``XD`` of shape
        (N, 4 nc + 2), ``H`` of shape (N, nh), ``log`` of rows ``(t, x, dx/dt, hist)``.

    Returns
    -------
    tuple
        ``(Y, YD, hist, stats, t, y, log, H)`` with ``Y``, ``YD`` of shape (N, 2 n + 2):
        ``(q, q̇, W_in, W_cl)`` and ``(q̇, q̈, P_in, P_cl)`` in SI units.

    Examples
    --------
    One output row at the start, no log:

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-lubricated")
    >>> c = compile_scene(scene)
    >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    >>> qa, _ = assemble(c.assembly, q0, 0.0)
    >>> rs = reduced_system(scene, c, qa)
    >>> x0 = initial_state(scene, rs)
    >>> stats = np.zeros(10)
    >>> out = (x0[None], np.zeros((1, 6)), np.zeros(0), stats, 0.0, x0, np.zeros((0, 13)),
    ...        np.zeros((1, 0)))
    >>> Y, YD, *_ = expand_solution(rs, np.zeros(1), out)
    >>> Y.shape, round(float(Y[0, 6]), 9)
    ((1, 20), 0.17)
    """
    from ..integrate.events import S_VIOL_POS

    X, XD, hist, stats, t, x, log, H = out
    n = rs.con.mass.shape[0]
    nx = X.shape[1]
    nh = hist.shape[0]
    done = np.all(np.isfinite(X), axis=1)
    nd = int(done.sum())
    # output instants and log rows expanded together in time order, each position solve
    # starting from its predecessor's: a log that begins a cycle after the start, expanded
    # from the initial configuration, could land on another assembly branch
    T = np.concatenate([np.asarray(t_out, dtype=float)[done], log[:, 0]])
    XX = np.concatenate([X[done], log[:, 1:1 + nx]])
    HH = np.concatenate([H[done], log[:, 1 + 2 * nx:1 + 2 * nx + nh]])
    order = np.argsort(T, kind="stable")
    Ys, YDs, res = expand_rows(np.ascontiguousarray(T[order]), np.ascontiguousarray(XX[order]),
                               np.ascontiguousarray(HH[order]), rs)
    Ya = np.empty_like(Ys)
    YDa = np.empty_like(YDs)
    Ya[order] = Ys
    YDa[order] = YDs
    stats[S_VIOL_POS] = max(stats[S_VIOL_POS], res)
    Y = np.full((X.shape[0], 2 * n + 2), np.nan)
    YD = np.full_like(Y, np.nan)
    Y[done] = Ya[:nd]
    YD[done] = YDa[:nd]
    Yl, YDl = Ya[nd:], YDa[nd:]
    big = np.empty((log.shape[0], 1 + 2 * (2 * n + 2) + nh))
    big[:, 0] = log[:, 0]
    big[:, 1:1 + 2 * n + 2] = Yl
    big[:, 1 + 2 * n + 2:1 + 2 * (2 * n + 2)] = YDl
    big[:, 1 + 2 * (2 * n + 2):] = log[:, 1 + 2 * nx:]
    y = Y[-1].copy() if done.all() else np.full(2 * n + 2, np.nan)
    return Y, YD, hist, stats, t, y, big, H


@njit(cache=True)
def reduced_clearance_jacobian(t, x, hist, rs, rw, f, JS):
    """The fast part of ``∂f/∂x``, the one the clearance forces drive, into ``JS``.

    ``JS``'s rows ``nz … ny − 1`` and columns ``0 … 2 nz − 1`` are written; ``f`` receives
    ``f(t, x)``.

    The generalised force of joint k on ``z`` is ``Rᵀ G_k F_k`` with ``F_k = (F_x, F_y, M_S,
    M_B)``: by virtual work ``F·δe_k + M_S δθ_S + M_B δθ_B`` and ``δe_k = δz_k`` exactly, so its
    columns are the unit vectors of ``z_k`` for ``F_x, F_y`` and the θ-rows of ``R`` for the
    moments. With ``s = (e, ė, ω_B, ω_S)`` the force law's arguments, ``∂e/∂z = I``,
    ``∂ė/∂ż = I`` and ``∂ω/∂ż`` the θ-rows of ``R``,

        ∂z̈/∂x ⊃ (Rᵀ M R)⁻¹ Σ_k (Rᵀ G_k) (∂F_k/∂s) (∂s/∂x),

    with ``∂F/∂s`` by forward differences of the force law alone (δ = √u max(|s_i|, c) for
    the eccentricity and its rate, √u max(|ω|, 1 rad/s) for the angular velocities), ``R``
    and ``G`` held. What it leaves out (the turning of ``R`` and of the lever arms with the
    state, the mechanism's inertia and gravity terms) is smooth, of relative size ``c / L``
    against the film's or contact's stiffness; the integrator takes it from finite
    differences of the mechanism without clearance forces. The clearance power's row gets
    ``∂(F·ė + M_S ω_S + M_B ω_B)/∂x`` on the same terms.

    Parameters
    ----------
    t : float
        Time (s).
    x : ndarray, shape (ny,)
        The reduced state, ``ny = 4 nc + 2``.
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (m/s).
    rs : ReducedSystem
        The reduced system.
    rw : ReducedWorkspace
        Its workspace.
    f : ndarray, shape (ny,)
        Receives ``f(t, x)``.
    JS : ndarray, shape (ny, ny)
        Receives the clearance forces' part of the Jacobian.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-lubricated")
    >>> c = compile_scene(scene)
    >>> q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    >>> qa, _ = assemble(c.assembly, q0, 0.0)
    >>> rs = reduced_system(scene, c, qa)
    >>> rw = make_reduced_workspace(rs)
    >>> x = initial_state(scene, rs)
    >>> f, JS = np.empty(6), np.zeros((6, 6))
    >>> reduced_clearance_jacobian(0.0, x, np.zeros(0), rs, rw, f, JS)
    >>> bool(np.isfinite(JS).all()), f[:2].tolist()
    (True, [0.0, 0.0])
    """
    x, hist, rs, rw, f, JS = borrowed((x, hist, rs, rw, f, JS))
    reduced_rhs_into(t, x, hist, rs, rw, f)  # R, Rᵀ M R's factor, q, q̇ at x
    dyn = rs.dyn
    nc = rs.cl_row.shape[0]
    nz = 2 * nc
    ny = x.shape[0]
    R = rw.R
    L = rw.Mr  # Cholesky factor of Rᵀ M R (lower triangle)
    q = rw.q
    v = rw.v
    cs = rw.cws.cs
    sn = rw.cws.sn
    for i in range(nz, ny):
        for c in range(2 * nz):
            JS[i, c] = 0.0
    s0 = np.empty(6)
    dF = np.empty((4, 6))
    ds = np.zeros((6, 2 * nz))
    G = np.empty((nz, 4))
    H = np.empty((4, 2 * nz))
    col = np.empty(nz)
    for k in range(nc):
        b = dyn.cl_b[k]
        j = dyn.cl_j[k]
        p = dyn.cl_p[k]
        (s0[0], s0[1], s0[2], s0[3], s0[4], s0[5], _, _, _, _) = joint_state(
            q, v, b, j, dyn.cl_sb[k, 0], dyn.cl_sb[k, 1], dyn.cl_sj[k, 0], dyn.cl_sj[k, 1],
            cs, sn)
        h = dyn.cl_hist[k]
        impact = hist[h] if h >= 0 else 0.0
        F0x, F0y, F0s, F0b, _ = clearance_force(s0[0], s0[1], s0[2], s0[3], s0[4], s0[5],
                                                impact, p)
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
            dF[0, i] = (f0_ - F0x) / d
            dF[1, i] = (f1_ - F0y) / d
            dF[2, i] = (f2_ - F0s) / d
            dF[3, i] = (f3_ - F0b) / d
        # ∂s/∂x: e, ė of joint k, ω_B, ω_S through R's θ-rows
        for a in range(6):
            for u in range(2 * nz):
                ds[a, u] = 0.0
        ds[0, 2 * k] = 1.0
        ds[1, 2 * k + 1] = 1.0
        ds[2, nz + 2 * k] = 1.0
        ds[3, nz + 2 * k + 1] = 1.0
        for u in range(nz):
            ds[4, nz + u] = R[3 * b + 2, u] if b >= 0 else 0.0
            ds[5, nz + u] = R[3 * j + 2, u] if j >= 0 else 0.0
        for r in range(4):
            for u in range(2 * nz):
                acc = 0.0
                for a in range(6):
                    acc += dF[r, a] * ds[a, u]
                H[r, u] = acc
        # Rᵀ G_k: unit columns of z_k for (F_x, F_y), θ-rows of R for (M_S, M_B)
        for i in range(nz):
            G[i, 0] = 0.0
            G[i, 1] = 0.0
            G[i, 2] = R[3 * j + 2, i] if j >= 0 else 0.0
            G[i, 3] = R[3 * b + 2, i] if b >= 0 else 0.0
        G[2 * k, 0] = 1.0
        G[2 * k + 1, 1] = 1.0
        for u in range(2 * nz):
            for i in range(nz):
                col[i] = G[i, 0] * H[0, u] + G[i, 1] * H[1, u] + G[i, 2] * H[2, u] \
                    + G[i, 3] * H[3, u]
            # (Rᵀ M R)⁻¹ col with the Cholesky factor L
            for i in range(nz):
                s_ = col[i]
                for m in range(i):
                    s_ -= L[i, m] * col[m]
                col[i] = s_ / L[i, i]
            for i in range(nz - 1, -1, -1):
                s_ = col[i]
                for m in range(i + 1, nz):
                    s_ -= L[m, i] * col[m]
                col[i] = s_ / L[i, i]
            for i in range(nz):
                JS[nz + i, u] += col[i]
            # clearance power F·ė + M_S ω_S + M_B ω_B
            JS[2 * nz + 1, u] += (s0[2] * H[0, u] + s0[3] * H[1, u] + s0[5] * H[2, u]
                                  + s0[4] * H[3, u] + F0x * ds[2, u] + F0y * ds[3, u]
                                  + F0s * ds[5, u] + F0b * ds[4, u])
