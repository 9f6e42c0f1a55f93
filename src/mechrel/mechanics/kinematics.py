"""Position assembly and kinematic analysis.

Assembly solves Φ(q, t) = 0 by Newton–Raphson with the minimum-norm correction
``Δq = −Φ_qᵀ (Φ_q Φ_qᵀ)⁻¹ Φ`` (Nikravesh 1988, §4.4; valid for any number of degrees of
freedom: the correction moves the guess as little as possible). Velocities solve
``Φ_q q̇ = −Φ_t`` in the same minimum-norm sense. For a fully driven mechanism (as many
independent constraints as coordinates) the kinematic analysis needs no dynamics at all:
``q`` by Newton at each instant, ``q̇ = −Φ_q⁻¹ Φ_t``, ``q̈ = Φ_q⁻¹ γ``.

Most machines need no Newton iteration at all: :mod:`~mechrel.mechanics.construction` places
their bodies in closed form, and :func:`kinematic_analysis` uses it where it applies. Where it
does not, Newton's Φ_q is square, so the kinematic analysis factors it by its own sparse LU
with partial pivoting (:class:`LUFactors`; a LAPACK call from numba costs several µs of fixed
overhead at n ≈ 24, more than this whole factorisation of a Jacobian with at most six
non-zeros per row) once per Newton iteration, and reuses the factors at the converged ``q``
for the velocity and the acceleration.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ..errors import AssemblyError
from .constraints import constraint_terms, constraints
from .construction import _construct, construction
from .dynamics import make_workspace

# the public API; LUFactors and the _lu_* functions are the sparse solver behind it
__all__ = ["assemble", "assemble_positions", "kinematic_analysis"]


@njit(cache=True)
def _newton(q0, t, sys, tol, max_iter):
    q = q0.copy()
    phi, phit, J = constraints(q, t, sys)
    it = 0
    while it < max_iter:
        if phi.shape[0] == 0 or np.max(np.abs(phi)) <= tol:
            return q, phi, it, True
        JJ = J @ J.T
        q -= J.T @ np.linalg.solve(JJ, phi)
        phi, phit, J = constraints(q, t, sys)
        it += 1
    return q, phi, it, phi.shape[0] == 0 or np.max(np.abs(phi)) <= tol


@njit(cache=True)
def _velocity(q, t, sys):
    _, phit, J = constraints(q, t, sys)
    if phit.shape[0] == 0:
        return np.zeros(q.shape[0])
    return J.T @ np.linalg.solve(J @ J.T, -phit)


def assemble_positions(system, q_guess, t=0.0, *, tol=1e-12, max_iter=50, labels=None):
    """Assemble positions at time ``t``: :func:`assemble` without the velocities (for a
    caller that needs the configuration only; the same ``q``, bitwise).

    Parameters
    ----------
    system, q_guess, t, tol, max_iter, labels
        As for :func:`assemble`.

    Returns
    -------
    q : ndarray
        Assembled coordinates (m, rad).

    Raises
    ------
    AssemblyError
        Naming the constraints that stay violated and by how much.

    Examples
    --------
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank"))
    >>> q = assemble_positions(c.ideal, c.q_guess, 0.0)
    >>> bool((q == assemble(c.ideal, c.q_guess, 0.0)[0]).all())
    True
    """
    q0 = np.asarray(q_guess, dtype=float)
    try:
        q, phi, it, ok = _newton(q0, float(t), system, float(tol), int(max_iter))
    except np.linalg.LinAlgError:
        phi, _, _ = constraints(q0, float(t), system)
        q, ok = q0, False
    if not ok or not np.all(np.isfinite(q)):
        worst = np.argsort(-np.abs(phi))[:6]
        parts = []
        for r in worst:
            if abs(phi[r]) > tol:
                name = labels[r] if labels is not None else f"row {r}"
                parts.append(f"{name}: |Φ| = {abs(phi[r]):.3g}")
        raise AssemblyError(
            f"the mechanism cannot be assembled at t = {t:g} s: constraints stay violated "
            f"after Newton–Raphson (tolerance {tol:g}): " + "; ".join(parts)
            + ". Check the geometry (link lengths, ground points) and the initial guesses "
            "of body positions and angles.")
    return q


def assemble(system, q_guess, t=0.0, *, tol=1e-12, max_iter=50, labels=None):
    """Assemble positions and velocities at time ``t``.

    Parameters
    ----------
    system : System
        A compiled mechanism (:class:`mechrel.mechanics.system.System`) whose constraints
        fix every coordinate.
    q_guess : ndarray, shape (n,)
        Initial guess (m, rad).
    t : float
        Time (s).
    tol : float
        Max |Φ| accepted (m, rad).
    max_iter : int
        Newton iterations allowed.
    labels : sequence of str, optional
        One label per constraint row, used in the error message.

    Returns
    -------
    q, v : ndarray
        Assembled coordinates and velocities (minimum-norm solution of Φ_q q̇ = −Φ_t).

    Raises
    ------
    AssemblyError
        As :func:`assemble_positions`; or the constraint Jacobian is singular at ``q`` (a
        locked or redundant configuration: no velocity solves Φ_q q̇ = −Φ_t).

    Examples
    --------
    The slider-crank (crank 0.05 m, rod 0.12 m, 5000 rpm) at t = 0, crank along +x: the
    slider centre is at 0.17 m and the crank turns at 523.6 rad/s:

    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank"))
    >>> q, v = assemble(c.ideal, c.q_guess, 0.0, labels=c.labels["ideal"])
    >>> round(float(q[6]), 9), round(float(v[2]), 4)
    (0.17, 523.5988)
    """
    q = assemble_positions(system, q_guess, t, tol=tol, max_iter=max_iter, labels=labels)
    try:
        v = _velocity(q, float(t), system)
    except np.linalg.LinAlgError as exc:  # singular Φ_q: a locked or redundant configuration
        raise AssemblyError(f"velocity analysis failed at t = {t:g} s: the constraint Jacobian "
                            "is singular (redundant constraints or a locked configuration)"
                            ) from exc
    return q, v


_NOT_SIGN = np.int64(0x7FFFFFFFFFFFFFFF)  # all bits of a double but the sign: ±0.0 test as zero


class LUFactors(NamedTuple):
    """Sparse LU factors ``P A = L U`` of an n × n matrix and the plan that produced them.

    A constraint Jacobian has at most six non-zeros per row and little fill-in (nine-bar:
    70 of 576 entries, 89 in L and U together), so the factors are kept as lists of their
    entries and a solve costs about as many multiply-adds as the factors have entries instead
    of n². Consecutive Jacobians of a kinematic analysis share their pattern and almost always
    their pivot order (nine-bar, one cycle at 1°: 7 plans for 721 factorisations):
    :func:`_lu_factor` records both (the plan: pivots, index arrays, the pattern ``off``) and
    :func:`_lu_refactor` then repeats only the arithmetic.

    "Position" is a row's place after the interchanges so far (LAPACK's convention, used
    while planning); "row" is its index in the matrix as given: the factors and the plan
    address rows, so that neither the replay nor the solve moves any.
    """

    lp: np.ndarray  # (n + 1,) int: step k subtracts lv[lp[k]:lp[k + 1]] × its pivot row …
    lr: np.ndarray  # (n²,) int: … from the rows lr[…]
    lv: np.ndarray  # (n²,)
    up: np.ndarray  # (n + 1,) int: U's row k right of the diagonal: uv[up[k]:up[k + 1]] …
    ui: np.ndarray  # (n²,) int: … in the columns ui[…]
    uv: np.ndarray  # (n²,)
    ur: np.ndarray  # (n,) int: the row that becomes U's row k (the pivot row of step k)
    ud: np.ndarray  # (n,) 1 / diagonal of U (the pivots' reciprocals)
    pp: np.ndarray  # (n + 1,) int: the rows pr[pp[k]:pp[k + 1]] can hold column k's pivot
    pr: np.ndarray  # (n²,) int: (in ascending position, for the first-on-ties rule)
    pat: np.ndarray  # (n, n) uint8: work array: structure of the partly eliminated matrix
    perm: np.ndarray  # (n,) int: work array: row at each position
    wk: np.ndarray  # (n,) int: work array
    y: np.ndarray  # (n,) work array of the solve
    off: np.ndarray  # (n²,) int64: 0 where the planned matrix has an entry, 2⁶³ − 1 elsewhere
    valid: np.ndarray  # (1,) uint8: 1 once a plan is recorded


@njit(cache=True)
def _lu_workspace(n):
    """Storage for the :class:`LUFactors` of an n × n matrix (no plan yet)."""
    nn = n * n
    return LUFactors(
        np.zeros(n + 1, np.int64), np.zeros(nn, np.int64), np.zeros(nn),  # lp, lr, lv
        np.zeros(n + 1, np.int64), np.zeros(nn, np.int64), np.zeros(nn),  # up, ui, uv
        np.zeros(n, np.int64), np.zeros(n),  # ur, ud
        np.zeros(n + 1, np.int64), np.zeros(nn, np.int64),  # pp, pr
        np.zeros((n, n), np.uint8), np.zeros(n, np.int64), np.zeros(n, np.int64),  # pat, perm, wk
        np.zeros(n), np.zeros(nn, np.int64), np.zeros(1, np.uint8))  # y, off, valid


@njit(cache=True)
def _lu_factor(A, f):
    """LU factorisation with partial pivoting of the square ``A`` into ``f``, recording the
    plan for :func:`_lu_refactor` (``A`` is overwritten).

    Gaussian elimination with the pivot rule of LAPACK's ``dgetrf`` (the largest |entry| of
    the column, the first one on ties), so the solutions agree with ``np.linalg.solve`` to
    round-off. Only structural non-zeros are visited: the non-zeros of ``A`` and their fill-in
    (tracked in ``f.pat`` rather than read from the values, so that the plan stays valid for
    any matrix with the same pattern, also one whose eliminations do not cancel by chance).
    Skipping an entry that is zero only skips subtracting ``0 × u``: it changes no result.

    Raises
    ------
    np.linalg.LinAlgError
        On an exactly zero pivot column (or one of NaNs), as ``np.linalg.solve`` does for a
        singular matrix.
    """
    n = A.shape[0]
    lp, lr, lv, up, ui, uv, ur, ud, pp, pr, pat, perm, wk, y, off, valid = f
    valid[0] = 0
    for i in range(n):
        perm[i] = i
        for j in range(n):
            nz = A[i, j] != 0.0
            pat[i, j] = nz
            off[i * n + j] = 0 if nz else _NOT_SIGN
    nl = 0
    nu = 0
    for k in range(n):
        p = k
        amax = 0.0
        nw = 0  # wk[:nw]: the positions >= k with an entry in column k, ascending
        for i in range(k, n):
            if pat[i, k]:
                wk[nw] = i
                pr[pp[k] + nw] = perm[i]
                nw += 1
                a = abs(A[i, k])
                if a > amax:
                    amax = a
                    p = i
        pp[k + 1] = pp[k] + nw
        if amax == 0.0:
            raise np.linalg.LinAlgError("Matrix is singular to machine precision.")
        if p != k:  # columns < k of these positions are no longer read: swap the rest only
            for j in range(k, n):
                tmp = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = tmp
                b = pat[k, j]
                pat[k, j] = pat[p, j]
                pat[p, j] = b
            r = perm[k]
            perm[k] = perm[p]
            perm[p] = r
        ur[k] = perm[k]
        rd = 1.0 / A[k, k]  # multipliers times the reciprocal pivot, as LAPACK's dgetrf2
        ud[k] = rd
        for j in range(k + 1, n):  # U's row k is final: later steps only change positions > k
            if pat[k, j]:
                ui[nu] = j
                uv[nu] = A[k, j]
                nu += 1
        up[k + 1] = nu
        for r in range(nw):
            i = wk[r]
            if i == p:  # the pivot, now at position k
                continue
            if i == k:  # the interchange moved it to position p
                i = p
            el = A[i, k] * rd
            lr[nl] = perm[i]
            lv[nl] = el
            nl += 1
            for c in range(up[k], nu):
                j = ui[c]
                A[i, j] -= el * uv[c]
                pat[i, j] = 1
        lp[k + 1] = nl
    valid[0] = 1


@njit(cache=True, inline='always')
def _lu_refactor(A, f):
    """Factor ``A`` with the plan recorded by :func:`_lu_factor` (``A`` is overwritten).

    Returns False, leaving the factors unusable, when ``A`` has a non-zero outside the
    planned pattern or partial pivoting would choose another pivot than the plan; otherwise
    the factors are exactly those :func:`_lu_factor` would compute (same pivots, same
    operations in the same order) at a fraction of the cost: no search for the non-zeros and
    no row interchanges (the plan addresses the rows where they are).
    """
    n = A.shape[0]
    lp, lr, lv, up, ui, uv, ur, ud, pp, pr, pat, perm, wk, y, off, valid = f
    if not valid[0]:
        return False
    # Any non-zero (or NaN) where the plan has no entry? On the bits of the doubles, so that
    # the test is an integer OR over all n² entries, which the compiler vectorises: a float
    # test per entry would cost as much as the rest of the refactorisation.
    bits = np.ascontiguousarray(A).reshape(n * n).view(np.int64)
    outside = 0
    for i in range(n * n):
        outside |= bits[i] & off[i]
    if outside != 0:
        return False
    for k in range(n):
        # the pivot search among the rows that can hold an entry in column k (the others
        # are exact zeros): the plan holds only if this picks the planned row
        prow = -1
        amax = 0.0
        for r in range(pp[k], pp[k + 1]):
            i = pr[r]
            a = abs(A[i, k])
            if a > amax:
                amax = a
                prow = i
        if amax == 0.0:
            raise np.linalg.LinAlgError("Matrix is singular to machine precision.")
        if prow != ur[k]:
            return False
        rd = 1.0 / A[prow, k]
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
def _lu_solve(f, b):
    """Solve ``A x = b`` in place in ``b`` from the factors of :func:`_lu_factor` or
    :func:`_lu_refactor`."""
    n = b.shape[0]
    lp, lr, lv, up, ui, uv, ur, ud, y = f.lp, f.lr, f.lv, f.up, f.ui, f.uv, f.ur, f.ud, f.y
    for i in range(n):
        y[i] = b[i]
    for k in range(n):  # the elimination steps, applied to b in the order they were made
        yk = y[ur[k]]
        for c in range(lp[k], lp[k + 1]):
            y[lr[c]] -= lv[c] * yk
    for k in range(n - 1, -1, -1):  # U x = y; times the reciprocal: a division's latency
        s = y[ur[k]]                # would dominate this chain of dependent steps
        for c in range(up[k], up[k + 1]):
            s -= uv[c] * b[ui[c]]
        b[k] = s * ud[k]


@njit(cache=True, inline='always')
def _max_abs(x):
    """Max |x_i| (0 for an empty x); NaN if any entry is NaN, so that a NaN never passes a
    tolerance test (as with ``np.max(np.abs(x))``)."""
    r = 0.0
    for i in range(x.shape[0]):
        a = abs(x[i])
        if a > r or a != a:
            r = a
            if a != a:
                return a
    return r


@njit(cache=True)
def _jacobian_into(ws, row_body, J):
    """The dense Φ_q (m × n) into ``J`` from the sparse rows that
    :func:`~mechrel.mechanics.constraints.constraint_terms` left in ``ws``: row r acts on the
    bodies ``row_body[r]`` (−1: ground) with ``ws.coef[6 r:6 r + 6]``. Every other entry is
    set to zero (the factorisation overwrites ``J``)."""
    co = ws.coef
    n = J.shape[1]
    for r in range(J.shape[0]):
        for c in range(n):
            J[r, c] = 0.0
        for s in range(2):
            b = row_body[r, s]
            if b >= 0:
                o = 6 * r + 3 * s
                J[r, 3 * b] = co[o]
                J[r, 3 * b + 1] = co[o + 1]
                J[r, 3 * b + 2] = co[o + 2]


@njit(cache=True)
def _kinematics(q0, times, sys, tol, max_iter):
    """Kinematic analysis of a fully driven mechanism (m == n) at ``times``.

    Returns ``Q, V, A, max_violation, done``; ``done < len(times)`` when Newton did not
    converge within ``max_iter`` iterations at ``times[done]`` (``Q`` etc. then hold the
    instants before it). A singular Φ_q raises ``np.linalg.LinAlgError``.

    The constraint terms come from the right-hand side's allocation-free
    :func:`~mechrel.mechanics.constraints.constraint_terms` (one sine and cosine per body,
    the sparse rows of Φ_q): evaluated at zero velocity it gives Φ and Φ_t, at the solved
    velocity γ (its Baumgarte combination undone: ``γ = c + 2α Φ̇ + β² Φ``). It is called
    from one place (it is inlined, and each call site would be compiled again).
    """
    nt = times.shape[0]
    n = q0.shape[0]
    Q = np.empty((nt, n))
    V = np.empty((nt, n))
    A = np.empty((nt, n))
    lu = _lu_workspace(n)
    ws = make_workspace(sys)
    row_body = sys.row_body
    alpha2 = 2.0 * sys.baumgarte[0]
    beta2 = sys.baumgarte[1] * sys.baumgarte[1]
    J = np.empty((n, n))
    dq = np.empty(n)
    rest = np.zeros(n)
    viol = 0.0
    q = q0.copy()
    v = np.zeros(n)
    a = np.zeros(n)
    tprev = times[0]
    for k in range(nt):
        t = times[k]
        dt = t - tprev
        # Taylor predictor from the previous instant (|Φ| ~ 1e-8 on the nine-bar at 1°
        # steps): one Newton iteration then converges
        for i in range(n):
            q[i] = q[i] + v[i] * dt + 0.5 * a[i] * dt * dt
        it = 0
        solved = False  # Newton at zero velocity (Φ̇ = Φ_t), then once at the solved q̇ (γ)
        while True:
            constraint_terms(t, q, v if solved else rest, sys, ws)
            if solved:
                break
            res = _max_abs(ws.phi)
            if not res <= tol and it >= max_iter:
                return Q[:k], V[:k], A[:k], viol, k
            # factor Φ_q, by the previous factorisation's plan when it still applies. The
            # factors at the converged q are the ones the velocity and acceleration solves
            # need.
            _jacobian_into(ws, row_body, J)
            if not _lu_refactor(J, lu):
                if lu.valid[0]:  # the replay stopped part-way through J: fill it again
                    _jacobian_into(ws, row_body, J)
                _lu_factor(J, lu)
            if res <= tol:
                for i in range(n):
                    v[i] = -ws.phidot[i]
                _lu_solve(lu, v)  # Φ_q q̇ = −Φ_t
                solved = True
                continue
            for i in range(n):
                dq[i] = ws.phi[i]
            _lu_solve(lu, dq)  # Newton step Φ_q Δq = Φ (square: the minimum-norm one)
            for i in range(n):
                q[i] -= dq[i]
            it += 1
        for i in range(n):
            a[i] = ws.c[i] + (alpha2 * ws.phidot[i] + beta2 * ws.phi[i])
        _lu_solve(lu, a)  # Φ_q q̈ = γ
        for i in range(n):
            Q[k, i] = q[i]
            V[k, i] = v[i]
            A[k, i] = a[i]
        viol = max(viol, res)
        tprev = t
    return Q, V, A, viol, nt


def kinematic_analysis(system, q_guess, times, *, tol=1e-12, max_iter=50, labels=None):
    """Positions, velocities and accelerations of a fully driven mechanism at ``times``.

    A mechanism built of driven or fixed-angle bodies and class-II groups (the nine-bar, the
    slider-crank, the four-bar) is placed in closed form by
    :mod:`~mechrel.mechanics.construction`, its residual Φ checked at the first and last
    instant; from the first instant that cannot be built so (a toggle, an overflow), and for
    every other mechanism, each instant is solved by Newton–Raphson from the previous one.

    Parameters
    ----------
    system : System
        A compiled mechanism (:class:`mechrel.mechanics.system.System`) with as many
        constraints (drivers included) as coordinates.
    q_guess : ndarray, shape (n,)
        Guess for the first instant (m, rad); each later instant starts from the previous one.
    times : ndarray
        Instants (s), increasing.
    tol : float
        Max |Φ| accepted (m, rad).
    max_iter : int
        Newton iterations allowed per instant.
    labels : sequence of str, optional
        One label per constraint row, used in the error message.

    Returns
    -------
    Q, V, A : ndarray, shape (len(times), n)
    max_violation : float
        Largest |Φ| over the instants solved by Newton and the first and last instant placed
        in closed form (m or rad).

    Raises
    ------
    AssemblyError
        If the mechanism is not fully driven or Newton fails at some instant (a toggle or a
        branch that stops existing).

    Examples
    --------
    A quarter turn of the slider-crank's crank later (3 ms at 5000 rpm) the slider is at
    sqrt(0.12² − 0.05²) = 0.109087 m:

    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank"))
    >>> Q, V, A, worst = kinematic_analysis(c.ideal, c.q_guess, np.array([0.0, 0.003]))
    >>> Q[:, 6].round(6).tolist(), bool(worst < 1e-12)
    ([0.17, 0.109087], True)
    """
    n = system.mass.shape[0]
    if system.n_constraints != n:
        raise AssemblyError(
            f"kinematic analysis needs a fully driven mechanism: {system.n_constraints} "
            f"constraints for {n} coordinates ({n - system.n_constraints} degrees of freedom "
            "left); use forward dynamics instead")
    times = np.ascontiguousarray(times, dtype=float)
    q_guess = np.asarray(q_guess, dtype=float)
    plan = construction(system)
    if plan is not None and plan.n_free:  # cannot happen for n_constraints == n (a complete
        plan = None  # plan has as many free angles as degrees of freedom); the guard keeps it so
    head = None  # the instants placed in closed form before Newton took over
    if plan is not None:  # closed form; Newton from the first instant it cannot build, if any
        # with |Φ| of the first and last instant built (module construction's docstring)
        Q, V, A, done, viol = _construct(q_guess, times, system, plan)
        if viol <= tol:  # (a NaN fails too)
            if done == times.shape[0]:
                return Q, V, A, viol
            head = (Q, V, A, viol)
            q_guess = Q[done - 1] if done > 0 else q_guess
            times = times[done:]
    try:
        Q, V, A, viol, done = _kinematics(q_guess, times, system, float(tol), int(max_iter))
    except np.linalg.LinAlgError as exc:
        raise AssemblyError("kinematic analysis hit a singular constraint Jacobian (a toggle "
                            "or dead-centre position of the mechanism)") from exc
    if done < times.shape[0]:
        # re-run the failing instant in Python for a message naming the violated constraints
        last = Q[done - 1] if done > 0 else q_guess
        assemble(system, last, float(times[done]), tol=tol, max_iter=max_iter, labels=labels)
        raise AssemblyError(f"kinematic analysis: Newton–Raphson failed at t = "
                            f"{times[done]:g} s (the assembly branch ends there)")
    if head is not None:
        Q0, V0, A0, viol0 = head
        return (np.concatenate([Q0, Q]), np.concatenate([V0, V]), np.concatenate([A0, A]),
                max(viol0, viol))
    return Q, V, A, viol
