"""The estimators of ``mechrel.uq``, one module each, and the one table of them (:data:`METHODS`).

Methods: :func:`~mechrel.uq.fosm` (``fosm.py``), :func:`~mechrel.uq.monte_carlo`
(``monte_carlo.py``), :func:`~mechrel.uq.sobol_indices` (``sobol.py``),
:func:`~mechrel.uq.normality_check` (``normality.py``), :func:`~mechrel.uq.form` (``form.py``),
:func:`~mechrel.uq.sorm` (``sorm.py``), :func:`~mechrel.uq.importance_sampling`
(``importance.py``), :func:`~mechrel.uq.subset_simulation` (``subset.py``),
:func:`~mechrel.uq.active_learning` (``ak.py``); the polynomial
chaos is in ``mechrel.uq.surrogates``, the limit states in ``mechrel.uq.problem``. They share
one keyword-only interface::

    method(model=, inputs=, allowable=, event= | limit_state=, seed=, <settings>,
           n_jobs=, backend=, cache=, progress=, chunk_size=)

and return frozen results with ``.to_frame()``, ``.provenance``, ``.warnings`` and
``.n_evaluations`` (:class:`~mechrel.uq.estimators.protocols.Result`). The public names are
imported from :mod:`mechrel.uq`.

The registry
------------
:data:`METHODS` maps a method's name to a :class:`Method`: the estimator and its result type
(imported lazily, as ``"module:attribute"`` under ``mechrel.uq``, or the objects themselves),
its settings with defaults and checks, and its kind. The older estimators (``fosm``,
``monte_carlo``, ``polynomial_chaos``, ``sobol_indices``) are listed by reference, their
settings read from their signatures (their own argument checks apply). Adding a method is one
module plus one :func:`register` call (or one entry below); the study runner and the command
line then offer it (:mod:`mechrel.study.presenters`); ``docs/uq.md`` ("How to add a method")
shows it.
"""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

from mechrel.errors import StudyError

__all__ = ["METHODS", "Method", "Setting", "register", "get_method", "COMMON_ARGUMENTS"]

#: Arguments every estimator takes that are not method settings (the shared interface): the
#: failure definition is ``limit_state=`` or ``allowable=`` with ``event=``.
COMMON_ARGUMENTS = ("model", "inputs", "limit_state", "allowable", "event", "evaluations", "seed",
                    "n_jobs", "backend", "cache", "progress", "chunk_size")


@dataclass(frozen=True)
class Setting:
    """One method setting: its default and an optional check.

    Parameters
    ----------
    default : object
        The value used when a study or call does not set it.
    check : callable, optional
        ``check(name, value) -> value``, raising :class:`~mechrel.errors.StudyError` naming the
        setting, the value and what is allowed (None: the estimator checks it itself).
    doc : str, default ""
        A one-line description (shown by the command line).
    samples : bool, default False
        The setting is a number of model runs the method holds in memory at once (a sample
        count): the study runner checks it against the machine's memory before any method
        runs.

    Examples
    --------
    >>> s = METHODS["form"].settings["max_iter"]
    >>> s.default, s.check("form.max_iter", 10)
    (100, 10)
    """

    default: Any
    check: Callable[[str, Any], Any] | None = None
    doc: str = ""
    samples: bool = False


@dataclass(frozen=True)
class Method:
    """One row of the registry of methods.

    Parameters
    ----------
    name : str
        The estimator's name (the key of :data:`METHODS`).
    estimator : str or callable
        ``"module:attribute"`` under ``mechrel.uq`` (imported when first used), or the function
        itself (a method defined outside mechrel).
    result : str or type
        The result class, given the same way.
    kind : str
        ``"reliability"``, ``"sensitivity"``, ``"surrogate"`` or ``"rare_event"``.
    summary : str
        A one-line description.
    declared_settings : mapping of str to Setting, optional
        The settings with defaults and checks; None: read from the estimator's signature (every
        keyword not in :data:`COMMON_ARGUMENTS`, checked by the estimator).
    short : str, optional
        The method's name in study files and on the command line (``mechrel reliability
        --method``), default ``name``; a study file sets, in the table of that name, the
        settings that have a check.
    exports : tuple of str, default ()
        Further public names of the estimator's module (its design function, extra result
        types): :mod:`mechrel.uq` exports them with the estimator and its result type.

    Examples
    --------
    >>> m = METHODS["importance_sampling"]
    >>> m.key, m.kind, m.function.__name__
    ('is', 'rare_event', 'importance_sampling')
    """

    name: str
    estimator: str | Callable
    result: str | type
    kind: str
    summary: str
    declared_settings: Mapping[str, Setting] | None = field(default=None)
    short: str | None = None
    exports: tuple[str, ...] = ()

    @property
    def public_names(self) -> dict[str, str]:
        """The names :mod:`mechrel.uq` exports for the method, with their modules.

        Returns
        -------
        dict of str to str
            ``{name: module under mechrel.uq}``: the estimator, its result type and
            :attr:`exports`; empty for a method given as objects (defined outside mechrel).

        Examples
        --------
        >>> names = METHODS["form"].public_names
        >>> list(names), set(names.values())
        (['form', 'FORMResult', 'FORMConvergenceError'], {'estimators.form'})
        """
        out: dict[str, str] = {}
        if not isinstance(self.estimator, str):
            return out
        module = self.estimator.split(":")[0]
        for path in (self.estimator, self.result, *(f"{module}:{x}" for x in self.exports)):
            if isinstance(path, str):
                mod, attr = path.split(":")
                out[attr] = mod
        return out

    @property
    def key(self) -> str:
        """The method's name in study files and on the command line.

        Returns
        -------
        str
            ``short``, or ``name`` without one.

        Examples
        --------
        >>> METHODS["monte_carlo"].key, METHODS["form"].key
        ('mc', 'form')
        """
        return self.short or self.name

    def _load(self, path):
        if not isinstance(path, str):  # the function or class itself
            return path
        mod, attr = path.split(":")
        return getattr(importlib.import_module(f"mechrel.uq.{mod}"), attr)

    @property
    def function(self) -> Callable:
        """The estimator function (imported on first use).

        Returns
        -------
        callable
            The estimator.

        Examples
        --------
        >>> METHODS["form"].function.__name__
        'form'
        """
        return self._load(self.estimator)

    @property
    def result_type(self) -> type:
        """The result class of the estimator (imported on first use).

        Returns
        -------
        type
            The result class.

        Examples
        --------
        >>> METHODS["form"].result_type.__name__
        'FORMResult'
        """
        return self._load(self.result)

    @property
    def settings(self) -> Mapping[str, Setting]:
        """The method's settings, read-only.

        Returns
        -------
        mapping of str to Setting
            The declared settings, or those read from the estimator's signature.

        Examples
        --------
        >>> sorted(METHODS["form"].settings)
        ['contribution', 'max_design_points', 'max_iter', 'scheme', 'search', 'start', 'step', 'tol', 'tol_direction']
        """
        if self.declared_settings is not None:
            return MappingProxyType(dict(self.declared_settings))
        sig = inspect.signature(self.function)
        return MappingProxyType({
            k: Setting(p.default if p.default is not inspect.Parameter.empty else None)
            for k, p in sig.parameters.items() if k not in COMMON_ARGUMENTS
        })

    def validate(self, settings: Mapping[str, Any] | None = None) -> dict:
        """The full settings: the defaults overridden by ``settings``, each given value checked.

        Parameters
        ----------
        settings : mapping, optional
            The settings given.

        Returns
        -------
        dict
            Every setting of the method with its value.

        Raises
        ------
        StudyError
            If a key is unknown (the message lists the allowed ones), or a check fails.

        Examples
        --------
        >>> METHODS["form"].validate({"max_iter": 5})["max_iter"]
        5
        >>> METHODS["form"].validate({"iterations": 5})
        Traceback (most recent call last):
        ...
        mechrel.errors.StudyError: form: settings ['iterations']: unknown; allowed: ['contribution', 'max_design_points', 'max_iter', 'scheme', 'search', 'start', 'step', 'tol', 'tol_direction']
        """
        given = dict(settings or {})
        known = self.settings
        unknown = sorted(set(given) - set(known))
        if unknown:
            raise StudyError(f"{self.name}: settings {unknown}: unknown; allowed: {sorted(known)}")
        out = {}
        for k, s in known.items():
            v = given.get(k, s.default)
            out[k] = s.check(f"{self.name}.{k}", v) if (s.check is not None and k in given) else v
        return out

    def __call__(self, **kwargs: Any):
        """Run the estimator: common arguments pass through, settings are validated first."""
        common = {k: v for k, v in kwargs.items() if k in COMMON_ARGUMENTS}
        settings = self.validate({k: v for k, v in kwargs.items() if k not in COMMON_ARGUMENTS})
        return self.function(**common, **settings)


def _pos_int(minimum: int) -> Callable[[str, Any], int]:
    def check(name: str, v: Any) -> int:
        from .form import check_positive
        return check_positive(name, v, integer=True, minimum=minimum - 1)
    return check


def _pos_float(name: str, v: Any) -> float:
    from .form import check_positive
    return check_positive(name, v)


def _choice(allowed: tuple) -> Callable[[str, Any], Any]:
    def check(name: str, v: Any) -> Any:
        if v not in allowed:
            raise StudyError(f"{name}: got {v!r}; allowed: {list(allowed)}")
        return v
    return check


def _fraction(name: str, v: Any) -> float:
    from ..._checks import ARGS
    return ARGS.fraction(name, v, open_lo=True, open_hi=True)


def _closed_fraction(name: str, v: Any) -> float:
    from ..._checks import ARGS
    return ARGS.fraction(name, v)


def _correlation(name: str, v: Any) -> float:
    from ..._checks import ARGS
    return ARGS.fraction(name, v, open_hi=True)


_FORM_SETTINGS = {
    "step": Setting(1e-4, _pos_float, "finite-difference step in standard normal units"),
    "scheme": Setting("central", _choice(("central", "forward")), "finite-difference scheme"),
    "tol": Setting(1e-6, _pos_float, "tolerance of the surface criterion |g|/|g0|"),
    "max_iter": Setting(100, _pos_int(1), "iteration limit"),
    "search": Setting("system", _choice(("system", "single")),
                      "design points of every failure mode that matters, or one search"),
    "max_design_points": Setting(8, _pos_int(1), "the most design points searched"),
    "contribution": Setting(0.01, _fraction, "search a mode whose linearised P_f is this fraction of the largest"),
}
_FAILURES = {
    "failures": Setting("exclude", _choice(("exclude", "as_failure")), "what a failed model sample counts as"),
    "max_failure_fraction": Setting(0.1, _closed_fraction, "refuse above this fraction of failed samples"),
    "confidence_level": Setting(0.95, _fraction, "level of the interval on P_f"),
}

_METHODS: dict[str, Method] = {}


def register(method: Method) -> Method:
    """Add a method to :data:`METHODS`.

    Parameters
    ----------
    method : Method
        The method; its name must be new.

    Returns
    -------
    Method
        ``method``.

    Raises
    ------
    StudyError
        If ``method`` is not a :class:`Method` or its name is already registered.

    Examples
    --------
    >>> register(METHODS["fosm"])
    Traceback (most recent call last):
    ...
    mechrel.errors.StudyError: register: method 'fosm' is already registered; allowed: a new name
    """
    return _add(_METHODS, method, who="register", by="name")


def _add(table: dict, method: Method, *, who: str, by: str, reserved: tuple = ()) -> Method:
    """``table[method.<by>] = method``: the one check and message of every method registry
    (:func:`register`, and the inverse and design registries), ``who`` naming the registering
    function; a key in ``reserved`` counts as taken."""
    if not isinstance(method, Method):
        raise StudyError(f"{who}: got {type(method).__name__}; allowed: a Method")
    key = getattr(method, by)
    if key in table or key in reserved:
        raise StudyError(f"{who}: method {key!r} is already registered; allowed: a new {by}")
    table[key] = method
    return method


for _m in (
    Method("fosm", "estimators.fosm:fosm", "estimators.fosm:FOSMResult", "reliability",
           "first-order second-moment interference formula (the paper's eqs. 25-28)",
           exports=("fosm_design", "fd_steps")),
    Method("monte_carlo", "estimators.monte_carlo:monte_carlo", "estimators.monte_carlo:MonteCarloResult", "reliability",
           "crude Monte Carlo reliability and moments", short="mc",
           exports=("monte_carlo_design",)),
    Method("polynomial_chaos", "surrogates.pce:polynomial_chaos", "surrogates.pce:PCEResult", "surrogate",
           "polynomial chaos expansion (chaospy)", short="pce",
           exports=("pce_design", "multi_indices")),
    Method("sobol_indices", "estimators.sobol:sobol_indices", "estimators.sobol:SobolResult", "sensitivity",
           "Sobol' indices (SALib / Saltelli)", exports=("sobol_design", "peak_abs")),
    Method("form", "estimators.form:form", "estimators.form:FORMResult", "rare_event",
           "FORM: design points by iHLRF, P_f of their series (or parallel) system",
           _FORM_SETTINGS | {"start": Setting(None), "tol_direction": Setting(None, _pos_float)},
           exports=("FORMConvergenceError",)),
    Method("sorm", "estimators.sorm:sorm", "estimators.sorm:SORMResult", "rare_event",
           "SORM: Hohenbichler-Rackwitz / Tvedt / Breitung from the curvatures at the design point",
           _FORM_SETTINGS | {"design_point": Setting(None),
                             "formula": Setting("hohenbichler", _choice(("hohenbichler", "tvedt", "breitung"))),
                             "curvature_step": Setting(1e-2, _pos_float)}),
    Method("importance_sampling", "estimators.importance:importance_sampling",
           "estimators.importance:ImportanceSamplingResult", "rare_event",
           "importance sampling from a defensive mixture centred on FORM's design points",
           _FORM_SETTINGS | _FAILURES | {"n": Setting(1000, _pos_int(2), samples=True), "design_point": Setting(None),
                                         "defensive": Setting(0.1, _closed_fraction,
                                                              "weight of the standard normal in the mixture")},
           short="is"),
    Method("subset_simulation", "estimators.subset:subset_simulation",
           "estimators.subset:SubsetSimulationResult", "rare_event",
           "subset simulation (Au & Beck) with conditional sampling or modified Metropolis",
           _FAILURES | {"n_per_level": Setting(1000, _pos_int(10), samples=True), "p0": Setting(0.1, _fraction),
                        "proposal": Setting("conditional", _choice(("conditional", "modified_metropolis"))),
                        "rho": Setting(0.8, _correlation), "spread": Setting(1.0, _pos_float),
                        "max_levels": Setting(20, _pos_int(1))},
           short="subset"),
    Method("active_learning", "estimators.ak:active_learning", "estimators.ak:AKResult", "rare_event",
           "active learning (AK-MCS / multi-point AK-IS): Kriging surrogates of the components, "
           "refined where they decide the sign of g",
           {"n_initial": Setting(None, _pos_int(2), "model runs of the initial design (default max(10, 2(d + 2)))"),
            "initial": Setting(None, None, "an earlier AKResult whose runs join the initial design (Python only)"),
            "batch_size": Setting(2, _pos_int(1), "points per iteration (one executor call)"),
            "max_evaluations": Setting(300, _pos_int(2), "model-run budget"),
            "tolerance": Setting(0.1, _pos_float, "stop when the interval's half-width <= tolerance * P_f"),
            "learning": Setting("U", _choice(("U", "EFF")), "learning function"),
            "population": Setting("auto", _choice(("auto", "monte_carlo", "importance")),
                                  "Monte Carlo or importance-sampling population"),
            "n_population": Setting(10_000, _pos_int(100), "initial population size"),
            "max_population": Setting(1_000_000, _pos_int(100), "largest population"),
            "trend": Setting("linear", _choice(("linear", "constant")), "Kriging trend"),
            "max_failure_fraction": _FAILURES["max_failure_fraction"],
            "confidence_level": _FAILURES["confidence_level"]},
           short="ak"),
):
    register(_m)

#: name → :class:`Method`, read-only.
METHODS: Mapping[str, Method] = MappingProxyType(_METHODS)


def get_method(name: str) -> Method:
    """The registered method ``name``.

    Parameters
    ----------
    name : str
        The method's name (a key of :data:`METHODS`).

    Returns
    -------
    Method
        Its registry row.

    Raises
    ------
    StudyError
        If the name is unknown (the message lists the known ones).

    Examples
    --------
    >>> get_method("sorm").kind
    'rare_event'
    """
    try:
        return METHODS[name]
    except (KeyError, TypeError):
        raise StudyError(f"method: got {name!r}; allowed: {sorted(METHODS)}") from None
