"""FORM: the first-order reliability method (design point by iHLRF).

In the standard normal space u of the inputs (Nataf transform, plus the random allowables as
independent coordinates) the design point u* is the point of the limit surface G(u) = 0 nearest
to the origin; β = ±‖u*‖ (negative when the origin itself fails) and P_f ≈ Φ(−β), exact when G
is linear in u (Hasofer & Lind 1974; Rackwitz & Fiessler 1978).

Search: the improved Hasofer–Lind–Rackwitz–Fiessler iteration (Zhang & Der Kiureghian 1995)

    d_k = [(∇G_k·u_k − G_k)/‖∇G_k‖²] ∇G_k − u_k,    u_{k+1} = u_k + λ_k d_k,

with λ_k = b^j (b = 1/2) the first step satisfying Armijo's rule (parameter 1/4) on the merit function
m(u) = ½‖u‖² + c_k |G(u)|, c_k = γ · max(‖u_k‖, ‖u_k + d_k‖)/‖∇G_k‖, γ = 2: c_k > ‖u_k‖/‖∇G_k‖
makes d_k a descent direction (Zhang & Der Kiureghian's condition), and the ‖u_k + d_k‖ term
accepts the full step from the origin on a linear G. Both terms scale like u/‖∇G‖, so the
merit does not depend on the units of g (a form with ½‖u + d‖²/|G| instead blows up as G → 0
in small units, e.g. metres of error, and stalls the line search). Converged when |G_k| ≤ tol·|G_0| and ‖u_k − (α_k·u_k) α_k‖ ≤
tol_direction·max(1, ‖u_k‖) with α_k = −∇G_k/‖∇G_k‖ (u_k on the surface and parallel to the
normal). The error of β is about |G(u*)|/‖∇G‖ (first order in the surface criterion) plus
β·(direction error)²/2 (second order), so the direction tolerance can be looser than the
finite-difference round-off of the gradient allows for the surface one.

Gradients by central (or forward) differences in u with step ``step``: the 2d (or d) points and
the centre go to the executor together, so they run in parallel and are cached.

Importance factors: α_j² (Σ α_j² = 1) is the share of the variance of the linearised margin
from the j-th standard normal coordinate. For independent inputs that is the input itself; with
correlated inputs the coordinates are those of the Nataf transform (Cholesky order).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from scipy import special

from mechrel._checks import ARGS
from mechrel.errors import StudyError

from ..execution.executor import Evaluations
from ..problem.inputs import seed_record
from ._problem import Problem, RareEventResult, refuse_evaluations

__all__ = ["form", "FORMResult", "FORMConvergenceError"]

SCHEMES = ("central", "forward")
EPS = float(np.finfo(float).eps)


class FORMConvergenceError(StudyError):
    """The design-point search did not converge.

    Parameters
    ----------
    message : str
        What did not converge, and what to try.
    history : DataFrame
        Every iterate of the search (also ``.history``).

    Examples
    --------
    >>> from mechrel.uq import FORMConvergenceError, form
    >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    >>> wavy = FunctionModel(lambda X: 3.0 - X[:, 0] ** 3 + 5 * X[:, 0], ["x"], ["g"],
    ...                      vectorized=True)
    >>> try:
    ...     form(model=wavy, inputs=inputs, max_iter=2)
    ... except FORMConvergenceError as exc:
    ...     print(len(exc.history) <= 3)
    True
    """

    def __init__(self, message: str, history: pd.DataFrame):
        super().__init__(message)
        self.history = history


@dataclass(frozen=True, eq=False)
class FORMResult(RareEventResult):
    """FORM result (frozen).

    Parameters
    ----------
    table : DataFrame
        One row: ``pf`` = Φ(−β), ``beta``, ``n_evaluations``, ``n_iterations``, ``g_origin``
        (G at u = 0).
    design_point : DataFrame
        One row per input, allowables included: ``u`` (standard normal), ``x`` (physical, SI),
        ``alpha`` (−∇G/‖∇G‖), ``importance`` (α²), ``dg_du``.
    history : DataFrame
        One row per iteration.
    u_star : ndarray
        The design point in standard normal space.
    grad_u : ndarray
        ∇G at the design point.
    g_star : float
        G at the design point.
    evaluations : Evaluations or None
        Every model row of the search.
    provenance : dict
        How the result was made (with the limit state's description).
    warnings : tuple of str, default ()
        Caveats of the estimate (FORM issues none: a search that fails raises :class:`FORMConvergenceError`).

    Examples
    --------
    >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
    >>> inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
    >>> margin = FunctionModel(lambda X: 3.0 * 2**0.5 - X[:, 0] - X[:, 1], ["x1", "x2"], ["g"],
    ...                        vectorized=True)
    >>> from mechrel.uq import form
    >>> r = form(model=margin, inputs=inputs)
    >>> round(r.pf / 1.3498980316e-3, 6), int(r.to_frame()["n_iterations"].iloc[0]) >= 1
    (1.0, True)
    """

    table: pd.DataFrame
    design_point: pd.DataFrame
    history: pd.DataFrame
    u_star: np.ndarray
    grad_u: np.ndarray
    g_star: float
    evaluations: Evaluations | None
    provenance: dict = field(repr=False)
    warnings: tuple[str, ...] = ()

    @property
    def alpha(self) -> pd.Series:
        """The unit vector α toward the design point in the standard-normal space, per input.

        Returns
        -------
        pandas.Series
            The ``alpha`` column of ``design_point`` (dimensionless).

        Examples
        --------
        >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
        >>> inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
        >>> margin = FunctionModel(lambda X: 3.0 - X[:, 0] - X[:, 1], ["x1", "x2"], ["g"],
        ...                        vectorized=True)
        >>> form(model=margin, inputs=inputs).alpha.round(6).tolist()   # (1, 1)/√2
        [0.707107, 0.707107]
        """
        return self.design_point["alpha"]

    @property
    def importance(self) -> pd.Series:
        """The importance of each input, α_j², the share of β² it accounts for.

        Returns
        -------
        pandas.Series
            The ``importance`` column of ``design_point`` (dimensionless, sums to 1).

        Examples
        --------
        >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
        >>> inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
        >>> margin = FunctionModel(lambda X: 3.0 - X[:, 0] - X[:, 1], ["x1", "x2"], ["g"],
        ...                        vectorized=True)
        >>> form(model=margin, inputs=inputs).importance.round(6).tolist()
        [0.5, 0.5]
        """
        return self.design_point["importance"]

    @property
    def x_star(self) -> pd.Series:
        """The design point (the most probable failure point) in the physical inputs.

        Returns
        -------
        pandas.Series
            The ``x`` column of ``design_point``, in the inputs' units.

        Examples
        --------
        >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
        >>> inputs = UncertainInputs.from_specs({"x1": Normal(1.0, 2.0), "x2": Normal(0.0, 1.0)})
        >>> margin = FunctionModel(lambda X: 5.0 - X[:, 0], ["x1", "x2"], ["g"], vectorized=True)
        >>> form(model=margin, inputs=inputs).x_star.round(6).tolist()
        [5.0, 0.0]
        """
        return self.design_point["x"]


def gradient(problem: Problem, u: np.ndarray, *, step: float, scheme: str) -> tuple[float, np.ndarray]:
    """G(u) and ∇G(u) by finite differences, all points in one executor call."""
    d = u.shape[0]
    E = np.eye(d) * step
    U = np.vstack([u[None, :], u + E] + ([u - E] if scheme == "central" else []))
    G, ok, reasons = problem.g(U)
    if not ok.all():
        bad = [f"point {i}: {reasons[i]}" for i in np.flatnonzero(~ok)][:4]
        raise StudyError(
            f"{problem.what}: the finite-difference stencil at u = {np.round(u, 4).tolist()} needs every point; "
            f"{int((~ok).sum())} failed ({'; '.join(bad)}); allowed: a smaller step, or a sampling method "
            "(importance_sampling, subset_simulation)"
        )
    # actual steps (u + h) - (u - h) in floating point, as in fosm
    up = (U[1 : d + 1] - (U[d + 1 :] if scheme == "central" else u[None, :])).diagonal()
    dG = (G[1 : d + 1] - (G[d + 1 :] if scheme == "central" else G[0])) / up
    return float(G[0]), dG


def design_point_search(problem: Problem, *, u0: np.ndarray, step: float, scheme: str, tol: float,
                        tol_direction: float, max_iter: int, armijo: float = 0.25, gamma: float = 2.0,
                        max_halvings: int = 30) -> tuple[np.ndarray, float, np.ndarray, pd.DataFrame, float]:
    """The iHLRF iteration (module docstring); returns (u*, G*, ∇G*, history, G(u0))."""
    u = np.array(u0, dtype=float)
    rows = []
    g0 = None

    def hist() -> pd.DataFrame:
        return pd.DataFrame(rows, columns=["iteration", "beta", "g", "merit_c", "step_length",
                                           "surface_criterion", "direction_criterion", "n_evaluations"]
                            ).set_index("iteration")

    for k in range(max_iter + 1):
        G, dG = gradient(problem, u, step=step, scheme=scheme)
        if g0 is None:
            g0 = G
        norm = float(np.linalg.norm(dG))
        if not norm > 0:
            rows.append((k, float(np.linalg.norm(u)), G, np.nan, np.nan, np.nan, np.nan, problem.n_evaluations))
            raise FORMConvergenceError(
                f"{problem.what}: gradient of g is zero at iteration {k} (u = {np.round(u, 4).tolist()}, g = {G:.6g}); "
                "the limit state does not depend on the inputs there (never or always violated?), or the point is on "
                "a tie of a series/parallel system (min/max of equal branches); allowed: a limit state whose margin "
                "varies with the inputs, another start=, or subset_simulation for systems", hist())
        alpha = -dG / norm
        crit_g = abs(G) / abs(g0) if g0 != 0 else abs(G)
        crit_u = float(np.linalg.norm(u - (alpha @ u) * alpha)) / max(1.0, float(np.linalg.norm(u)))
        converged = crit_g <= tol and crit_u <= tol_direction
        if converged or k == max_iter:
            rows.append((k, float(np.linalg.norm(u)), G, np.nan, np.nan, crit_g, crit_u, problem.n_evaluations))
            if not converged:
                raise FORMConvergenceError(
                    f"{problem.what}: design-point search did not converge in max_iter = {max_iter} iterations "
                    f"(last: |g|/|g0| = {crit_g:.3g}, direction criterion = {crit_u:.3g}, tol = {tol:g}, "
                    f"tol_direction = {tol_direction:g}); "
                    "allowed: a larger max_iter or tol, a larger step for a noisy model, or a sampling method; "
                    "the iterates are in .history", hist())
            return u, G, dG, hist(), g0
        d = (dG @ u - G) / norm**2 * dG - u
        c = gamma * max(float(np.linalg.norm(u)), float(np.linalg.norm(u + d))) / norm
        m0 = 0.5 * float(u @ u) + c * abs(G)
        slope = float((u + c * np.sign(G) * dG) @ d)
        lam = 1.0
        for _ in range(max_halvings):
            Gt, okt, _r = problem.g((u + lam * d)[None, :])
            if okt[0]:
                mt = 0.5 * float((u + lam * d) @ (u + lam * d)) + c * abs(float(Gt[0]))
                # slope >= 0: plain HL-RF step; a merit change below the merit's own round-off
                # means u_k is the solution to working precision
                if slope >= 0 or mt - m0 <= armijo * lam * slope or mt - m0 <= 16 * EPS * m0:
                    break
            lam *= 0.5
        else:
            rows.append((k, float(np.linalg.norm(u)), G, c, lam, crit_g, crit_u, problem.n_evaluations))
            raise FORMConvergenceError(
                f"{problem.what}: line search found no step decreasing the merit function at iteration {k} "
                f"after {max_halvings} halvings (a noisy model, failed model points or a non-smooth limit state); "
                "allowed: for a noisy (ODE-integrated) model a larger step= and tol= (e.g. 0.05 and 1e-3), "
                "else a sampling method (importance_sampling, subset_simulation); the iterates are in .history",
                hist())
        rows.append((k, float(np.linalg.norm(u)), G, c, lam, crit_g, crit_u, problem.n_evaluations))
        u = u + lam * d
    raise AssertionError("unreachable")  # pragma: no cover


def check_positive(name: str, value: Any, *, integer: bool = False, minimum: float = 0.0) -> Any:
    ok = (isinstance(value, (int, np.integer)) if integer else isinstance(value, (int, float, np.integer, np.floating)))
    if isinstance(value, (bool, np.bool_)) or not ok or not np.isfinite(value) or not value > minimum:
        kind = "an integer" if integer else "a number"
        raise StudyError(f"{name}: got {value!r}; allowed: {kind} > {minimum:g}")
    return int(value) if integer else float(value)


def form(
    *,
    model: Any,
    inputs: Any,
    evaluations: Any = None,
    limit_state: Any = None,
    seed: Any = None,
    step: float = 1e-4,
    scheme: str = "central",
    tol: float = 1e-6,
    tol_direction: float | None = None,
    max_iter: int = 100,
    start: Any = None,
    n_jobs: int = 1,
    backend: str = "loky",
    cache: Any = None,
    progress: bool = False,
    chunk_size: int | None = None,
) -> FORMResult:
    """First-order reliability (FORM) by iHLRF; see the module docstring.

    Parameters
    ----------
    model, inputs, limit_state
        The model, its uncertain inputs and the limit state (default: the model's only output is
        the margin g; failure g ≤ 0).
    evaluations : None
        Precomputed evaluations cannot be used (the method chooses its points as it goes);
        anything but None is an error. Accepted so that every estimator shares one interface.
    seed
        Unused (FORM draws nothing); accepted so that every estimator shares one interface.
    step, scheme
        Finite-difference step in standard normal units and ``"central"`` (2d + 1 points per
        iteration, default) or ``"forward"`` (d + 1).
    tol, tol_direction, max_iter
        Tolerances of the surface and the direction criteria (``tol_direction=None``: ``tol``)
        and the iteration limit.
    start
        Starting point in physical units (one value per input, allowables last), default the
        origin of u (the medians).
    n_jobs, backend, cache, progress, chunk_size
        Passed to :func:`mechrel.uq.evaluate`.

    Returns
    -------
    FORMResult

    Raises
    ------
    FORMConvergenceError
        No convergence (its ``history`` holds the iterates).

    Examples
    --------
    A linear margin g = 3√2 − x1 − x2 of standard normals: β = 3 exactly.

    >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
    >>> inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
    >>> margin = FunctionModel(lambda X: 3.0 * 2**0.5 - X[:, 0] - X[:, 1], ["x1", "x2"], ["g"],
    ...                        vectorized=True)
    >>> from mechrel.uq import form
    >>> r = form(model=margin, inputs=inputs)
    >>> round(r.beta, 8), r.design_point["importance"].round(6).tolist()
    (3.0, [0.5, 0.5])
    """
    refuse_evaluations(evaluations, "form")
    problem = Problem(model=model, inputs=inputs, limit_state=limit_state, n_jobs=n_jobs, backend=backend,
                      cache=cache, progress=progress, chunk_size=chunk_size, what="form")
    return _form(problem, seed=seed, step=step, scheme=scheme, tol=tol, tol_direction=tol_direction,
                 max_iter=max_iter, start=start)


def _form(problem: Problem, *, seed: Any, step: float, scheme: str, tol: float, max_iter: int,
          start: Any, tol_direction: float | None = None, method: str = "form") -> FORMResult:
    step = check_positive("step", step)
    ARGS.choice("scheme", scheme, SCHEMES)
    tol = check_positive("tol", tol)
    tol_direction = tol if tol_direction is None else check_positive("tol_direction", tol_direction)
    max_iter = check_positive("max_iter", max_iter, integer=True, minimum=0)
    if start is None:
        u0 = np.zeros(problem.d)
    else:
        x0 = np.asarray(start, dtype=float).reshape(-1)
        if x0.shape != (problem.d,) or not np.all(np.isfinite(x0)):
            raise StudyError(f"start: got {start!r}; allowed: {problem.d} finite values in the order {list(problem.names)}")
        u0 = problem.inputs.to_standard_normal(x0[None, :])[0]
    u, G, dG, history, g0 = design_point_search(problem, u0=u0, step=step, scheme=scheme, tol=tol,
                                                       tol_direction=tol_direction, max_iter=max_iter)
    norm = float(np.linalg.norm(dG))
    alpha = -dG / norm
    # signed β: positive when the origin is safe (g0 > 0); β = α·u* on the converged surface
    beta = float(alpha @ u)
    x = problem.to_x(u)[0]
    dp = pd.DataFrame({"u": u, "x": x, "alpha": alpha, "importance": alpha**2, "dg_du": dG},
                      index=pd.Index(problem.names, name="input"))
    n_ev = problem.n_evaluations
    table = pd.DataFrame({"pf": [float(special.ndtr(-beta))], "beta": [beta], "n_evaluations": [n_ev],
                          "n_iterations": [int(history.index[-1])], "g_origin": [float(g0)]},
                         index=pd.Index([problem.limit_state.name], name="limit_state"))
    prov = problem.provenance(method=method, seed=seed_record(seed),
                              settings={"step": step, "scheme": scheme, "tol": tol, "tol_direction": tol_direction,
                                        "max_iter": max_iter,
                                        "start": None if start is None else list(map(float, np.ravel(start))),
                                        "algorithm": "iHLRF (Zhang & Der Kiureghian 1995), Armijo on ½‖u‖² + c|G|"})
    u_ro, g_ro = np.array(u), np.array(dG)
    u_ro.setflags(write=False)
    g_ro.setflags(write=False)
    return FORMResult(table, dp, history, u_ro, g_ro, float(G), problem.all_evaluations(), prov)
