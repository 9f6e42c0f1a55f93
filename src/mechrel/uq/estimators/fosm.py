"""First-order second-moment (FOSM) reliability, the paper's eqs. (25)–(28).

The paper treats the actual error i at each crank angle as normal without saying where its mean
and spread come from. Here they are the first-order propagation of the input uncertainty:

    μ_i = f(μ_X),   σ_i² = ∇fᵀ Σ_X ∇f,

with Σ_X the covariance of the inputs (true moments of the marginals, Pearson correlation) and ∇f
by central differences, 2d + 1 model evaluations in total.

Finite-difference step
----------------------
The central difference has truncation error h²|f‴|/6 and round-off/noise error ≈ ε_f|f|/h, where
ε_f is the relative noise of the model output: machine epsilon for an analytic function, but the
solver tolerance (rtol) for an ODE-integrated mechanism. Balancing the two gives
h ∝ (ε_f)^(1/3) times the scale on which f varies. ``step="auto"`` uses

    h_j = noise^(1/3) · max(|μ_j|, σ_j),

with ``noise`` the model's relative output noise (default: machine epsilon → h_j ≈ 6·10⁻⁶ of the
input's magnitude; pass the integrator's rtol for a simulated mechanism, e.g. 1e-8 → 2·10⁻³).
``step=<float>`` instead sets h_j = step·σ_j (a fraction of the input's standard deviation:
a "statistical" secant slope over the input spread, the robust choice when the response is
noisy or only piecewise smooth, e.g. dry contact); an array sets absolute steps. The actual
steps are taken as (x + h) − (x − h) in floating point, so representation error of x ± h
does not enter the slope.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from mechrel.errors import StudyError

from .._docs import fill_doc
from .._common import (
    CountedByProvenance,
    _labels,
    check_inputs,
    emit_warnings,
    exclusive_source,
    executor_kwargs,
    failure_message,
    make_provenance,
    quantity_scale,
    readonly,
    run,
)
from ..execution.executor import Evaluations
from ..problem.inputs import UncertainInputs
from ..results import OutputViews, ResultTable, limit_state_value
from ..problem.model import check_model
from ..problem.allowables import (check_event, per_angle_mask, reliability_one_sided,
                          reliability_two_sided, resolve_allowables)
from ._problem import Problem

__all__ = ["fosm", "fosm_design", "fd_steps", "FOSMResult"]

EPS = float(np.finfo(float).eps)


def fd_steps(inputs: UncertainInputs, step: Any = "auto", noise: float = EPS) -> np.ndarray:
    """Finite-difference steps h_j (see the module docstring).

    Parameters
    ----------
    inputs : UncertainInputs
        The inputs (their means and standard deviations, SI units).
    step : "auto", float or array, default "auto"
        "auto": ``noise**(1/3) * max(|μ_j|, σ_j)``; a float f > 0: f σ_j; an array: the
        steps themselves (the inputs' units).
    noise : float in (0, 1)
        Relative noise of the outputs, for "auto".

    Returns
    -------
    ndarray, shape (d,)
        h_j in the inputs' units.

    Raises
    ------
    StudyError
        A step or noise outside what is allowed.

    Examples
    --------
    >>> from mechrel.uq import Normal, UncertainInputs
    >>> u = UncertainInputs.from_specs({"a": Normal(1.0, 0.1), "b": Normal(2.0, 0.2)})
    >>> fd_steps(u, 0.5).tolist()
    [0.05, 0.1]
    """
    mu, sd = inputs.mean, inputs.std
    if isinstance(step, str):
        if step != "auto":
            raise StudyError(f"step: got {step!r}; allowed: 'auto', a fraction of the std (float > 0) or an array of absolute steps")
        if not (isinstance(noise, (int, float)) and 0 < noise < 1):
            raise StudyError(f"noise: relative output noise of the model must be in (0, 1), got {noise!r}")
        h = noise ** (1.0 / 3.0) * np.maximum(np.abs(mu), sd)
    elif np.ndim(step) == 0:
        try:
            f = float(step)
        except (TypeError, ValueError):
            raise StudyError(f"step: got {step!r}; allowed: 'auto', a float > 0 or an array") from None
        if not (np.isfinite(f) and f > 0):
            raise StudyError(f"step: a fraction of the std must be > 0, got {step!r}")
        h = f * sd
    else:
        h = np.asarray(step, dtype=float)
        if h.shape != (inputs.d,) or not np.all(np.isfinite(h) & (h > 0)):
            raise StudyError(f"step: absolute steps need {inputs.d} finite values > 0, got {step!r}")
    return h


def fosm_design(inputs: UncertainInputs, *, step: Any = "auto", noise: float = EPS) -> np.ndarray:
    """The (2d + 1, d) stencil: row 0 = μ_X, rows 1 + 2j / 2 + 2j = μ_X ± h_j e_j.

    Parameters
    ----------
    inputs : UncertainInputs
        Their means (SI units) are the stencil's centre.
    step, noise
        As for :func:`fosm` (:func:`fd_steps`).

    Returns
    -------
    ndarray, shape (2d + 1, d)
        The points :func:`fosm` evaluates, in the inputs' units.

    Examples
    --------
    >>> from mechrel.uq import Normal, UncertainInputs
    >>> u = UncertainInputs.from_specs({"a": Normal(1.0, 0.1), "b": Normal(2.0, 0.2)})
    >>> fosm_design(u, step=0.5).tolist()
    [[1.0, 2.0], [1.05, 2.0], [0.95, 2.0], [1.0, 2.1], [1.0, 1.9]]
    """
    inputs = check_inputs(inputs, None)
    mu = inputs.mean
    h = fd_steps(inputs, step, noise)
    X = np.tile(mu, (2 * inputs.d + 1, 1))
    for j in range(inputs.d):
        X[1 + 2 * j, j] = mu[j] + h[j]
        X[2 + 2 * j, j] = mu[j] - h[j]
    return X


@dataclass(frozen=True, eq=False)
class FOSMResult(OutputViews, CountedByProvenance):
    """FOSM reliability per output, or mean-value FOSM on a limit state (frozen).

    What :func:`fosm` returns, whatever its arguments: with ``allowable=`` the per-output
    ``table`` (``pf_table`` is None), with ``limit_state=`` the limit state's ``pf_table``
    (``table`` is None).

    Parameters
    ----------
    table : DataFrame or None
        Per output (a :class:`~mechrel.uq.results.ResultTable`): ``mean``, ``std`` (first-order
        mean μ_i and standard deviation σ_i of the error), ``allowable_mean``, ``allowable_std``
        (μ_I and σ_I of the allowable), ``beta`` (the paper's index (μ_I − μ_i)/sqrt(σ_I² + σ_i²)),
        ``R_one_sided`` (= Φ(beta), the paper's R), ``beta_minus`` ((μ_I + μ_i)/s),
        ``R_two_sided`` (P(−I < i < I)), ``reliability`` (the one selected by ``event``) and
        ``beta_generalized`` (Φ⁻¹(reliability)).
    gradient : DataFrame
        ∂output/∂input (outputs × inputs), by central differences; on a limit state one row
        (the limit state's name): ∂g/∂x at the means, per input (random allowables included),
        in g's unit per input unit.
    event : {"two-sided", "one-sided"} or None
        The event whose probability is ``reliability`` (None on a limit state).
    steps : ndarray
        The finite-difference step of each input (its unit).
    input_std, input_correlation : ndarray
        The inputs' standard deviations and Pearson correlation matrix used.
    allowable
        The allowables as given (None on a limit state).
    evaluations : Evaluations or None
        The 2d + 1 model runs.
    provenance : dict
        How the result was made (method, settings, counts, versions, time).
    warnings : tuple of str
        Why the numbers may not be trustworthy (each also issued as an
        :class:`~mechrel.errors.EstimateWarning`): a non-smooth model (dry contact), outputs whose
        response the step does not resolve (a kink, an impact, chaos), outputs with a zero
        gradient (σ_i = 0, so β = ±∞ and R ∈ {0, 1} there are not estimates); on a limit state,
        a limit state on cycle extremes, a kink of g at the means, a zero gradient (then
        ``beta`` and ``pf`` are NaN: they would only reflect round-off).
    pf_table : DataFrame or None, default None
        With ``limit_state=`` (a :class:`~mechrel.uq.results.ResultTable`): one row (index: the
        limit state's name), ``pf`` = Φ(−β), ``beta`` = μ_g/σ_g, ``mean`` (μ_g = g(μ_X)),
        ``std`` (σ_g) and ``n_evaluations`` (2d + 1). Exact for a limit state linear in normal
        inputs (and allowables); otherwise a first-order approximation about the means, which
        is not invariant to how g is written (FORM is).

    Examples
    --------
    >>> from mechrel.uq import Allowable, Normal, UncertainInputs, linear_model
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
    >>> model, allow = linear_model([0.0], [[1.0]], ["x"]), Allowable(0.2, 0.0)
    >>> r = fosm(model=model, inputs=inputs, allowable=allow, progress=False)
    >>> r.provenance["method"], r.n_evaluations, r.warnings
    ('fosm', 3, ())
    """

    table: pd.DataFrame | None
    gradient: pd.DataFrame
    event: str | None
    steps: np.ndarray
    input_std: np.ndarray
    input_correlation: np.ndarray
    allowable: Any
    evaluations: Evaluations | None
    provenance: dict = field(repr=False)
    warnings: tuple[str, ...] = ()
    pf_table: pd.DataFrame | None = None

    def to_frame(self) -> pd.DataFrame:
        """The result's table: a copy of ``table`` (or of ``pf_table`` on a limit state).

        Returns
        -------
        pandas.DataFrame
            One row per output (the columns listed under ``table``), or the limit state's row.

        Examples
        --------
        >>> from mechrel.uq import Allowable, Normal, UncertainInputs, linear_model
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
        >>> r = fosm(model=linear_model([0.0], [[1.0]], ["x"]), inputs=inputs,
        ...          allowable=Allowable(0.2, 0.0), progress=False)
        >>> round(float(r.to_frame()["std"].iloc[0]), 12)
        0.1
        """
        table = self.table if self.table is not None else self.pf_table
        assert table is not None  # one of the two, by construction
        return table.copy()

    @property
    def beta(self) -> Any:
        """The reliability index β = (μ_I − μ_i)/√(σ_I² + σ_i²) per output (on a limit state μ_g/σ_g).

        Returns
        -------
        pandas.Series or float
            The ``beta`` column of ``table`` (dimensionless); on a limit state the float
            ``pf_table["beta"]``.

        Examples
        --------
        >>> from mechrel.uq import Allowable, Normal, UncertainInputs, linear_model
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
        >>> r = fosm(model=linear_model([0.0], [[1.0]], ["x"]), inputs=inputs,
        ...          allowable=Allowable(0.3, 0.04), progress=False)
        >>> round(float(r.beta.iloc[0]), 6)   # 0.3 / √(0.04² + 0.1²)
        2.78543
        """
        if self.table is None:
            return limit_state_value(self, "beta")
        return self.table["beta"]

    @property
    def pf(self) -> float:
        """The probability of failure Φ(−β) of the limit state (a result of ``limit_state=``).

        Returns
        -------
        float
            ``pf_table["pf"]``.

        Raises
        ------
        StudyError
            If the result was run with ``allowable=`` (then ``1 - reliability`` per output).

        Examples
        --------
        >>> from mechrel.uq import FunctionModel, LimitState, Normal, UncertainInputs
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
        >>> g = FunctionModel(lambda X: 2.0 - X[:, 0], ["x"], ["g"], vectorized=True)
        >>> r = fosm(model=g, inputs=inputs, limit_state=LimitState.margin(), progress=False)
        >>> round(r.pf, 6)   # Φ(−2)
        0.02275
        """
        return limit_state_value(self, "pf")

    @property
    def reliability(self) -> pd.Series:
        """The reliability of the selected ``event`` per output.

        Returns
        -------
        pandas.Series
            The ``reliability`` column of ``table`` (a probability).

        Examples
        --------
        >>> from mechrel.uq import Allowable, Normal, UncertainInputs, linear_model
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
        >>> r = fosm(model=linear_model([0.0], [[1.0]], ["x"]), inputs=inputs,
        ...          allowable=Allowable(0.2, 0.0), progress=False, event="one-sided")
        >>> round(float(r.reliability.iloc[0]), 4)   # Φ(2)
        0.9772
        """
        return self._views_frame()["reliability"]

    def importance(self) -> pd.DataFrame:
        """The share of σ_i² from each input, (∂f/∂x_j σ_j)² / σ_i² (on a limit state, of σ_g²).

        An exact decomposition for independent inputs; with correlated inputs the shares do not
        include the cross terms and need not sum to 1.

        Returns
        -------
        pandas.DataFrame
            Outputs (or the limit state) × inputs, dimensionless.

        Examples
        --------
        >>> from mechrel.uq import Allowable, Normal, UncertainInputs, linear_model
        >>> inputs = UncertainInputs.from_specs({"a": Normal(0.0, 1.0), "b": Normal(0.0, 1.0)})
        >>> r = fosm(model=linear_model([0.0], [[1.0, 2.0]], ["a", "b"]), inputs=inputs,
        ...          allowable=Allowable(10.0, 0.0), progress=False)
        >>> r.importance().round(12).iloc[0].tolist()   # 1/5 and 4/5
        [0.2, 0.8]
        """
        g = self.gradient.to_numpy() * self.input_std[None, :]
        var = self.to_frame()["std"].to_numpy() ** 2
        with np.errstate(divide="ignore", invalid="ignore"):
            share = g**2 / var[:, None]
        return pd.DataFrame(share, index=self.gradient.index, columns=self.gradient.columns)


@fill_doc
def fosm(
    *,
    model: Any = None,
    inputs: UncertainInputs,
    evaluations: Evaluations | None = None,
    allowable: Any = None,
    event: str = "two-sided",
    limit_state: Any = None,
    seed: Any = None,
    step: Any = "auto",
    noise: float | None = None,
    n_jobs: int = 1,
    backend: str = "loky",
    cache: Any = None,
    progress: bool = True,
    chunk_size: int | None = None,
) -> FOSMResult:
    """FOSM reliability (paper eqs. 25–28) with first-order propagation of ``inputs``.

    Pass ``model=`` (2d + 1 evaluations are run here) or ``evaluations=`` of
    ``fosm_design(inputs, step=step, noise=noise)``. ``event="one-sided"`` is the paper's
    R = Φ(β) = P(I − i > 0) on the signed error; ``event="two-sided"`` (default) is
    P(|i| < I), see :mod:`mechrel.uq.problem.allowables`. Both are always in the table.
    ``allowable``: None (paper defaults per ``quantity``), an ``Allowable`` or {quantity: Allowable}.
    ``noise`` (for ``step="auto"``): the relative noise of the model outputs; None takes the
    model's optional ``output_noise`` attribute (e.g. the integrator's rtol), else machine epsilon.
    A failed stencil point makes the gradient undefined: ``StudyError`` naming the points.

    Parameters
    ----------
    model : Model, optional
        The model evaluated at the 2d + 1 stencil points (exclusive with ``evaluations``).
    inputs : UncertainInputs
        The uncertain inputs; their means and standard deviations (SI units) set the stencil.
    evaluations : Evaluations, optional
        Precomputed evaluations of exactly :func:`fosm_design` ``(inputs, step, noise)``.
    allowable : Allowable or mapping, optional
        The allowable error I ~ N(mean, std²) in the outputs' units: None (the default
        allowables per quantity, :data:`mechrel.uq.problem.allowables.DEFAULT_ALLOWABLES`), one
        :class:`~mechrel.uq.problem.allowables.Allowable` for every output, or
        ``{quantity: Allowable}``.
    event : {"two-sided", "one-sided"}, default "two-sided"
        The safe event: P(|i| < I) (two-sided) or the paper's P(i < I) on the signed error.
    limit_state : LimitState, optional
        In place of ``allowable``/``event``: mean-value FOSM on the limit state g (its random
        allowables are inputs too): μ_g = g(μ_X), σ_g² = ∇gᵀ Σ ∇g by central differences,
        β = μ_g/σ_g, P_f = Φ(−β), in the result's ``pf_table``. Needs ``model=``.
    seed : optional
        Unused (FOSM draws nothing); accepted so that every estimator shares one interface.
    step : "auto" or float or array, default "auto"
        Central-difference steps h_j in the inputs' units; "auto" balances truncation against
        ``noise`` (:func:`fd_steps`).
    noise : float, optional
        Relative noise of the outputs (dimensionless) for ``step="auto"``.
    %(executor)s

    Returns
    -------
    FOSMResult
        Per output: μ_i, σ_i, β, both reliabilities; ``.to_frame()``, ``.provenance``; on a
        limit state its ``pf_table`` (``.pf``, ``.beta``).

    Raises
    ------
    StudyError
        A bad argument (naming it, its value and what is allowed), or a failed stencil point.

    Examples
    --------
    An output y = x with x ~ N(0, 0.1²) against a fixed allowable 0.2: β = 2, and the
    two-sided reliability is P(|y| < 0.2) = 2 Φ(2) − 1:

    >>> from mechrel.uq import Allowable, Normal, UncertainInputs, fosm, linear_model
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
    >>> r = fosm(model=linear_model([0.0], [[1.0]], ["x"]), inputs=inputs,
    ...          allowable=Allowable(0.2, 0.0), progress=False)
    >>> row = r.to_frame().iloc[0]
    >>> round(float(row["beta"]), 6), round(float(row["R_two_sided"]), 4)
    (2.0, 0.9545)

    On a limit state, g = 3 − x1 − x2 of standard normals: β = 3/√2 exactly, in the same
    result type:

    >>> from mechrel.uq import FunctionModel, LimitState
    >>> inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
    >>> g = FunctionModel(lambda X: 3.0 - X[:, 0] - X[:, 1], ["x1", "x2"], ["g"], vectorized=True)
    >>> r = fosm(model=g, inputs=inputs, limit_state=LimitState.margin(), progress=False)
    >>> type(r).__name__, round(r.beta * 2**0.5, 9), r.n_evaluations, r.table is None
    ('FOSMResult', 3.0, 5, True)
    """
    t0 = time.perf_counter()
    exclusive_source(model, evaluations, what="fosm")
    if noise is None:
        noise = float(getattr(model, "output_noise", EPS)) if model is not None else EPS
    check_event(event)
    if limit_state is not None:
        if allowable is not None:
            raise StudyError("fosm: allowable= and limit_state= are both given; allowed: one of them "
                             "(a limit state carries its own allowables)")
        if model is None:
            raise StudyError("fosm: limit_state= with evaluations=: the limit state's random allowables "
                             "are points of the stencil too; allowed: model= and inputs= with limit_state=")
        return _limit_state_fosm(model=model, inputs=inputs, limit_state=limit_state, step=step, noise=noise,
                                 executor=executor_kwargs(n_jobs, backend, cache, progress, chunk_size))
    if model is not None:
        names = check_model(model)[0]
    else:
        assert evaluations is not None  # exclusive_source: exactly one
        names = evaluations.input_names
    inputs = check_inputs(inputs, names)
    X = fosm_design(inputs, step=step, noise=noise)
    if model is not None:
        ev = run(model, X, executor_kwargs(n_jobs, backend, cache, progress, chunk_size))
    else:
        assert evaluations is not None  # exclusive_source: exactly one
        ev = evaluations
        if ev.X.shape != X.shape or not np.array_equal(ev.X, X):
            raise StudyError(
                "fosm: evaluations.X is not fosm_design(inputs, step=..., noise=...) for these "
                "arguments; evaluate exactly that design"
            )
    if ev.n_failed:
        labels = ["mean"] + [f"{n} {s} h" for n in inputs.names for s in ("+", "-")]
        bad = [f"{labels[i]}: {ev.reasons[i]}" for i in np.flatnonzero(~ev.ok)]
        raise StudyError(
            "fosm: the finite-difference stencil needs every point; "
            f"{failure_message(ev)}. Failed points: {bad[:6]}. Try a smaller step or Monte Carlo."
        )
    Y = ev.Y
    mu_i = Y[0]
    dx = X[1::2, :].diagonal() - X[2::2, :].diagonal()  # actual (x+h) - (x-h)
    G = (Y[1::2] - Y[2::2]).T / dx[None, :]  # (n_out, d)
    cov = inputs.covariance
    var = np.einsum("kj,jl,kl->k", G, cov, G)
    sigma_i = np.sqrt(np.maximum(var, 0.0))
    mu_I, sd_I, _ = resolve_allowables(ev.output_index, allowable)
    beta, r1 = reliability_one_sided(mu_i, sigma_i, mu_I, sd_I)
    _, bm, r2, _ = reliability_two_sided(mu_i, sigma_i, mu_I, sd_I)
    rel = r1 if event == "one-sided" else r2
    from scipy import special

    table = ResultTable(
        {
            "mean": mu_i, "std": sigma_i, "allowable_mean": mu_I, "allowable_std": sd_I,
            "beta": beta, "R_one_sided": r1, "beta_minus": bm, "R_two_sided": r2,
            "reliability": rel, "beta_generalized": special.ndtri(rel),
        },
        index=ev.output_index,
    )
    grad = pd.DataFrame(G, index=ev.output_index, columns=list(inputs.names))
    h = fd_steps(inputs, step, noise)
    prov = make_provenance(
        method="fosm", seed=None, evaluations=[ev], wall_time=time.perf_counter() - t0, inputs=inputs,
        settings={"event": event, "step": step if isinstance(step, str) or np.ndim(step) == 0 else list(map(float, step)),
                  "noise": noise, "steps": h.tolist(), "allowable": repr(allowable) if allowable is not None else "paper defaults",
                  "gradient": "central differences, 2d+1 evaluations"},
    )
    checks, blank = fosm_checks(model, ev.output_index, Y, sigma_i, sd_I)
    # not estimates: the cycle extremes (not differentiable) and, against a fixed allowable, a
    # zero gradient (β = ±∞ from round-off)
    table.loc[blank, ["beta", "R_one_sided", "beta_minus", "R_two_sided", "reliability",
                      "beta_generalized"]] = np.nan
    table.loc[~per_angle_mask(ev.output_index), "std"] = np.nan
    notes = emit_warnings(checks)
    return FOSMResult(table, grad, event, readonly(h), readonly(inputs.std), readonly(inputs.pearson_correlation),
                      allowable, ev, prov, notes)


UNRESOLVED = 0.5
"""FOSM's resolution test: the forward and backward slopes f(μ + h) − f(μ) and f(μ) − f(μ − h)
of a smooth response differ by O(h f″), a small fraction of either at a step that resolves the
response; where they differ by more than this fraction of the larger, the step spans a kink, an
impact or chaotic scatter, and the central difference is not a derivative."""
ZERO = 1e-12
"""A gradient, or a slope, is taken as zero when it changes the output by less than this
fraction of the largest |output| of its quantity (about ten thousand times the rounding of a
double)."""


def fosm_checks(model, index, Y: np.ndarray, sigma_i: np.ndarray,
                sigma_I: np.ndarray | None = None) -> tuple[list[str], np.ndarray]:
    """Why a FOSM result from the stencil outputs ``Y`` (rows: μ, then μ ± h_j per input) may
    not be trustworthy (see :class:`FOSMResult`), and which outputs get no β or R: the cycle
    extremes (a maximum over the cycle is not differentiable where its instant jumps or the
    error is zero: a σ there is a secant or round-off), and, against a fixed allowable
    (``sigma_I`` = 0), the outputs whose gradient is zero (β = ±∞ from round-off)."""
    out = []
    reason = getattr(model, "nonsmooth", None)
    if reason:
        out.append(f"fosm: the model is not smooth ({reason}): its finite-difference gradient "
                   "is a secant across impacts, not a derivative, and its error is not normal; "
                   "trust Monte Carlo for this model")
    scale = quantity_scale(index, Y)
    floor = ZERO * scale
    up = Y[1::2] - Y[0]          # (d, n_out) forward changes
    down = Y[0] - Y[2::2]        # backward changes
    big = np.maximum(np.abs(up), np.abs(down))
    angle = per_angle_mask(index)
    n_out = int(angle.sum())
    if n_out == 0:
        out.append("fosm: every output is a cycle extreme (max, min, max_abs): a maximum over the cycle is "
                   "not differentiable where its instant jumps or the error is zero, so FOSM gives no σ, β "
                   "or R for it; estimate the whole cycle by Monte Carlo or a rare-event method")
    unresolved = np.any((big > floor) & (np.abs(up - down) > UNRESOLVED * big), axis=0) & angle
    if unresolved.any():
        out.append(f"fosm: the finite-difference step does not resolve the response at "
                   f"{int(unresolved.sum())} of {n_out} outputs, e.g. "
                   f"{_labels(index, unresolved)}: the forward and backward slopes differ by "
                   f"more than {UNRESOLVED:.0%} (a kink, an impact, a chaotic response, or a "
                   "turning point where the first-order term vanishes), so σ_i there is not a "
                   "first-order standard deviation; use Monte Carlo")
    kinked_ext = np.any((big > floor) & (np.abs(up - down) > UNRESOLVED * big), axis=0) & ~angle
    flat_ext = (sigma_i <= floor) & ~angle
    if n_out and (kinked_ext | flat_ext).any():
        out.append(f"fosm: {int((kinked_ext | flat_ext).sum())} cycle extreme(s) are not differentiable at "
                   f"the means, e.g. {_labels(index, kinked_ext | flat_ext)} (a kink: the peak moves, or the "
                   "error is zero there, as for geometric tolerances alone): FOSM gives the cycle extremes "
                   "no σ, β or R; estimate the whole cycle by Monte Carlo or a rare-event method")
    zero = (sigma_i <= floor) & angle
    fixed = np.zeros(len(index), dtype=bool) if sigma_I is None else (np.asarray(sigma_I) == 0)
    if zero.any():
        out.append(f"fosm: the finite-difference gradient is zero at {int(zero.sum())} of "
                   f"{n_out} outputs, e.g. {_labels(index, zero)}: σ_i = 0 (a flat response, a kink "
                   "between the stencil points, or a step below the model's resolution)"
                   + (", so β and R are left empty (NaN) where the allowable is fixed"
                      if (zero & fixed).any() else "")
                   + "; use Monte Carlo there")
    blank = ~angle | (zero & fixed)
    return out, blank


def _limit_state_fosm(*, model, inputs, limit_state, step, noise, executor) -> FOSMResult:
    """Mean-value FOSM on ``limit_state``: the (2d + 1)-point stencil of :func:`fosm_design`
    over the inputs and the random allowables, g through the model."""
    from scipy import special

    problem = Problem(model=model, inputs=inputs, limit_state=limit_state, what="fosm", **executor)
    X = fosm_design(problem.inputs, step=step, noise=noise)
    G, ok, reasons = problem.g_at_x(X)
    if not ok.all():
        labels = ["mean"] + [f"{n} {s} h" for n in problem.names for s in ("+", "-")]
        bad = [f"{labels[i]}: {reasons[i]}" for i in np.flatnonzero(~ok)]
        raise StudyError(f"fosm: the finite-difference stencil needs every point; failed points: {bad[:6]}; "
                         "allowed: a smaller step, or Monte Carlo")
    dx = X[1::2, :].diagonal() - X[2::2, :].diagonal()
    grad = (G[1::2] - G[2::2]) / dx
    sigma_g = float(np.sqrt(max(float(grad @ problem.inputs.covariance @ grad), 0.0)))
    mu_g = float(G[0])
    notes = []
    reason = getattr(model, "nonsmooth", None)
    if reason:
        notes.append(f"fosm: the model is not smooth ({reason}): its finite-difference gradient is a secant "
                     "across impacts, not a derivative; use subset_simulation or Monte Carlo")
    # g's own resolution: a change below ZERO of its size is round-off, and forward and backward
    # slopes that disagree are a kink (a tie of failure modes: min/max of equal branches)
    up, down = G[1::2] - G[0], G[0] - G[2::2]
    big = np.maximum(np.abs(up), np.abs(down))
    floor = ZERO * float(np.max(np.abs(G)))
    kink = bool(np.any((big > floor) & (np.abs(up - down) > UNRESOLVED * big)))
    members = problem.bound.members
    extremes = [o for o in members["output"] if isinstance(o, tuple) and o and isinstance(o[-1], str)]
    if extremes:
        notes.append(f"fosm: the limit state uses cycle extremes ({extremes[0]}{', ...' if len(extremes) > 1 else ''}): "
                     "a maximum over the cycle is not differentiable where its instant jumps or the error is zero, "
                     "so mean-value FOSM does not apply; use form (search='system'), subset_simulation or "
                     "Monte Carlo")
    if kink:
        notes.append("fosm: g is not differentiable at the means (its forward and backward slopes differ by more "
                     f"than {UNRESOLVED:.0%}: a kink, e.g. a tie of several failure modes, min/max of equal "
                     "branches): σ_g is not a first-order standard deviation; use form (search='system') or "
                     "subset_simulation")
    if not sigma_g > ZERO * max(abs(mu_g), float(np.max(np.abs(G)))):
        notes.append(f"fosm: the gradient of g is zero at the means (σ_g = {sigma_g:.3g}, round-off of g = "
                     f"{mu_g:.6g}): β = ±∞ and P_f ∈ {{0, 1}} would only reflect round-off, so they are left "
                     "empty (NaN); the means may sit on a tie of several failure modes: use form "
                     "(search='system') or subset_simulation")
        beta = math.nan
    else:
        beta = mu_g / sigma_g
    caveats = emit_warnings(notes, stacklevel=4)
    table = ResultTable({"pf": [float(special.ndtr(-beta))], "beta": [beta], "mean": [mu_g],
                         "std": [sigma_g], "n_evaluations": [problem.n_evaluations]},
                        index=pd.Index([problem.limit_state.name], name="limit_state"))
    prov = problem.provenance(method="fosm", seed=None,
                              settings={"step": step if isinstance(step, str) or np.ndim(step) == 0
                                        else list(map(float, step)), "noise": noise,
                                        "gradient": "central differences, 2d+1 evaluations, at the means"})
    gradient = pd.DataFrame(grad[None, :], index=table.index, columns=list(problem.names))
    return FOSMResult(None, gradient, None, readonly(fd_steps(problem.inputs, step, noise)),
                      readonly(problem.inputs.std), readonly(problem.inputs.pearson_correlation),
                      None, problem.all_evaluations(), prov, caveats, pf_table=table)
