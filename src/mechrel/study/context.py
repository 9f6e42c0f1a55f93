"""The state a ``mechrel reliability`` run shares between its methods' presenters.

One :class:`Context` per run: the study, its model, inputs and allowables, the run's seed and
settings, and what the methods have produced so far (results, evaluations, notes, values the
presenters share such as the whole-cycle estimates and the FORM design point). The presenters
(:mod:`mechrel.study.presenters`) and the rare-event helpers (:mod:`mechrel.study.rare`)
read and fill it; it imports neither.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ..errors import StudyError
from ..uq._common import SampleFailuresError

__all__ = ["Context"]


@dataclass
class Context:
    """What one run of :func:`~mechrel.study.runner.run_reliability` shares between presenters.

    Parameters
    ----------
    study : Study
        The study.
    model : Model
        Its model.
    inputs : UncertainInputs
        Its uncertain inputs.
    allowables : dict
        ``{quantity: Allowable}`` (m, m/s, m/s²).
    event : {"one-sided", "two-sided"}
        The study's event.
    seed : int or SeedSequence
        The run's seed.
    n : int
        Monte Carlo's sample count.
    max_failure_fraction : float
        The largest fraction of failed samples the sampling methods accept.
    common : dict
        The estimators' common arguments (``n_jobs``, ``backend``, ``cache``, ``progress``).
    max_failure_fraction_given : bool, default False
        The caller set ``max_failure_fraction`` (it then overrides the methods' own tables).
    results : dict, optional
        The results so far, by name.
    evaluations : dict, optional
        The evaluations so far, by name.
    notes : list, optional
        Warning lines for the summary.
    presenters : list, optional
        The presenters of the run.
    shared : dict, optional
        Objects built once per run (the whole-cycle limit state).
    target : float, optional
        The target reliability of the inverse question (None: not asked).

    Examples
    --------
    >>> from mechrel.study.rare import _demo
    >>> from mechrel.uq.estimators import METHODS
    >>> study, model = _demo()   # analytic: a velocity extreme 6 + x1 + x2 (m/s)
    >>> ctx = Context(study, model, study.uncertain_inputs(), study.allowables(), "two-sided",
    ...               seed=7, n=64, max_failure_fraction=0.1, common={"progress": False})
    >>> ctx.event, ctx.results
    ('two-sided', {})
    """

    study: Any
    model: Any
    inputs: Any
    allowables: dict
    event: str
    seed: Any
    n: int
    max_failure_fraction: float
    common: dict
    max_failure_fraction_given: bool = False
    results: dict = field(default_factory=dict)
    evaluations: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)
    presenters: list = field(default_factory=list)
    shared: dict = field(default_factory=dict)
    target: float | None = None

    def estimate(self, name, estimator, *, result_name=None, **kwargs):
        """Run an estimator and record its evaluations and result.

        The evaluations are recorded as ``evaluations[name]`` (also when the estimator refuses with
        :class:`~mechrel.uq.SampleFailuresError`), the result as ``results[result_name or name]``.

        Parameters
        ----------
        name : str
            The name of the evaluations.
        estimator : callable
            The estimator (or a result's method, such as ``PCEResult.reliability``).
        result_name : str, optional
            The name of the result (default ``name``).
        **kwargs
            The estimator's arguments.

        Returns
        -------
        Result
            The estimator's result.

        Raises
        ------
        SampleFailuresError
            When the estimator refuses because of failed samples (re-raised).

        Examples
        --------
        >>> from mechrel.study.rare import _demo
        >>> from mechrel.uq.estimators import METHODS
        >>> study, model = _demo()   # analytic: a velocity extreme 6 + x1 + x2 (m/s)
        >>> ctx = Context(study, model, study.uncertain_inputs(), study.allowables(), "two-sided",
        ...               seed=7, n=64, max_failure_fraction=0.1, common={"progress": False})
        >>> r = ctx.estimate("fosm", METHODS["fosm"].function, model=model, inputs=ctx.inputs,
        ...                  allowable=ctx.allowables, event=ctx.event, progress=False)
        >>> ctx.evaluations["fosm"].n, ctx.results["fosm"] is r
        (5, True)
        """
        try:
            result = estimator(**kwargs)
        except SampleFailuresError as exc:
            self.evaluations[name] = exc.evaluations
            raise
        if getattr(result, "evaluations", None) is not None:
            self.evaluations[name] = result.evaluations
        self.results[result_name or name] = result
        return result

    def settings(self, method) -> dict:
        """The settings of a method in this run.

        The study file's table of the method's key over the registry's defaults;
        ``max_failure_fraction``, when the method has that setting, the caller's
        (``--max-failure-fraction``) over the table's over the study's
        ``reliability.max_failure_fraction``.

        Parameters
        ----------
        method : mechrel.uq.estimators.Method
            A registry entry.

        Returns
        -------
        dict
            Every setting of the method with its value.

        Raises
        ------
        StudyError
            If the study's table of the method holds an invalid setting (naming the study file).

        Examples
        --------
        >>> from mechrel.study.rare import _demo
        >>> from mechrel.uq.estimators import METHODS
        >>> study, model = _demo()   # analytic: a velocity extreme 6 + x1 + x2 (m/s)
        >>> ctx = Context(study, model, study.uncertain_inputs(), study.allowables(), "two-sided",
        ...               seed=7, n=64, max_failure_fraction=0.1, common={"progress": False})
        >>> s = ctx.settings(METHODS["subset_simulation"])
        >>> s["max_failure_fraction"], s["n_per_level"]
        (0.1, 1000)
        """
        given = dict(self.study.method_settings.get(method.key, {}))
        if "max_failure_fraction" in method.settings:
            if self.max_failure_fraction_given:
                given["max_failure_fraction"] = self.max_failure_fraction
            else:
                given.setdefault("max_failure_fraction", self.max_failure_fraction)
        try:
            return method.validate(given)
        except StudyError as exc:
            raise StudyError(f"{self.study.source}: [{method.key}] {exc}") from None

    def angles(self, table):
        """The rows of a per-output table at the analysis angles, without the cycle extremes.

        Parameters
        ----------
        table : pandas.DataFrame
            Indexed by ``(quantity, crank_angle)``.

        Returns
        -------
        pandas.DataFrame
            The rows at the analysis angles, the crank angles as floats (degrees).

        Examples
        --------
        >>> from mechrel.study.presenters import FOSM
        >>> from mechrel.study.rare import _demo
        >>> from mechrel.uq.estimators import METHODS
        >>> study, model = _demo()   # analytic: a velocity extreme 6 + x1 + x2 (m/s)
        >>> ctx = Context(study, model, study.uncertain_inputs(), study.allowables(), "two-sided",
        ...               seed=7, n=64, max_failure_fraction=0.1, common={"progress": False})
        >>> p = FOSM()
        >>> p.run(ctx, METHODS["fosm"])
        >>> ctx.angles(ctx.results["fosm"].table).index.tolist()
        [('velocity', 0.0)]
        """
        from ..uq.results import per_angle

        return per_angle(table)
