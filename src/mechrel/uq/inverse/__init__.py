"""The inverse question: the allowable error a mechanism can promise at a target reliability.

The forward methods (:mod:`mechrel.uq.estimators`) take an allowable and give the probability
that the error stays within it over the cycle. :func:`~mechrel.uq.inverse_reliability` turns
that round: for a target reliability R_t it gives, per quantity and for the whole cycle, the
deterministic allowable a with P(the error stays within a over the whole cycle) = R_t, with its
confidence interval. That allowable is the R_t-quantile of the cycle's extreme (max |error| for
the two-sided event, max error for the one-sided one).

Modules: ``extremes.py`` (the scalars whose quantiles are asked for: each quantity's cycle
extreme, and the whole cycle's common factor), ``quantile.py`` (the entry point, its result,
the checks and warnings every method shares), one module per method: ``order_statistics.py``
(Monte Carlo), ``subset_levels.py`` (subset simulation), ``pma.py`` (inverse FORM).

The registry
------------
:data:`INVERSE_METHODS` maps a method's key to a :class:`~mechrel.uq.estimators.Method` (kind
``"inverse"``): the function, its settings with defaults and checks, a summary. A method is a
function called with keyword arguments only::

    method(*, model, inputs, extremes, scalars, target, seed, confidence_level, failures,
           max_failure_fraction, executor, **settings) -> InverseEstimate

It estimates the ``target``-quantile of each scalar named in ``scalars`` (of
``extremes.values(Y)``) with its interval and returns an
:class:`~mechrel.uq.inverse.quantile.InverseEstimate`; :func:`~mechrel.uq.inverse_reliability`
builds the table, the warnings and the provenance around it. A new method (the active-learning
surrogate of the rare-event work, for one) is one module plus one :func:`register_inverse`
call; ``mechrel reliability --target-reliability`` and the study file's ``inverse.methods``
then offer it, with the settings of the study table of its key.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from ..estimators import METHODS, Method, Setting, _add

__all__ = ["INVERSE_METHODS", "register_inverse", "choose_method", "MC_RESOLUTION"]

#: Monte Carlo resolves the target's quantile when at least this many samples are expected
#: beyond it, n (1 − R_t) >= 10: the quantile is then read between order statistics that a
#: handful of samples do not decide. Below it, ``method="auto"`` takes subset simulation.
MC_RESOLUTION = 10.0

_INVERSE: dict[str, Method] = {}


def register_inverse(method: Method) -> Method:
    """Add a method to :data:`INVERSE_METHODS`.

    Parameters
    ----------
    method : mechrel.uq.estimators.Method
        The method (kind ``"inverse"``); its key (``short``, else ``name``) must be new. Its
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
    >>> register_inverse(INVERSE_METHODS["mc"])
    Traceback (most recent call last):
    ...
    mechrel.errors.StudyError: register_inverse: method 'mc' is already registered; allowed: a new key
    """
    return _add(_INVERSE, method, who="register_inverse", by="key", reserved=("auto",))


def _sample_count(name, v):
    from ..._checks import ARGS
    return ARGS.sample_count(name, v)


def _rule(name, v):
    from ..._checks import ARGS
    from ..problem.inputs import SAMPLING_RULES
    return ARGS.choice(name, v, SAMPLING_RULES)


# The forward methods' settings (with their checks) are those of the inverse subset and FORM
# too: a study's [subset] and [form] tables set both.
_SHARED = ("failures", "max_failure_fraction", "confidence_level", "start",
           # the forward FORM's system search: the inverse FORM searches each quantity twice
           "search", "max_design_points", "contribution")
for _m in (
    Method("inverse_monte_carlo", "inverse.order_statistics:inverse_monte_carlo",
           "inverse.quantile:InverseEstimate", "inverse",
           "Monte Carlo order statistics: the quantile with its distribution-free binomial "
           "interval",
           {"n": Setting(1000, _sample_count, "samples"),
            "rule": Setting("random", _rule, "sampling rule"),
            "evaluations": Setting(None, None, "precomputed evaluations of the same design")},
           short="mc"),
    Method("inverse_subset", "inverse.subset_levels:inverse_subset",
           "inverse.quantile:InverseEstimate", "inverse",
           "subset simulation's level thresholds: the quantile at p0^k and below",
           {k: v for k, v in METHODS["subset_simulation"].settings.items() if k not in _SHARED},
           short="subset"),
    Method("inverse_form", "inverse.pma:inverse_form", "inverse.quantile:InverseEstimate",
           "inverse",
           "inverse FORM (PMA): the largest extreme on the sphere of radius Φ⁻¹(R_t)",
           {k: v for k, v in METHODS["form"].settings.items() if k not in _SHARED},
           short="form"),
):
    register_inverse(_m)

#: key → :class:`~mechrel.uq.estimators.Method` of the inverse methods, read-only.
INVERSE_METHODS: Mapping[str, Method] = MappingProxyType(_INVERSE)


def choose_method(target: float, n: int) -> str:
    """The method ``method="auto"`` takes for a target reliability.

    Monte Carlo (``"mc"``) when its ``n`` samples resolve the target, n (1 − R_t) >=
    :data:`MC_RESOLUTION`; subset simulation (``"subset"``) otherwise, whose cost grows with
    log(1/(1 − R_t)) instead of 1/(1 − R_t). Inverse FORM is never chosen by itself: it is an
    approximation without an interval (docs/uq.md, "The inverse question").

    Parameters
    ----------
    target : float
        The target reliability, in (0, 1).
    n : int
        Monte Carlo's sample count.

    Returns
    -------
    str
        ``"mc"`` or ``"subset"``.

    Examples
    --------
    >>> choose_method(0.99, 1000), choose_method(0.999, 1000)
    ('mc', 'subset')
    """
    return "mc" if n * (1.0 - target) >= MC_RESOLUTION - 1e-9 else "subset"
