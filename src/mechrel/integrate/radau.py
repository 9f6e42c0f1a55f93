"""Compiled Radau IIA of order 5 (the RADAU5 algorithm of Hairer & Wanner), for stiff scenes.

Everything per step runs in numba: the simplified Newton iteration on the transformed stage
equations (one real and one complex linear system of the size of the state), the
finite-difference Jacobian of ``mechrel.mechanics.dynamics.rhs`` and its reuse across steps, LU
factorisations with partial pivoting (numba has no ``scipy.linalg.lu_factor``), the filtered
error estimate, Gustafsson's predictive step-size control and the dense output of the
collocation polynomial at the output instants. The kernel calls the problem functions by
module-global reference (docs/architecture.md).

Algorithm (HW II, §IV.8 and the Fortran code ``radau5.f``; constants as there)
------------------------------------------------------------------------------
* Stages ``Z = (Y_i − y)``, ``i = 1..3`` at ``t + c_i h``; the simplified Newton iteration
  works on ``W = (T⁻¹ ⊗ I) Z``, where ``T⁻¹ A⁻¹ T = diag(γ, [[α, −β], [β, α]])``, so each
  iteration solves ``(γ/h · I − J) ΔW₁ = r₁`` (real) and
  ``((α + iβ)/h · I − J)(ΔW₂ + iΔW₃) = r₂ + i r₃`` (complex), with ``J = ∂f/∂y`` kept fixed.
  Both are condensed to the coordinates (as RADAU5 does for second-order systems): ``J`` is
  ``[[0, I, 0], [A_q, A_v, 0], [P_q, P_v, 0]]`` for ``y = [q, q̇, W]``, so only the n × n
  matrices ``g² I − g A_v − A_q`` are factorised, not the (2n + 2)-square ones: 8× fewer
  operations on the nine-bar (n = 24), where the full LU pair took half the run time.
* Newton stops when ``η ‖ΔW‖ ≤ κ``, ``η = θ/(1 − θ)`` from the observed contraction ``θ``,
  ``κ = max(10 u/rtol', min(0.03, rtol'^½))``; at most 7 iterations. When the predicted
  error after 7 iterations stays above ``κ`` the step is shrunk at once; divergence
  (``θ ≥ 0.99``), 7 iterations, a singular matrix or a non-finite stage halves the step
  ("Newton failure"). After ``MAX_NEWTON_FAILURES`` consecutive failures, or 5 singular
  matrices, the kernel stops with ``STATUS_NEWTON``.
* Jacobian reuse: after an accepted step ``J`` is kept if the last Newton contraction was
  ``θ ≤ THET = 0.1`` (RADAU5's recommendation for costly Jacobians), and the matrices are
  even kept (no new LU) if additionally the proposed step ratio is in [1, 1.2]; otherwise
  ``J`` is updated at the new point (partially, see below). After a rejected step a Jacobian
  that is already fresh is kept (only the LU is redone), a stale one is recomputed in full.
* Error estimate ``err = (I − hγ₀J)⁻¹ (γ₀ h f(y₀) + Σ e_i Z_i)`` (the filter keeps the
  estimate bounded for stiff components), recomputed once with ``f(y₀ + err)`` after a
  rejection or on the first step, as RADAU5 does.
* Step size: ``h_new = h · fac · err^(−1/4)`` with ``fac`` decreasing with the Newton
  iterations, bounded to ``[h/5, 8h]``, and Gustafsson's predictive controller
  (HW II, eq. IV.8.21) after the second accepted step.
* Dense output: the collocation polynomial through ``y``, ``Y₁``, ``Y₂``, ``Y₃`` (order 3 in
  between the steps; exact at the step ends) and the predictor of the next Newton start.
* Tolerances: RADAU5's own error estimate is of lower order than the method, and RADAU5
  therefore integrates with ``rtol' = 0.1 rtol^(2/3)``, ``atol' = rtol' · atol/rtol``, which
  makes the global error roughly proportional to the requested ``rtol``. This kernel does the
  same, so ``rtol``/``atol`` mean what they mean for ``radau5`` (not SciPy's ``Radau``, which
  uses them untransformed).

Finite-difference Jacobian
--------------------------
Only the acceleration and power rows are differenced: the rows ``dq/dt = q̇`` have the exact
entries ``[0, I, 0]`` and no row depends on the two work integrals (``rhs`` reads only ``q``
and ``q̇``), so a Jacobian costs ``2n`` right-hand-side evaluations for ``n`` coordinates.
Forward differences with the increment ``δ_j = √u · max(|y_j|, atol/rtol)`` (``u`` the unit
round-off): the truncation error is ``O(δ f'')`` and the round-off error ``O(u |f| / δ)``;
``δ ∝ √u`` balances the two for a component of size ``|y_j|``, and the floor ``atol/rtol``
is the magnitude below which the user's tolerances declare the component negligible, so a
component crossing zero is never differenced with a meaningless increment. The Jacobian only
drives Newton (not the accuracy of the result); an inaccurate Jacobian shows up as slower
contraction, which triggers a recomputation. Measured on the lubricated nine-bar along a
trajectory (ε up to 0.98): column-wise relative error ≤ 3e-3 against central differences.

Partial updates: the stiff, fast-changing entries of ``J`` are the derivatives of the
clearance-joint forces and what they drive through the constraints (the multipliers λ and
the accelerations carry the forces). :func:`mechrel.mechanics.jacobian.clearance_jacobian`
computes that *fast part* semi-analytically — the force laws differenced alone (cheap), the
joint kinematics and the constrained response exact, with the Schur factor of the
right-hand side — for the cost of about four right-hand sides (6.9 µs against 1.5 µs on the
nine-bar, where differencing the clearance bodies' columns took 24 evaluations). The *smooth rest*
(constraint geometry, gravity, Baumgarte terms) is the finite-difference Jacobian of the same
mechanism with the clearance forces switched off
(:func:`mechrel.mechanics.system.without_clearance_forces`; the force laws are proportional
to the viscosity and the contact stiffness) minus its own fast part. A full Jacobian is
rest + fast part at the same point: no finite difference ever crosses a stiff film, whose
thickness c (1 − ε) can be as small as the increment (at ε = 1 − 4e-6 the differenced
Jacobian was useless and the run drifted off the constraints by 3e-5 m). After an accepted
step with θ > THET only the fast part is refreshed; a full Jacobian is computed at the
start, after a history change, after a Newton failure or error-test rejection with a stale
Jacobian, and at least every ``MAX_PARTIAL`` updates. On the lubricated nine-bar this needs
6.5k right-hand sides per cycle where differencing the clearance bodies' columns needed
12.4k (docs/dev/performance-log.md, "Integrators").

Code structure
--------------
:func:`radau5_kernel` holds the step loop and its control: step size (error test,
Gustafsson's controller, Newton shrink and failure), when to update the Jacobian and when to
refactorise, contact onsets, outputs and the log. Each numerical part of a step is a compiled
helper with a documented contract, in the order a step calls them (the subroutines of
``radau5.f`` they correspond to in brackets):

* :func:`_update_jacobian` — the Jacobian, full or partial (below);
* :func:`_factor_matrices` — the real and complex condensed iteration matrices and their LU
  factors (:func:`_build_matrices`, :func:`lu_factor`; DECOMR, DECOMC);
* :func:`_newton_start` — the Newton starting values from the previous collocation polynomial;
* :func:`_solve_collocation` — the simplified Newton iteration (RADCOR's loop), returning
  converged / failed / shrunk, the iterations, θ and η; it is the only place the stages call
  the right-hand side (:func:`~mechrel.mechanics.dynamics.rhs_inline`, one inlined call site);
* :func:`_estimate_error` — the filtered error estimate (ESTRAD);
* :func:`_collocation_coefficients` — the accepted step's collocation polynomial (CONTR5's
  coefficients), and :func:`_dense_output`, its value inside the step.

The helpers' arithmetic is the kernel's, in the same order, so the cut left every result
bitwise unchanged. :func:`_solve_collocation` is compiled on its own (the cold warm-up compiles
it in its helper process, :func:`mechrel.warmup.split_compile`); the others are
``inline='always'``, compiled into the kernel: as separate functions they added about 10 s to
a cold one-process compile (each passes the System and Workspace tuples) for no gain at run
time. The called helpers take their arrays borrowed at entry
(:func:`~mechrel.mechanics.borrow.borrowed`): a plain call of the Newton iteration otherwise
cost 5–6 % of a warm cycle in reference counts. The inlined ones do not borrow: inlined, their
body cannot keep its caller's arrays alive, and a caller that did not use an array after the
call (another kernel reusing a helper) had it freed under the borrowed copy
(:mod:`mechrel.mechanics.borrow`, "The rules"). The kernel instead borrows its work arrays
once and holds their owners to its return (:func:`~mechrel.mechanics.borrow.keep_alive`), so
the helpers see them borrowed and any other caller may pass its own arrays.

History and contact onsets
--------------------------
As in :mod:`mechrel.integrate.explicit`: a step that passed the error test but ends in a new
contact deeper than ``onset_tol`` is retried with the step that the secant of the gap puts
at ``onset_tol / 2`` inside (:func:`~mechrel.integrate.events.onset_fraction`); only then is
the step accepted and :func:`~mechrel.integrate.events.update_history_from` called. When the
history changes, ``f(y)`` and the Jacobian (which depend on it) are recomputed.

Statistics: ``n_rhs`` includes the Jacobian columns; ``n_jacobians`` counts full and partial
Jacobians; ``n_rejected`` counts steps rejected by the error test and steps whose Newton
iteration did not converge (diverged, or was predicted too slow and the step shrunk), the
latter also in ``n_newton_rejected``; ``n_lu`` counts factorisations of the pair (real,
complex) of iteration matrices. On the lubricated nine-bar nearly all rejections are Newton's
(124 of 125 per cycle at rtol 3e-4): the step size there is set by the convergence of the
simplified Newton iteration, not by the error estimate (docs/dev/performance-log.md, "Cost per
cycle against the floor").

References
----------
Hairer & Wanner, *Solving Ordinary Differential Equations II*, 2nd ed., Springer 1996, §IV.5
(Radau IIA), §IV.8 (implementation: eqs. 8.12–8.21, Table 8.x), and the Fortran code
``radau5.f`` (subroutines RADCOR, ESTRAD, CONTR5; version of 1996/2002). Gustafsson,
"Control-theoretic techniques for stepsize selection in implicit Runge–Kutta methods", ACM
TOMS 20 (1994).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..errors import SimulationError
from ..mechanics.borrow import borrowed, keep_alive
from ..mechanics.construction import construction
from ..mechanics.constraints import violations_at
from ..mechanics.formulation import (evaluate, evaluate_inline, fast_jacobian, gaps,
                                     has_fast_part, n_coordinates, output_width,
                                     write_output)
from ..mechanics.reduced import (ReducedSystem, expand_rows, make_reduced_work, n_reduced,
                                 reduced_coordinates)
from ..mechanics.system import without_clearance_forces
from ..scene.model import FORMULATIONS
from .events import (CTL_DONE, FORMULATION_TEXT, H_START_FLOOR, S_FORMULATION, S_JAC, S_LU,
                     S_NEWTON_REJECTED, S_ONSET_REJECTED, S_REJECTED, S_RHS, S_STATUS, S_STEPS,
                     S_VIOL_POS, S_VIOL_VEL, STATUS_NEWTON,
                     STATUS_NONFINITE, all_finite, log_row, new_log, onset_fraction, out_of_budget,
                     record_violation, start, update_history_from)
from .base import Integrator

# the public entry points; the underscored functions are the kernel's building blocks
# (module docstring, "Code structure")
__all__ = ["Radau", "radau5_kernel", "reduced_system", "fd_jacobian", "lu_factor", "lu_solve"]

# ---------------------------------------------------------------------------- constants
UROUND = 2.220446049250313e-16
SQRT_UROUND = math.sqrt(UROUND)
SQ6 = math.sqrt(6.0)
C1 = (4.0 - SQ6) / 10.0
C2 = (4.0 + SQ6) / 10.0
C1M1 = C1 - 1.0
C2M1 = C2 - 1.0
C1MC2 = C1 - C2
DD1 = -(13.0 + 7.0 * SQ6) / 3.0
DD2 = (-13.0 + 7.0 * SQ6) / 3.0
DD3 = -1.0 / 3.0
_U1 = (6.0 + 81.0 ** (1.0 / 3.0) - 9.0 ** (1.0 / 3.0)) / 30.0
_ALPH = (12.0 - 81.0 ** (1.0 / 3.0) + 9.0 ** (1.0 / 3.0)) / 60.0
_BETA = (81.0 ** (1.0 / 3.0) + 9.0 ** (1.0 / 3.0)) * math.sqrt(3.0) / 60.0
_CNO = _ALPH * _ALPH + _BETA * _BETA
U1 = 1.0 / _U1  # γ: real eigenvalue of A⁻¹
ALPH = _ALPH / _CNO  # α ± iβ: complex pair of eigenvalues of A⁻¹
BETA = _BETA / _CNO
T11, T12, T13 = 9.1232394870892942792e-02, -0.14125529502095420843, -3.0029194105147424492e-02
T21, T22, T23 = 0.24171793270710701896, 0.20412935229379993199, 0.38294211275726193779
T31 = 0.96604818261509293619  # T32 = 1, T33 = 0
TI11, TI12, TI13 = 4.3255798900631553510, 0.33919925181580986954, 0.54177053993587487119
TI21, TI22, TI23 = -4.1787185915519047273, -0.32768282076106238708, 0.47662355450055045196
TI31, TI32, TI33 = -0.50287263494578687595, 2.5719269498556054292, -0.59603920482822492497

NIT = 7  # maximum Newton iterations per step
# Keep the Jacobian while the Newton contraction θ stays below THET. RADAU5's default is 0.001
# for cheap Jacobians and its documentation recommends 0.1 when they are costly. Here the
# update after an accepted step is the fast (clearance) part only, which costs about four
# right-hand sides (module docstring), so refreshing it often pays: measured on the lubricated
# nine-bar at rtol 1e-7 (right-hand sides per cycle, with MAX_PARTIAL = 30): THET = 0.3 →
# 14.2k, 0.1 → 8.3k, 0.03 → 6.5k, 0.01 → 6.0k; at rtol 1e-3: 29.5k, 14.3k, 5.2k, 7.9k
# (docs/dev/performance-log.md). 0.03 is the best over the tolerances measured.
THET = 0.03
SAFE = 0.9
FACL = 5.0  # h_new ≥ h / FACL
FACR = 0.125  # h_new ≤ h / FACR
QUOT1 = 1.0  # keep the step (and the LU) while 1 ≤ h_new / h ≤ 1.2
QUOT2 = 1.2
NIT_FIXED = 30  # fixed-step mode: no step to shrink, so iterate longer
MAX_PARTIAL = 30  # partial (fast-part) updates between two full Jacobians; 10 → 30 saved
# 7 % of the evaluations, 100 nothing more (lubricated nine-bar)
# consecutive Newton failures (each halves h) before giving up: 2^-40 ~ 1e-12 of the step that
# first failed. At 10 (2^-10) a lubricated joint of 0.1 um clearance, whose film is stiffer by
# (R/c)^3, stopped at t = 0; RADAU5 itself halves without a count (it stops only on a step too
# small for t's round-off, which at t = 0 gives no bound). A run that never failed 10 times in a
# row takes the same steps as before.
MAX_NEWTON_FAILURES = 40
MAX_SINGULAR = 5


# ---------------------------------------------------------------------------- linear algebra
@njit(cache=True)
def lu_factor(A, piv):
    """In-place LU factorisation with partial pivoting, ``P A = L U``.

    Unit lower ``L`` below the diagonal, ``U`` on and above it; row interchanges in ``piv``
    as in LAPACK's getrf. Works for real and complex matrices. The pivot is the entry of
    largest ``|Re| + |Im|`` in its column (the first on ties), the rule of LAPACK's zgetrf
    (its izamax measures an entry by dcabs1 = |Re| + |Im|; Anderson et al., *LAPACK Users'
    Guide*, 3rd ed., 1999): for a real matrix that is |a|, for a complex one it avoids a
    ``hypot`` per candidate, a quarter of the complex factorisation's time at n = 24.

    Parameters
    ----------
    A : ndarray, shape (n, n), float or complex
        The matrix; overwritten by ``L`` and ``U``.
    piv : ndarray of int, shape (n,)
        Receives the row interchanges: row k was swapped with row ``piv[k]``.

    Returns
    -------
    bool
        False if a pivot column is exactly zero (``A`` singular), True otherwise.

    Examples
    --------
    >>> A = np.array([[1.0, 2.0], [3.0, 4.0]])
    >>> piv = np.zeros(2, dtype=np.int64)
    >>> lu_factor(A, piv), piv.tolist(), A.round(6).tolist()
    (True, [1, 1], [[3.0, 4.0], [0.333333, 0.666667]])
    >>> lu_factor(np.zeros((2, 2)), piv)
    False
    """
    A, piv = borrowed((A, piv))
    n = A.shape[0]
    for k in range(n):
        p = k
        v = A[k, k]
        amax = abs(v.real) + abs(v.imag)
        for i in range(k + 1, n):
            v = A[i, k]
            a = abs(v.real) + abs(v.imag)
            if a > amax:
                amax = a
                p = i
        piv[k] = p
        if amax == 0.0:
            return False
        if p != k:
            for j in range(n):
                tmp = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = tmp
        inv = 1.0 / A[k, k]
        for i in range(k + 1, n):
            lik = A[i, k] * inv
            A[i, k] = lik
            if lik != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= lik * A[k, j]
    return True


@njit(cache=True)
def lu_solve(LU, piv, b):
    """Solve ``A x = b`` in place from :func:`lu_factor`'s output.

    Parameters
    ----------
    LU : ndarray, shape (n, n), float or complex
        The factors from :func:`lu_factor`.
    piv : ndarray of int, shape (n,)
        Its row interchanges.
    b : ndarray, shape (n,)
        The right-hand side; overwritten by ``x``.

    Examples
    --------
    >>> A = np.array([[1.0, 2.0], [3.0, 4.0]])
    >>> piv = np.zeros(2, dtype=np.int64)
    >>> lu_factor(A, piv)
    True
    >>> b = np.array([5.0, 11.0])
    >>> lu_solve(A, piv, b)
    >>> b.round(12).tolist()
    [1.0, 2.0]
    """
    LU, piv, b = borrowed((LU, piv, b))
    n = LU.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= LU[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= LU[i, j] * b[j]
        b[i] = s / LU[i, i]


# ---------------------------------------------------------------------------- Jacobian
@njit(cache=True)
def fd_jacobian(t, y, f0, hist, sys, ws, J, floor, yp, fp):
    """``J = ∂rhs/∂y`` at ``(t, y)`` by forward differences.

    The increments are ``δ_j = √u max(|y_j|, floor)``; the rows ``dq/dt = q̇`` are exact and
    the work integrals' columns zero.

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray, shape (ny,)
        The state ``(q, q̇, W_in, W_cl)`` (m, rad; m/s, rad/s; J), ``ny = 2 n + 2``.
    f0 : ndarray, shape (ny,)
        ``rhs(t, y)``.
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (impact speed, m/s).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).
    ws : Workspace
        Its workspace (:class:`~mechrel.mechanics.dynamics.Workspace`).
    J : ndarray, shape (ny, ny)
        Receives the Jacobian (SI units of ``f`` over those of ``y``).
    floor : float
        Floor of the increments' scale (SI units of ``y``; the integrator passes atol/rtol).
    yp, fp : ndarray, shape (ny,)
        Work arrays.

    Returns
    -------
    int
        The number of right-hand-side evaluations, ``2 n``.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.dynamics import make_workspace, rhs
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> f0, J = rhs(0.0, y, np.zeros(0), dyn), np.zeros((20, 20))
    >>> fd_jacobian(0.0, y, f0, np.zeros(0), dyn, make_workspace(dyn), J, 1e-4, np.empty(20),
    ...             np.empty(20))
    18
    >>> bool((J[:9, 9:18] == np.eye(9)).all()), bool((J[:, 18:] == 0).all())
    (True, True)
    """
    y, f0, hist, sys, ws, J, yp, fp = borrowed((y, f0, hist, sys, ws, J, yp, fp))
    n = n_coordinates(sys)
    ny = y.shape[0]
    for i in range(n):
        for j in range(ny):
            J[i, j] = 0.0
        J[i, n + i] = 1.0
    for i in range(n, ny):
        for j in range(2 * n, ny):
            J[i, j] = 0.0
    for j in range(ny):
        yp[j] = y[j]
    count = 0
    for j in range(2 * n):
        count += 1
        yj = y[j]
        yp[j] = yj + SQRT_UROUND * max(abs(yj), floor)
        d = yp[j] - yj  # the increment actually represented
        evaluate_inline(t, yp, hist, sys, ws, fp)
        for i in range(n, ny):
            J[i, j] = (fp[i] - f0[i]) / d
        yp[j] = yj
    return count


@njit(cache=True)
def _build_matrices(J, h, E1, E2):
    """The condensed iteration matrices ``g² I − g A_v − A_q`` (n × n) for ``g = γ/h``
    (real, ``E1``) and ``g = (α + iβ)/h`` (complex, ``E2``); see :func:`_solve_condensed`."""
    J, E1, E2 = borrowed((J, E1, E2))
    n = E1.shape[0]
    g1 = U1 / h
    g2 = complex(ALPH / h, BETA / h)
    for i in range(n):
        for j in range(n):
            aq = J[n + i, j]
            av = J[n + i, n + j]
            E1[i, j] = -g1 * av - aq
            E2[i, j] = -g2 * av - aq
        E1[i, i] += g1 * g1
        E2[i, i] += g2 * g2


@njit(cache=True)
def _solve_condensed(E, piv, J, g, b, work):
    """Solve ``(g I − J) x = b`` in place in ``b`` (length 2n + m) from the LU of the condensed
    matrix ``E = g² I − g A_v − A_q``.

    ``J`` has the structure of the dynamics, ``[[0, I, 0], [A_q, A_v, 0], [P_q, P_v, 0]]``
    (coordinates, velocities, m work integrals), so eliminating the velocity block leaves one
    n × n system: ``E x_q = b_v + g b_q − A_v b_q``, then ``x_v = g x_q − b_q`` and
    ``x_W = (b_W + P_q x_q + P_v x_v) / g`` (RADAU5's treatment of second-order systems,
    HW II §IV.8). ``work`` is a length-n array of ``b``'s type."""
    E, piv, J, b, work = borrowed((E, piv, J, b, work))
    n = E.shape[0]
    ny = b.shape[0]
    for i in range(n):
        s = b[n + i] + g * b[i]
        for j in range(n):
            s -= J[n + i, n + j] * b[j]
        work[i] = s
    lu_solve(E, piv, work)
    for i in range(n):
        xq = work[i]
        xv = g * xq - b[i]
        b[i] = xq
        b[n + i] = xv
    for i in range(2 * n, ny):
        s = b[i]
        for j in range(2 * n):
            s += J[i, j] * b[j]
        b[i] = s / g


@njit(cache=True)
def _rms(a, scal):
    s = 0.0
    for i in range(a.shape[0]):
        s += (a[i] / scal[i]) ** 2
    return math.sqrt(s / a.shape[0])


# ---------------------------------------------------------------------------- the step's parts
# The kernel keeps the step loop and its control (step size, Jacobian and LU reuse, rejection,
# contact onsets, outputs); each numerical part of a step is one of these helpers (as SciPy's
# ``_ivp/radau.py`` cuts its solver into ``solve_collocation_system``, ``predict_factor``, …).
# Their arithmetic is the kernel's, in the same order: the results are bitwise those of the
# kernel before the cut. All but _solve_collocation are inlined (module docstring, "Code
# structure").

NEWTON_CONVERGED = 0  # outcomes of _solve_collocation
NEWTON_FAILED = 1  # divergence, NIT iterations or a non-finite stage: halve the step
NEWTON_SHRINK = 2  # converging too slowly for NIT iterations: the step was shrunk already


@njit(cache=True, inline='always')
def _update_jacobian(t, y, f0, hist, sys, sys_smooth, ws, J, JS, Jsm, partial, n_partial,
                     use_partial, jac_floor, yp, fa, fb, stats):
    """Bring the Jacobian ``J`` of the right-hand side up to date at ``(t, y)`` (module
    docstring, "Partial updates").

    Without clearance joints (``use_partial`` False) ``J`` is the finite-difference Jacobian
    (:func:`fd_jacobian`). With them ``J`` = smooth rest + fast part: a *partial* update
    (``partial`` and fewer than ``MAX_PARTIAL`` since the last full one) keeps the smooth rest
    ``Jsm`` and recomputes only the fast part
    (:func:`~mechrel.mechanics.jacobian.clearance_jacobian`); a full update first recomputes
    ``Jsm`` from differences of ``sys_smooth`` minus its own fast part.

    Parameters
    ----------
    t : float
        Time (s).
    y, f0 : ndarray, shape (ny,)
        The state (SI units) and ``rhs(t, y)``.
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (m/s).
    sys, sys_smooth : System
        The mechanism and the same without clearance forces.
    ws : Workspace
        The right-hand side's workspace.
    J : ndarray, shape (ny, ny)
        The Jacobian; updated.
    JS : ndarray, shape (ny, ny)
        Receives the fast part (rows ``nq …``, columns ``< 2 nq``).
    Jsm : ndarray, shape (ny − nq, 2 nq)
        The smooth rest of the last full update; recomputed by a full one.
    partial : bool
        A partial update is allowed.
    n_partial : int
        Partial updates since the last full one.
    use_partial : bool
        The scene has clearance joints (``J`` is rest + fast part).
    jac_floor : float
        Floor of the difference increments' scale (``atol/rtol``, SI units of ``y``).
    yp, fa, fb : ndarray, shape (ny,)
        Work arrays (``fa``, ``fb``: two rows of the kernel's stage values).
    stats : ndarray
        Statistics vector: the evaluations are added to ``S_RHS``, one Jacobian to ``S_JAC``.

    Returns
    -------
    int
        The new count of partial updates since the last full one.
    """
    nq = n_coordinates(sys)
    ny = y.shape[0]
    if partial and n_partial < MAX_PARTIAL:
        n_partial += 1  # keep the smooth part Jsm of the last full Jacobian
    elif use_partial:
        # the smooth rest by differences of the mechanism without clearance forces
        # (minus its constraint-geometry share, which clearance_jacobian recomputes
        # with the full multipliers)
        fast_jacobian(t, y, hist, sys_smooth, ws, fb, JS)
        stats[S_RHS] += 1 + fd_jacobian(t, y, fb, hist, sys_smooth, ws, J, jac_floor,
                                        yp, fa)
        for i in range(nq, ny):
            for c in range(2 * nq):
                Jsm[i - nq, c] = J[i, c] - JS[i, c]
        n_partial = 0
    else:
        stats[S_RHS] += fd_jacobian(t, y, f0, hist, sys, ws, J, jac_floor, yp, fa)
        n_partial = 0
    if use_partial:  # J = smooth part + the fast (clearance) part now
        fast_jacobian(t, y, hist, sys, ws, fa, JS)
        stats[S_RHS] += 1
        for i in range(nq, ny):
            for c in range(2 * nq):
                J[i, c] = Jsm[i - nq, c] + JS[i, c]
    stats[S_JAC] += 1
    return n_partial


@njit(cache=True, inline='always')
def _factor_matrices(J, h, E1, E2, piv1, piv2):
    """Build and LU-factorise the real and complex condensed iteration matrices for the step
    ``h`` (:func:`_build_matrices`, :func:`lu_factor`).

    Parameters
    ----------
    J : ndarray, shape (ny, ny)
        The Jacobian.
    h : float
        The step (s).
    E1, E2 : ndarray, shape (nq, nq), float and complex
        Receive the factors.
    piv1, piv2 : ndarray of int, shape (nq,)
        Receive their row interchanges.

    Returns
    -------
    bool
        False if either matrix is singular (then ``E2`` is not factorised).
    """
    _build_matrices(J, h, E1, E2)
    ok = lu_factor(E1, piv1)
    if ok:
        ok = lu_factor(E2, piv2)
    return ok


@njit(cache=True, inline='always')
def _newton_start(first, h, hold, cont1, cont2, cont3, z1, z2, z3, w1, w2, w3):
    """Starting values of the Newton iteration: zero on the first step, else the previous
    step's collocation polynomial extrapolated to the new stages (RADCOR).

    Parameters
    ----------
    first : bool
        The first step (no polynomial yet).
    h, hold : float
        The new and the previous step (s).
    cont1, cont2, cont3 : ndarray, shape (ny,)
        The previous polynomial's coefficients (:func:`_collocation_coefficients`).
    z1, z2, z3 : ndarray, shape (ny,)
        Receive the stages ``Z_i = Y_i − y`` (SI units of ``y``).
    w1, w2, w3 : ndarray, shape (ny,)
        Receive the transformed stages ``W = (T⁻¹ ⊗ I) Z``.
    """
    ny = z1.shape[0]
    if first:
        for i in range(ny):
            z1[i] = 0.0
            z2[i] = 0.0
            z3[i] = 0.0
            w1[i] = 0.0
            w2[i] = 0.0
            w3[i] = 0.0
    else:
        c3q = h / hold
        c1q = C1 * c3q
        c2q = C2 * c3q
        for i in range(ny):
            ak1 = cont1[i]
            ak2 = cont2[i]
            ak3 = cont3[i]
            a = c1q * (ak1 + (c1q - C2M1) * (ak2 + (c1q - C1M1) * ak3))
            b = c2q * (ak1 + (c2q - C2M1) * (ak2 + (c2q - C1M1) * ak3))
            c = c3q * (ak1 + (c3q - C2M1) * (ak2 + (c3q - C1M1) * ak3))
            z1[i] = a
            z2[i] = b
            z3[i] = c
            w1[i] = TI11 * a + TI12 * b + TI13 * c
            w2[i] = TI21 * a + TI22 * b + TI23 * c
            w3[i] = TI31 * a + TI32 * b + TI33 * c


@njit(cache=True)
def _solve_collocation(t, h, tph, y, hist, sys, ws, J, E1, piv1, E2, piv2, fac1, alphn, betan,
                       scal, fnewt, faccon, nit, fixed, z1, z2, z3, w1, w2, w3, F3, ystage, r1,
                       rc, work1, work2, stats):
    """The simplified Newton iteration on the collocation system of one step (module docstring).

    From the starting values in ``z``, ``w`` (:func:`_newton_start`), iterate with the
    factorised matrices until ``η ‖ΔW‖ ≤ κ`` (``η = θ/(1 − θ)``, ``κ = fnewt``), at most
    ``nit`` iterations; shrink ``h`` at once when the predicted error after ``nit`` iterations
    stays above ``κ`` (not with ``fixed``).

    Parameters
    ----------
    t, h : float
        The step's start and size (s).
    tph : float
        The step's end (s): ``t + h``, or the output instant the last step ends on.
    y : ndarray, shape (ny,)
        The state at ``t`` (SI units).
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (m/s).
    sys : System
        The mechanism.
    ws : Workspace
        The right-hand side's workspace.
    J : ndarray, shape (ny, ny)
        The Jacobian the matrices were built from.
    E1, piv1, E2, piv2 : ndarray
        The factorised real and complex matrices (:func:`_factor_matrices`).
    fac1, alphn, betan : float
        ``γ/h``, ``α/h``, ``β/h`` of the ``h`` the matrices were built for (1/s).
    scal : ndarray, shape (ny,)
        Error scale ``atol + rtol |y|`` (SI units of ``y``).
    fnewt : float
        The Newton tolerance κ.
    faccon : float
        η of the previous step's iteration.
    nit : int
        Maximum iterations.
    fixed : bool
        Fixed-step mode (never shrink).
    z1, z2, z3, w1, w2, w3 : ndarray, shape (ny,)
        The stages and the transformed stages; updated to the iterate.
    F3 : ndarray, shape (3, ny)
        Receives f at the three stages.
    ystage, r1 : ndarray, shape (ny,)
        Work arrays.
    rc : ndarray of complex, shape (ny,)
        Work array.
    work1, work2 : ndarray, shape (nq,), float and complex
        Work arrays of :func:`_solve_condensed`.
    stats : ndarray
        Statistics vector: the evaluations are added to ``S_RHS``.

    Returns
    -------
    tuple
        ``(status, newt, theta, faccon, h)``: ``NEWTON_CONVERGED``, ``NEWTON_FAILED`` or
        ``NEWTON_SHRINK``; the iterations done; the contraction θ observed; η; the step (s),
        shrunk with ``NEWTON_SHRINK``.
    """
    (y, hist, sys, ws, J, E1, piv1, E2, piv2, scal, z1, z2, z3, w1, w2, w3, F3, ystage, r1, rc,
     work1, work2, stats) = borrowed((y, hist, sys, ws, J, E1, piv1, E2, piv2, scal, z1, z2, z3,
                                      w1, w2, w3, F3, ystage, r1, rc, work1, work2, stats))
    ny = y.shape[0]
    fa = F3[0]
    fb = F3[1]
    fc = F3[2]
    faccon = max(faccon, UROUND) ** 0.8
    theta = THET
    newt = 0
    dynold = 1.0
    thqold = 1.0
    status = NEWTON_SHRINK
    while True:
        if newt >= nit:
            status = NEWTON_FAILED
            break
        for st in range(3):  # one (inlined) call site for the three stages
            z = z1 if st == 0 else (z2 if st == 1 else z3)
            ts = t + C1 * h if st == 0 else (t + C2 * h if st == 1 else tph)
            for i in range(ny):
                ystage[i] = y[i] + z[i]
            evaluate_inline(ts, ystage, hist, sys, ws, F3[st])
        stats[S_RHS] += 3
        for i in range(ny):
            r1[i] = TI11 * fa[i] + TI12 * fb[i] + TI13 * fc[i] - fac1 * w1[i]
            re = TI21 * fa[i] + TI22 * fb[i] + TI23 * fc[i] - alphn * w2[i] + betan * w3[i]
            im = TI31 * fa[i] + TI32 * fb[i] + TI33 * fc[i] - alphn * w3[i] - betan * w2[i]
            rc[i] = complex(re, im)
        _solve_condensed(E1, piv1, J, fac1, r1, work1)
        _solve_condensed(E2, piv2, J, complex(alphn, betan), rc, work2)
        newt += 1
        s = 0.0
        for i in range(ny):
            s += (r1[i] / scal[i]) ** 2 + (rc[i].real / scal[i]) ** 2 \
                + (rc[i].imag / scal[i]) ** 2
        dyno = math.sqrt(s / (3.0 * ny))
        if not math.isfinite(dyno):
            status = NEWTON_FAILED
            break
        if newt > 1 and newt < nit:
            thq = dyno / dynold
            if newt == 2:
                theta = thq
            else:
                theta = math.sqrt(thq * thqold)
            thqold = thq
            if theta < 0.99:
                faccon = theta / (1.0 - theta)
                dyth = faccon * dyno * theta ** (nit - 1 - newt) / fnewt
                if dyth >= 1.0 and not fixed:  # no convergence in NIT iterations: shrink
                    qnewt = max(1e-4, min(20.0, dyth))
                    h *= 0.8 * qnewt ** (-1.0 / (4.0 + nit - 1 - newt))
                    break
            else:
                status = NEWTON_FAILED
                break
        dynold = max(dyno, UROUND)
        for i in range(ny):
            w1[i] += r1[i]
            w2[i] += rc[i].real
            w3[i] += rc[i].imag
            z1[i] = T11 * w1[i] + T12 * w2[i] + T13 * w3[i]
            z2[i] = T21 * w1[i] + T22 * w2[i] + T23 * w3[i]
            z3[i] = T31 * w1[i] + w2[i]
        if faccon * dyno <= fnewt:
            status = NEWTON_CONVERGED
            break
    return status, newt, theta, faccon, h


@njit(cache=True, inline='always')
def _estimate_error(t, h, y, f0, hist, sys, ws, J, E1, piv1, fac1, scal, z1, z2, z3, fe, ev,
                    ystage, fa, work1, refine, stats):
    """The filtered error estimate of a converged step (ESTRAD).

    ``err = ‖(γ/h I − J)⁻¹ (f(y) + (e·Z)/h)‖`` in the scaled RMS norm, recomputed once with
    ``f(y + err)`` in place of ``f(y)`` when it is ≥ 1 and ``refine`` (first step or after a
    rejection), as RADAU5 does.

    Parameters
    ----------
    t, h : float
        The step's start and size (s).
    y, f0 : ndarray, shape (ny,)
        The state at ``t`` and ``rhs(t, y)``.
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (m/s).
    sys : System
        The mechanism.
    ws : Workspace
        The right-hand side's workspace.
    J, E1, piv1 : ndarray
        The Jacobian and the factorised real matrix (:func:`_factor_matrices`).
    fac1 : float
        ``γ/h`` (1/s).
    scal : ndarray, shape (ny,)
        Error scale (SI units of ``y``).
    z1, z2, z3 : ndarray, shape (ny,)
        The converged stages.
    fe, ev, ystage, fa : ndarray, shape (ny,)
        Work arrays (``ev`` receives the error vector).
    work1 : ndarray, shape (nq,)
        Work array of :func:`_solve_condensed`.
    refine : bool
        Allow the recomputation (first step, or the step after a rejection).
    stats : ndarray
        Statistics vector: the evaluation is added to ``S_RHS``.

    Returns
    -------
    float
        The scaled error, ≥ 1e-10; 1e10 if it is not finite.
    """
    ny = y.shape[0]
    hee1 = DD1 / h
    hee2 = DD2 / h
    hee3 = DD3 / h
    for i in range(ny):
        fe[i] = hee1 * z1[i] + hee2 * z2[i] + hee3 * z3[i]
        ev[i] = fe[i] + f0[i]
    _solve_condensed(E1, piv1, J, fac1, ev, work1)
    err = max(_rms(ev, scal), 1e-10)
    if err >= 1.0 and refine:
        for i in range(ny):
            ystage[i] = y[i] + ev[i]
        evaluate(t, ystage, hist, sys, ws, fa)
        stats[S_RHS] += 1
        for i in range(ny):
            ev[i] = fa[i] + fe[i]
        _solve_condensed(E1, piv1, J, fac1, ev, work1)
        err = max(_rms(ev, scal), 1e-10)
    if not math.isfinite(err):
        err = 1e10
    return err


@njit(cache=True, inline='always')
def _collocation_coefficients(z1, z2, z3, cont1, cont2, cont3):
    """Coefficients of the accepted step's collocation polynomial (CONTR5).

    The polynomial through ``y``, ``Y₁``, ``Y₂``, ``Y₃`` in ``s = (t' − t)/h ∈ [−1, 0]`` from
    the step's end ``t`` (:func:`_dense_output`); also the predictor of the next step's Newton
    start (:func:`_newton_start`).

    Parameters
    ----------
    z1, z2, z3 : ndarray, shape (ny,)
        The accepted stages ``Z_i = Y_i − y`` (SI units of ``y``).
    cont1, cont2, cont3 : ndarray, shape (ny,)
        Receive the coefficients.
    """
    for i in range(z1.shape[0]):
        z1i = z1[i]
        z2i = z2[i]
        cont1[i] = (z2i - z3[i]) / C2M1
        ak = (z1i - z2i) / C1MC2
        acont3 = (ak - z1i / C1) / C2
        cont2[i] = (ak - cont1[i]) / C1M1
        cont3[i] = cont2[i] - acont3


@njit(cache=True, inline='always')
def _dense_output(s, y, cont1, cont2, cont3, out):
    """The collocation polynomial at ``s = (t' − t)/h`` (−1 < s ≤ 0) into ``out``.

    Parameters
    ----------
    s : float
        The instant as a fraction of the step from its end ``t``.
    y : ndarray, shape (ny,)
        The state at the step's end (SI units).
    cont1, cont2, cont3 : ndarray, shape (ny,)
        The coefficients (:func:`_collocation_coefficients`).
    out : ndarray, shape (ny,)
        Receives the state at ``t + s h``.
    """
    for i in range(y.shape[0]):
        out[i] = y[i] + s * (cont1[i] + (s - C2M1) * (cont2[i] + (s - C1M1) * cont3[i]))


# ---------------------------------------------------------------------------- the kernel
@njit(cache=True, nogil=True)
def radau5_kernel(sys, sys_smooth, t0, y0, hist, t_out, h0, rtol_user, atol_user, max_steps,
                  onset_tol, fixed, ctl, log_from, n_dense):
    """Radau IIA (order 5) from ``(t0, y0)`` over the increasing output instants ``t_out``.

    With ``fixed`` True the step ``h0`` is kept constant (no error control; for
    convergence-order checks) except that the last step ends on ``t_out[-1]``; Newton may then
    take up to ``NIT_FIXED`` iterations with a fresh Jacobian at every step, and a failure
    stops with ``STATUS_NEWTON``.

    Parameters
    ----------
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).
    sys_smooth : System
        The same without clearance forces
        (:func:`~mechrel.mechanics.system.without_clearance_forces`), whose finite-difference
        Jacobian the partial updates keep.
    t0 : float
        Start time (s).
    y0 : ndarray, shape (ny,)
        Initial state (SI units; :func:`~mechrel.mechanics.dynamics.rhs`).
    hist : ndarray, shape (nh,)
        Initial history of the contact-capable joints (m/s).
    t_out : ndarray, shape (N,)
        Increasing output instants (s).
    h0 : float
        Initial (with ``fixed``: the constant) step (s); ≤ 0 picks it automatically.
    rtol_user, atol_user : float
        Tolerances in RADAU5's convention (module docstring; ``atol`` in the SI units of ``y``).
    max_steps : int
        Step budget.
    onset_tol : float
        Tolerance (s) on the instant of a contact onset.
    fixed : bool
        Constant step without error control.
    ctl : ndarray of int64, shape (2,)
        Control vector: outputs done, stop request (:mod:`mechrel.integrate.events`).
    log_from : float
        Log every accepted step from this time on (s); ``inf``: no log.
    n_dense : int
        Points per step taken inside it from the collocation polynomial in the log.

    Returns
    -------
    tuple
        ``(Y, YD, hist, stats, t, y, log, H)``: the states and their derivatives at ``t_out``
        in the absolute layout (shape (N, 2 n + 2), whichever formulation ``sys`` is in:
        :func:`~mechrel.mechanics.formulation.write_output`), the final history, the
        statistics vector (``N_STATS``), the time and state reached (in ``sys``'s
        formulation), the step log (rows in the absolute layout) and the history at each
        output instant (shape (N, nh)); as :func:`~mechrel.integrate.explicit.rk4_kernel`.

    Examples
    --------
    A millisecond of the lubricated slider-crank from its centred start:

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.dynamics import make_workspace, rhs
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> from mechrel.integrate.events import S_STATUS
    >>> from mechrel.mechanics.system import without_clearance_forces
    >>> out = radau5_kernel(dyn, without_clearance_forces(dyn), 0.0, y, np.zeros(0),
    ...                     np.array([0.0, 1e-3]), 0.0, 1e-6, 1e-9, 100000, 1e-9, False,
    ...                     np.zeros(2, dtype=np.int64), math.inf, 0)
    >>> Y, stats = out[0], out[3]
    >>> Y.shape, float(stats[S_STATUS]), round(float(Y[1, 2]), 4)
    ((2, 20), 0.0, 0.5236)
    """
    nout = t_out.shape[0]
    ny = y0.shape[0]
    # RADAU5's tolerance transformation (module docstring)
    rtol = 0.1 * rtol_user ** (2.0 / 3.0)
    atol = rtol * (atol_user / rtol_user)
    fnewt = max(10.0 * UROUND / rtol, min(0.03, math.sqrt(rtol)))
    jac_floor = atol / rtol
    nit = NIT_FIXED if fixed else NIT

    Y, YD, stats, floors, y, f0, k, tend, ws = start(sys, t0, y0, hist, t_out)
    H = np.zeros((nout, hist.shape[0]))  # the history state at each output instant
    for i in range(k):
        H[i] = hist
    ctl[CTL_DONE] = k
    t = t0
    scal = np.empty(ny)
    for i in range(ny):
        scal[i] = atol + rtol * abs(y[i])
    h = h0
    if h <= 0.0:  # Hairer's starting-step heuristic (HNW I, §II.4), as in dopri5_kernel
        d0 = _rms(y, scal)
        d1 = _rms(f0, scal)
        h = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
        h = max(h, H_START_FLOOR * max(1.0, abs(t)))
    if k < nout:
        h = min(h, tend - t)
    h_fixed = h

    J = np.zeros((ny, ny))
    nq = n_coordinates(sys)
    E1 = np.zeros((nq, nq))
    E2 = np.zeros((nq, nq), dtype=np.complex128)
    piv1 = np.zeros(nq, dtype=np.int64)
    piv2 = np.zeros(nq, dtype=np.int64)
    work1 = np.zeros(nq)
    work2 = np.zeros(nq, dtype=np.complex128)
    z1 = np.zeros(ny)
    z2 = np.zeros(ny)
    z3 = np.zeros(ny)
    w1 = np.zeros(ny)
    w2 = np.zeros(ny)
    w3 = np.zeros(ny)
    cont1 = np.zeros(ny)
    cont2 = np.zeros(ny)
    cont3 = np.zeros(ny)
    r1 = np.zeros(ny)
    rc = np.zeros(ny, dtype=np.complex128)
    fe = np.zeros(ny)
    ev = np.zeros(ny)
    ystage = np.zeros(ny)
    F3 = np.zeros((3, ny))  # f at the three stages (fa, fb: its rows, below)
    yp = np.zeros(ny)

    use_partial = has_fast_part(sys)  # absolute, with clearance joints: partial updates
    JS = np.zeros((ny, ny))  # clearance part of the Jacobian (rows nq …, columns < 2 nq)
    Jsm = np.zeros((ny - nq, 2 * nq))  # the rest, from the last full Jacobian
    # np.bool_ and np.int64: typed as plain bool and int64 from the start, so the helpers that
    # take these flags compile once (a literal True, False or 0 compiled them a second time)
    partial = np.bool_(False)  # the next Jacobian may refresh only the clearance columns
    n_partial = np.int64(0)
    need_jac = True
    need_lu = True
    caljac = False  # the current J was computed at the current (t, y)
    first = np.bool_(True)
    reject = False
    last = False
    hold = h
    hacc = h
    erracc = 1e-2
    faccon = 1.0
    theta = THET
    n_accept = 0
    n_fail = 0
    n_sing = 0
    fac1 = U1 / h
    alphn = ALPH / h
    betan = BETA / h
    hnew = h

    nh = hist.shape[0]
    contacts = nh > 0
    g0 = np.empty(nh)
    g1 = np.empty(nh)
    gd1 = np.empty(nh)
    if contacts:
        gaps(t, y, sys, g0, gd1)  # kept from step to step: the end of one is the next's start
    log, nlog = new_log(log_from, output_width(sys), nh)  # rows in the absolute layout
    ydense = np.zeros(ny)  # a state from the collocation polynomial (an output, a log point)
    fdense = np.zeros(ny)  # and its derivative
    yrow = np.zeros(output_width(sys))  # a log row in the absolute layout
    frow = np.zeros(output_width(sys))
    # The work arrays, borrowed for the rest of the call (mechanics/borrow.py): ``owners``
    # holds them until the return, and the inlined step helpers, which must not borrow what
    # they are given, see them borrowed from here. (Y, YD, H, y, hist, stats and the log are
    # returned and stay counted.)
    owners = (ws, f0, floors, J, E1, E2, piv1, piv2, work1, work2, z1, z2, z3, w1, w2, w3,
              cont1, cont2, cont3, r1, rc, fe, ev, ystage, F3, yp, JS, Jsm, scal, g0, g1, gd1,
              ydense, fdense, yrow, frow)
    (ws, f0, floors, J, E1, E2, piv1, piv2, work1, work2, z1, z2, z3, w1, w2, w3, cont1, cont2,
     cont3, r1, rc, fe, ev, ystage, F3, yp, JS, Jsm, scal, g0, g1, gd1, ydense, fdense, yrow,
     frow) = borrowed(owners)
    sys, sys_smooth = borrowed((sys, sys_smooth))  # arguments: alive for the call
    fa = F3[0]
    fb = F3[1]
    while k < nout:
        if need_jac:
            n_partial = _update_jacobian(t, y, f0, hist, sys, sys_smooth, ws, J, JS, Jsm,
                                         partial, n_partial, use_partial, jac_floor, yp, fa, fb,
                                         stats)
            partial = False
            caljac = True
            need_jac = False
            need_lu = True
        if out_of_budget(stats, h, t, max_steps, ctl):
            break
        if need_lu:
            ok = _factor_matrices(J, h, E1, E2, piv1, piv2)
            stats[S_LU] += 1
            fac1 = U1 / h
            alphn = ALPH / h
            betan = BETA / h
            need_lu = False
            if not ok:
                n_sing += 1
                n_fail += 1
                if n_sing >= MAX_SINGULAR or fixed:
                    stats[S_STATUS] = STATUS_NEWTON
                    break
                h *= 0.5
                reject = True
                last = False
                need_lu = True
                if not caljac:
                    need_jac = True
                continue
        tph = tend if last else t + h

        # starting values of the Newton iteration: the previous collocation polynomial
        _newton_start(first, h, hold, cont1, cont2, cont3, z1, z2, z3, w1, w2, w3)

        # simplified Newton iteration
        status, newt, theta, faccon, h = _solve_collocation(
            t, h, tph, y, hist, sys, ws, J, E1, piv1, E2, piv2, fac1, alphn, betan, scal, fnewt,
            faccon, nit, fixed, z1, z2, z3, w1, w2, w3, F3, ystage, r1, rc, work1, work2, stats)

        if status != NEWTON_CONVERGED:
            stats[S_REJECTED] += 1
            stats[S_NEWTON_REJECTED] += 1
            reject = True
            last = False
            if status == NEWTON_FAILED:
                n_fail += 1
                if n_fail >= MAX_NEWTON_FAILURES or fixed:
                    stats[S_STATUS] = STATUS_NEWTON
                    break
                h *= 0.5
            need_lu = True
            if not caljac:
                need_jac = True
            continue
        n_fail = 0

        # error estimate (ESTRAD): (γ/h I − J)⁻¹ (f(y) + (e·Z)/h)
        if fixed:
            err = 0.0
        else:
            err = _estimate_error(t, h, y, f0, hist, sys, ws, J, E1, piv1, fac1, scal, z1, z2,
                                  z3, fe, ev, ystage, fa, work1, first or reject, stats)

        # proposed step
        fac = min(SAFE, SAFE * (1.0 + 2.0 * NIT) / (newt + 2.0 * NIT))
        quot = max(FACR, min(FACL, err ** 0.25 / fac))
        hnew = h / quot

        if err < 1.0:
            # contact onset inside the step: shorten it to locate the onset
            if contacts:
                for i in range(ny):
                    ystage[i] = y[i] + z3[i]
                gaps(tph, ystage, sys, g1, gd1)
                th_on = onset_fraction(g0, g1, hist, onset_tol)
                if th_on < 1.0:
                    stats[S_ONSET_REJECTED] += 1
                    h *= th_on
                    last = False
                    need_lu = True
                    continue
            # accepted
            first = False
            n_accept += 1
            if n_accept > 1:  # Gustafsson's predictive controller
                facgus = (hacc / h) * (err * err / erracc) ** 0.25 / SAFE
                facgus = max(FACR, min(FACL, facgus))
                quot = max(quot, facgus)
                hnew = h / quot
            hacc = h
            erracc = max(1e-2, err)
            hold = h
            t = tph
            for i in range(ny):
                y[i] += z3[i]
            _collocation_coefficients(z1, z2, z3, cont1, cont2, cont3)
            stats[S_STEPS] += 1
            # outputs in (told, t] from the collocation polynomial, s = (t_out − t)/h ∈ (−1, 0]
            while k < nout and t_out[k] <= t:
                if t_out[k] == t:
                    ydense[:] = y
                else:
                    _dense_output((t_out[k] - t) / hold, y, cont1, cont2, cont3, ydense)
                evaluate(t_out[k], ydense, hist, sys, ws, fdense)
                write_output(sys, ws, ydense, fdense, Y[k], YD[k])
                H[k] = hist
                stats[S_RHS] += 1
                k += 1
            ctl[CTL_DONE] = k
            if t > log_from:  # the solution log: points of the collocation polynomial
                for j in range(1, n_dense + 1):
                    s = j / (n_dense + 1.0) - 1.0
                    tj = t + s * hold
                    if tj >= log_from:
                        _dense_output(s, y, cont1, cont2, cont3, ydense)
                        evaluate(tj, ydense, hist, sys, ws, fdense)
                        stats[S_RHS] += 1
                        write_output(sys, ws, ydense, fdense, yrow, frow)
                        log, nlog = log_row(log, nlog, tj, yrow, frow, hist)
            if not all_finite(y):
                stats[S_STATUS] = STATUS_NONFINITE
                break
            changed = False
            if contacts:
                g0, g1 = g1, g0
                changed = update_history_from(g0, gd1, hist, floors, stats)
            evaluate(t, y, hist, sys, ws, f0)
            record_violation(ws, stats)
            stats[S_RHS] += 1
            if t > log_from:  # and the step's end (ws still holds its evaluation)
                write_output(sys, ws, y, f0, yrow, frow)
                log, nlog = log_row(log, nlog, t, yrow, frow, hist)
            for i in range(ny):
                scal[i] = atol + rtol * abs(y[i])
            caljac = False
            if fixed:
                hnew = h_fixed
            if reject:
                hnew = min(hnew, h)
            reject = False
            if k >= nout:
                break
            if t + hnew * (1.0 + 1e-6) >= tend:
                h = tend - t
                last = True
            else:
                qt = hnew / h
                if (theta <= THET and qt >= QUOT1 and qt <= QUOT2 and not changed
                        and not fixed):
                    continue  # keep h, J and the LU
                h = hnew
            if changed or theta > THET or fixed:
                need_jac = True
                partial = use_partial and not changed and not fixed
            else:
                need_lu = True
        else:
            # rejected by the error test
            stats[S_REJECTED] += 1
            reject = True
            last = False
            if first:
                h *= 0.1
            else:
                h = hnew
            need_lu = True
            if not caljac:
                need_jac = True
    keep_alive(owners)
    return Y, YD, hist, stats, t, y, log[:nlog], H


# ---------------------------------------------------------------------------- the class
class Radau(Integrator):
    """Compiled Radau IIA of order 5 (RADAU5) for stiff scenes (lubricated joints).

    Default tolerances ``rtol = 1e-6``, ``atol = 1e-9`` in RADAU5's convention (module
    docstring; internally ``rtol' ≈ 1e-5``), for a stiff scene used without settings: on the
    lubricated nine-bar they put the peak slider acceleration within 6e-6 (relative) of a
    tight-tolerance reference, and every sample within 1e-4 of the peak, in under 300 steps
    per cycle (docs/dev/performance-log.md); ``atol = 1e-9`` is a nanometre (nanoradian, nm/s)
    floor, far below the clearances (≥ 0.1 mm) and their rates that the scenes resolve. Scenes
    whose type selects ``radau`` automatically use ``DEFAULT_SOLVERS`` (1e-7, 1e-10).

    Parameters
    ----------
    fixed_step : bool, optional
        Integrate at the constant step ``step`` without error control (for convergence-order
        checks only). Default False.
    formulation : {"auto", "absolute", "reduced"}, optional
        The equations integrated. ``"reduced"``: the clearance joints' eccentricities and
        the free coordinates of the undriven links and sliders
        (:mod:`mechrel.mechanics.reduced`; ``2 (2 nc + nf) + 2`` states, the constraints
        exact), for a mechanism the construction places in closed form and that has
        something to integrate
        (:func:`reduced_system`); ``"absolute"``: all bodies' coordinates with Lagrange
        multipliers (:mod:`mechrel.mechanics.dynamics`), for every mechanism. ``"auto"``
        (default) is ``"reduced"`` where it applies. Either way the results are in the
        absolute layout; :attr:`SolverStats.formulation <mechrel.integrate.base.SolverStats>`
        says which ran. The tolerances weigh different states (eccentricities in m, free
        angles in rad, against body coordinates), so the same settings are not the same
        accuracy: docs/performance.md compares the two at equal accuracy.
    **kwargs
        The settings of :class:`~mechrel.integrate.base.Integrator` (``step`` (s), ``rtol``,
        ``atol``, ``max_steps``, ``onset_tolerance``).

    Raises
    ------
    SimulationError
        ``fixed_step`` without a ``step``, an unknown ``formulation``, or a bad setting
        (:class:`~mechrel.integrate.base.Integrator`).

    Examples
    --------
    >>> Radau().settings
    {'rtol': 1e-06, 'atol': 1e-09}
    >>> Radau(step=1e-5, fixed_step=True).settings
    {'rtol': 1e-06, 'atol': 1e-09, 'step': 1e-05, 'fixed_step': True}
    """

    name = "radau"
    stiff = True
    defaults = {"rtol": 1e-6, "atol": 1e-9}
    formulations = FORMULATIONS  # the scene's [solver] formulation takes the same values

    def __init__(self, *, fixed_step: bool = False, formulation: str = "auto", **kwargs):
        super().__init__(**kwargs)
        self.fixed_step = bool(fixed_step)
        if self.fixed_step and self.step is None:
            raise SimulationError("solver.step: the fixed-step mode of 'radau' needs a step (s)")
        if formulation not in self.formulations:
            raise SimulationError(f"radau's formulation = {formulation!r}: allowed: "
                                  + ", ".join(repr(f) for f in self.formulations))
        self.formulation = formulation

    @property
    def settings(self) -> dict:
        """The settings this integrator uses: its tolerances, the step in fixed-step mode and a
        formulation other than ``"auto"``.

        Returns
        -------
        dict
            ``{"rtol": ..., "atol": ...}``, plus ``"step"`` (s) and ``"fixed_step": True`` with
            ``fixed_step``, and ``"formulation"`` when one was asked for.

        Examples
        --------
        >>> Radau(rtol=1e-8).settings
        {'rtol': 1e-08, 'atol': 1e-09}
        >>> Radau(formulation="absolute").settings
        {'rtol': 1e-06, 'atol': 1e-09, 'formulation': 'absolute'}
        """
        out = {"rtol": self.rtol, "atol": self.atol}
        if self.fixed_step:
            out["step"] = self.step
            out["fixed_step"] = True
        if self.formulation != "auto":
            out["formulation"] = self.formulation
        return out

    def formulation_for(self, system) -> str:
        """``"reduced"`` where the reduced equations apply and were not declined
        (``formulation="absolute"``), else ``"absolute"``.

        Parameters
        ----------
        system : System
            The mechanism with its clearance joints as force elements.

        Returns
        -------
        str

        Raises
        ------
        SimulationError
            ``formulation="reduced"`` where they do not apply (:func:`reduced_system`).

        Examples
        --------
        >>> from mechrel.mechanics.system import compile_scene
        >>> from mechrel.scene import load_scene
        >>> sys = compile_scene(load_scene("nine-bar-lubricated")).dynamic
        >>> Radau().formulation_for(sys), Radau(formulation="absolute").formulation_for(sys)
        ('reduced', 'absolute')
        """
        if self.formulation == "absolute":
            return "absolute"
        return "absolute" if reduced_system(
            system, None, required=self.formulation == "reduced") is None else "reduced"

    def _before(self, system, t0, y0, hist, t_out):
        """``(reduced system or None, what the kernel integrates, its smooth part, its initial
        state)``: the reduced equations where they apply (:func:`reduced_system`, the
        reduced initial state), else the absolute ones."""
        reduced = None if self.formulation == "absolute" else reduced_system(
            system, y0, required=self.formulation == "reduced")
        if reduced is None:
            return None, system, without_clearance_forces(system), y0
        return (reduced, reduced, *_reduced_start(reduced, y0))

    def _advance(self, system, t0, y0, hist, t_out, ctl, log_from=math.inf, n_dense=0,
                 prep=None):
        _, equations, smooth, start = prep or self._before(system, t0, y0, hist, t_out)
        return radau5_kernel(equations, smooth, t0, start, hist, t_out, self.step or 0.0,
                             self.rtol, self.atol, self.max_steps, self.onset_tolerance,
                             self.fixed_step, ctl, log_from, n_dense)

    def _after(self, prep, out, t_out, ctl):
        """On the reduced equations, their outputs completed in the absolute layout
        (:func:`_finish_reduced`)."""
        reduced = prep[0]
        return out if reduced is None else _reduced_outputs(reduced, out, t_out, ctl)


def reduced_system(system, y0, *, required=False):
    """The :class:`~mechrel.mechanics.reduced.ReducedSystem` of ``system`` at the state
    ``y0``, or None where the reduced equations do not apply.

    They apply when the construction (:func:`~mechrel.mechanics.construction.construction`)
    places every body from the drivers, the clearance joints' eccentricities and the free
    coordinates of the undriven degrees of freedom (free angles of links, free positions of
    sliders), i.e. when the mechanism is built of the groups it knows; and when it has
    clearance joints or an undriven degree of freedom (otherwise there is nothing to
    integrate).

    Parameters
    ----------
    system : System
        The mechanism with its clearance joints as force elements.
    y0 : ndarray, shape (2 n + 2,) or None
        The initial state; its configuration fixes the assembly branch and the angles'
        continuation (None: only whether the equations apply; the result's ``q_ref`` is
        then empty).
    required : bool, optional
        Raise instead of returning None.

    Returns
    -------
    ReducedSystem or None

    Raises
    ------
    SimulationError
        With ``required``, where the reduced equations do not apply (the reason).

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("nine-bar-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> y0 = np.concatenate([q, v, np.zeros(2)])
    >>> reduced_system(c.dynamic, y0).con.cl_nodes.shape
    (2, 2)

    The double pendulum is integrated in its two links' angles; the ideal nine-bar, fully
    driven, has nothing to integrate:

    >>> d = compile_scene(load_scene("double-pendulum"))
    >>> reduced_system(d.dynamic, np.zeros(14)).con.n_free
    2
    >>> i = compile_scene(load_scene("nine-bar"))
    >>> reduced_system(i.dynamic, None) is None
    True
    >>> reduced_system(i.dynamic, None, required=True)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    mechrel.errors.SimulationError: radau's formulation = 'reduced': the mechanism has no ...
    """
    why = None
    con = construction(system)
    if con is None:
        why = ("the mechanism cannot be placed in closed form from its drivers, the clearance "
               "joints' eccentricities and its undriven links' angles and sliders' positions "
               "(a group the construction does not know, such as a class-III group, or a "
               "revolute joint holding a prescribed offset)")
    elif n_reduced(con) == 0:
        why = ("the mechanism has no clearance joint and no undriven degree of freedom: "
               "nothing to integrate")
    if why is None:
        n = system.mass.shape[0] if y0 is not None else 0
        q_ref = np.zeros(0) if y0 is None else np.asarray(y0[:n], dtype=float)
        return ReducedSystem(system, con, np.ascontiguousarray(q_ref).copy())
    if required:
        raise SimulationError(
            f"radau's formulation = 'reduced': {why}; allowed for mechanisms the construction "
            "places and that have clearance joints or undriven degrees of freedom (use 'auto' "
            "or 'absolute')")
    return None


def _reduced_start(red, y0):
    """``(the reduced system without clearance forces, the reduced initial state)``: what
    :class:`Radau` integrates the reduced equations from (``(z, ż, W)``,
    :func:`~mechrel.mechanics.reduced.reduced_coordinates`). The kernel writes its outputs and
    log in the absolute layout (from each output's own evaluation,
    :func:`~mechrel.mechanics.reduced.output_row`); :func:`_reduced_outputs` expands the final
    state after it, so that a caller sees the contract of
    :class:`~mechrel.integrate.base.Integrator` unchanged. Around the kernel there are two
    compiled calls, the reduced initial state and :func:`_finish_reduced`: each compiled call
    with the mechanism's arrays costs its dispatch (~10 µs)."""
    system, con = red.sys, red.con
    n = system.mass.shape[0]
    yr0 = reduced_coordinates(system, con, y0[:n], y0[n:2 * n], work=y0[2 * n:2 * n + 2])
    return red._replace(sys=without_clearance_forces(system)), yr0


def _reduced_outputs(red, out, t_out, ctl):
    """What the kernel returned on the reduced equations ``red``, in the absolute layout:
    the final state expanded and the constraint violation reported, that of the first and
    last outputs, by the dense constraint functions (the construction satisfies the
    constraints to round-off at every instant)."""
    Y, YD, hist, stats, t, y, log, H = out
    pos, vel, ya = _finish_reduced(Y, t_out, int(ctl[CTL_DONE]), t, y, red.sys, red.con,
                                   red.q_ref)
    stats[S_VIOL_POS] = max(stats[S_VIOL_POS], pos)
    stats[S_VIOL_VEL] = max(stats[S_VIOL_VEL], vel)
    stats[S_FORMULATION] = FORMULATION_TEXT.index("reduced")
    return Y, YD, hist, stats, t, ya, log, H


@njit(cache=True, nogil=True)
def _finish_reduced(Y, t_out, n_done, t, y, sys, con, q_ref):
    """After the reduced kernel, in one compiled call: the constraint violation of the first
    and last outputs stored (``n_done`` of the rows ``Y``, absolute layout;
    :func:`~mechrel.mechanics.constraints.violations_at`), and the final reduced state ``y``
    at ``t`` expanded to the absolute layout (:func:`~mechrel.mechanics.reduced.expand_rows`;
    the angles continue the last output's). Returns ``(max |Φ|, max |Φ̇|, final row)``."""
    n = sys.mass.shape[0]
    rows = np.empty(2, dtype=np.int64)
    m = 0
    for k in (0, n_done - 1):
        if 0 <= k < Y.shape[0]:
            rows[m] = k
            m += 1
    pos, vel = violations_at(Y, t_out, rows[:m], sys)
    rw = make_reduced_work(sys, con, q_ref)
    if m > 0 and np.all(np.isfinite(Y[rows[m - 1], :n])):
        rw.th_ref[:] = Y[rows[m - 1], 2:n:3]
    ny = 2 * n + 2
    ya, yda = np.empty((1, ny)), np.empty((1, ny))
    fr = np.zeros((1, y.shape[0]))  # the final state's z'' is not needed: q, q' only
    T = np.empty(1)
    T[0] = t
    expand_rows(T, y.reshape(1, y.shape[0]), fr, sys, con, rw, ya, yda)
    return pos, vel, ya[0]
