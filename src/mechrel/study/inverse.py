"""The inverse question of a study (``mechrel reliability --target-reliability R``, or
``[inverse] target = R`` in the study file): the allowable per quantity and for the whole cycle
at which the whole-cycle reliability is R (:func:`mechrel.uq.inverse_reliability`).

Methods: those of ``[inverse] methods`` (default ``["auto"]``: Monte Carlo when the study's
``reliability.n`` samples resolve the target, n (1 − R) ≥ 10, else subset simulation), each
with the settings of the study's table of its key (``[subset]``, ``[form]``; Monte Carlo takes
``reliability.n`` and ``reliability.rule``, and reuses the samples of the run's forward Monte
Carlo, the same design). The reference allowables of the whole cycle's common factor are the
study's allowable means; their std is not used (the allowable found is deterministic).
"""

from __future__ import annotations

import math

import pandas as pd

from ..errors import StudyError
from ..outputs import QUANTITY_INFO
from ..uq._common import SampleFailuresError

__all__ = ["methods_of", "estimate_one", "table", "summary_lines", "record"]


def methods_of(study, target: float, n: int) -> list[str]:
    """The inverse methods a study runs, ``"auto"`` resolved, each once, in the study's order.

    Parameters
    ----------
    study : mechrel.study.study.Study
        The study (``inverse.methods``).
    target : float
        The target reliability.
    n : int
        Monte Carlo's sample count in this run.

    Returns
    -------
    list of str
        Keys of :data:`mechrel.uq.inverse.INVERSE_METHODS`.

    Examples
    --------
    >>> from mechrel.study.rare import _demo
    >>> study, _ = _demo()
    >>> methods_of(study, 0.99, 2000), methods_of(study, 0.999, 2000)
    (['mc'], ['subset'])
    """
    from ..uq.inverse import choose_method

    keys = [choose_method(target, n) if k == "auto" else k for k in study.inverse["methods"]]
    return list(dict.fromkeys(keys))


def estimate_one(ctx, key: str):
    """Run the inverse method ``key`` on the study of ``ctx`` (a
    :class:`~mechrel.study.context.Context` whose ``target`` is set).

    The result goes to ``ctx.results["inverse_KEY"]``, its evaluations to
    ``ctx.evaluations["inverse_KEY"]`` (not when it reuses the forward Monte Carlo's); a method
    that cannot answer (FORM not converging, a scalar that stops rising) is a note of the
    summary instead of an error, so that the run's other results are kept.

    Parameters
    ----------
    ctx : mechrel.study.context.Context
        The run.
    key : str
        A key of :data:`mechrel.uq.inverse.INVERSE_METHODS`.

    Returns
    -------
    InverseResult or None
        None when the method could not answer.

    Raises
    ------
    SampleFailuresError
        More failed samples than the run's ``max_failure_fraction`` (its evaluations are
        recorded first).

    Examples
    --------
    >>> from mechrel.study.context import Context
    >>> from mechrel.study.rare import _demo
    >>> study, model = _demo()   # velocity extreme 6 + x1 + x2 (m/s), x standard normal
    >>> ctx = Context(study, model, study.uncertain_inputs(), study.allowables(), "two-sided",
    ...               seed=7, n=1000, max_failure_fraction=0.1, common={"progress": False},
    ...               target=0.99)
    >>> r = estimate_one(ctx, "form")      # 6 + √2 Φ⁻¹(0.99)
    >>> round(float(r.table.loc[("velocity", "velocity"), "allowable"]), 6)
    9.289953
    """
    from ..uq import inverse_reliability
    from ..uq.inverse import INVERSE_METHODS

    method = INVERSE_METHODS[key]
    table = dict(ctx.study.method_settings.get(key, {}))
    settings = {k: v for k, v in table.items() if k in method.settings}
    reused = None
    if key == "mc":
        settings = {"n": ctx.n, "rule": ctx.study.reliability["rule"]}
        mc = ctx.results.get("mc")
        if mc is not None and getattr(mc, "evaluations", None) is not None:
            reused = mc.evaluations  # the forward Monte Carlo's design (same n, rule, seed)
            settings = {"evaluations": reused}
    if ctx.max_failure_fraction_given or "max_failure_fraction" not in table:
        fraction = ctx.max_failure_fraction
    else:
        fraction = table["max_failure_fraction"]
    name = f"inverse_{key}"
    try:
        r = inverse_reliability(model=ctx.model, inputs=ctx.inputs, target=ctx.target,
                                event=ctx.event, allowable=ctx.allowables, method=key,
                                seed=ctx.seed, failures=table.get("failures", "exclude"),
                                confidence_level=table.get("confidence_level", 0.95),
                                max_failure_fraction=fraction, **settings, **ctx.common)
    except SampleFailuresError as exc:
        ctx.evaluations[name] = exc.evaluations
        raise
    except StudyError as exc:
        ctx.notes.append(f"inverse ({key}): no answer: {exc}")
        return None
    if reused is None and r.evaluations is not None:
        ctx.evaluations[name] = r.evaluations
    ctx.results[name] = r
    return r


def table(results) -> pd.DataFrame:
    """``inverse.csv``: the tables of the inverse results, one block per method.

    Parameters
    ----------
    results : dict
        ``{key: InverseResult}``.

    Returns
    -------
    pandas.DataFrame
        Columns ``method``, ``target``, ``group``, ``quantity``, then
        :data:`mechrel.uq.inverse.quantile.TABLE_COLUMNS`.

    Examples
    --------
    >>> from mechrel.study.context import Context
    >>> from mechrel.study.rare import _demo
    >>> study, model = _demo()
    >>> ctx = Context(study, model, study.uncertain_inputs(), study.allowables(), "two-sided",
    ...               seed=7, n=1000, max_failure_fraction=0.1, common={"progress": False},
    ...               target=0.99)
    >>> table({"form": estimate_one(ctx, "form")}).columns[:5].tolist()
    ['method', 'target', 'group', 'quantity', 'allowable']
    """
    frames = []
    for key, r in results.items():
        t = r.to_frame().reset_index()
        t.insert(0, "target", r.target)
        t.insert(0, "method", key)
        frames.append(t)
    return pd.concat(frames, ignore_index=True)


def _interval(lo: float, hi: float) -> str:
    return "" if math.isnan(lo) and math.isnan(hi) else f"[{lo:.4g}, {hi:.4g}]"


def summary_lines(ctx, results) -> list[str]:
    """The summary's lines of the inverse question: per method the allowable of each quantity
    with its interval, and the whole cycle's factor with the allowables it gives.

    Parameters
    ----------
    ctx : mechrel.study.context.Context
        The run (its study's allowables, for the note on their std).
    results : dict
        ``{key: InverseResult}``.

    Returns
    -------
    list of str
        The lines.

    Examples
    --------
    >>> from mechrel.study.context import Context
    >>> from mechrel.study.rare import _demo
    >>> study, model = _demo()
    >>> ctx = Context(study, model, study.uncertain_inputs(), study.allowables(), "two-sided",
    ...               seed=7, n=1000, max_failure_fraction=0.1, common={"progress": False},
    ...               target=0.99)
    >>> print(summary_lines(ctx, {"form": estimate_one(ctx, "form")})[1])
        velocity: 9.29 m/s, the other quantities unconstrained
    """
    lines = []
    for key, r in results.items():
        t = r.table
        level = f"{r.confidence_level:.0%} intervals" if key != "form" else "no intervals"
        cost = (f"the forward Monte Carlo's {r.n_evaluations} samples"
                if r.provenance["settings"].get("rule") == "user-supplied" else
                f"{r.n_evaluations} model evaluations")
        lines.append(f"  allowable for whole-cycle R = {r.target:g} ({key}: {cost}, {level}):")
        for g in dict.fromkeys(t.index.get_level_values("group")):
            rows = t.xs(g, level="group")
            if g != "all" or list(rows.index) == ["all"]:  # a quantity, or a model without
                row = rows.iloc[0]
                value = " ".join(filter(None, (f"{row['allowable']:.4g}", row["unit"],
                                               _interval(row["allowable_lo"],
                                                         row["allowable_hi"]))))
                lines.append(f"    {g}: {value}, the other quantities unconstrained")
                continue
            first = rows.iloc[0]
            each = ", ".join(f"{q} {row['allowable']:.4g} {row['unit']}"
                             for q, row in rows.iterrows())
            factor = " ".join(filter(None, (f"{first['factor']:.4g}",
                                            _interval(first["factor_lo"], first["factor_hi"]))))
            lines.append(f"    whole cycle: {factor} × the study's allowables: {each}")
    randoms = [f"{q} {a.std:g} {QUANTITY_INFO[q].unit if q in QUANTITY_INFO else ''}".strip()
               for q, a in ctx.allowables.items() if a.std > 0]
    if results and randoms:
        lines.append("    (deterministic allowables: the study's allowable std ("
                     + ", ".join(randoms) + ") is not part of the inverse question)")
    return lines


def record(results) -> dict:
    """The inverse results for ``summary.json``: per method its table and diagnostics.

    Parameters
    ----------
    results : dict
        ``{key: InverseResult}``.

    Returns
    -------
    dict
        ``{key: {"target", "method", "table": [rows], "details": {name: [rows]}}}``.

    Examples
    --------
    >>> from mechrel.study.context import Context
    >>> from mechrel.study.rare import _demo
    >>> study, model = _demo()
    >>> ctx = Context(study, model, study.uncertain_inputs(), study.allowables(), "two-sided",
    ...               seed=7, n=1000, max_failure_fraction=0.1, common={"progress": False},
    ...               target=0.99)
    >>> sorted(record({"form": estimate_one(ctx, "form")})["form"])
    ['details', 'table', 'target']
    """
    return {key: {"target": r.target,
                  "table": r.to_frame().reset_index().to_dict(orient="records"),
                  "details": {k: v.reset_index().to_dict(orient="records")
                              for k, v in r.details.items()}}
            for key, r in results.items()}
