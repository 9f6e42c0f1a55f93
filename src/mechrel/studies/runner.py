"""Runners behind ``mechrel reliability`` and ``mechrel sensitivity``: evaluate a study with
the estimators of :mod:`mechrel.uq`, write tables and figures, return a printable summary."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from ..io import write_json, write_table

UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s²"}


def _plot_reliability(fosm_t, mc_t, quantities, title, path):
    """Per quantity: the reliability index (left, as the paper's figures) and the probability
    of exceeding the allowable, 1 − R, on a log scale (right), where differences between
    methods near R = 1 are visible. Monte Carlo shows its confidence interval; a point with no
    observed failure shows only its upper bound (▼)."""
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from scipy.stats import norm

    fig, axes = plt.subplots(len(quantities), 2, figsize=(11, 2.7 * len(quantities) + 0.6),
                             sharex=True, constrained_layout=True, squeeze=False)
    floor = 1e-7
    for row, q in zip(axes, quantities):
        ax_b, ax_p = row
        if fosm_t is not None:
            f = fosm_t.xs(q, level="quantity")
            ax_b.plot(f.index, f["beta_generalized"], "o-", ms=4, label="FOSM")
            ax_p.semilogy(f.index, np.maximum(1 - f["reliability"], floor), "o-", ms=4,
                          label="FOSM")
        if mc_t is not None:
            m = mc_t.xs(q, level="quantity")
            pf = 1 - m["reliability"]
            hi, lo = 1 - m["reliability_lo"], 1 - m["reliability_hi"]
            ax_p.fill_between(m.index, np.maximum(lo, floor), np.maximum(hi, floor),
                              color="C1", alpha=0.25, label="MC 95 % interval")
            seen = pf > 0
            ax_p.semilogy(m.index[seen], pf[seen], "s--", ms=3, color="C1", label="Monte Carlo")
            ax_p.plot(m.index[~seen], hi[~seen], "v", ms=5, color="C1",
                      label="MC upper bound (no failure seen)" if (~seen).any() else None)
            beta_mc = norm.ppf(np.clip(m["reliability"], 0, 1 - floor))
            ax_b.plot(m.index[seen], beta_mc[seen], "s--", ms=3, color="C1",
                      label="Monte Carlo")
            ax_b.fill_between(m.index, norm.ppf(np.clip(m["reliability_lo"], floor, 1 - floor)),
                              norm.ppf(np.clip(m["reliability_hi"], floor, 1 - floor)),
                              color="C1", alpha=0.2)
        ax_b.set_ylabel(f"β ({q})")
        ax_p.set_ylabel(f"1 − R ({q})")
        for ax in row:
            ax.grid(alpha=0.3, which="both")
        ax_p.legend(fontsize=7, loc="best")
    for ax in axes[-1]:
        ax.set_xlabel("crank angle (deg)")
        ax.set_xticks(np.arange(0, 361, 36))
    axes[0][0].set_title("reliability index Φ⁻¹(R)")
    axes[0][1].set_title("probability of exceeding the allowable")
    fig.suptitle(title)
    fig.savefig(path, dpi=130)
    plt.close(fig)


def run_reliability(study, *, methods=None, n=None, n_jobs=1, seed=None, out=None,
                    progress=True, cache=True, backend="loky"):
    """Run the study's reliability methods; write ``reliability.csv``, ``whole_cycle.csv``,
    ``reliability.png`` and ``summary.json`` to ``out``. Returns (summary lines, results)."""
    from ..uq import fosm, monte_carlo

    start = time.perf_counter()
    cfg = dict(study.reliability)
    methods = tuple(methods or cfg.get("methods", ("fosm", "mc")))
    if "all" in methods:
        methods = ("fosm", "mc", "pce")
    n = int(n or cfg.get("n", 256))
    seed = seed if seed is not None else cfg.get("seed")
    form = cfg.get("form", "two-sided")
    rule = cfg.get("rule", "sobol")
    model = study.model()
    inputs = study.uncertain_inputs()
    allow = study.allowables()
    out = Path(out) if out else None
    cache_path = (out / "evaluations.sqlite") if (out and cache) else None
    if out:
        out.mkdir(parents=True, exist_ok=True)
    common = dict(n_jobs=n_jobs, backend=backend, cache=cache_path, progress=progress)
    results, lines, frames = {}, [], []
    lines.append(f"study {study.name}: scene {model.scene.name}, inputs "
                 f"{', '.join(inputs.names)}; form {form}")
    if "fosm" in methods:
        r = fosm(model=model, inputs=inputs, allowable=allow, form=form, **common)
        results["fosm"] = r
        frames.append(r.to_frame().add_prefix("fosm."))
    if "mc" in methods:
        r = monte_carlo(model=model, inputs=inputs, n=n, rule=rule, seed=seed,
                        allowable=allow, form=form, **common)
        results["mc"] = r
        frames.append(r.to_frame().add_prefix("mc."))
    if "pce" in methods:
        from ..uq import polynomial_chaos
        r = polynomial_chaos(model=model, inputs=inputs, order=int(cfg.get("pce_order", 2)),
                             seed=seed, **common)
        results["pce"] = r
        frames.append(r.to_frame().add_prefix("pce."))
        surrogate = r.reliability(n=2**17, rule="sobol", seed=seed, allowable=allow,
                                  form=form)
        results["pce_reliability"] = surrogate
        frames.append(surrogate.to_frame()[["reliability", "reliability_lo", "reliability_hi"]]
                      .add_prefix("pce_surrogate."))
    if "fosm" in results and "mc" in results:
        from ..uq import normality_check
        results["normality"] = normality_check(fosm=results["fosm"], monte_carlo=results["mc"])
        frames.append(results["normality"].to_frame().add_prefix("normality."))
    table = pd.concat(frames, axis=1) if frames else pd.DataFrame()
    if "pce" in results:
        loo = results["pce"].loo_error
        if loo is not None:
            lines.append(f"  PCE order {results['pce'].order} ({results['pce'].evaluations.X.shape[0]} "
                         f"training runs): leave-one-out error median {float(loo.median()):.3g}, "
                         f"max {float(loo.max()):.3g} (relative to each output's variance)")
    if "normality" in results:
        nt = results["normality"].to_frame()
        flag = [c for c in nt.columns if "flag" in c]
        if flag:
            lines.append(f"  normality check: FOSM's normal assumption flagged at "
                         f"{int(nt[flag[0]].sum())} of {len(nt)} (quantity, angle) points")
    for q in study.quantities:
        parts = [f"  {q:13s}"]
        if "fosm" in results:
            t = results["fosm"].table.xs(q, level="quantity")
            k = t["reliability"].idxmin()
            parts.append(f"FOSM min R {t['reliability'].min():.4f} at {k:g}° "
                         f"(β = {t['beta'].loc[k]:.3f})")
        if "pce_reliability" in results:
            t = results["pce_reliability"].table.xs(q, level="quantity")
            parts.append(f"PCE min R {t['reliability'].min():.4f} at "
                         f"{t['reliability'].idxmin():g}°")
        if "mc" in results:
            t = results["mc"].table.xs(q, level="quantity")
            k = t["reliability"].idxmin()
            parts.append(f"MC min R {t['reliability'].min():.4f} "
                         f"[{t['reliability_lo'].loc[k]:.4f}, {t['reliability_hi'].loc[k]:.4f}]"
                         f" at {k:g}°")
        lines.append("; ".join(parts))
    if "mc" in results:
        mc = results["mc"]
        wc = mc.whole_cycle
        for key, row in wc.iterrows():
            lines.append(f"  whole-cycle reliability ({key}): {row['reliability']:.4f} "
                         f"[{row['reliability_lo']:.4f}, {row['reliability_hi']:.4f}]")
        lines.append(f"  Monte Carlo: {mc.evaluations.X.shape[0]} samples ({rule}), "
                     f"{mc.n_failed} failed" + (f": {mc.failure_counts}" if mc.n_failed else ""))
    wall = time.perf_counter() - start
    n_calls = sum(int(getattr(getattr(r, "evaluations", None), "n_model_calls", 0))
                  for k, r in results.items() if k in ("fosm", "mc", "pce"))
    lines.append(f"  {n_calls} model evaluations in {wall:.1f} s (n_jobs = {n_jobs})")
    if out:
        write_table(table.reset_index(), out / "reliability.csv")
        if "mc" in results:
            write_table(results["mc"].whole_cycle.reset_index(), out / "whole_cycle.csv")
        _plot_reliability(results["fosm"].table if "fosm" in results else None,
                          results["mc"].table if "mc" in results else None,
                          study.quantities, f"{study.name}: reliability per crank angle "
                          f"({form})", out / "reliability.png")
        write_json({"study": study.name, "source": study.source, "methods": list(methods),
                    "n": n, "seed": seed, "form": form, "wall_time": wall,
                    "provenance": {k: dict(v.provenance) for k, v in results.items()},
                    "summary": lines}, out / "summary.json")
        lines.append(f"  wrote {out}/reliability.csv, whole_cycle.csv, reliability.png, "
                     "summary.json")
    return lines, results


def _plot_sobol(result, path, title):
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    first, total = result.first, result.total
    fc, tc = result.first_conf, result.total_conf
    outputs = list(first.index)
    inputs = list(first.columns)
    fig, axes = plt.subplots(1, len(outputs), figsize=(4.2 * len(outputs), 3.6),
                             constrained_layout=True, squeeze=False)
    x = np.arange(len(inputs))
    for ax, out in zip(axes[0], outputs):
        ax.bar(x - 0.2, first.loc[out], 0.4, yerr=fc.loc[out], capsize=3, label="first order S1")
        ax.bar(x + 0.2, total.loc[out], 0.4, yerr=tc.loc[out], capsize=3, label="total order ST")
        ax.set_xticks(x, inputs, rotation=20)
        ax.set_ylim(0, 1.05)
        ax.set_title(str(out).replace("peak_abs_", "peak |error|: "), fontsize=10)
        ax.grid(axis="y", alpha=0.3)
    axes[0][0].set_ylabel("Sobol index")
    axes[0][0].legend(fontsize=8)
    fig.suptitle(title)
    fig.savefig(path, dpi=130)
    plt.close(fig)


def run_sensitivity(study, *, n=None, n_jobs=1, seed=None, out=None, progress=True,
                    cache=True, backend="loky"):
    """Sobol indices (SALib) of the peak |error| over the cycle per quantity with respect to
    the study's inputs; writes ``sensitivity.csv`` (ranked) and ``sensitivity.png``."""
    from ..uq import peak_abs, sobol_indices

    start = time.perf_counter()
    cfg = dict(study.sensitivity)
    n = int(n or cfg.get("n", 256))
    seed = seed if seed is not None else cfg.get("seed")
    model = study.model()
    inputs = study.uncertain_inputs()
    out = Path(out) if out else None
    if out:
        out.mkdir(parents=True, exist_ok=True)
    res = sobol_indices(model=model, inputs=inputs, n=n, seed=seed, reducer=peak_abs,
                        n_jobs=n_jobs, backend=backend, progress=progress,
                        cache=(out / "evaluations.sqlite") if (out and cache) else None)
    table = res.to_frame().reset_index()
    table = table.sort_values([table.columns[0], "ST"], ascending=[True, False])
    lines = [f"study {study.name}: Sobol indices of the peak |error| over the cycle "
             f"(N = {n}, {res.evaluations.X.shape[0]} model runs, "
             f"{res.n_blocks_dropped} Saltelli blocks dropped for failures)"]
    for out_name, grp in table.groupby(table.columns[0], sort=False):
        ranked = ", ".join(f"{r[table.columns[1]]} ST={r['ST']:.3f}±{r['ST_conf']:.3f} "
                           f"S1={r['S1']:.3f}" for _, r in grp.iterrows())
        lines.append(f"  {out_name}: {ranked}")
    wall = time.perf_counter() - start
    lines.append(f"  wall time {wall:.1f} s (n_jobs = {n_jobs})")
    if out:
        write_table(table, out / "sensitivity.csv")
        _plot_sobol(res, out / "sensitivity.png", f"{study.name}: what drives the error")
        write_json({"study": study.name, "n": n, "seed": seed, "wall_time": wall,
                    "provenance": dict(res.provenance), "summary": lines},
                   out / "sensitivity.json")
        lines.append(f"  wrote {out}/sensitivity.csv, sensitivity.png, sensitivity.json")
    return lines, res
