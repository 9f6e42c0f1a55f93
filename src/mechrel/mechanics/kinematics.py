"""Position assembly and kinematic analysis.

Assembly solves Φ(q, t) = 0 by Newton–Raphson with the minimum-norm correction
``Δq = −Φ_qᵀ (Φ_q Φ_qᵀ)⁻¹ Φ`` (Nikravesh 1988, §4.4; valid for any number of degrees of
freedom: the correction moves the guess as little as possible). Velocities solve
``Φ_q q̇ = −Φ_t`` in the same minimum-norm sense. For a fully driven mechanism (as many
independent constraints as coordinates) the kinematic analysis needs no dynamics at all:
``q`` by Newton at each instant, ``q̇ = −Φ_q⁻¹ Φ_t``, ``q̈ = Φ_q⁻¹ γ``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..errors import AssemblyError
from .problem import constraints, gamma


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


def assemble(system, q_guess, t=0.0, *, tol=1e-12, max_iter=50, labels=None):
    """Assemble positions and velocities at time ``t``.

    Parameters
    ----------
    system : System
    q_guess : ndarray, shape (n,)
        Initial guess (m, rad).
    t : float
        Time (s).
    tol : float
        Max |Φ| accepted (m, rad).
    labels : sequence of str, optional
        One label per constraint row, used in the error message.

    Returns
    -------
    q, v : ndarray
        Assembled coordinates and velocities (minimum-norm solution of Φ_q q̇ = −Φ_t).

    Raises
    ------
    AssemblyError
        Naming the constraints that stay violated and by how much.
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
    try:
        v = _velocity(q, float(t), system)
    except np.linalg.LinAlgError as exc:  # singular Φ_q: a locked or redundant configuration
        raise AssemblyError(f"velocity analysis failed at t = {t:g} s: the constraint Jacobian "
                            "is singular (redundant constraints or a locked configuration)"
                            ) from exc
    return q, v


@njit(cache=True)
def _kinematics(q0, times, sys, tol, max_iter):
    nt = times.shape[0]
    n = q0.shape[0]
    Q = np.empty((nt, n))
    V = np.empty((nt, n))
    A = np.empty((nt, n))
    viol = 0.0
    q = q0.copy()
    v = np.zeros(n)
    a = np.zeros(n)
    tprev = times[0]
    for k in range(nt):
        t = times[k]
        dt = t - tprev
        guess = q + v * dt + 0.5 * a * dt * dt
        q, phi, it, ok = _newton(guess, t, sys, tol, max_iter)
        if not ok:
            return Q[:k], V[:k], A[:k], viol, k
        _, phit, J = constraints(q, t, sys)
        v = np.linalg.solve(J, -phit)
        a = np.linalg.solve(J, gamma(q, v, t, sys))
        Q[k] = q
        V[k] = v
        A[k] = a
        viol = max(viol, np.max(np.abs(phi)))
        tprev = t
    return Q, V, A, viol, nt


def kinematic_analysis(system, q_guess, times, *, tol=1e-12, max_iter=50, labels=None):
    """Positions, velocities and accelerations of a fully driven mechanism at ``times``.

    Returns
    -------
    Q, V, A : ndarray, shape (len(times), n)
    max_violation : float
        Largest |Φ| over the instants (m or rad).

    Raises
    ------
    AssemblyError
        If the mechanism is not fully driven or Newton fails at some instant (a toggle or a
        branch that stops existing).
    """
    n = system.mass.shape[0]
    if system.n_constraints != n:
        raise AssemblyError(
            f"kinematic analysis needs a fully driven mechanism: {system.n_constraints} "
            f"constraints for {n} coordinates ({n - system.n_constraints} degrees of freedom "
            "left); use forward dynamics instead")
    times = np.ascontiguousarray(times, dtype=float)
    try:
        Q, V, A, viol, done = _kinematics(np.asarray(q_guess, dtype=float), times, system,
                                          float(tol), int(max_iter))
    except np.linalg.LinAlgError as exc:
        raise AssemblyError("kinematic analysis hit a singular constraint Jacobian (a toggle "
                            "or dead-centre position of the mechanism)") from exc
    if done < times.shape[0]:
        # re-run the failing instant in Python for a message naming the violated constraints
        last = Q[done - 1] if done > 0 else np.asarray(q_guess, dtype=float)
        assemble(system, last, float(times[done]), tol=tol, max_iter=max_iter, labels=labels)
        raise AssemblyError(f"kinematic analysis: Newton–Raphson failed at t = "
                            f"{times[done]:g} s (the assembly branch ends there)")
    return Q, V, A, viol
