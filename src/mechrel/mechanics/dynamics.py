"""The forward-dynamics right-hand side: accelerations and multipliers of a state.

Owns the equations of motion and their solution: the :class:`Workspace` of one evaluation
(:func:`make_workspace`), the accelerations and Lagrange multipliers
(:func:`accelerations_into`, :func:`accelerations`) and the right-hand side ``dy/dt``
(:func:`rhs_into`, the kernels' allocation-free form; :func:`rhs_inline`, the same body for one
inlined call site per kernel; :func:`rhs`, a fresh array for Python callers). The integrator
kernels in :mod:`mechrel.integrate` call these by module-global reference
(docs/architecture.md). All ``@njit(cache=True)``.

Formulation (Nikravesh 1988, *Computer-Aided Analysis of Mechanical Systems*, ch. 6 and 13;
Baumgarte 1972): with ``q`` the absolute coordinates, ``Φ(q, t) = 0`` the constraints
(:mod:`mechrel.mechanics.constraints`) and ``Q`` the applied forces
(:mod:`mechrel.mechanics.applied`),

    [ M    Φ_qᵀ ] [ q̈ ]   [ Q                        ]
    [ Φ_q  0    ] [ λ  ] = [ γ − 2α Φ̇ − β² Φ          ]     (paper eq. 24, corrected)

with ``γ = −(Φ_q q̇)_q q̇ − 2 Φ_qt q̇ − Φ_tt`` and ``Φ̇ = Φ_q q̇ + Φ_t``. ``M`` is diagonal, so the
system is solved through the Schur complement ``S = Φ_q M⁻¹ Φ_qᵀ`` (m × m, symmetric positive
definite while the constraints are independent):
``S λ = Φ_q M⁻¹ Q − c``, ``q̈ = M⁻¹ (Q − Φ_qᵀ λ)``, by a sparse Cholesky factorisation whose
pattern :func:`~mechrel.mechanics.system.schur_structure` precomputes.

State vector ``y = [q (n), q̇ (n), W_in, W_cl]``: the last two entries (``N_WORK``) integrate
the power of the drivers (input work, J) and of the clearance-joint forces (J), for energy
balances.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .applied import applied_forces_trig
from .borrow import borrowed
from .constraints import constraint_terms, n_constraints
from .joints import n_contacts

N_WORK = 2  # extra states: driver work, clearance-force work


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
        Penetration δ (m) and its rate δ̇ (m/s) of each contact-capable joint, as
        :func:`~mechrel.mechanics.joints.gaps`.

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
    (:func:`~mechrel.mechanics.constraints.constraint_terms`). The drivers' generalized force
    is ``−Φ_q,dᵀ λ_d``, so their power is ``−Σ λ_d θ̇_d``.

    Inlined, it does not borrow its arguments (:mod:`mechrel.mechanics.borrow`, "The rules");
    each System and Workspace attribute it reads costs a reference-count pair unless the
    caller passes them borrowed, as :func:`rhs_into`, Radau's Newton iteration and the
    explicit stages do.

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
        History of the contact-capable joints (impact speed, m/s;
        :func:`~mechrel.mechanics.joints.n_contacts`).
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
    sys, ws = borrowed((sys, ws))  # arguments: alive for the call (mechanics/borrow.py)
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
        History of the contact-capable joints (impact speed, m/s;
        :func:`~mechrel.mechanics.joints.n_contacts`).
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
        History of the contact-capable joints (impact speed, m/s;
        :func:`~mechrel.mechanics.joints.n_contacts`).
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
    sys, wb = borrowed((sys, ws))  # ws, used below, keeps wb's arrays alive
    pin, pcl = accelerations_into(t, y, hist, sys, wb)
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
        History of the contact-capable joints (impact speed, m/s;
        :func:`~mechrel.mechanics.joints.n_contacts`).
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
