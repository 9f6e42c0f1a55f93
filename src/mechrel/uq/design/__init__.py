"""Design for reliability: the cheapest design (the loosest tolerances, the largest clearance)
whose whole-cycle reliability stays at or above a target.

:func:`~mechrel.uq.design_for_reliability` minimises a cost of the design variables (an
input's mean, an input's std or tolerance half-width, a fixed scene value) within their bounds,
subject to reliability constraints R ≥ R_t over the whole cycle (or per analysis angle, the
literature's constraint, for comparison), verifies the optimum by an independent run and draws
the trade-off curve of cost against reliability. docs/uq.md, "Design for reliability".

Modules: ``space.py`` (the design variables and constraints, the map from a design to the
inputs: common random numbers), ``expression.py`` (the cost's safe expression language),
``constraints.py`` (each constraint's factor k from the model's outputs), ``core.py`` (the
entry point, the optimiser, the result, the trade-off curve, the verification), one module per
method: ``augmented.py`` (``"ak"``: Kriging in the model's input space, learnt at the current
optimum), ``crn.py`` (``"mc"``: the model on one Monte Carlo sample mapped through each
design).

The registry
------------
:data:`DESIGN_METHODS` maps a method's key to a :class:`~mechrel.uq.estimators.Method` (kind
``"design"``). A method is a function called with keyword arguments only::

    method(*, problem, seed, confidence_level, failures, max_failure_fraction, executor,
           **settings) -> DesignEstimate

(:class:`~mechrel.uq.design.core.DesignProblem`, a ``SeedSequence`` of which the method uses
children 0–6, :class:`~mechrel.uq.design.core.DesignEstimate`): it returns its optimum and its
final estimate of the constraints, from which :func:`~mechrel.uq.design_for_reliability` draws
the trade-off curve. A new method is one module plus one :func:`register_design` call; the
study file's ``[design] method`` then offers it, with the settings of its table
``[design.KEY]``.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from ..estimators import Method, Setting, _add

__all__ = ["DESIGN_METHODS", "register_design"]

_DESIGN: dict[str, Method] = {}


def register_design(method: Method) -> Method:
    """Add a method to :data:`DESIGN_METHODS`.

    Parameters
    ----------
    method : mechrel.uq.estimators.Method
        The method (kind ``"design"``); its key (``short``, else ``name``) must be new. Its
        function follows the contract of the module docstring.

    Returns
    -------
    Method
        ``method``.

    Raises
    ------
    StudyError
        If ``method`` is not a :class:`~mechrel.uq.estimators.Method` or its key is taken.

    Examples
    --------
    >>> register_design(DESIGN_METHODS["ak"])
    Traceback (most recent call last):
    ...
    mechrel.errors.StudyError: register_design: method 'ak' is already registered; allowed: a new key
    """
    return _add(_DESIGN, method, who="register_design", by="key")


def _count(minimum: int, what: str):
    def check(name, v):
        from ..._checks import ARGS
        return ARGS.integer(name, v, ge=minimum, what=what)
    return check


def _positive(name, v):
    from ..._checks import ARGS
    return ARGS.number(name, v, gt=0)


def _rule(name, v):
    from ..._checks import ARGS
    from ..problem.inputs import SAMPLING_RULES
    return ARGS.choice(name, v, SAMPLING_RULES)


def _trend(name, v):
    from ..._checks import ARGS
    return ARGS.choice(name, v, ("linear", "constant"))


for _m in (
    Method("design_active_learning", "design.augmented:design_active_learning",
           "design.core:DesignEstimate", "design",
           "Kriging of the cycle extremes in the model's input space, learnt where the current "
           "optimum's constraints are decided (common random numbers across designs)",
           {"n_initial": Setting(None, _count(3, "model runs"), "model runs of the initial "
                                 "design (default max(10, 2 (inputs + design variables + 2)))"),
            "batch_size": Setting(2, _count(1, "model runs per iteration"),
                                  "model runs per iteration"),
            "max_evaluations": Setting(200, _count(2, "a model-run budget"),
                                       "model-run budget"),
            "tolerance": Setting(0.1, _positive, "stop when the surrogate's P_f bounds at the "
                                                  "optimum are within this fraction of 1 − R_t"),
            "tol_design": Setting(1e-3, _positive, "and the optimum moved less than this "
                                                    "(relative) in an iteration"),
            "n_population": Setting(100_000, _count(1000, "samples"), "population (at least "
                                                                     "200/(1 − R_t))"),
            "max_population": Setting(1_000_000, _count(1000, "samples"), "largest population"),
            "trend": Setting("linear", _trend, "the Kriging trend"),
            "initial": Setting(None, None, "an earlier DesignResult of the same model, whose "
                                           "runs start the surrogate")},
           short="ak"),
    Method("design_monte_carlo", "design.crn:design_monte_carlo", "design.core:DesignEstimate",
           "design",
           "the model on one Monte Carlo sample mapped through every design (common random "
           "numbers), the constraint from its order statistics",
           {"n": Setting(10_000, _count(2, "a sample count"), "samples per design"),
            "rule": Setting("random", _rule, "sampling rule"),
            "max_designs": Setting(None, _count(1, "a design count"),
                                   "designs the optimiser may try")},
           short="mc"),
):
    register_design(_m)

#: key → :class:`~mechrel.uq.estimators.Method` of the design methods, read-only.
DESIGN_METHODS: Mapping[str, Method] = MappingProxyType(_DESIGN)
