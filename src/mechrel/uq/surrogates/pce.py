"""Polynomial chaos expansions (chaospy distributions and quadrature, own linear algebra).

Basis
-----
Orthonormal polynomials of the *germ*: the input marginals themselves when the inputs are
independent (Hermite for normal, Legendre for uniform, Laguerre for gamma, Jacobi for beta, and
the truncated normal's and lognormal's own; recurrence coefficients from ``chaospy.stieltjes``),
or iid standard normals z with x = T(z) (the Nataf map of
:class:`~mechrel.uq.problem.inputs.UncertainInputs`) when they are correlated. An independent
Gumbel, Weibull or ``ScipyMarginal`` input is expanded in Hermite polynomials of its own
standard-normal image z_j = Φ⁻¹(F_j(x_j)) (:data:`OWN_POLYNOMIALS`). Multivariate terms are
products Ψ_α(ξ) = Π_j p_{α_j}(ξ_j) over the multi-indices with hyperbolic norm
(Σ α_j^q)^(1/q) ≤ order (q = 1: total degree). Evaluation uses the three-term recurrence directly
(chaospy's symbolic ``numpoly`` evaluation is orders of magnitude slower for 10⁵ points).

Coefficients
------------
``method="regression"``: least squares on ``ceil(oversampling · P)`` samples (P basis terms)
drawn by ``rule`` (rounded up to a power of 2 for ``rule="sobol"``); error estimate: leave-one-out in closed form through the hat matrix,
e_LOO = mean_i[((y_i − ŷ_i)/(1 − h_ii))²] / Var(y) (relative; ``loo_error``). Failed samples are
dropped (counted; refuses above ``max_failure_fraction`` or when fewer than P + 1 remain:
:class:`~mechrel.uq.SampleFailuresError`, a ``StudyError`` carrying the evaluations).
``method="quadrature"``: spectral projection c_α = Σ_q w_q Ψ_α(ξ_q) y_q on
``chaospy.generate_quadrature(order, germ, rule=quadrature_rule, sparse=sparse)`` (Gaussian:
order + 1 points per dimension, exact for the products Ψ_α·f of degree ≤ 2·order + 1). A failed
node invalidates the rule: ``SampleFailuresError``. Error estimate: relative mean-square error on
``n_validation`` extra random samples (``validation_error``).

Post-processing (directly from the coefficients; chaospy's ``Sens_*`` are not used)
-----------------------------------------------------------------------------------
mean = c_0, Var = Σ_{α≠0} c_α², first-order S_j = Σ_{α: only α_j > 0} c_α² / Var, total-order
S_Tj = Σ_{α: α_j > 0} c_α² / Var. Sobol' indices are only reported for independent inputs (for a
correlated germ they would be indices of the decorrelated z, not of x).
Surrogate reliability: :meth:`PCEResult.reliability` samples the surrogate (cheap) and runs the
Monte Carlo estimator on it; its intervals cover the sampling error only, not the surrogate's
own error (check ``loo_error``/``validation_error``).
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from mechrel.errors import StudyError

from .._docs import fill_doc
from ..._checks import ARGS
from .._common import (
    CountedByProvenance,
    SampleFailuresError,
    check_inputs,
    emit_warnings,
    exclusive_source,
    executor_kwargs,
    failure_message,
    make_provenance,
    readonly,
    run,
)
from ..execution.executor import STATUS_OK, Evaluations
from ..problem.inputs import SAMPLING_RULES, UncertainInputs, as_seed_sequence, child_seed, seed_record
from ..problem.model import check_model
from ..results import OutputViews

__all__ = ["polynomial_chaos", "pce_design", "PCEResult", "multi_indices"]

METHODS = ("regression", "quadrature")

OWN_POLYNOMIALS = ("normal", "uniform", "truncnormal", "lognormal", "gamma", "beta")
"""The marginals (by ``kind``) that an expansion of independent inputs writes in their own
orthogonal polynomials. Every other one (Gumbel, Weibull, any ``ScipyMarginal``) is expanded in
Hermite polynomials of its standard-normal image z_j = Φ⁻¹(F_j(x_j)), exact for any input with a
finite variance: chaospy has no closed-form recurrence for them, and its discretised Stieltjes
procedure is not accurate for all of them (an orthonormality error of 7.5e-2 for a Weibull of
modulus 0.8, of 0.2 for a generalised extreme value law), while a heavy-tailed law has no
orthogonal polynomials beyond half its number of finite moments. The Sobol' indices are
unchanged (z_j is a one-to-one function of x_j alone)."""


def multi_indices(d: int, order: int, q_norm: float = 1.0) -> np.ndarray:
    """Multi-indices α ∈ ℕ^d with (Σ α_j^q)^(1/q) ≤ order, graded by total degree (α = 0 first).

    Parameters
    ----------
    d : int
        Number of inputs.
    order : int
        Total order.
    q_norm : float in (0, 1], default 1.0
        Hyperbolic truncation (1: every α of total degree ≤ order).

    Returns
    -------
    ndarray of int, shape (P, d)

    Examples
    --------
    >>> multi_indices(2, 2).tolist()
    [[0, 0], [1, 0], [0, 1], [2, 0], [1, 1], [0, 2]]
    >>> multi_indices(2, 2, q_norm=0.5).tolist()  # the interaction term [1, 1] is dropped
    [[0, 0], [1, 0], [0, 1], [2, 0], [0, 2]]
    """
    out = []
    for total in range(order + 1):
        for combo in itertools.combinations_with_replacement(range(d), total):
            a = np.zeros(d, dtype=int)
            for j in combo:
                a[j] += 1
            out.append(a)
    A = np.array(out, dtype=int).reshape(-1, d)
    # combinations_with_replacement enumerates each multiset once; order within a degree is
    # lexicographic in the variables, which is all we need.
    if q_norm < 1.0:
        with np.errstate(divide="ignore"):
            qn = np.sum(A.astype(float) ** q_norm, axis=1) ** (1.0 / q_norm)
        A = A[qn <= order + 1e-9]
    return A


MAX_EVALUATIONS = 100_000
"""The model evaluations :func:`polynomial_chaos` starts unless asked for more
(``max_evaluations``): the number of terms grows as C(d + order, order), so that order 200 in
three inputs would start 2.7 million (days of simulations) on a typing slip."""


def _n_terms(d: int, order: int, q_norm: float, cap: int) -> int:
    """How many multi-indices :func:`multi_indices` returns, counted without building them (at
    most ``cap + 1``: the count stops there)."""
    if q_norm >= 1.0:
        return math.comb(d + order, order)
    limit = order + 1e-9
    count = 0

    def walk(j: int, partial: float) -> bool:  # True: past cap
        nonlocal count
        if j == d:
            count += 1
            return count > cap
        a = 0
        while a <= order and (partial + a**q_norm) ** (1.0 / q_norm) <= limit:
            if walk(j + 1, partial + a**q_norm):
                return True
            a += 1
        return False

    walk(0, 0.0)
    return count


def design_size(d: int, order: int, *, method: str = "regression", oversampling: float = 2.0,
                rule: str = "sobol", q_norm: float = 1.0, cap: int | None = None) -> int:
    """The model evaluations of the training design of :func:`polynomial_chaos`, counted
    without building it (for a full quadrature grid, the Gauss count ``(order + 1)^d``; a
    Smolyak grid is counted once built).

    Parameters
    ----------
    d : int
        Number of inputs.
    order, method, oversampling, rule, q_norm
        As in :func:`polynomial_chaos`.
    cap : int, optional
        Count hyperbolic (``q_norm < 1``) terms only up to this many terms (the count is then
        larger than any limit it is compared with).

    Returns
    -------
    int
        The number of training samples.

    Examples
    --------
    >>> design_size(3, 2, rule="random")      # 10 terms, twice over
    20
    >>> design_size(3, 200)                   # 1 373 701 terms: 2^22 Sobol' points
    4194304
    """
    if method == "quadrature":
        return (order + 1) ** d
    P = _n_terms(d, order, q_norm, cap if cap is not None else 10**7)
    n = int(math.ceil(float(oversampling) * P))
    if rule == "sobol":
        n = 1 << (n - 1).bit_length()  # balanced Sobol' sets need a power of 2 (pce_design)
    return n


def check_cost(d: int, order: int, max_evaluations: int | None, *, method: str = "regression",
               oversampling: float = 2.0, rule: str = "sobol", q_norm: float = 1.0,
               names: tuple[str, str] = ("order", "max_evaluations")) -> int:
    """Refuse a polynomial chaos whose training design needs more than ``max_evaluations``
    model evaluations (None: any number), saying what it would cost and what fits.

    Parameters
    ----------
    d, order, method, oversampling, rule, q_norm
        As in :func:`design_size`.
    max_evaluations : int or None
        The limit (:data:`MAX_EVALUATIONS` by default in :func:`polynomial_chaos`).
    names : (str, str), default ("order", "max_evaluations")
        The names of the order and of the limit in the message (a study's fields).

    Returns
    -------
    int
        The evaluations (as counted by :func:`design_size`, capped past the limit).

    Raises
    ------
    StudyError
        The design needs more evaluations than the limit.

    Examples
    --------
    >>> check_cost(3, 200, 100_000)
    Traceback (most recent call last):
    ...
    mechrel.errors.StudyError: order = 200: an expansion of order 200 in 3 inputs has 1373701 terms, 4194304 model evaluations (2 per term, rounded up to a power of 2 for Sobol' points), more than max_evaluations = 100000; allowed: order <= 56 for 3 inputs, or max_evaluations = 4194304 (or more) to run them knowingly
    """
    if max_evaluations is None:
        return design_size(d, order, method=method, oversampling=oversampling, rule=rule,
                           q_norm=q_norm)
    max_evaluations = ARGS.integer(names[1], max_evaluations, ge=1)
    cap = int(max_evaluations / max(float(oversampling), 1.0)) + 1

    def size(k: int) -> int:
        return design_size(d, k, method=method, oversampling=oversampling, rule=rule,
                           q_norm=q_norm, cap=cap)

    n = size(order)
    if n <= max_evaluations:
        return n
    fits = order
    while fits > 0 and size(fits) > max_evaluations:
        fits -= 1
    if method == "quadrature":
        how = f"a Gauss grid of {order + 1} points per input: {n} model evaluations"
    else:
        P = _n_terms(d, order, q_norm, cap)
        terms = f"{P} terms" if q_norm >= 1.0 or P <= cap else f"more than {cap} terms"
        how = (f"{terms}, {n} model evaluations ({float(oversampling):g} per term"
               + (", rounded up to a power of 2 for Sobol' points)" if rule == "sobol" else ")"))
    raise StudyError(f"{names[0]} = {order}: an expansion of order {order} in {d} inputs has "
                     f"{how}, more than {names[1]} = {max_evaluations}; allowed: {names[0]} <= "
                     f"{fits} for {d} inputs, or {names[1]} = {n} (or more) to run them knowingly")


def _recurrences(inputs: UncertainInputs, order: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per germ dimension: (A_k, B_k), k = 0..order, of the monic three-term recurrence."""
    import chaospy

    out = []
    for m, image in zip(inputs.marginals, _normal_image(inputs)):
        if image:
            A = np.zeros(order + 1)
            B = np.arange(order + 1, dtype=float)
            B[0] = 1.0
        else:
            coef, _, _ = chaospy.stieltjes(order, m.chaospy())
            A = np.asarray(coef[0]).reshape(-1)[: order + 1].astype(float)
            B = np.asarray(coef[1]).reshape(-1)[: order + 1].astype(float)
        out.append((A, B))
    return out


def _univariate(xi: np.ndarray, A: np.ndarray, B: np.ndarray, order: int) -> np.ndarray:
    """Orthonormal p_0..p_order at xi: p_{k+1} = ((x − A_k) p_k − √B_k p_{k−1}) / √B_{k+1}."""
    P = np.empty((order + 1, xi.shape[0]))
    P[0] = 1.0
    if order >= 1:
        P[1] = (xi - A[0]) / math.sqrt(B[1])
    for k in range(1, order):
        P[k + 1] = ((xi - A[k]) * P[k] - math.sqrt(B[k]) * P[k - 1]) / math.sqrt(B[k + 1])
    return P


def _basis(xi: np.ndarray, alphas: np.ndarray, rec: Sequence[tuple[np.ndarray, np.ndarray]],
           order: int) -> np.ndarray:
    """(n, P) basis matrix Ψ_α(ξ)."""
    n, d = xi.shape
    uni = [_univariate(xi[:, j], *rec[j], order) for j in range(d)]
    Psi = np.ones((n, alphas.shape[0]))
    for j in range(d):
        Psi *= uni[j][alphas[:, j]].T
    return Psi


def _least_squares(Psi: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients and leverages h_ii of the least-squares fit Ψc ≈ Y.

    Normal equations via Cholesky (G = ΨᵀΨ = LLᵀ, W = L⁻¹Ψᵀ, c = L⁻ᵀWY, h = column norms² of
    W): for an orthonormal basis on a well-spread design cond(Ψ) is O(1–100), so squaring it
    costs nothing in accuracy, and it is several times faster than Householder QR with
    multithreaded BLAS on a busy machine. Falls back to QR when G is ill-conditioned
    (cond(G) > 1e10), and refuses a rank-deficient design.
    """
    from scipy import linalg

    G = Psi.T @ Psi
    try:
        L = np.linalg.cholesky(G)
        dl = np.abs(np.diag(L))
        good = (dl.min() / dl.max()) ** 2 > 1e-10
    except np.linalg.LinAlgError:
        good = False
    if good:
        W = linalg.solve_triangular(L, Psi.T, lower=True, check_finite=False)
        coef = linalg.solve_triangular(L.T, W @ Y, lower=False, check_finite=False)
        return coef, np.sum(W**2, axis=0)
    Q, R = np.linalg.qr(Psi)
    rdiag = np.abs(np.diag(R))
    if rdiag.min() <= 1e-10 * rdiag.max():
        raise StudyError(
            f"polynomial_chaos: the regression matrix is rank deficient (condition ~{rdiag.max() / max(rdiag.min(), 1e-300):.2g}); "
            "use more or better spread samples (rule='sobol') or a lower order"
        )
    return np.linalg.solve(R, Q.T @ Y), np.sum(Q**2, axis=1)


def _germ(inputs: UncertainInputs) -> str:
    return "inputs" if inputs.independent else "standard_normal"


def _normal_image(inputs: UncertainInputs) -> tuple[bool, ...]:
    """Per input: whether its germ is its standard-normal image (else the input itself)."""
    return tuple(not inputs.independent or m.kind not in OWN_POLYNOMIALS for m in inputs.marginals)


def _to_germ(inputs: UncertainInputs, X: np.ndarray, inverse: bool = False) -> np.ndarray:
    """The germ points of input points X (n, d); with ``inverse``, the input points of germ
    points."""
    if not inputs.independent:
        return inputs.from_standard_normal(X) if inverse else inputs.to_standard_normal(X)
    out = np.array(X, dtype=float)
    for j, (m, image) in enumerate(zip(inputs.marginals, _normal_image(inputs))):
        if image:
            out[:, j] = m.from_z(out[:, j]) if inverse else m.to_z(out[:, j])
    return out


def _germ_joint(inputs: UncertainInputs):
    import chaospy

    return chaospy.J(*[chaospy.Normal(0, 1) if image else m.chaospy()
                       for m, image in zip(inputs.marginals, _normal_image(inputs))])


def pce_design(
    inputs: UncertainInputs,
    *,
    order: int,
    method: str = "regression",
    oversampling: float = 2.0,
    rule: str = "sobol",
    quadrature_rule: str = "gaussian",
    sparse: bool = False,
    q_norm: float = 1.0,
    seed: Any = None,
) -> tuple[np.ndarray, np.ndarray | None]:
    """(X, weights): the training design of :func:`polynomial_chaos` (weights None for regression).

    Parameters
    ----------
    inputs : UncertainInputs
        The uncertain inputs.
    order, method, oversampling, rule, quadrature_rule, sparse, q_norm, seed
        As for :func:`polynomial_chaos`.

    Returns
    -------
    X : ndarray, shape (m, d)
        The training points, in the inputs' units.
    weights : ndarray, shape (m,), or None
        The quadrature weights (they sum to 1), None for regression.

    Raises
    ------
    StudyError
        If ``oversampling`` is < 1, or an argument is invalid.

    Examples
    --------
    Regression on twice the 6 terms of order 2 in two inputs, rounded up to a power of 2
    (a balanced Sobol' set); a 3 × 3 Gauss grid for quadrature:

    >>> from mechrel.uq import Normal, UncertainInputs
    >>> u = UncertainInputs.from_specs({"a": Normal(1.0, 0.1), "b": Normal(2.0, 0.2)})
    >>> X, w = pce_design(u, order=2, seed=1)
    >>> X.shape, w is None
    ((16, 2), True)
    >>> X, w = pce_design(u, order=2, method="quadrature")
    >>> X.shape, round(float(w.sum()), 12)
    ((9, 2), 1.0)
    """
    inputs = check_inputs(inputs, None)
    order = ARGS.integer("order", order, ge=0)
    ARGS.choice("method", method, METHODS)
    if method == "regression":
        ARGS.choice("rule", rule, SAMPLING_RULES)
        P = multi_indices(inputs.d, order, q_norm).shape[0]
        try:
            ov = float(oversampling)
        except (TypeError, ValueError):
            ov = float("nan")
        if not (np.isfinite(ov) and ov >= 1):
            raise StudyError(f"oversampling: samples per basis term must be >= 1 (2-3 recommended), got {oversampling!r}")
        n = int(math.ceil(ov * P))
        if rule == "sobol":
            n = 1 << (n - 1).bit_length()  # balanced Sobol' sets need a power of 2
        return inputs.sample(n, rule, child_seed(as_seed_sequence(seed), 0)), None
    import chaospy

    nodes, weights = chaospy.generate_quadrature(order, _germ_joint(inputs), rule=quadrature_rule, sparse=sparse)
    return _to_germ(inputs, np.asarray(nodes, dtype=float).T, inverse=True), np.asarray(weights, dtype=float)


@dataclass(frozen=True, eq=False)
class PCEResult(OutputViews, CountedByProvenance):
    """A fitted polynomial chaos expansion (frozen).

    Parameters
    ----------
    coefficients : ndarray, shape (P, n_out)
        The expansion's coefficients.
    multi_indices : ndarray, shape (P, d)
        The polynomial degrees of each term.
    order : int
        Total order of the expansion.
    method : str
        How the coefficients were fitted (``"regression"``).
    germ : str
        The germ the polynomials are orthogonal for (``"inputs"``: the inputs' own marginals,
        or the standard-normal image of those outside :data:`OWN_POLYNOMIALS`;
        ``"standard_normal"``: the standard normal space of correlated inputs).
    inputs : UncertainInputs
        The inputs the expansion is of.
    output_index : pandas.Index
        The outputs' labels.
    mean, std : Series
        Mean and standard deviation of each output, from the coefficients.
    sobol_first, sobol_total : DataFrame or None
        First- and total-order Sobol' indices from the coefficients (independent inputs only).
    loo_error, validation_error : Series or None
        Leave-one-out error and the error on a validation sample, relative to each output's
        variance.
    evaluations : Evaluations
        The training runs.
    provenance : dict
        How the result was made.
    _recurrence : tuple, default ()
        Internal: the orthogonal polynomials' recurrence coefficients (for :meth:`predict`).
    warnings : tuple of str, default ()
        Outputs whose leave-one-out error exceeds :data:`LOO_THRESHOLD` (also issued as
        :class:`~mechrel.errors.EstimateWarning`, and carried by :meth:`reliability`'s result).

    Examples
    --------
    The surrogate of y = 2 x + 1 reproduces it at any point:

    >>> import numpy as np
    >>> from mechrel.uq import Normal, UncertainInputs, linear_model, polynomial_chaos
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
    >>> r = polynomial_chaos(model=linear_model([1.0], [[2.0]], ["x"]), inputs=inputs,
    ...                      order=1, seed=1, progress=False)
    >>> np.round(r.predict(np.array([[0.5]])), 12).tolist()
    [[2.0]]
    """

    coefficients: np.ndarray
    multi_indices: np.ndarray
    order: int
    method: str
    germ: str
    inputs: UncertainInputs
    output_index: pd.Index
    mean: pd.Series
    std: pd.Series
    sobol_first: pd.DataFrame | None
    sobol_total: pd.DataFrame | None
    loo_error: pd.Series | None
    validation_error: pd.Series | None
    evaluations: Evaluations
    provenance: dict = field(repr=False)
    _recurrence: tuple = field(repr=False, default=())
    warnings: tuple[str, ...] = ()

    def to_frame(self) -> pd.DataFrame:
        """The per-output table of the surrogate's moments, errors and Sobol' indices.

        Returns
        -------
        pandas.DataFrame
            One row per output: ``mean``, ``std`` (the output's unit), ``loo_error``,
            ``validation_error``, and ``S1_<input>``, ``ST_<input>`` (dimensionless).

        Examples
        --------
        The surrogate of y = 2 x + 1, x ~ N(0, 0.1²), has mean 1 and std 0.2:

        >>> from mechrel.uq import Normal, UncertainInputs, linear_model
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
        >>> r = polynomial_chaos(model=linear_model([1.0], [[2.0]], ["x"]), inputs=inputs,
        ...                      order=1, seed=1, progress=False)
        >>> r.to_frame()[["mean", "std"]].round(12).iloc[0].tolist()
        [1.0, 0.2]
        """
        df = pd.DataFrame({"mean": self.mean, "std": self.std})
        df["loo_error"] = self.loo_error if self.loo_error is not None else np.nan
        df["validation_error"] = self.validation_error if self.validation_error is not None else np.nan
        if self.sobol_first is not None and self.sobol_total is not None:
            for c in self.sobol_first.columns:
                df[f"S1_{c}"] = self.sobol_first[c]
            for c in self.sobol_total.columns:
                df[f"ST_{c}"] = self.sobol_total[c]
        return df

    def predict(self, X: Any, *, block: int = 20000) -> np.ndarray:
        """The surrogate's outputs at input points.

        Parameters
        ----------
        X : array_like, shape (n, d)
            The input points, in the inputs' units.
        block : int, default 20000
            Rows evaluated at once (bounds the memory of the basis matrix).

        Returns
        -------
        ndarray, shape (n, n_out)
            The surrogate's outputs.

        Raises
        ------
        StudyError
            If ``X`` does not have one column per input.

        Examples
        --------
        >>> from mechrel.uq import Normal, UncertainInputs, linear_model
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
        >>> r = polynomial_chaos(model=linear_model([1.0], [[2.0]], ["x"]), inputs=inputs,
        ...                      order=1, seed=1, progress=False)
        >>> np.round(r.predict([[0.25], [-1.0]]), 12).tolist()
        [[1.5], [-1.0]]
        """
        X = np.atleast_2d(np.asarray(X, dtype=float))
        if X.shape[1] != self.inputs.d:
            raise StudyError(f"predict: X must have {self.inputs.d} columns {list(self.inputs.names)}, got {X.shape}")
        Z = _to_germ(self.inputs, X)
        out = np.empty((X.shape[0], self.coefficients.shape[1]))
        for s in range(0, X.shape[0], block):
            Psi = _basis(Z[s : s + block], self.multi_indices, self._recurrence, self.order)
            out[s : s + block] = Psi @ self.coefficients
        return out

    def surrogate_evaluations(self, *, n: int, rule: str = "random", seed: Any = None) -> Evaluations:
        """Evaluate the surrogate at ``n`` samples of the inputs.

        Parameters
        ----------
        n : int
            The number of samples (>= 2).
        rule : {"random", "latin_hypercube", "sobol"}, default "random"
            The sampling rule.
        seed : int, SeedSequence or None, optional
            The seed.

        Returns
        -------
        Evaluations
            The samples and the surrogate's outputs (a non-finite row is a failure).

        Raises
        ------
        StudyError
            If ``n`` is not a sample count >= 2 or ``rule`` is unknown.

        Examples
        --------
        >>> from mechrel.uq import Normal, UncertainInputs, linear_model
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
        >>> r = polynomial_chaos(model=linear_model([1.0], [[2.0]], ["x"]), inputs=inputs,
        ...                      order=1, seed=1, progress=False)
        >>> r.surrogate_evaluations(n=100, seed=2).n_ok
        100
        """
        X = self.inputs.sample(ARGS.sample_count("n", n), rule, child_seed(as_seed_sequence(seed), 0))
        Y = self.predict(X)
        ok = np.all(np.isfinite(Y), axis=1)
        return Evaluations(X, Y, np.where(ok, STATUS_OK, "failed"), tuple(None if o else "non-finite surrogate" for o in ok),
                           self.inputs.names, self.output_index, cache_key=self.evaluations.cache_key,
                           settings={"surrogate": f"PCE order {self.order} ({self.method})"})

    def reliability(self, *, n: int = 100_000, rule: str = "random", seed: Any = None, **monte_carlo_kwargs):
        """Monte Carlo on the surrogate (``n`` cheap samples).

        The intervals of the result cover the sampling error only, not the surrogate's error.

        Parameters
        ----------
        n : int, default 100000
            The number of surrogate samples.
        rule : {"random", "latin_hypercube", "sobol"}, default "random"
            The sampling rule.
        seed : int, SeedSequence or None, optional
            The seed.
        **monte_carlo_kwargs
            Those of :func:`mechrel.uq.monte_carlo` (``allowable``, ``event``, ``allowable_mode``,
            ...).

        Returns
        -------
        MonteCarloResult
            The reliability, its provenance naming the surrogate.

        Raises
        ------
        StudyError
            If an argument is invalid (see :func:`mechrel.uq.monte_carlo`).

        Examples
        --------
        P(|2 x| < 0.4) for x ~ N(0, 0.1²) is 2 Φ(2) − 1 = 0.9545:

        >>> from mechrel.uq import Allowable, Normal, UncertainInputs, linear_model
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
        >>> r = polynomial_chaos(model=linear_model([0.0], [[2.0]], ["x"]), inputs=inputs,
        ...                      order=1, seed=1, progress=False)
        >>> mc = r.reliability(n=20000, seed=3, allowable=Allowable(0.4, 0.0))
        >>> bool(abs(float(mc.reliability.iloc[0]) - 0.9545) < 0.005)   # 3 s.e. ≈ 0.0044
        True
        """
        from ..estimators.monte_carlo import MonteCarloResult, monte_carlo

        ss = as_seed_sequence(seed)
        ev = self.surrogate_evaluations(n=n, rule=rule, seed=ss)
        res = monte_carlo(evaluations=ev, seed=ss, **monte_carlo_kwargs)
        assert isinstance(res, MonteCarloResult)  # evaluations= never takes a limit state
        res.provenance["surrogate"] = {"method": "pce", "order": self.order, "pce_method": self.method,
                                       "pce_provenance": self.provenance, "rule": rule}
        if self.warnings:  # the surrogate's caveats belong to every number computed from it
            import dataclasses

            res = dataclasses.replace(res, warnings=res.warnings + emit_warnings(
                [f"{w} (this Monte Carlo result is computed on that surrogate; its interval "
                 "covers the sampling error only)" for w in self.warnings]))
        return res


@fill_doc
def polynomial_chaos(
    *,
    model: Any = None,
    inputs: UncertainInputs,
    order: int,
    method: str = "regression",
    oversampling: float = 2.0,
    rule: str = "sobol",
    quadrature_rule: str = "gaussian",
    sparse: bool = False,
    q_norm: float = 1.0,
    n_validation: int | None = None,
    seed: Any = None,
    evaluations: Evaluations | None = None,
    validation: Evaluations | None = None,
    max_failure_fraction: float = 0.1,
    max_evaluations: int | None = MAX_EVALUATIONS,
    n_jobs: int = 1,
    backend: str = "loky",
    cache: Any = None,
    progress: bool = True,
    chunk_size: int | None = None,
) -> PCEResult:
    """Fit a PCE of total ``order`` (see the module docstring for the methods and the errors).

    ``model=`` evaluates :func:`pce_design` (and ``n_validation`` random validation samples;
    default 0 for regression — LOO is free — and 32 for quadrature). ``evaluations=`` fits
    precomputed training evaluations (any design for regression; the exact
    :func:`pce_design` nodes for quadrature), optionally with ``validation=`` evaluations.

    Parameters
    ----------
    model : Model, optional
        The model evaluated at the training design (exclusive with ``evaluations``).
    inputs : UncertainInputs
        The uncertain inputs (independent, or correlated normals through the Nataf map).
    order : int
        Total polynomial order, an integer >= 0.
    method : {"regression", "quadrature"}, default "regression"
        Least squares on ``oversampling`` × (number of terms) samples, or Gauss quadrature.
    oversampling : float, default 2.0
        Training samples per polynomial term (regression).
    rule : str, default "sobol"
        Sampling rule of the regression design.
    quadrature_rule : str, default "gaussian"
        chaospy quadrature rule (quadrature).
    sparse : bool, default False
        Smolyak sparse grid (quadrature).
    q_norm : float in (0, 1], default 1.0
        Hyperbolic truncation of the multi-indices (1: total order).
    n_validation : int >= 0, optional
        Random validation samples (default 0 for regression, 32 for quadrature).
    seed : int >= 0, SeedSequence or None
        The study's seed.
    evaluations, validation : Evaluations, optional
        Precomputed training and validation evaluations.
    max_failure_fraction : float in [0, 1], default 0.1
        Refuse above this fraction of failed training samples (regression).
    max_evaluations : int or None, default MAX_EVALUATIONS
        Refuse, before any evaluation, a training design of more model evaluations (saying
        how many, and the largest order within the limit); None: no limit.
    %(executor)s

    Returns
    -------
    PCEResult
        Coefficients, mean, std, leave-one-out and validation errors, Sobol' indices;
        ``.predict(X)``, ``.reliability(...)``, ``.to_frame()``.

    Raises
    ------
    StudyError
        A bad argument (naming it, its value and what is allowed).
    SampleFailuresError
        Too many failed samples, or any failed quadrature node.

    Examples
    --------
    A first-order expansion reproduces a linear model exactly: its std is the input's:

    >>> from mechrel.uq import Normal, UncertainInputs, linear_model, polynomial_chaos
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
    >>> r = polynomial_chaos(model=linear_model([0.0], [[1.0]], ["x"]), inputs=inputs,
    ...                      order=1, seed=1, progress=False)
    >>> round(float(r.to_frame()["std"].iloc[0]), 12)
    0.1
    """
    t0 = time.perf_counter()
    exclusive_source(model, evaluations, what="polynomial_chaos")
    ARGS.choice("method", method, METHODS)
    ARGS.fraction("max_failure_fraction", max_failure_fraction)
    order = ARGS.integer("order", order, ge=0)
    q_norm = ARGS.fraction("q_norm", q_norm, open_lo=True)
    if model is not None:
        names = check_model(model)[0]
    else:
        assert evaluations is not None  # exclusive_source: exactly one
        names = evaluations.input_names
    inputs = check_inputs(inputs, names)
    if model is not None:  # the evaluations it would start, before building anything
        check_cost(inputs.d, order, max_evaluations, method=method, oversampling=oversampling,
                   rule=rule, q_norm=q_norm)
    ss = as_seed_sequence(seed)
    if n_validation is None:
        n_validation = 0 if method == "regression" else 32
    n_validation = ARGS.integer("n_validation", n_validation, ge=0)
    germ = _germ(inputs)
    alphas = multi_indices(inputs.d, order, q_norm) if method == "regression" else multi_indices(inputs.d, order, 1.0)
    P = alphas.shape[0]
    X_design, weights = pce_design(inputs, order=order, method=method, oversampling=oversampling, rule=rule,
                                   quadrature_rule=quadrature_rule, sparse=sparse, q_norm=q_norm, seed=ss)
    exe = executor_kwargs(n_jobs, backend, cache, progress, chunk_size)
    if model is not None:
        if max_evaluations is not None and X_design.shape[0] > max_evaluations:  # Smolyak
            raise StudyError(f"order = {order}: a sparse grid of {X_design.shape[0]} nodes in "
                             f"{inputs.d} inputs, more than max_evaluations = {max_evaluations}"
                             f"; allowed: a lower order, or max_evaluations = "
                             f"{X_design.shape[0]} (or more) to run them knowingly")
        ev = run(model, X_design, exe)
    else:
        assert evaluations is not None  # exclusive_source: exactly one
        ev = evaluations
        if method == "quadrature" and (ev.X.shape != X_design.shape or not np.allclose(ev.X, X_design, rtol=1e-12, atol=0)):
            raise StudyError("polynomial_chaos: quadrature needs evaluations at exactly pce_design(...) nodes")
    rec = _recurrences(inputs, order)
    Z = _to_germ(inputs, ev.X)
    loo = None
    if method == "regression":
        if ev.n_failed > max_failure_fraction * ev.n:
            raise SampleFailuresError(
                f"polynomial_chaos: {failure_message(ev)}, more than max_failure_fraction={max_failure_fraction}", ev)
        ok = ev.ok
        if ok.sum() < P + 1:
            raise SampleFailuresError(
                f"polynomial_chaos: {int(ok.sum())} successful samples for {P} basis terms; need more than {P} "
                "(raise oversampling, lower order or q_norm)", ev
            )
        Psi = _basis(Z[ok], alphas, rec, order)
        Yk = ev.Y[ok]
        coef, h = _least_squares(Psi, Yk)
        resid = Yk - Psi @ coef
        with np.errstate(divide="ignore", invalid="ignore"):
            loo_res = resid / (1.0 - h)[:, None]
            var_y = Yk.var(axis=0, ddof=1)
            loo_vals = np.mean(loo_res**2, axis=0) / var_y
        loo_vals = np.where(h.max() >= 1 - 1e-12, np.inf, loo_vals)
        loo = pd.Series(loo_vals, index=ev.output_index, name="loo_error")
    else:
        if ev.n_failed:
            raise SampleFailuresError(
                f"polynomial_chaos: quadrature needs every node; {failure_message(ev)}. "
                "Use method='regression' (which drops failed samples) or narrow the inputs.", ev
            )
        Psi = _basis(Z, alphas, rec, order)
        assert weights is not None  # pce_design: quadrature has weights
        coef = (Psi * weights[:, None]).T @ ev.Y
    val = None
    val_ev = validation
    if model is not None and n_validation > 0:
        Xv = inputs.sample(int(n_validation), "random", child_seed(ss, 1))
        val_ev = run(model, Xv, exe)
    if val_ev is not None:
        okv = val_ev.ok
        if okv.sum() >= 2:
            Zv = _to_germ(inputs, val_ev.X[okv])
            pred = _basis(Zv, alphas, rec, order) @ coef
            with np.errstate(divide="ignore", invalid="ignore"):
                val = pd.Series(np.mean((val_ev.Y[okv] - pred) ** 2, axis=0) / val_ev.Y[okv].var(axis=0, ddof=1),
                                index=ev.output_index, name="validation_error")
    c2 = coef**2
    var = c2[1:].sum(axis=0)
    mean = pd.Series(coef[0], index=ev.output_index, name="mean")
    std = pd.Series(np.sqrt(var), index=ev.output_index, name="std")
    s1 = st = None
    if inputs.independent:
        active = alphas > 0
        only = active & (active.sum(axis=1, keepdims=True) == 1)
        with np.errstate(divide="ignore", invalid="ignore"):
            S1 = (only.T.astype(float) @ c2) / var  # (d, n_out)
            ST = (active.T.astype(float) @ c2) / var
        cols = pd.Index(list(inputs.names), name="input")
        s1 = pd.DataFrame(S1.T, index=ev.output_index, columns=cols)
        st = pd.DataFrame(ST.T, index=ev.output_index, columns=cols)
    prov = make_provenance(
        method="polynomial_chaos", seed=seed_record(ss), evaluations=[ev, val_ev] if val_ev is not None else [ev],
        inputs=inputs, wall_time=time.perf_counter() - t0,
        settings={"order": order, "method": method, "n_terms": P, "n_train": ev.n, "oversampling": oversampling,
                  "rule": rule if method == "regression" else None,
                  "quadrature_rule": quadrature_rule if method == "quadrature" else None,
                  "sparse": sparse, "q_norm": q_norm, "germ": germ, "n_validation": 0 if val_ev is None else val_ev.n,
                  "failed_samples_dropped": ev.n_failed if method == "regression" else 0},
    )
    notes = emit_warnings(pce_warnings(loo, ev.output_index, order))
    return PCEResult(readonly(coef), readonly(alphas), order, method, germ, inputs, ev.output_index, mean, std,
                     s1, st, loo, val, ev, prov, tuple(rec), notes)


LOO_THRESHOLD = 0.1
"""Largest leave-one-out error (the cross-validated squared error relative to the output's
variance) at which a PCE is taken as trustworthy. Above it more than a tenth of the output's
variance is not reproduced by the expansion out of its own training points; the surrogate's
tail probabilities, on which its reliability depends, are then not reliable, however narrow
the sampling interval of a Monte Carlo run on the surrogate."""


def pce_warnings(loo, index, order: int) -> list[str]:
    """Outputs whose leave-one-out error exceeds :data:`LOO_THRESHOLD`."""
    if loo is None:
        return []
    values = np.asarray(loo, dtype=float)
    bad = np.isfinite(values) & (values > LOO_THRESHOLD)
    if not bad.any():
        return []
    from .._common import _labels

    return [f"pce: the leave-one-out error of the order-{order} expansion exceeds "
            f"{LOO_THRESHOLD:g} at {int(bad.sum())} of {len(values)} outputs (max "
            f"{np.nanmax(values):.3g}, e.g. {_labels(index, bad)}): the surrogate does not "
            "reproduce the model there, so its moments and reliability are not trustworthy; "
            "raise the order or the training samples, or use Monte Carlo"]
