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

Systems (``search="system"``, the default)
------------------------------------------
One design point sees one failure mode. A limit state over a group of outputs, a two-sided
tolerance, a series of components, and above all a mechanism's whole cycle (per quantity,
cycle sector and sign) is a series system of *members*
(:attr:`~mechrel.uq.problem.limit_state.BoundLimitState.members`), several of which may carry
a design point of similar β; a search from the origin finds one of them and P_f = Φ(−β) is a
fraction of the truth. FORM therefore

1. linearises every member at the start (one stencil: each evaluation gives every output), a
   sector extreme through the analysis angles it spans where it has a kink there
   (:meth:`~mechrel.uq.problem.limit_state.BoundLimitState.member_proxies`), and ranks the
   members by their linearised β;
2. searches the design point of each member that matters: in order of β, skipping a member
   whose linearised normal lies within :data:`CLUSTER` of one already chosen (the same failure
   mode), while Φ(−β) ≥ ``contribution`` × the largest, at most ``max_design_points``; the first
   from the start, the others from their linearised design points;
3. probes the sphere of radius β_min + :data:`PROBE_MARGIN` (±e_j, the diagonals for d ≤ 4,
   the mirror −α of each design point found, and :data:`N_PROBE_RANDOM` fixed random
   directions) for failing points that no design point's half-space {α·u ≥ β} holds, and
   searches again from them (an *opaque* margin, a model output or a function, may hide
   several design points: g = 3.5 − |u₁| has two); failing probes still unexplained are a
   warning;
4. combines the distinct design points as a series system: P_f = P(∪ {α_i·u ≥ β_i}), computed
   without model calls (:func:`~mechrel.uq.estimators._system.union_probability`), with
   Ditlevsen's bounds (Hohenbichler & Rackwitz 1983; Ditlevsen 1979; the multiple design point
   approach of Der Kiureghian & Dakessian 1998). β is then −Φ⁻¹(P_f).

A parallel system (``LimitState.parallel``) has one joint design point, the nearest point where
every component fails, found by sequential quadratic programming on the components linearised
at each iterate; P_f = Φ_m(−β; R) of the components linearised there (exact for linear
components; classic FORM's Φ(−‖u*‖) overestimates it, 6× on two independent β = 3 modes).

With a single design point and a smooth margin the result is classic FORM, number for number;
the probes then cost one executor call of 2d + 8 (+ 2^d for d ≤ 4) points.
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
from .._common import emit_warnings
from ..problem.inputs import seed_record
from ._problem import Problem, RareEventResult, refuse_evaluations
from ._system import ditlevsen_bounds, intersection_probability, union_probability

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
        Every model row of the searches and probes.
    provenance : dict
        How the result was made (with the limit state's description).
    warnings : tuple of str, default ()
        Caveats of the estimate, also issued as :class:`~mechrel.errors.EstimateWarning`:
        several design points (P_f is their first-order series combination), modes not
        searched or not reached (failing probes no design point explains), a non-smooth model,
        a parallel system. A single design point of a smooth margin issues none.
    design_points : DataFrame, optional
        One row per design point (``point``): ``member`` (the failure mode: component, output
        label and sign, e.g. a cycle sector of a quantity), ``member_index`` (its row of
        :attr:`~mechrel.uq.problem.limit_state.BoundLimitState.members`; −1 for the system
        margin itself), ``component``, ``output``, ``sign``, ``beta``, ``pf_mode`` = Φ(−β),
        ``how`` (``"search"``, ``"linearised"`` for a search that did not converge and is
        represented by its starting hyperplane, ``"joint"`` for a parallel system's components
        at the joint design point) and ``n_iterations``.
    points : DataFrame, optional
        Per design point and input (MultiIndex ``(point, input)``): ``u``, ``x``, ``alpha``,
        ``importance``, ``dg_du``.
    system : {"series", "parallel"}, default "series"
        How the design points combine.

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
    design_points: pd.DataFrame | None = None
    points: pd.DataFrame | None = None
    system: str = "series"

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


def _stencil(fn, u: np.ndarray, *, step: float, scheme: str, what: str):
    """Margins and their finite-difference gradients at u, all points in one executor call.

    ``fn(U) -> (G (n, k), ok, reasons)``. Returns ``(G (k,), dG (k, d), up (d, k), down (d, k))``
    with ``up``/``down`` the forward and backward changes (``down`` NaN for the forward scheme).
    """
    d = u.shape[0]
    E = np.eye(d) * step
    U = np.vstack([u[None, :], u + E] + ([u - E] if scheme == "central" else []))
    G, ok, reasons = fn(U)
    if not ok.all():
        bad = [f"point {i}: {reasons[i]}" for i in np.flatnonzero(~ok)][:4]
        raise StudyError(
            f"{what}: the finite-difference stencil at u = {np.round(u, 4).tolist()} needs every point; "
            f"{int((~ok).sum())} failed ({'; '.join(bad)}); allowed: a smaller step, or subset_simulation "
            "(which needs no gradient)"
        )
    G = G.reshape(U.shape[0], -1)
    # actual steps (u + h) - (u - h) in floating point, as in fosm
    if scheme == "central":
        h = (U[1 : d + 1] - U[d + 1 :]).diagonal()
        up, down = G[1 : d + 1] - G[0], G[0] - G[d + 1 :]
        dG = ((G[1 : d + 1] - G[d + 1 :]) / h[:, None]).T
    else:
        h = (U[1 : d + 1] - u[None, :]).diagonal()
        up, down = G[1 : d + 1] - G[0], np.full((d, G.shape[1]), np.nan)
        dG = (up / h[:, None]).T
    return G[0], dG, up, down


def gradient(fn, u: np.ndarray, *, step: float, scheme: str, what: str = "form") -> tuple[float, np.ndarray]:
    """G(u) and ∇G(u) of a scalar margin ``fn`` by finite differences (one executor call)."""
    G, dG, _up, _down = _stencil(fn, u, step=step, scheme=scheme, what=what)
    return float(G[0]), dG[0]


def kinked(up: np.ndarray, down: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Per margin (columns of ``up``/``down``, shape (d, k)): whether its forward and backward
    slopes differ by more than :data:`KINK` of the larger along some coordinate (a kink, a
    tie of failure modes, a non-smooth model), ignoring changes below round-off of ``scale``."""
    big = np.maximum(np.abs(up), np.abs(down))
    with np.errstate(invalid="ignore"):
        k = (big > 1e-12 * scale[None, :]) & (np.abs(up - down) > KINK * big)
    return np.any(k, axis=0)


KINK = 0.5
"""A margin's forward and backward slopes at a point differ by more than this fraction of the
larger: it is not differentiable there (the test of :data:`mechrel.uq.estimators.fosm.UNRESOLVED`)."""


def design_point_search(fn, *, u0: np.ndarray, step: float, scheme: str, tol: float,
                        tol_direction: float, max_iter: int, what: str = "form", count=lambda: 0,
                        g_scale: float | None = None, notes: list | None = None,
                        armijo: float = 0.25, gamma: float = 2.0,
                        max_halvings: int = 30) -> tuple[np.ndarray, float, np.ndarray, pd.DataFrame, float]:
    """The iHLRF iteration (module docstring) on the scalar margin ``fn(U) -> (G, ok, reasons)``;
    returns (u*, G*, ∇G*, history, G(u0)). ``count()`` gives the evaluations so far (history);
    ``g_scale`` the margin the surface criterion is relative to (default G(u0); a search started
    near the surface passes the margin at the origin); ``notes`` receives a note when the search
    stops at the model's noise floor (below)."""
    u = np.array(u0, dtype=float)
    rows = []
    g0 = None

    def at_noise_floor(crit_g, crit_u):
        # on the surface, and the direction's error changes β by less than the surface tolerance
        # (β·δ²/2, module docstring): the gradient's noise, not the iteration, limits the direction
        r = float(np.linalg.norm(u))
        if crit_g <= tol and 0.5 * r * crit_u**2 <= tol * max(1.0, r):
            if notes is not None:
                notes.append(f"{what}: a search stopped at the model's noise floor (|g|/|g0| = {crit_g:.2g}, "
                             f"direction criterion {crit_u:.2g} > tol_direction = {tol_direction:g}: β changes "
                             f"by about {0.5 * r * crit_u**2:.1g} from it)")
            return True
        return False

    def hist() -> pd.DataFrame:
        return pd.DataFrame(rows, columns=["iteration", "beta", "g", "merit_c", "step_length",
                                           "surface_criterion", "direction_criterion", "n_evaluations"]
                            ).set_index("iteration")

    for k in range(max_iter + 1):
        G, dG = gradient(fn, u, step=step, scheme=scheme, what=what)
        if g0 is None:
            g0 = G
        norm = float(np.linalg.norm(dG))
        if not norm > 0:
            rows.append((k, float(np.linalg.norm(u)), G, np.nan, np.nan, np.nan, np.nan, count()))
            raise FORMConvergenceError(
                f"{what}: gradient of g is zero at iteration {k} (u = {np.round(u, 4).tolist()}, g = {G:.6g}); "
                "the limit state does not depend on the inputs there (never or always violated?), or the point is on "
                "a tie of a series/parallel system (min/max of equal branches); allowed: a limit state whose margin "
                "varies with the inputs, or subset_simulation", hist())
        alpha = -dG / norm
        ref = g0 if g_scale is None else g_scale
        crit_g = abs(G) / abs(ref) if ref != 0 else abs(G)
        crit_u = float(np.linalg.norm(u - (alpha @ u) * alpha)) / max(1.0, float(np.linalg.norm(u)))
        converged = crit_g <= tol and crit_u <= tol_direction
        if converged or k == max_iter:
            rows.append((k, float(np.linalg.norm(u)), G, np.nan, np.nan, crit_g, crit_u, count()))
            if not converged and at_noise_floor(crit_g, crit_u):
                return u, G, dG, hist(), g0
            if not converged:
                raise FORMConvergenceError(
                    f"{what}: design-point search did not converge in max_iter = {max_iter} iterations "
                    f"(last: |g|/|g0| = {crit_g:.3g}, direction criterion = {crit_u:.3g}, tol = {tol:g}, "
                    f"tol_direction = {tol_direction:g}); "
                    "allowed: a larger max_iter or tol, a larger step for a noisy model, or subset_simulation; "
                    "the iterates are in .history", hist())
            return u, G, dG, hist(), g0
        d = (dG @ u - G) / norm**2 * dG - u
        c = gamma * max(float(np.linalg.norm(u)), float(np.linalg.norm(u + d))) / norm
        m0 = 0.5 * float(u @ u) + c * abs(G)
        slope = float((u + c * np.sign(G) * dG) @ d)
        lam = 1.0
        for _ in range(max_halvings):
            Gt, okt, _r = fn((u + lam * d)[None, :])
            if okt[0]:
                mt = 0.5 * float((u + lam * d) @ (u + lam * d)) + c * abs(float(Gt[0]))
                # slope >= 0: plain HL-RF step; a merit change below the merit's own round-off
                # means u_k is the solution to working precision
                if slope >= 0 or mt - m0 <= armijo * lam * slope or mt - m0 <= 16 * EPS * m0:
                    break
            lam *= 0.5
        else:
            rows.append((k, float(np.linalg.norm(u)), G, c, lam, crit_g, crit_u, count()))
            if at_noise_floor(crit_g, crit_u):
                return u, G, dG, hist(), g0
            raise FORMConvergenceError(
                f"{what}: line search found no step decreasing the merit function at iteration {k} "
                f"after {max_halvings} halvings (a noisy model, failed model points or a non-smooth limit state); "
                "allowed: for a noisy (ODE-integrated) model a larger step= and tol= (e.g. 0.05 and 1e-3), "
                "else subset_simulation; the iterates are in .history",
                hist())
        rows.append((k, float(np.linalg.norm(u)), G, c, lam, crit_g, crit_u, count()))
        u = u + lam * d
    raise AssertionError("unreachable")  # pragma: no cover


@dataclass
class _Point:
    """One design point found by the searches (internal)."""

    member: int
    u: np.ndarray
    g: float
    grad: np.ndarray
    history: pd.DataFrame
    g0: float
    how: str                      # "search", "linearised" (a search that failed: its start's hyperplane)

    @property
    def alpha(self) -> np.ndarray:
        return -self.grad / float(np.linalg.norm(self.grad))

    @property
    def beta(self) -> float:
        # signed: positive when the origin is safe; β = α·u* on the converged surface
        return float(self.alpha @ self.u)


class _Search:
    """The design points of a limit state's members (module docstring, "Systems")."""

    def __init__(self, problem: Problem, *, step, scheme, tol, tol_direction, max_iter,
                 max_design_points, contribution, what):
        self.problem = problem
        self.notes: list[str] = []
        self.kw = dict(step=step, scheme=scheme, tol=tol, tol_direction=tol_direction, max_iter=max_iter,
                       what=what, count=lambda: problem.n_evaluations, notes=self.notes)
        self.g_start: np.ndarray | None = None
        self.max_points = max_design_points
        self.contribution = contribution
        self.what = what
        self.members = problem.bound.members
        self.points: list[_Point] = []
        self.unexplained: list[np.ndarray] = []

    def member_fn(self, m: int):
        def fn(U):
            Gm, ok, reasons, _Y, _A = self.problem.members(U)
            return Gm[:, m], ok, reasons
        return fn

    def all_fn(self, U):
        Gm, ok, reasons, _Y, _A = self.problem.members(U)
        return Gm, ok, reasons

    def label(self, m: int) -> str:
        row = self.members.iloc[m]
        if row["output"] is None:
            return str(row["name"])
        out = row["output"]
        lbl = "(" + ", ".join(f"{v:g}°" if isinstance(v, float) else str(v) for v in out) + ")" \
            if isinstance(out, tuple) else str(out)
        return f"{row['name']} {lbl}{row['sign']}"

    # ------------------------------------------------------------------ ranking at the start
    def rank(self, u0: np.ndarray):
        """Linearise every member at u0 (one stencil; proxies where a member has a kink there)
        and order them: ``[(beta, alpha, member, u_start)]`` by β, with ``g0`` the system margin."""
        problem = self.problem
        step, scheme = self.kw["step"], self.kw["scheme"]
        d = u0.shape[0]
        E = np.eye(d) * step
        U = np.vstack([u0[None, :], u0 + E] + ([u0 - E] if scheme == "central" else []))
        Gm, ok, reasons, Y, A = problem.members(U)
        if not ok.all():
            bad = [f"point {i}: {reasons[i]}" for i in np.flatnonzero(~ok)][:4]
            raise StudyError(
                f"{self.what}: the finite-difference stencil at u = {np.round(u0, 4).tolist()} needs every point; "
                f"{int((~ok).sum())} failed ({'; '.join(bad)}); allowed: a smaller step, or subset_simulation "
                "(which needs no gradient)")
        g0 = float(problem.bound.system_from_members(Gm[:1])[0])
        self.g_start = Gm[0]
        lin = []
        proxies = problem.bound.member_proxies()
        scale = np.max(np.abs(Gm), axis=0)
        G0, dG, up, down = self._diff(U, Gm, u0)
        kink = kinked(up, down, scale) if scheme == "central" else np.zeros(Gm.shape[1], dtype=bool)
        for m in range(Gm.shape[1]):
            cands = []
            if not kink[m]:
                cands.append((G0[m], dG[m]))
            if proxies[m].size and (kink[m] or not np.linalg.norm(dG[m]) > 0):
                P = problem.bound.proxy_values(Y, A, m, proxies[m])
                P0, dP, _u, _d = self._diff(U, P, u0)
                cands += [(P0[j], dP[j]) for j in range(P.shape[1])]
            best = None
            for g, grad in cands:
                nrm = float(np.linalg.norm(grad))
                if not nrm > 0:
                    continue
                beta = float((g - grad @ u0) / nrm)
                if best is None or beta < best[0]:
                    best = (beta, -grad / nrm)
            if best is not None:
                lin.append((best[0], best[1], m))
        lin.sort(key=lambda t: t[0])
        return lin, g0, kink

    def _diff(self, U, G, u0):
        d = u0.shape[0]
        if self.kw["scheme"] == "central":
            h = (U[1 : d + 1] - U[d + 1 :]).diagonal()
            return G[0], ((G[1 : d + 1] - G[d + 1 :]) / h[:, None]).T, G[1 : d + 1] - G[0], G[0] - G[d + 1 :]
        h = (U[1 : d + 1] - u0[None, :]).diagonal()
        up = G[1 : d + 1] - G[0]
        return G[0], (up / h[:, None]).T, up, np.full_like(up, np.nan)

    def candidates(self, lin):
        """The members worth a search: by linearised β, each not covered by a chosen one
        (normals within :data:`CLUSTER`), while Φ(−β) ≥ ``contribution`` × the largest."""
        chosen = []
        if not lin:
            return chosen
        p_max = float(special.ndtr(-lin[0][0]))
        for beta, alpha, m in lin:
            if float(special.ndtr(-beta)) < self.contribution * p_max or len(chosen) >= self.max_points:
                break
            if any(float(alpha @ a) >= CLUSTER for _b, a, _m in chosen):
                continue
            chosen.append((beta, alpha, m))
        return chosen

    def left_out(self, lin, chosen) -> float:
        """Σ Φ(−β) of the linearised members neither searched nor covered by a chosen one."""
        tot = 0.0
        for beta, alpha, m in lin:
            if any(m == mm for _b, _a, mm in chosen):
                continue
            if any(float(alpha @ a) >= CLUSTER for _b, a, _m in chosen):
                continue
            tot += float(special.ndtr(-beta))
        return tot

    # ------------------------------------------------------------------ searches
    def search(self, m: int, u_start: np.ndarray, *, fallback=None) -> _Point | None:
        """A design-point search on member m from u_start; on failure the fallback hyperplane
        (beta, alpha) stands in, with a note, or None."""
        scale = None if self.g_start is None else float(self.g_start[m])
        try:
            u, G, dG, hist, g0 = design_point_search(self.member_fn(m), u0=u_start, g_scale=scale, **self.kw)
        except FORMConvergenceError as exc:
            if fallback is None:
                raise
            beta, alpha = fallback
            self.notes.append(f"{self.what}: the design-point search of member {self.label(m)} did not converge "
                              f"({str(exc).split(';')[0].split(': ', 1)[-1]}); its linearisation at the start "
                              f"(β ≈ {beta:.3g}) stands in for it")
            return _Point(m, beta * alpha, 0.0, -alpha, exc.history, np.nan, "linearised")
        return _Point(m, u, G, dG, hist, g0, "search")

    def add(self, p: _Point) -> bool:
        """Keep p unless it repeats a design point already found (returns whether it is new)."""
        for q in self.points:
            if float(np.linalg.norm(p.u - q.u)) <= SAME * max(1.0, float(np.linalg.norm(q.u))):
                return False
        self.points.append(p)
        return True

    def explained(self, u: np.ndarray) -> bool:
        return any(float(q.alpha @ u) >= q.beta - 1e-9 for q in self.points)

    # ------------------------------------------------------------------ probes
    def probe_directions(self) -> np.ndarray:
        d = self.problem.d
        dirs = [np.eye(d), -np.eye(d)]
        if d <= 4:
            signs = np.array(np.meshgrid(*[[-1.0, 1.0]] * d)).reshape(d, -1).T
            dirs.append(signs / np.sqrt(d))
        dirs += [-q.alpha[None, :] for q in self.points]
        extra = np.random.default_rng(PROBE_SEED).standard_normal((N_PROBE_RANDOM, d))
        dirs.append(extra / np.linalg.norm(extra, axis=1)[:, None])
        D = np.vstack(dirs)
        return D

    def probe(self, radius: float):
        """Evaluate the system margin on the sphere of ``radius``: the failing probes that no
        design point's half-space holds, with the member failing most at each."""
        D = self.probe_directions()
        U = radius * D
        Gm, ok, _reasons, _Y, _A = self.problem.members(U)
        G = self.problem.bound.system_from_members(Gm)
        out = []
        for i in np.flatnonzero(ok & (G <= 0)):
            if not self.explained(U[i]):
                out.append((U[i], int(np.nanargmin(Gm[i]))))
        return out

    def explore(self, radius: float):
        """Search from every unexplained failing probe (module docstring)."""
        rounds = 0
        while len(self.points) < self.max_points and rounds < 3:
            rounds += 1
            found = self.probe(radius)
            if not found:
                self.unexplained = []
                return
            progress = False
            for u, m in found:
                if len(self.points) >= self.max_points or self.explained(u):
                    continue
                try:
                    p = self.search(m, u)
                except FORMConvergenceError:
                    continue
                if self.add(p):
                    progress = True
            if not progress:
                break
        self.unexplained = [u for u, _m in self.probe(radius)]


CLUSTER = 0.95
"""Two members whose linearised normals at the start have α_i·α_j above this share a design
point (within about 18°): only the one with the smaller β is searched."""
SAME = 0.02
"""Two design points closer than this fraction of their distance from the origin are one."""
PROBE_MARGIN = 1.0
"""The sphere probed for unexplained failures has the radius β_min + this (standard normal
units): a failure mode within one β of the most important one contributes ≳ 1 % of it."""
N_PROBE_RANDOM = 8
"""Probe directions drawn at random (besides ±e_j, the diagonals for d ≤ 4 and the mirror of
each design point); from a fixed seed, so FORM stays deterministic."""
PROBE_SEED = 20221014
START_RADII = (2.0, 3.5, 5.0, 7.0)
"""Where a search from the start stalls (a tie of failure modes at the start, where the
gradient vanishes), spheres of these radii are probed for failing points to start from."""
SEARCHES = ("system", "single")


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
    search: str = "system",
    max_design_points: int = 8,
    contribution: float = 0.01,
    n_jobs: int = 1,
    backend: str = "loky",
    cache: Any = None,
    progress: bool = False,
    chunk_size: int | None = None,
) -> FORMResult:
    """First-order reliability (FORM) of a limit state and its system; see the module docstring.

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
        and the iteration limit of each search.
    start
        Starting point in physical units (one value per input, allowables last), default the
        origin of u (the medians).
    search : {"system", "single"}, default "system"
        ``"system"``: the design points of every failure mode (member) that matters, found by
        one search each, plus the probes for modes no search reached, combined as a series
        system (or the joint design point of a parallel system); ``"single"``: one search from
        ``start`` (classic FORM), with the same diagnostics as warnings.
    max_design_points : int, default 8
        The most design points searched.
    contribution : float, default 0.01
        A member is searched when its linearised Φ(−β) at the start is at least this fraction
        of the largest.
    n_jobs, backend, cache, progress, chunk_size
        Passed to :func:`mechrel.uq.evaluate`.

    Returns
    -------
    FORMResult

    Raises
    ------
    FORMConvergenceError
        The most important design point's search did not converge (its ``history`` holds the
        iterates), or no failure mode was found.

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

    Two failure modes, |x1| ≥ 3.5, written as one margin: the searches find both design points
    and combine them, P_f = 2Φ(−3.5):

    >>> tie = FunctionModel(lambda X: 3.5 - abs(X[:, 0]), ["x1", "x2"], ["g"], vectorized=True)
    >>> r = form(model=tie, inputs=inputs)                                  # doctest: +SKIP
    >>> len(r.design_points), round(r.pf / (2 * 2.326290790355e-4), 4)     # doctest: +SKIP
    (2, 1.0)
    """
    refuse_evaluations(evaluations, "form")
    problem = Problem(model=model, inputs=inputs, limit_state=limit_state, n_jobs=n_jobs, backend=backend,
                      cache=cache, progress=progress, chunk_size=chunk_size, what="form")
    return _form(problem, seed=seed, step=step, scheme=scheme, tol=tol, tol_direction=tol_direction,
                 max_iter=max_iter, start=start, search=search, max_design_points=max_design_points,
                 contribution=contribution)


def _form(problem: Problem, *, seed: Any, step: float, scheme: str, tol: float, max_iter: int,
          start: Any, tol_direction: float | None = None, method: str = "form", search: str = "system",
          max_design_points: int = 8, contribution: float = 0.01) -> FORMResult:
    step = check_positive("step", step)
    ARGS.choice("scheme", scheme, SCHEMES)
    ARGS.choice("search", search, SEARCHES)
    tol = check_positive("tol", tol)
    tol_direction = tol if tol_direction is None else check_positive("tol_direction", tol_direction)
    max_iter = check_positive("max_iter", max_iter, integer=True, minimum=0)
    max_design_points = check_positive("max_design_points", max_design_points, integer=True)
    contribution = ARGS.fraction("contribution", contribution, open_lo=True, open_hi=False)
    if start is None:
        u0 = np.zeros(problem.d)
    else:
        x0 = np.asarray(start, dtype=float).reshape(-1)
        if x0.shape != (problem.d,) or not np.all(np.isfinite(x0)):
            raise StudyError(f"start: got {start!r}; allowed: {problem.d} finite values in the order {list(problem.names)}")
        u0 = problem.inputs.to_standard_normal(x0[None, :])[0]
    settings = {"step": step, "scheme": scheme, "tol": tol, "tol_direction": tol_direction,
                "max_iter": max_iter, "start": None if start is None else list(map(float, np.ravel(start))),
                "search": search, "max_design_points": max_design_points, "contribution": contribution,
                "algorithm": "iHLRF (Zhang & Der Kiureghian 1995), Armijo on ½‖u‖² + c|G|"}
    S = _Search(problem, step=step, scheme=scheme, tol=tol, tol_direction=tol_direction, max_iter=max_iter,
                max_design_points=max_design_points, contribution=contribution, what=problem.what)
    notes: list[str] = []
    reason = getattr(problem.model, "nonsmooth", None)
    if reason:
        notes.append(f"{problem.what}: the model is not smooth ({reason}): its finite-difference gradients are "
                     "secants, the design point and β are not FORM's; trust subset_simulation or Monte Carlo")
    parallel = problem.limit_state.system == "parallel" and len(problem.limit_state.components) > 1
    if parallel:
        return _parallel_form(problem, S, u0, settings=settings, method=method, notes=notes, seed=seed)
    lin, g_start, _kink = S.rank(u0)
    left = 0.0
    if search == "single":
        fn = _system_fn(problem)
        u, G, dG, hist, g0 = design_point_search(fn, u0=u0, **S.kw)
        S.points.append(_Point(-1, u, G, dG, hist, g0, "search"))
        p = S.points[0]
        others = [S.label(m) for b, a, m in lin
                  if special.ndtr(-b) >= contribution * special.ndtr(-p.beta) and float(p.alpha @ a) < CLUSTER]
        if others:
            notes.append(f"{problem.what}: {len(others)} other failure mode(s) have a linearised β near this design "
                         f"point's ({', '.join(others[:4])}{', ...' if len(others) > 4 else ''}): one design point "
                         "sees one of them, so P_f is underestimated; use search='system' or subset_simulation")
        S.unexplained = [uu for uu, _m in S.probe(max(p.beta, 0.0) + PROBE_MARGIN)]
    else:
        chosen = S.candidates(lin)
        for k, (beta, alpha, m) in enumerate(chosen):
            if k == 0:
                try:
                    p = S.search(m, u0)
                except FORMConvergenceError as exc:
                    if "gradient of g is zero" not in str(exc) or len(chosen) > 1:
                        raise
                    continue   # a tie at the start: the probes below start the searches
            else:
                p = S.search(m, beta * alpha, fallback=(beta, alpha))
            S.add(p)
        if not S.points:
            # no member could be linearised at the start, or the search stalled on a tie there:
            # start from the failing points of growing spheres
            for r in START_RADII:
                found = S.probe(r)
                for uu, m in found:
                    if len(S.points) >= max_design_points or S.explained(uu):
                        continue
                    try:
                        S.add(S.search(m, uu))
                    except FORMConvergenceError:
                        continue
                if S.points:
                    break
            if not S.points:
                history = pd.DataFrame([(0, float(np.linalg.norm(u0)), g_start, np.nan, np.nan, np.nan, np.nan,
                                         problem.n_evaluations)],
                                       columns=["iteration", "beta", "g", "merit_c", "step_length",
                                                "surface_criterion", "direction_criterion", "n_evaluations"]
                                       ).set_index("iteration")
                raise FORMConvergenceError(
                    f"{problem.what}: gradient of g is zero at iteration 0 (u = {np.round(u0, 4).tolist()}, "
                    f"g = {g_start:.6g}) and no point of the spheres of radius "
                    f"{', '.join(f'{r:g}' for r in START_RADII)} around the origin fails: the limit state does not "
                    "depend on the inputs there, or is never violated; allowed: a limit state whose margin varies "
                    "with the inputs, another start=, or subset_simulation", history)
        beta_min = min(q.beta for q in S.points)
        S.explore(max(beta_min, 0.0) + PROBE_MARGIN)
        left = S.left_out(lin, chosen)
    pts = sorted(S.points, key=lambda q: q.beta)
    betas = np.array([q.beta for q in pts])
    alphas = np.array([q.alpha for q in pts])
    if len(pts) == 1:
        pf = float(special.ndtr(-betas[0]))
        lo = hi = pf
        beta = float(betas[0])
    else:
        pf, _cov = union_probability(betas, alphas)
        lo, hi = ditlevsen_bounds(betas, alphas)
        beta = float(-special.ndtri(pf))
        names = ", ".join(f"{S.label(q.member) if q.member >= 0 else problem.limit_state.name} "
                          f"(β = {q.beta:.3g})" for q in pts[:4])
        notes.append(f"{problem.what}: {len(pts)} design points ({names}{', ...' if len(pts) > 4 else ''}): P_f = "
                     f"{pf:.3g} is the probability of the union of their linearisations (first-order series "
                     f"system; Ditlevsen's bounds [{lo:.3g}, {hi:.3g}]); FORM ignores each mode's curvature: "
                     "compare with SORM or a sampling method")
    if search == "system" and left > 0.05 * pf:
        notes.append(f"{problem.what}: members not searched (max_design_points = {max_design_points}, contribution = "
                     f"{contribution:g}) have linearised probabilities adding up to {left:.3g}, "
                     f"{left / pf:.0%} of P_f: raise max_design_points or lower contribution, or use subset_simulation")
    if S.unexplained:
        notes.append(f"{problem.what}: {len(S.unexplained)} failing point(s) of the probe sphere lie outside every "
                     f"design point's half-space (e.g. u = {np.round(S.unexplained[0], 3).tolist()}): a failure "
                     "region FORM did not reach, so P_f may be underestimated; use subset_simulation")
    notes += _merged(S.notes)
    return _result(problem, pts, S, pf=pf, beta=beta, lo=lo, hi=hi, g0=g_start, settings=settings,
                   method=method, notes=notes, system="series", seed=seed)


def _merged(notes: list[str]) -> list[str]:
    """The searches' notes, those of searches stopped at the noise floor merged into one."""
    noise = [n for n in notes if "noise floor" in n]
    rest = [n for n in notes if "noise floor" not in n]
    if len(noise) > 1:
        noise = [noise[0].replace("a search stopped", f"{len(noise)} searches stopped (the first:", 1)
                 .replace("from it)", "from it))", 1)]
    return rest + noise


def _system_fn(problem: Problem):
    def fn(U):
        Gm, ok, reasons, _Y, _A = problem.members(U)
        return problem.bound.system_from_members(Gm), ok, reasons
    return fn


def _qp(A: np.ndarray, b: np.ndarray, x0: np.ndarray) -> np.ndarray | None:
    """The point of {v : A v ≤ b} nearest the origin (None if the set is empty)."""
    from scipy.optimize import minimize

    scale = np.maximum(np.linalg.norm(A, axis=1), 1e-300)
    An, bn = A / scale[:, None], b / scale
    res = minimize(lambda v: 0.5 * float(v @ v), x0, jac=lambda v: v, method="SLSQP", tol=1e-14,
                   constraints=[{"type": "ineq", "fun": lambda v: bn - An @ v, "jac": lambda v: -An}],
                   options={"maxiter": 500})
    if not res.success or np.max(An @ res.x - bn) > 1e-8 * max(1.0, float(np.linalg.norm(res.x))):
        return None
    return res.x


def _parallel_form(problem: Problem, S: _Search, u0: np.ndarray, *, settings, method, notes, seed) -> FORMResult:
    """The joint design point of a parallel system by sequential quadratic programming (min ½‖u‖²
    with every component failing, each linearised at the iterate), then P_f = Φ_m(−β; R) of the
    components linearised there (Hohenbichler & Rackwitz 1983)."""
    comp = S.members["component"].to_numpy()
    K = len(problem.limit_state.components)

    def comp_fn(U):
        Gm, ok, reasons, _Y, _A = problem.members(U)
        return np.column_stack([Gm[:, comp == k].min(axis=1) for k in range(K)]), ok, reasons

    kw = S.kw
    u = u0.copy()
    rows = []
    g_start = None
    for it in range(kw["max_iter"] + 1):
        Gc, dGc, _up, _down = _stencil(comp_fn, u, step=kw["step"], scheme=kw["scheme"], what=problem.what)
        if g_start is None:
            g_start = float(Gc.max())
            g_scale = np.maximum(np.abs(Gc), 1e-300)
        norms = np.linalg.norm(dGc, axis=1)
        if not np.all(norms > 0):
            raise FORMConvergenceError(
                f"{problem.what}: a component of the parallel system has a zero gradient at u = "
                f"{np.round(u, 4).tolist()}; allowed: components whose margins vary with the inputs, or "
                "subset_simulation", pd.DataFrame(rows))
        v = _qp(dGc, dGc @ u - Gc, u)
        if v is None:
            raise FORMConvergenceError(
                f"{problem.what}: the components of the parallel system cannot all fail near u = "
                f"{np.round(u, 4).tolist()} (their linearisations exclude each other); allowed: subset_simulation",
                pd.DataFrame(rows))
        du = v - u
        crit_u = float(np.linalg.norm(du)) / max(1.0, float(np.linalg.norm(u)))
        crit_g = float(np.max(np.maximum(Gc, 0.0) / g_scale))
        rows.append((it, float(np.linalg.norm(u)), float(Gc.max()), np.nan, 1.0, crit_g, crit_u,
                     problem.n_evaluations))
        if crit_u <= kw["tol_direction"] and crit_g <= kw["tol"]:
            break
        # a full SQP step, halved while it leaves the region where the linearisation was taken
        lim = max(2.0, float(np.linalg.norm(u)))
        if np.linalg.norm(du) > lim:
            du *= lim / float(np.linalg.norm(du))
        u = u + du
    else:
        raise FORMConvergenceError(
            f"{problem.what}: the joint design point of the parallel system did not converge in max_iter = "
            f"{kw['max_iter']} iterations; allowed: a larger max_iter or tol, or subset_simulation",
            pd.DataFrame(rows))
    history = pd.DataFrame(rows, columns=["iteration", "beta", "g", "merit_c", "step_length",
                                          "surface_criterion", "direction_criterion", "n_evaluations"]
                           ).set_index("iteration")
    alphas = -dGc / norms[:, None]
    betas = (Gc - dGc @ u) / norms
    pf = intersection_probability(betas, alphas)
    beta = float(-special.ndtri(pf))
    pts = [_Point(-1 - k, betas[k] * alphas[k], float(Gc[k]), dGc[k], history, float("nan"), "joint")
           for k in range(K)]
    notes.append(f"{problem.what}: parallel system: P_f = Φ_m(−β; R) of its {K} components linearised at their "
                 f"joint design point (|u*| = {float(np.linalg.norm(u)):.3g}; first order, exact for linear "
                 "components; Hohenbichler & Rackwitz 1983): compare with a sampling method where they are curved")
    res = _result(problem, pts, S, pf=pf, beta=beta, lo=pf, hi=pf, g0=g_start, settings=settings, method=method,
                  notes=notes, system="parallel", joint=(u, float(Gc.max()), dGc[int(np.argmax(Gc))], history),
                  seed=seed)
    return res


def _result(problem, pts, S, *, pf, beta, lo, hi, g0, settings, method, notes, system, seed,
            joint=None) -> FORMResult:
    names = problem.names
    X = problem.to_x(np.array([q.u for q in pts]))
    rows, frames = [], []
    comps = problem.limit_state.components
    for k, q in enumerate(pts):
        if system == "parallel":
            c = comps[-1 - q.member]
            rows.append((k, c.name, -1, c.name, None, "", q.beta, float(special.ndtr(-q.beta)), q.how, np.nan))
        elif q.member < 0:
            rows.append((k, problem.limit_state.name, -1, problem.limit_state.name, None, "", q.beta,
                         float(special.ndtr(-q.beta)), q.how, int(q.history.index[-1]) if len(q.history) else 0))
        else:
            r = S.members.iloc[q.member]
            rows.append((k, S.label(q.member), q.member, r["name"], r["output"], r["sign"], q.beta,
                         float(special.ndtr(-q.beta)), q.how,
                         int(q.history.index[-1]) if len(q.history) else 0))
        frames.append(pd.DataFrame({"u": q.u, "x": X[k], "alpha": q.alpha, "importance": q.alpha**2,
                                    "dg_du": q.grad}, index=pd.Index(names, name="input")))
    dps = pd.DataFrame(rows, columns=["point", "member", "member_index", "component", "output", "sign", "beta",
                                      "pf_mode", "how", "n_iterations"]).set_index("point")
    points = pd.concat(frames, keys=range(len(pts)), names=["point", "input"])
    if joint is not None:
        u, G, dG, history = joint
        alpha = -dG / float(np.linalg.norm(dG))
        principal = _Point(-1, u, G, dG, history, g0, "joint")
    else:
        principal = pts[0]
        u, G, dG, history = principal.u, principal.g, principal.grad, principal.history
        alpha = principal.alpha
    x = problem.to_x(u)[0]
    dp = pd.DataFrame({"u": u, "x": x, "alpha": alpha, "importance": alpha**2, "dg_du": dG},
                      index=pd.Index(names, name="input"))
    n_ev = problem.n_evaluations
    n_it = int(history.index[-1]) if len(history) else 0
    table = pd.DataFrame({"pf": [float(pf)], "beta": [float(beta)], "n_evaluations": [n_ev],
                          "n_iterations": [n_it], "g_origin": [float(g0)],
                          "n_design_points": [len(pts)], "beta_min": [float(principal.beta) if joint is None
                                                                       else float(np.linalg.norm(u))],
                          "pf_lower": [float(lo)], "pf_upper": [float(hi)]},
                         index=pd.Index([problem.limit_state.name], name="limit_state"))
    prov = problem.provenance(method=method, seed=seed_record(seed), settings={**settings, "system": system})
    caveats = emit_warnings(notes, stacklevel=4)
    u_ro, g_ro = np.array(u), np.array(dG)
    u_ro.setflags(write=False)
    g_ro.setflags(write=False)
    return FORMResult(table, dp, history, u_ro, g_ro, float(G), problem.all_evaluations(), prov, caveats,
                      dps, points, system)
