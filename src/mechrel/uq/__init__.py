"""mechrel.uq — uncertainty quantification of output errors.

Problem (:class:`UncertainInputs`, a :class:`Model`) → sample/design (``*_design`` functions,
:meth:`UncertainInputs.sample`) → evaluate (:func:`evaluate`: joblib/Dask, cache, failures) →
analyse (:func:`fosm`, :func:`monte_carlo`, :func:`polynomial_chaos`, :func:`sobol_indices`,
:func:`normality_check`). Every estimator takes keyword arguments only, accepts either
``model=`` (it evaluates its own design through :func:`evaluate`) or precomputed
``evaluations=``, and returns a frozen result with ``.to_frame()`` and ``.provenance``.
See ``docs/uq.md``.
"""

import importlib
from typing import TYPE_CHECKING

# Public name -> submodule. Imports are lazy (PEP 562) so that a worker process unpickling a
# model (which imports ``mechrel.uq.model``) does not pay for scipy.stats, chaospy and SALib.
_EXPORTS = {
    "_common": ["SampleFailuresError"],
    "analytic": ["ishigami", "ishigami_indices", "ishigami_inputs", "ishigami_model", "linear_model"],
    "cache": ["EvaluationCache"],
    "executor": ["BACKENDS", "Evaluations", "evaluate"],
    "estimators": ["METHODS", "LimitState", "form", "FORMResult", "FORMConvergenceError", "sorm", "SORMResult",
                   "importance_sampling", "ImportanceSamplingResult", "subset_simulation", "SubsetSimulationResult"],
    "first_order": ["FOSMResult", "fd_steps", "fosm", "fosm_design"],
    "inputs": ["SAMPLING_RULES", "LogNormal", "Normal", "TruncNormal", "UncertainInputs", "Uniform", "child_seed"],
    "model": ["FunctionModel", "Model", "ModelFailure"],
    "mechanism": ["MechanismModel"],
    "montecarlo": ["MonteCarloResult", "monte_carlo", "monte_carlo_design"],
    "normality": ["NormalityResult", "normality_check"],
    "pce": ["PCEResult", "multi_indices", "pce_design", "polynomial_chaos"],
    "reliability": ["DEFAULT_ALLOWABLES", "FORMS", "Allowable", "binomial_interval", "bivariate_normal_cdf",
                    "reliability_one_sided", "reliability_two_sided"],
    "sobol": ["SobolResult", "peak_abs", "sobol_design", "sobol_indices"],
}
_WHERE = {name: mod for mod, names in _EXPORTS.items() for name in names}


def __getattr__(name: str):
    mod = _WHERE.get(name)
    if mod is None:
        raise AttributeError(f"module 'mechrel.uq' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{mod}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_WHERE))


if TYPE_CHECKING:  # pragma: no cover
    from ._common import SampleFailuresError
    from .analytic import ishigami, ishigami_indices, ishigami_inputs, ishigami_model, linear_model
    from .cache import EvaluationCache
    from .estimators import (METHODS, FORMConvergenceError, FORMResult, ImportanceSamplingResult, LimitState,
                             SORMResult, SubsetSimulationResult, form, importance_sampling, sorm, subset_simulation)
    from .executor import BACKENDS, Evaluations, evaluate
    from .first_order import FOSMResult, fd_steps, fosm, fosm_design
    from .inputs import SAMPLING_RULES, LogNormal, Normal, TruncNormal, UncertainInputs, Uniform, child_seed
    from .mechanism import MechanismModel
    from .model import FunctionModel, Model, ModelFailure
    from .montecarlo import MonteCarloResult, monte_carlo, monte_carlo_design
    from .normality import NormalityResult, normality_check
    from .pce import PCEResult, multi_indices, pce_design, polynomial_chaos
    from .reliability import (DEFAULT_ALLOWABLES, FORMS, Allowable, binomial_interval, bivariate_normal_cdf,
                              reliability_one_sided, reliability_two_sided)
    from .sobol import SobolResult, peak_abs, sobol_design, sobol_indices

__all__ = [
    # problem
    "Model", "ModelFailure", "FunctionModel", "MechanismModel",
    "UncertainInputs", "Normal", "TruncNormal", "Uniform", "LogNormal", "SAMPLING_RULES", "child_seed",
    "Allowable", "DEFAULT_ALLOWABLES", "FORMS", "LimitState",
    # evaluation
    "evaluate", "Evaluations", "EvaluationCache", "BACKENDS", "SampleFailuresError",
    # designs
    "fosm_design", "fd_steps", "monte_carlo_design", "pce_design", "multi_indices", "sobol_design",
    # estimators and results
    "fosm", "FOSMResult", "monte_carlo", "MonteCarloResult", "polynomial_chaos", "PCEResult",
    "sobol_indices", "SobolResult", "peak_abs", "normality_check", "NormalityResult",
    "form", "FORMResult", "FORMConvergenceError", "sorm", "SORMResult", "importance_sampling",
    "ImportanceSamplingResult", "subset_simulation", "SubsetSimulationResult", "METHODS",
    # formulas
    "reliability_one_sided", "reliability_two_sided", "bivariate_normal_cdf", "binomial_interval",
    # analytic models
    "linear_model", "ishigami", "ishigami_model", "ishigami_inputs", "ishigami_indices",
]
