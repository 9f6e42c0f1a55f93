"""How ``mechrel reliability`` runs and presents each registered method.

The runner (:func:`mechrel.study.runner.run_reliability`) names no method: for each method
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

import numpy as np
import pandas as pd

from ..errors import StudyError
from .context import Context

__all__ = ["Presenter", "PRESENTERS", "KIND_PRESENTERS", "presenter_class", "COMBINED"]


def _agg() -> None:
    """Draw without a display (before pyplot is imported; keeps a backend already chosen)."""
    import matplotlib
    matplotlib.use("Agg", force=False)


def _save(fig, path) -> None:
    import matplotlib.pyplot as plt

    from ..io import save_figure

    save_figure(fig, path, dpi=130)  # atomically: temporary file, then rename
    plt.close(fig)


class Presenter:
    """The hooks of one method (or a group of methods sharing a table) in a study run.

    Every hook has a default that does nothing, so a presenter overrides only what it shows.
    ``rank`` orders the per-quantity summary parts (least to most trusted) and picks the
    estimate the verdict trusts (the highest rank that gives a verdict); ``rows_per_n`` is the
    number of model runs per Monte Carlo sample ``n`` it needs in memory (checked before the
    run); ``files`` are the files it may write, removed when a run does not write them.

    Examples
    --------
    >>> from mechrel.uq.estimators import METHODS
    >>> presenter_class(METHODS["fosm"]).rank, Presenter.rank
    (1, 0)
    """

    rank = 0
    rows_per_n = 0
    files: tuple[str, ...] = ()

    def __init__(self):
        self.keys: list[str] = []

    def check(self, ctx: Context, method) -> None:
        """Check a method's settings before any method of the run evaluates the model: each by
        the registry's check, and those that count the model runs held in memory
        (:attr:`~mechrel.uq.estimators.Setting.samples`) against the machine's memory.

        Parameters
        ----------
        ctx : Context
            The run.
        method : mechrel.uq.estimators.Method
            The registry entry of the method.

        Raises
        ------
        StudyError
            A setting is invalid, or its model runs would not fit in memory.

        Examples
        --------
        >>> from mechrel.study.rare import _demo
        >>> from mechrel.uq.estimators import METHODS
        >>> from dataclasses import replace
        >>> study, model = _demo()   # analytic: a velocity extreme 6 + x1 + x2 (m/s)
        >>> study = replace(study, method_settings={"is": {"n": 10**15}})
        >>> ctx = Context(study, model, study.uncertain_inputs(), study.allowables(), "two-sided",
        ...               seed=7, n=64, max_failure_fraction=0.1, common={"progress": False})
        >>> Presenter().check(ctx, METHODS["importance_sampling"])
        Traceback (most recent call last):
        ...
        mechrel.errors.StudyError: is.n = 1000000000000000: 1e+15 model runs of ...
        """
        from ..uq._common import check_memory
        from ..uq.problem.model import check_model

        settings = ctx.settings(method)
        names, index = check_model(ctx.model)
        for key, setting in method.settings.items():
            if setting.samples:
                where = f"{method.key}.{key}"
                check_memory(settings[key], len(names) + len(index), where, settings[key])

    def run(self, ctx: Context, method) -> None:
        """Run a method, recording its result(s) in ``ctx.results``.

        Parameters
        ----------
        ctx : Context
            The run.
        method : mechrel.uq.estimators.Method
            The registry entry of the method.

        Raises
        ------
        NotImplementedError
            In the base class: every presenter runs its methods.

        Examples
        --------
        >>> from mechrel.study.rare import _demo
        >>> from mechrel.uq.estimators import METHODS
        >>> study, model = _demo()   # analytic: a velocity extreme 6 + x1 + x2 (m/s)
        >>> ctx = Context(study, model, study.uncertain_inputs(), study.allowables(), "two-sided",
        ...               seed=7, n=64, max_failure_fraction=0.1, common={"progress": False})
        >>> p = FOSM()
        >>> p.run(ctx, METHODS["fosm"])
        >>> p.keys, list(ctx.results)
        (['fosm'], ['fosm'])
        """
        raise NotImplementedError

    def finish(self, ctx: Context) -> None:
        """After every method of the run: compute the estimates that combine methods.

        Parameters
        ----------
        ctx : Context
            The run.

        Examples
        --------
        The default does nothing:

        >>> Presenter().finish(None) is None
        True
        """

    def frames(self, ctx: Context) -> list[pd.DataFrame]:
        """The column blocks of ``reliability.csv`` (per output and crank angle).

        Parameters
        ----------
        ctx : Context
            The run.

        Returns
        -------
        list of pandas.DataFrame
            The blocks, their columns prefixed with the method's key (default: none).

        Examples
        --------
        >>> from mechrel.study.rare import _demo
        >>> from mechrel.uq.estimators import METHODS
        >>> study, model = _demo()   # analytic: a velocity extreme 6 + x1 + x2 (m/s)
        >>> ctx = Context(study, model, study.uncertain_inputs(), study.allowables(), "two-sided",
        ...               seed=7, n=64, max_failure_fraction=0.1, common={"progress": False})
        >>> p = FOSM()
        >>> p.run(ctx, METHODS["fosm"])
        >>> p.frames(ctx)[0].columns[:2].tolist()
        ['fosm.mean', 'fosm.std']
        """
        return []

    def plotted(self, ctx: Context) -> list:
        """The per-angle reliability results drawn in ``reliability.png``.

        Parameters
        ----------
        ctx : Context
            The run.

        Returns
        -------
        list
            The results (default: none).

        Examples
        --------
        >>> from mechrel.study.rare import _demo
        >>> from mechrel.uq.estimators import METHODS
        >>> study, model = _demo()   # analytic: a velocity extreme 6 + x1 + x2 (m/s)
        >>> ctx = Context(study, model, study.uncertain_inputs(), study.allowables(), "two-sided",
        ...               seed=7, n=64, max_failure_fraction=0.1, common={"progress": False})
        >>> p = FOSM()
        >>> p.run(ctx, METHODS["fosm"])
        >>> p.plotted(ctx)[0] is ctx.results["fosm"]
        True
        """
        return []

    def head_lines(self, ctx: Context) -> list[str]:
        """The summary lines before the per-quantity lines.

        Parameters
        ----------
        ctx : Context
            The run.

        Returns
        -------
        list of str
            The lines (default: none).

        Examples
        --------
        >>> Presenter().head_lines(None)
        []
        """
        return []

    def quantity_part(self, ctx: Context, quantity: str) -> str | None:
        """The method's part of the per-quantity summary line.

        Parameters
        ----------
        ctx : Context
            The run.
        quantity : str
            The quantity.

        Returns
        -------
        str or None
            The part (default None: nothing to say).

        Examples
        --------
        >>> from mechrel.study.rare import _demo
        >>> from mechrel.uq.estimators import METHODS
        >>> study, model = _demo()   # analytic: a velocity extreme 6 + x1 + x2 (m/s)
        >>> ctx = Context(study, model, study.uncertain_inputs(), study.allowables(), "two-sided",
        ...               seed=7, n=64, max_failure_fraction=0.1, common={"progress": False})
        >>> p = FOSM()
        >>> p.run(ctx, METHODS["fosm"])
        >>> p.quantity_part(ctx, "velocity").split(" (")[0]   # Φ(4/√2) = 0.99766
        'FOSM min R 0.9977 at 0°'
        """
        return None

    def tail_lines(self, ctx: Context) -> list[str]:
        """The summary lines after the per-quantity lines.

        Parameters
        ----------
        ctx : Context
            The run.

        Returns
        -------
        list of str
            The lines (default: none).

        Examples
        --------
        >>> Presenter().tail_lines(None)
        []
        """
        return []

    def verdict_reason(self, ctx: Context, quantity: str) -> str | None:
        """What this estimate says about the trusted one's (a reason in its verdict line).

        Parameters
        ----------
        ctx : Context
            The run.
        quantity : str
            The quantity.

        Returns
        -------
        str or None
            The reason (default None).

        Examples
        --------
        FOSM gives a reason only beside a Monte Carlo run:

        >>> from mechrel.study.rare import _demo
        >>> from mechrel.uq.estimators import METHODS
        >>> study, model = _demo()   # analytic: a velocity extreme 6 + x1 + x2 (m/s)
        >>> ctx = Context(study, model, study.uncertain_inputs(), study.allowables(), "two-sided",
        ...               seed=7, n=64, max_failure_fraction=0.1, common={"progress": False})
        >>> p = FOSM()
        >>> p.run(ctx, METHODS["fosm"])
        >>> p.verdict_reason(ctx, "velocity") is None
        True
        """
        return None

    def verdict(self, ctx: Context, quantity: str, reasons: list[str]) -> str | None:
        """The verdict line for a quantity when this estimate is the most trusted one.

        Parameters
        ----------
        ctx : Context
            The run.
        quantity : str
            The quantity.
        reasons : list of str
            The other estimates' reasons (:meth:`verdict_reason`).

        Returns
        -------
        str or None
            The line (default None: no verdict from this estimate).

        Examples
        --------
        >>> from mechrel.study.rare import _demo
        >>> from mechrel.uq.estimators import METHODS
        >>> study, model = _demo()   # analytic: a velocity extreme 6 + x1 + x2 (m/s)
        >>> ctx = Context(study, model, study.uncertain_inputs(), study.allowables(), "two-sided",
        ...               seed=7, n=64, max_failure_fraction=0.1, common={"progress": False})
        >>> p = FOSM()
        >>> p.run(ctx, METHODS["fosm"])
        >>> p.verdict(ctx, "velocity", []).split(":")[0].strip()
        'velocity'
        """
        return None

    def whole_cycle_verdict(self, ctx: Context) -> str | None:
        """The verdict's whole-cycle line, when this presenter gives it.

        Parameters
        ----------
        ctx : Context
            The run.

        Returns
        -------
        str or None
            The line (default None).

        Examples
        --------
        >>> Presenter().whole_cycle_verdict(None) is None
        True
        """
        return None

    def write(self, ctx: Context, out) -> list[str]:
        """Write this presenter's files into a folder.

        Parameters
        ----------
        ctx : Context
            The run.
        out : pathlib.Path
            The output folder.

        Returns
        -------
        list of str
            The names of the files written (default: none).

        Examples
        --------
        >>> Presenter().write(None, None)
        []
        """
        return []

    def record(self, ctx: Context) -> dict:
        """What this presenter adds to ``summary.json``, beside the run's record.

        Parameters
        ----------
        ctx : Context
            The run.

        Returns
        -------
        dict
            Top-level keys and their JSON-friendly values (default: none).

        Examples
        --------
        >>> Presenter().record(None)
        {}
        """
        return {}


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
        mu_out = int(((t["fosm_mean"] < m["mean_lo"]) | (t["fosm_mean"] > m["mean_hi"])).sum())
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
                   "a first-order, normal model of the error; run --method mc to check it")
                + "".join(f"; {r}" for r in reasons))


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

    def write(self, ctx, out):
        from ..io import write_table

        write_table(ctx.results["mc"].whole_cycle.reset_index(), out / "whole_cycle.csv")
        return ["whole_cycle.csv"]


class PolynomialChaos(Presenter):
    """The PCE surrogate, and the reliability Monte Carlo gives on it (2¹⁷ Sobol' points)."""

    rank = 2

    def check(self, ctx, method):
        from ..uq.surrogates.pce import check_cost

        super().check(ctx, method)
        try:  # what the expansion will cost, refused past the study's limit
            check_cost(ctx.inputs.d, ctx.study.reliability["pce_order"],
                       ctx.study.reliability["pce_max_evaluations"],
                       names=("reliability.pce_order", "reliability.pce_max_evaluations"))
        except StudyError as exc:
            raise StudyError(f"{ctx.study.source}: {exc}") from None

    def run(self, ctx, method):
        self.keys.append(method.key)
        r = ctx.estimate(method.key, method.function, model=ctx.model, inputs=ctx.inputs,
                         order=ctx.study.reliability["pce_order"], seed=ctx.seed,
                         max_evaluations=ctx.study.reliability["pce_max_evaluations"],
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
                    "not checked against Monte Carlo" + "".join(f"; {r}" for r in reasons))
        return (f"    {quantity}: no estimate to trust: the PCE's leave-one-out error is "
                f"{worst:.3g} > {LOO_THRESHOLD:g} and there is no Monte Carlo run"
                + "".join(f"; {r}" for r in reasons))


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


class WholeCycle(Presenter):
    """The whole cycle across methods (no method of its own; the runner adds it after the
    methods' presenters): the verdict's whole-cycle lines (which estimate to trust, whether the
    others agree, :func:`.rare.verdict_lines`), the headline figure ``whole_cycle.png`` (every
    method's whole-cycle P_f side by side, :func:`mechrel.uq.plots.plot_whole_cycle`), the
    rare-event figure ``rare_events.png`` (design points, importance factors and, with Monte
    Carlo, P_f against the allowable, :func:`mechrel.uq.plots.plot_design_points`), and
    ``cycle_extremes.csv`` (each Monte Carlo sample's inputs and cycle extremes per quantity)."""

    files = ("whole_cycle.png", "rare_events.png", "cycle_extremes.csv")

    def finish(self, ctx):
        from .rare import whole_cycle_estimates

        ctx.shared["whole_cycle"] = whole_cycle_estimates(ctx.results)

    def whole_cycle_verdict(self, ctx):
        from .rare import per_angle_worst, verdict_lines

        est = ctx.shared.get("whole_cycle")
        if est is None or est.empty:
            if any(k in ctx.results for k in ("fosm", "pce")):
                return ["    whole cycle: not estimated (FOSM and PCE give per-angle "
                        "reliabilities); run "
                        "Monte Carlo (--method mc) or a rare-event method (form, sorm, is, subset)"]
            return None
        worst = per_angle_worst(ctx.results, ctx.study.quantities)
        return verdict_lines(est, worst=worst)

    def _form(self, ctx):
        from ..uq import FORMResult

        for r in ctx.results.values():
            fr = r if isinstance(r, FORMResult) else getattr(r, "form", None)
            if (isinstance(fr, FORMResult) and fr.design_points is not None
                    and fr.system == "series"):
                return fr
        return None

    def extremes(self, ctx):
        """Each Monte Carlo sample's inputs and its cycle extremes per quantity (NaN for a failed
        sample, with its reason), or None."""
        from ..uq.problem.allowables import EXTREME_STATS

        ev = ctx.evaluations.get("mc")
        if ev is None or not isinstance(ev.output_index, pd.MultiIndex) \
                or "crank_angle" not in ev.output_index.names:
            return None
        labels = [lbl for lbl in ev.output_index if lbl[1] in EXTREME_STATS]
        if not labels:
            return None
        pos = [ev.output_index.get_loc(lbl) for lbl in labels]
        cols = pd.MultiIndex.from_tuples(labels, names=["quantity", "statistic"])
        frame = pd.DataFrame(ev.Y[:, pos], columns=cols)
        frame[~ev.ok] = float("nan")
        return frame

    def write(self, ctx, out):
        from ..io import write_table
        from ..uq.plots import plot_design_points, plot_whole_cycle

        written = []
        est = ctx.shared.get("whole_cycle")
        if est is not None and not est.empty:
            _agg()
            target = None if ctx.target is None else 1.0 - ctx.target
            _save(plot_whole_cycle(est, target=target,
                                   title=f"{ctx.study.name}: whole-cycle P_f ({ctx.event}) by "
                                         "method"),
                  out / "whole_cycle.png")
            written.append("whole_cycle.png")
        ext = self.extremes(ctx)
        if ext is not None:
            ev = ctx.evaluations["mc"]
            table = pd.DataFrame(ev.X, columns=list(ev.input_names))
            for (q, stat) in ext.columns:
                table[f"{q}.{stat}"] = ext[(q, stat)].to_numpy()
            table["status"] = ["ok" if ok else "failed" for ok in ev.ok]
            table["reason"] = [r or "" for r in ev.reasons]
            table.index.name = "sample"
            write_table(table.reset_index(), out / "cycle_extremes.csv")
            written.append("cycle_extremes.csv")
        fr = self._form(ctx)
        if fr is not None:
            _agg()
            means = ({q: a.mean for q, a in ctx.allowables.items()}
                     if isinstance(ctx.allowables, dict) else None)
            _save(plot_design_points(fr, extremes=ext, allowables=means,
                                     title=f"{ctx.study.name}: whole-cycle design points"),
                  out / "rare_events.png")
            written.append("rare_events.png")
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
        # the count of its evaluations (computed, from the cache), as every line gives it
        counts = {k: ctx.evaluations[k].count.text() if k in ctx.evaluations
                  else f"{ctx.results[k].n_evaluations} model evaluations" for k in self.keys}
        return [f"  {k}: {counts[k]}, table in {k}.csv" for k in self.keys]

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

class Inverse(Presenter):
    """The inverse question (``--target-reliability``, ``[inverse] target``): the allowables
    for the target, by the study's inverse methods (:mod:`.inverse`), after the forward
    methods (it reuses the forward Monte Carlo's samples); ``inverse.csv``. It is no method of
    its own; the runner adds it after the methods' presenters."""

    files = ("inverse.csv",)

    def finish(self, ctx):
        from . import inverse

        if ctx.target is None:
            return
        for key in inverse.methods_of(ctx.study, ctx.target, ctx.n):
            if inverse.estimate_one(ctx, key) is not None:
                self.keys.append(key)

    def _results(self, ctx):
        return {k: ctx.results[f"inverse_{k}"] for k in self.keys}

    def tail_lines(self, ctx):
        from . import inverse

        return inverse.summary_lines(ctx, self._results(ctx))

    def whole_cycle_verdict(self, ctx):
        if not self.keys:
            return None
        results = self._results(ctx)
        # an answer without warnings before one with; FORM (no interval) last
        pick = min(results, key=lambda k: (bool(results[k].warnings), k == "form"))
        why = ("its interval holds whatever the error's distribution" if pick == "mc" else
               "its interval from the levels' Au–Beck c.o.v. (upper bound)" if pick == "subset"
               else "an approximation without an interval" if pick == "form" else
               "a registered method")
        warned = all(r.warnings for r in results.values())
        caveat = "; every answer carries a warning (above)" if warned else ""
        return (f"    allowable for R = {ctx.target:g}: {pick} ({why}){caveat}")

    def write(self, ctx, out):
        from ..io import write_table
        from . import inverse

        if not self.keys:
            return []
        write_table(inverse.table(self._results(ctx)), out / "inverse.csv")
        return ["inverse.csv"]

    def record(self, ctx):
        from . import inverse

        if ctx.target is None:
            return {}
        return {"target_reliability": ctx.target,
                "inverse": inverse.record(self._results(ctx))}


def cycle_closure(model, evaluations) -> tuple[dict[str, float], list[str]]:
    """Whether the analysed cycle closes in the evaluations a run made of ``model``.

    Parameters
    ----------
    model : Model
        The run's model; one without :meth:`~mechrel.uq.MechanismModel.cycle_closure` (no
        analysed cycle) has nothing to check.
    evaluations : iterable of Evaluations
        The run's evaluations; those of other outputs than ``model``'s are left out.

    Returns
    -------
    worst : dict
        ``{quantity: largest closure}`` of the quantities above
        :data:`~mechrel.simulation.extremes.CLOSURE_LIMIT`.
    lines : list of str
        Their warnings (:meth:`~mechrel.uq.MechanismModel.closure_warnings`).
    """
    from ..simulation.extremes import CLOSURE_LIMIT

    if not hasattr(model, "cycle_closure"):
        return {}, []
    Ys = [ev.Y for ev in evaluations if ev.output_index.equals(model.output_index)]
    if not Ys:
        return {}, []
    Y = np.concatenate(Ys)
    worst = model.cycle_closure(Y).max()  # failed rows (NaN) skipped
    return ({q: float(w) for q, w in worst.items() if w > CLOSURE_LIMIT},
            model.closure_warnings(Y))


class CycleClosure(Presenter):
    """Whether the analysed cycle closes on itself in every sample the run evaluated
    (:func:`cycle_closure`: a method's samples, FORM's steps, the inverse question's ...): a
    check of the model that every estimate shares, so it is no method of its own (the runner
    adds it after the methods' presenters). Where a quantity's cycle does not close, its
    warning joins the summary's and its verdict line says so."""

    def finish(self, ctx):
        self.worst, lines = cycle_closure(ctx.model, ctx.evaluations.values())
        ctx.notes += lines

    def verdict_reason(self, ctx, quantity):
        w = getattr(self, "worst", {}).get(quantity)
        if w is None:
            return None
        return (f"the analysed cycle does not close (by up to {100 * w:.2g} % of the error's "
                "span; see the warning)")

    def record(self, ctx):
        return {"cycle_closure": getattr(self, "worst", {})}


COMBINED: tuple[type[Presenter], ...] = (Normality, WholeCycle, Inverse, CycleClosure)
"""Presenters of estimates that combine methods; the runner adds them after the methods'."""


def presenter_class(method) -> type[Presenter]:
    """The presenter class of a registered method.

    The method's own entry in :data:`PRESENTERS`, else the one of its kind in
    :data:`KIND_PRESENTERS`, else :class:`Generic`.

    Parameters
    ----------
    method : mechrel.uq.estimators.Method
        A registry entry.

    Returns
    -------
    type
        A :class:`Presenter` subclass.

    Examples
    --------
    >>> from mechrel.uq.estimators import METHODS
    >>> presenter_class(METHODS["fosm"]).__name__, presenter_class(METHODS["sorm"]).__name__
    ('FOSM', 'RareEvents')
    """
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

