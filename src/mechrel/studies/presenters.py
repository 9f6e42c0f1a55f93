"""How ``mechrel reliability`` runs and presents each registered method.

The runner (:func:`mechrel.studies.runner.run_reliability`) names no method: for each method
of the run it takes the :class:`Presenter` of the method's registry entry
(:data:`mechrel.uq.estimators.METHODS`) from :func:`presenter_class` — the method's own entry
in :data:`PRESENTERS`, else the one of its ``kind`` — and asks it, in turn, to run the method,
for its columns of ``reliability.csv``, its summary lines, its part of the verdict and its
files. Methods that share a presenter class (the rare-event methods) share one instance, so
that they share a table (``rare_events.csv``) and a FORM design point.

A new method needs no presenter when the one of its kind fits:

``"rare_event"`` (:class:`RareEvents`)
    Called with ``limit_state=`` (the study's whole-cycle limit state, :mod:`.rare`): one row
    of ``rare_events.csv`` and of the summary.
``"reliability"`` (:class:`PerAngle`)
    Called with ``allowable=`` and ``event=`` (the study's allowables and event): its
    ``.to_frame()`` joins ``reliability.csv`` with the method's key as column prefix.
any other kind (:class:`Generic`)
    Called with whichever of ``limit_state=`` / ``allowable=`` its signature takes; its
    ``.to_frame()`` is written to ``KEY.csv``.

Settings come from the study file's table of the method's key (``[form]``, ``[subset]``, ...)
over the registry's defaults; FOSM, Monte Carlo and PCE keep their settings in
``[reliability]`` (``n``, ``rule``, ``pce_order``).
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass, field
from typing import Any

import pandas as pd

from ..errors import StudyError
from ..uq._common import SampleFailuresError

__all__ = ["Context", "Presenter", "PRESENTERS", "KIND_PRESENTERS", "presenter_class"]


@dataclass
class Context:
    """Everything one run of :func:`~mechrel.studies.runner.run_reliability` shares between
    the presenters: the study, its model, inputs, allowables and event, the run's settings
    (``max_failure_fraction_given``: the caller set it, over the methods' own tables), what
    the methods produced so far (``results`` and ``evaluations`` by name, ``notes``: warning
    lines), the presenters of the run, and ``shared`` objects built once per run (the
    whole-cycle limit state)."""

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

    def estimate(self, name, estimator, *, result_name=None, **kwargs):
        """``estimator(**kwargs)``, its evaluations recorded as ``evaluations[name]`` (also when
        it refuses with :class:`~mechrel.uq.SampleFailuresError`) and its result as
        ``results[result_name or name]``."""
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
        """The settings of ``method``: the study file's table of its key over the registry's
        defaults; ``max_failure_fraction``, when the method has that setting, the caller's
        (``--max-failure-fraction``) over the table's over the study's
        ``reliability.max_failure_fraction``."""
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
        """The rows of a per-output table at the analysis angles (without the cycle extremes),
        with the crank angles as floats."""
        from ..uq.problem.allowables import per_angle_mask

        t = table[per_angle_mask(table.index)].copy()
        names = list(t.index.names)
        k = names.index("crank_angle")
        t.index = pd.MultiIndex.from_tuples(
            [tuple(float(v) if i == k else v for i, v in enumerate(lbl)) for lbl in t.index],
            names=names)
        return t


class Presenter:
    """The hooks of one method (or a group of methods sharing a table) in a study run.

    Every hook has a default that does nothing, so a presenter overrides only what it shows.
    ``rank`` orders the per-quantity summary parts (least to most trusted) and picks the
    estimate the verdict trusts (the highest rank that gives a verdict); ``rows_per_n`` is the
    number of model runs per Monte Carlo sample ``n`` it needs in memory (checked before the
    run); ``files`` are the files it may write, removed when a run does not write them.
    """

    rank = 0
    rows_per_n = 0
    files: tuple[str, ...] = ()

    def __init__(self):
        self.keys: list[str] = []

    def run(self, ctx: Context, method) -> None:
        """Run ``method`` (a registry :class:`~mechrel.uq.estimators.Method`), recording its
        result(s) in ``ctx.results``."""
        raise NotImplementedError

    def finish(self, ctx: Context) -> None:
        """After every method of the run: estimates that combine methods."""

    def frames(self, ctx: Context) -> list[pd.DataFrame]:
        """Column blocks of ``reliability.csv`` (per output and crank angle)."""
        return []

    def plotted(self, ctx: Context) -> list:
        """Per-angle reliability results drawn in ``reliability.png``."""
        return []

    def head_lines(self, ctx: Context) -> list[str]:
        """Summary lines before the per-quantity lines."""
        return []

    def quantity_part(self, ctx: Context, quantity: str) -> str | None:
        """The method's part of the per-quantity summary line."""
        return None

    def tail_lines(self, ctx: Context) -> list[str]:
        """Summary lines after the per-quantity lines."""
        return []

    def verdict_reason(self, ctx: Context, quantity: str) -> str | None:
        """What this estimate says about the trusted one's (a reason in its verdict line)."""
        return None

    def verdict(self, ctx: Context, quantity: str, reasons: list[str]) -> str | None:
        """The verdict line for ``quantity`` when this estimate is the most trusted one."""
        return None

    def whole_cycle_verdict(self, ctx: Context) -> str | None:
        """The verdict's whole-cycle line, when this presenter gives it."""
        return None

    def write(self, ctx: Context, out) -> list[str]:
        """Write this presenter's files into ``out``; the names written."""
        return []


def _min_reliability(ctx, result, quantity):
    t = ctx.angles(result.table).xs(quantity, level="quantity")
    return t, t["reliability"].idxmin()


class FOSM(Presenter):
    """FOSM (the paper's interference formula), per crank angle."""

    rank = 1

    def run(self, ctx, method):
        self.keys.append(method.key)
        ctx.estimate(method.key, method.function, model=ctx.model, inputs=ctx.inputs,
                     allowable=ctx.allowables, event=ctx.event, **ctx.common)

    def frames(self, ctx):
        return [ctx.results["fosm"].to_frame().add_prefix("fosm.")]

    def plotted(self, ctx):
        return [ctx.results["fosm"]]

    def quantity_part(self, ctx, quantity):
        t, k = _min_reliability(ctx, ctx.results["fosm"], quantity)
        # the index of the R printed: Φ⁻¹(R) of the study's event (the table's ``beta`` is the
        # paper's one-sided index, which is not Φ⁻¹ of a two-sided R)
        return (f"FOSM min R {t['reliability'].min():.4f} at {k:g}° "
                f"(β = Φ⁻¹(R) = {t['beta_generalized'].loc[k]:.3f}, {ctx.event})")

    def verdict_reason(self, ctx, quantity):
        mc, nc = ctx.results.get("mc"), ctx.results.get("normality")
        if mc is None or nc is None:
            return None
        level = f"{mc.confidence_level:.0%}"
        t = ctx.angles(nc.table).xs(quantity, level="quantity")
        m = ctx.angles(mc.table).xs(quantity, level="quantity")
        r_out = int(((t["R_fosm"] < t["R_mc_lo"]) | (t["R_fosm"] > t["R_mc_hi"])).sum())
        mu_out = int(((t["mu_i"] < m["mean_lo"]) | (t["mu_i"] > m["mean_hi"])).sum())
        nonsmooth = getattr(ctx.model, "nonsmooth", None)
        if nonsmooth:
            return f"FOSM is not applicable ({nonsmooth})"
        if r_out or mu_out:
            return (f"FOSM's R is outside MC's {level} interval at {r_out} and its mean at "
                    f"{mu_out} of {len(t)} angles")
        return (f"FOSM agrees (its R and mean inside MC's {level} interval at every angle), "
                "so FOSM's 2d + 1 runs suffice for this design")

    def verdict(self, ctx, quantity, reasons):
        nonsmooth = getattr(ctx.model, "nonsmooth", None)
        return (f"    {quantity}: FOSM only, unchecked (no Monte Carlo run): "
                + (f"not applicable ({nonsmooth}); run Monte Carlo" if nonsmooth else
                   "a first-order, normal model of the error; run --method mc to check it"))


class MonteCarlo(Presenter):
    """Crude Monte Carlo: per crank angle and over the whole cycle (``whole_cycle.csv``)."""

    rank = 3
    rows_per_n = 1
    files = ("whole_cycle.csv",)

    def run(self, ctx, method):
        self.keys.append(method.key)
        cfg = ctx.study.reliability
        ctx.estimate(method.key, method.function, model=ctx.model, inputs=ctx.inputs, n=ctx.n,
                     rule=cfg["rule"], seed=ctx.seed, allowable=ctx.allowables,
                     event=ctx.event, max_failure_fraction=ctx.max_failure_fraction,
                     **ctx.common)

    def frames(self, ctx):
        return [ctx.results["mc"].to_frame().add_prefix("mc.")]

    def plotted(self, ctx):
        return [ctx.results["mc"]]

    def quantity_part(self, ctx, quantity):
        t, k = _min_reliability(ctx, ctx.results["mc"], quantity)
        return (f"MC min R {t['reliability'].min():.4f} "
                f"[{t['reliability_lo'].loc[k]:.4f}, {t['reliability_hi'].loc[k]:.4f}] at {k:g}°")

    def tail_lines(self, ctx):
        mc = ctx.results["mc"]
        lines = [f"  whole-cycle reliability ({key}): {row['reliability']:.4f} "
                 f"[{row['reliability_lo']:.4f}, {row['reliability_hi']:.4f}] "
                 f"(from the {row['basis']})" for key, row in mc.whole_cycle.iterrows()]
        lines.append(f"  Monte Carlo: {mc.evaluations.n} samples "
                     f"({ctx.study.reliability['rule']}), {mc.n_failed} failed")
        return lines

    def verdict(self, ctx, quantity, reasons):
        mc = ctx.results["mc"]
        level = f"{mc.confidence_level:.0%}"
        m = mc.table.xs(quantity, level="quantity")
        width = float((m["reliability_hi"] - m["reliability_lo"]).max())
        if width > 0.1:
            reasons = reasons + [f"MC's intervals are up to {width:.2f} wide: raise n to "
                                 "narrow them (the width falls as 1/sqrt(n))"]
        return (f"    {quantity}: trust Monte Carlo ({mc.evaluations.n_ok} successful samples, "
                f"{level} intervals that hold whatever the error's distribution)"
                + ("; " + "; ".join(reasons) if reasons else ""))

    def whole_cycle_verdict(self, ctx):
        if any(isinstance(p, RareEvents) for p in ctx.presenters):
            return None  # the rare-event methods' line names Monte Carlo too
        return ("    whole cycle: only Monte Carlo estimates it (FOSM and PCE give per-angle "
                "reliabilities)")

    def write(self, ctx, out):
        from ..io import write_table

        write_table(ctx.results["mc"].whole_cycle.reset_index(), out / "whole_cycle.csv")
        return ["whole_cycle.csv"]


class PolynomialChaos(Presenter):
    """The PCE surrogate, and the reliability Monte Carlo gives on it (2¹⁷ Sobol' points)."""

    rank = 2

    def run(self, ctx, method):
        self.keys.append(method.key)
        r = ctx.estimate(method.key, method.function, model=ctx.model, inputs=ctx.inputs,
                         order=ctx.study.reliability["pce_order"], seed=ctx.seed,
                         max_failure_fraction=ctx.max_failure_fraction, **ctx.common)
        ctx.estimate("pce_surrogate", r.reliability, result_name="pce_reliability", n=2**17,
                     rule="sobol", seed=ctx.seed, allowable=ctx.allowables, event=ctx.event)

    def _loo_worst(self, ctx, quantity):
        pce = ctx.results["pce"]
        loo = pce.loo_error.xs(quantity, level="quantity") if pce.loo_error is not None else None
        return float(loo.max()) if loo is not None and loo.notna().any() else float("nan")

    def frames(self, ctx):
        columns = ["reliability", "reliability_lo", "reliability_hi"]
        return [ctx.results["pce"].to_frame().add_prefix("pce."),
                ctx.results["pce_reliability"].to_frame()[columns].add_prefix("pce_surrogate.")]

    def plotted(self, ctx):
        return [ctx.results["pce_reliability"]]

    def head_lines(self, ctx):
        pce = ctx.results["pce"]
        if pce.loo_error is None:
            return []
        return [f"  PCE order {pce.order} ({pce.evaluations.n} training runs): leave-one-out "
                f"error median {float(pce.loo_error.median()):.3g}, max "
                f"{float(pce.loo_error.max()):.3g} (relative to each output's variance)"]

    def quantity_part(self, ctx, quantity):
        t, k = _min_reliability(ctx, ctx.results["pce_reliability"], quantity)
        return f"PCE min R {t['reliability'].min():.4f} at {k:g}°"

    def verdict_reason(self, ctx, quantity):
        from ..uq.surrogates.pce import LOO_THRESHOLD

        worst = self._loo_worst(ctx, quantity)
        if not worst <= LOO_THRESHOLD:
            return f"PCE is not (leave-one-out error {worst:.3g} > {LOO_THRESHOLD:g})"
        return f"PCE fits (leave-one-out error ≤ {worst:.3g})"

    def verdict(self, ctx, quantity, reasons):
        from ..uq.surrogates.pce import LOO_THRESHOLD

        worst = self._loo_worst(ctx, quantity)
        if worst <= LOO_THRESHOLD:
            return (f"    {quantity}: the PCE surrogate (leave-one-out error ≤ {worst:.3g}); "
                    "not checked against Monte Carlo")
        return (f"    {quantity}: no estimate to trust: the PCE's leave-one-out error is "
                f"{worst:.3g} > {LOO_THRESHOLD:g} and there is no Monte Carlo run")


class Normality(Presenter):
    """FOSM's normal assumption checked against Monte Carlo: runs when both did (it is no
    method of its own; the runner adds it after the methods' presenters)."""

    def finish(self, ctx):
        if "fosm" in ctx.results and "mc" in ctx.results:
            from ..uq import normality_check
            ctx.results["normality"] = normality_check(fosm=ctx.results["fosm"],
                                                       monte_carlo=ctx.results["mc"])

    def frames(self, ctx):
        if "normality" not in ctx.results:
            return []
        return [ctx.results["normality"].to_frame().add_prefix("normality.")]

    def head_lines(self, ctx):
        if "normality" not in ctx.results:
            return []
        nt = ctx.angles(ctx.results["normality"].to_frame())
        flag = [c for c in nt.columns if "flag" in c]
        if not flag:
            return []
        return [f"  normality check: FOSM's normal assumption flagged at "
                f"{int(nt[flag[0]].sum())} of {len(nt)} (quantity, angle) points"]


class RareEvents(Presenter):
    """The rare-event methods (kind ``"rare_event"``): the whole-cycle failure probability of
    the study's limit state (:mod:`.rare`), one row each of ``rare_events.csv``, and their
    design points in ``design_point.csv``."""

    files = ("rare_events.csv", "design_point.csv")

    def run(self, ctx, method):
        from . import rare

        self.keys.append(method.key)
        rare.estimate_one(ctx, method)

    def _results(self, ctx):
        return {k: ctx.results[k] for k in self.keys}

    def tail_lines(self, ctx):
        from . import rare

        return (["  whole cycle, any quantity beyond its allowable (rare-event methods):"]
                + rare.summary_lines(self._results(ctx)))

    def whole_cycle_verdict(self, ctx):
        mc = "mc" in ctx.results
        who = ", ".join(self.keys) + (" and Monte Carlo" if mc else "")
        verb = "estimates" if who == self.keys[0] else "estimate"
        return (f"    whole cycle: {who} {verb} it (FOSM and PCE give per-angle "
                "reliabilities); FORM and SORM are approximations, the sampling methods "
                "carry an interval")

    def write(self, ctx, out):
        from ..io import write_table
        from . import rare

        results = self._results(ctx)
        write_table(rare.table(results).reset_index(), out / "rare_events.csv")
        written = ["rare_events.csv"]
        dp = rare.design_points(results)
        if dp is not None:
            write_table(dp.reset_index(), out / "design_point.csv")
            written.append("design_point.csv")
        return written


def _run_on_study(ctx, method, prefer):
    """Run ``method`` on the study: its failure definition by what its signature takes
    (``prefer`` = ``"limit_state"``: the study's whole-cycle limit state before
    ``allowable=``/``event=``; ``"allowable"``: the other way round), ``seed=`` when it takes
    one, and its settings from the study file."""
    params = inspect.signature(method.function).parameters
    order = ("limit_state", "allowable")[:: 1 if prefer == "limit_state" else -1]
    takes = [arg for arg in order if arg in params]
    failure: dict = {}
    if takes and takes[0] == "limit_state":
        from .rare import whole_cycle_limit_state

        if "limit_state" not in ctx.shared:
            ctx.shared["limit_state"] = whole_cycle_limit_state(ctx.study, ctx.model)
        failure = {"limit_state": ctx.shared["limit_state"]}
    elif takes:
        failure = {"allowable": ctx.allowables, "event": ctx.event}
    seed = {"seed": ctx.seed} if "seed" in params else {}
    ctx.estimate(method.key, method.function, model=ctx.model, inputs=ctx.inputs, **failure,
                 **seed, **ctx.settings(method), **ctx.common)


class PerAngle(Presenter):
    """A per-angle reliability method (kind ``"reliability"``) without its own presenter: its
    table joins ``reliability.csv`` under its key, its lowest R per quantity the summary."""

    def run(self, ctx, method):
        self.keys.append(method.key)
        _run_on_study(ctx, method, prefer="allowable")

    def frames(self, ctx):
        return [ctx.results[k].to_frame().add_prefix(f"{k}.") for k in self.keys]

    def quantity_part(self, ctx, quantity):
        parts = []
        for k in self.keys:
            t, i = _min_reliability(ctx, ctx.results[k], quantity)
            parts.append(f"{k} min R {t['reliability'].min():.4f} at {i:g}°")
        return "; ".join(parts) or None


class Generic(Presenter):
    """Any other method: run on the study's failure definition (what its signature takes),
    its ``.to_frame()`` written to ``KEY.csv``, its cost in the summary."""

    def run(self, ctx, method):
        self.keys.append(method.key)
        _run_on_study(ctx, method, prefer="limit_state")

    def tail_lines(self, ctx):
        return [f"  {k}: {ctx.results[k].n_evaluations} model evaluations, table in {k}.csv"
                for k in self.keys]

    def write(self, ctx, out):
        from ..io import write_table

        for k in self.keys:
            write_table(ctx.results[k].to_frame().reset_index(), out / f"{k}.csv")
        return [f"{k}.csv" for k in self.keys]


PRESENTERS: dict[str, type[Presenter]] = {
    "fosm": FOSM, "monte_carlo": MonteCarlo, "polynomial_chaos": PolynomialChaos,
}
"""Registry name → its presenter class, for methods whose presentation is their own."""

KIND_PRESENTERS: dict[str, type[Presenter]] = {"rare_event": RareEvents, "reliability": PerAngle}
"""Registry kind → the presenter class of a method without its own (:class:`Generic` for
other kinds)."""

COMBINED: tuple[type[Presenter], ...] = (Normality,)
"""Presenters of estimates that combine methods; the runner adds them after the methods'."""


def presenter_class(method) -> type[Presenter]:
    """The presenter class of a registry :class:`~mechrel.uq.estimators.Method`."""
    return PRESENTERS.get(method.name) or KIND_PRESENTERS.get(method.kind, Generic)


def files_of(methods) -> tuple[str, ...]:
    """Every file the presenters of ``methods`` may write (a run removes those it does not
    write, so no earlier run's file is left beside its summary)."""
    out = []
    for m in methods:
        cls = presenter_class(m)
        names = cls.files if cls is not Generic else (f"{m.key}.csv",)
        out += [f for f in names if f not in out]
    return tuple(out)


def warnings_of(results) -> list[str]:
    """Every estimate's warnings, once each, in the order of the estimates."""
    out = []
    for r in results.values():
        for w in getattr(r, "warnings", ()):
            if w not in out and not any(w.startswith(o) for o in out):
                out.append(w)
    return out

