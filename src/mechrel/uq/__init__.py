"""mechrel.uq — uncertainty quantification of output errors.

The package has four parts, one folder each:

``problem/``
    What is uncertain and what is computed: the inputs (:class:`UncertainInputs`, the marginals,
    seeds), the :class:`Model` protocol with :class:`FunctionModel` and :class:`MechanismModel`,
    the analytic test models, and the failure event (:class:`Allowable` with its one- and
    two-sided reliability formulas, :class:`LimitState`).
``execution/``
    How a design is evaluated: :func:`evaluate` (joblib/Dask workers, failure capture) and the
    :class:`EvaluationCache`.
``estimators/``
    One module per method (:func:`fosm`, :func:`monte_carlo`, :func:`sobol_indices`,
    :func:`normality_check`, :func:`form`, :func:`sorm`, :func:`importance_sampling`,
    :func:`subset_simulation`, :func:`active_learning`) and :data:`METHODS`, the registry the study runner and the
    command line loop over.
``surrogates/``
    :func:`polynomial_chaos` and :func:`fit_kriging` (the Kriging model of :func:`active_learning`).
``results``
    The views every per-output result shares (:class:`OutputViews`: ``per_angle()``, the rows
    at the analysis angles, and ``cycle_extremes()``), also as functions of any table indexed
    by a model's outputs (:func:`per_angle`, :func:`cycle_extremes`).
``inverse/``, ``design/``
    The inverse question (:func:`inverse_reliability`: the allowable for a target reliability)
    and design for reliability (:func:`design_for_reliability`: the cheapest design that meets
    it).

Every estimator takes keyword arguments only, accepts either ``model=`` (it evaluates its own
design through :func:`evaluate`) or precomputed ``evaluations=``, and returns a frozen result
with ``.to_frame()``, ``.provenance`` and ``.n_evaluations``. See ``docs/uq.md``.

Every public name is imported from here (``from mechrel.uq import fosm``); the table below and
the registry of methods are the one list of them.
"""

import importlib

from .estimators import METHODS as _METHODS

# Public name -> submodule, the one list of the public API: the names below, and for every
# method of the registry (mechrel.uq.estimators.METHODS) its estimator, its result type and its
# further exports (Method.public_names), so that adding a method is one module plus one
# registration. Imports are lazy (PEP 562) so that a worker process unpickling a model (which
# imports ``mechrel.uq.problem.model``) does not pay for scipy.stats, chaospy and SALib.
_EXPORTS = {
    "problem.model": ["Model", "ModelFailure", "RowFailures", "FunctionModel", "evaluate_rows"],
    "problem.mechanism": ["MechanismModel"],
    "problem.inputs": ["UncertainInputs", "Normal", "TruncNormal", "Uniform", "LogNormal",
                       "Gumbel", "Weibull", "Gamma", "Beta", "ScipyMarginal",
                       "SAMPLING_RULES", "child_seed"],
    "problem.allowables": ["Allowable", "DEFAULT_ALLOWABLES", "EVENTS", "reliability_one_sided",
                           "reliability_two_sided", "bivariate_normal_cdf", "binomial_interval"],
    "problem.limit_state": ["LimitState"],
    "problem.analytic": ["linear_model", "ishigami", "ishigami_model", "ishigami_inputs",
                         "ishigami_indices"],
    "execution.executor": ["evaluate", "Evaluations", "EvaluationCount", "BACKENDS"],
    "execution.cache": ["EvaluationCache"],
    "_common": ["SampleFailuresError"],
    "results": ["OutputViews", "per_angle", "cycle_extremes"],
    "estimators": ["METHODS"],
    "estimators.normality": ["normality_check", "NormalityResult"],
    "surrogates.kriging": ["Kriging", "fit_kriging"],
    "inverse": ["INVERSE_METHODS"],
    "inverse.quantile": ["inverse_reliability", "InverseResult"],
    "design": ["DESIGN_METHODS"],
    "design.core": ["design_for_reliability", "DesignResult"],
    "design.space": ["DesignVariable", "ReliabilityConstraint"],
}
_WHERE = {name: mod for mod, names in _EXPORTS.items() for name in names}
_WHERE.update({name: mod for m in _METHODS.values() for name, mod in m.public_names.items()})
__all__ = list(_WHERE)

# Names of release 0.1 kept for one more release (a FutureWarning names the new one): fosm and
# monte_carlo return one type whatever their arguments, the limit state's part in pf_table.
_DEPRECATED = {"FOSMPfResult": "FOSMResult", "MonteCarloPfResult": "MonteCarloResult"}


def __getattr__(name: str):
    if name in _DEPRECATED:
        import warnings

        new = _DEPRECATED[name]
        warnings.warn(f"mechrel.uq.{name} is {new} (one result type per estimator, the limit "
                      f"state's part in {new}.pf_table); the old name goes in the release "
                      "after 0.1", FutureWarning, stacklevel=2)
        return __getattr__(new)
    mod = _WHERE.get(name)
    if mod is None:
        raise AttributeError(f"module 'mechrel.uq' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{mod}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_WHERE))
