#!/usr/bin/env python
"""Where and why FOSM departs from Monte Carlo on the nine-bar.

Per case (lubricated and dry at 3π rad/s, 0.5 mm, 100 cP; the input distribution of
studies/reliability_paper.py: clearance, viscosity, speed), per crank angle:

* FOSM (2d + 1 simulations) vs Monte Carlo (``--n`` Sobol points, cached in
  OUT/evaluations.sqlite so that a rerun resumes) with Wilson 95 % intervals, and the
  difference R_FOSM − R_MC with its interval;
* two allowables: the paper's I ~ N(μ_I, σ_I²) (drawn once per sample and quantity), and a
  fixed *probe* allowable I_q (σ_I = 0) chosen so that FOSM predicts R = 0.90 at the worst
  angle of each quantity. The paper's σ_I is 4–30 times the error's own spread here, so its
  reliability is nearly Φ((μ_I − |μ_i|)/σ_I) whatever the error's distribution; the probe
  allowable makes the result depend on the error's distribution, which is what FOSM models;
* the error's distribution: mean and std (FOSM's first-order moments vs MC with intervals),
  skewness, excess kurtosis, Anderson–Darling and Kolmogorov–Smirnov tests (normality_check),
  QQ plots at the worst angles;
* with the paper's allowable, P_f ~ 1e-3 is invisible to a few hundred 0/1 indicators, so
  the Monte Carlo estimate integrates the allowable's normal exactly per sample (conditional
  Monte Carlo, R = mean_k Φ((μ_I − |y_k|)/σ_I): the same probability with a far smaller
  variance; the binomial numbers are kept in the *_binomial columns);
* a paired decomposition on the same input sample: the FOSM linearisation evaluated at the
  Monte Carlo inputs (y_lin = μ_i + ∇f·(x − μ_X)) gives R_lin; R_MC − R_lin isolates the
  non-linearity of the response (with a paired interval), R_lin − R_FOSM the normal-formula
  and sampling part;
* the paper's one-sided Φ(β) on the signed error vs the two-sided P(|i| < I);
* whole-cycle reliability (the error within the allowable at every analysis angle of the
  cycle, jointly) vs the minimum point-in-time reliability.

For dry contact the FOSM step is also varied (±1σ secant, ±0.25σ, "auto") to show that its σ_i
is a property of the step, not of the mechanism.

    python studies/fosm_vs_mc.py --out results/fosm_vs_mc [--quick] [--jobs 2] [--n 512]

Note: AD/KS p-values assume independent samples; with Sobol points they are conservative
(fewer rejections). Use ``--rule random`` for calibrated p-values.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import optimize, stats

from mechrel.cli.args import sample_count, report_errors

sys.path.insert(0, str(Path(__file__).resolve().parent))
from reliability_paper import (  # noqa: E402
    CASES, QUANTITIES, RTOL, UNITS, markdown_table, case_inputs, case_model, fosm_settings,
)

SEED = 20221014
PROBE_R = 0.90
Z95 = stats.norm.ppf(0.975)


# ----------------------------------------------------------------------------- helpers
def probe_allowable(fosm_table: pd.DataFrame, target: float = PROBE_R) -> dict:
    """Fixed I_q per quantity with min over angles of FOSM's two-sided R = target."""
    from mechrel.uq import Allowable, reliability_two_sided

    out = {}
    for q in QUANTITIES:
        t = fosm_table.xs(q, level="quantity")
        mu, sd = t["mean"].to_numpy(), t["std"].to_numpy()

        def f(I):
            return reliability_two_sided(mu, sd, I, 0.0)[2].min() - target

        hi = float(np.max(np.abs(mu) + 10 * sd)) + 1e-12
        out[q] = Allowable(float(optimize.brentq(f, 1e-12, hi, xtol=1e-14 * hi)), 0.0)
    return out


def linearised(fosm, inputs, X: np.ndarray) -> np.ndarray:
    """FOSM's first-order model at the sample X."""
    G = fosm.gradient.to_numpy()
    return fosm.table["mean"].to_numpy()[None, :] + (X - inputs.mean[None, :]) @ G.T


def paired_diff(a: np.ndarray, b: np.ndarray):
    """Mean of a − b (0/1 indicators, same samples) with a normal 95 % interval."""
    d = a.astype(float) - b.astype(float)
    n = d.shape[0]
    m = d.mean(axis=0)
    se = d.std(axis=0, ddof=1) / np.sqrt(n)
    return m, m - Z95 * se, m + Z95 * se


def conditional_terms(Y, mu_I, sd_I, event):
    """Per sample and output, P(event | i = y) for I ~ N(μ_I, σ_I²) independent of i:
    two-sided P(I ≥ |y|), one-sided P(I ≥ y)."""
    v = np.abs(Y) if event == "two-sided" else Y
    return stats.norm.cdf((mu_I[None, :] - v) / sd_I[None, :])


def mean_ci(P, clip=True):
    """Column means of per-sample terms with a normal 95 % interval (conservative for Sobol)."""
    m = P.mean(axis=0)
    se = P.std(axis=0, ddof=1) / np.sqrt(P.shape[0])
    lo, hi = m - Z95 * se, m + Z95 * se
    return (m, np.clip(lo, 0, 1), np.clip(hi, 0, 1)) if clip else (m, lo, hi)


def whole_cycle_conditional(Y, index, mu_I, sd_I):
    """Whole-cycle reliability with one allowable draw per sample and quantity (as
    monte_carlo's "sampled" mode), integrated exactly: P(I ≥ max_θ |y_θ|)."""
    q = np.asarray(index.get_level_values("quantity"))
    rows = {}
    for g in QUANTITIES:
        cols = q == g
        P = stats.norm.cdf((mu_I[cols][0] - np.abs(Y[:, cols]).max(axis=1)) / sd_I[cols][0])
        rows[g] = mean_ci(P[:, None])
    # "all": independent allowables per quantity -> product of the per-quantity conditionals
    P = np.ones(Y.shape[0])
    for g in QUANTITIES:
        cols = q == g
        P = P * stats.norm.cdf((mu_I[cols][0] - np.abs(Y[:, cols]).max(axis=1)) / sd_I[cols][0])
    rows["all"] = mean_ci(P[:, None])
    return pd.DataFrame(
        {k: [float(v[0][0]), float(v[1][0]), float(v[2][0])] for k, v in rows.items()},
        index=["reliability", "reliability_lo", "reliability_hi"],
    ).T


def inside(Y, I, event):
    return (np.abs(Y) <= I) if event == "two-sided" else (Y <= I)


# ----------------------------------------------------------------------------- one case
def analyse_case(key, *, n, rule, seed, n_jobs, cache, progress, cycles, dry_steps):
    from mechrel.uq import Evaluations, fosm, monte_carlo, normality_check

    case = CASES[key]
    model, inputs = case_model(case, cycles=cycles), case_inputs(case)
    common = dict(n_jobs=n_jobs, cache=cache, progress=progress)
    t0 = time.perf_counter()
    settings = fosm_settings(case)
    f_paper = fosm(model=model, inputs=inputs, event="two-sided", **settings, **common)
    mc = monte_carlo(
        model=model, inputs=inputs, n=n, rule=rule, seed=seed, event="two-sided", **common
    )
    ev = mc.evaluations
    t_sim = time.perf_counter() - t0
    print(f"  {key}: FOSM {f_paper.evaluations.n} + MC {ev.n} points "
          f"({f_paper.evaluations.n_model_calls + ev.n_model_calls} simulated, "
          f"{ev.n_failed} failed) in {t_sim:.0f} s", flush=True)

    probe = probe_allowable(f_paper.table)
    allowables = {"paper": None, "probe": probe}
    res = {"case": key, "probe": {q: a.mean for q, a in probe.items()}, "allowables": {},
           "n_failed": ev.n_failed, "failure_counts": ev.failure_counts(), "t_sim": t_sim}
    ok = ev.ok
    Y = ev.Y[ok]
    Ylin_all = linearised(f_paper, inputs, ev.X)     # all rows: same allowable draws as ev
    Ylin = Ylin_all[ok]
    lin_ev = Evaluations.from_arrays(ev.X, np.where(ok[:, None], Ylin_all, np.nan),
                                     input_names=ev.input_names, output_index=ev.output_index,
                                     status=ev.status, reasons=ev.reasons)
    per_angle = {}
    for name, allow in allowables.items():
        f = f_paper if allow is None else fosm(evaluations=f_paper.evaluations, inputs=inputs,
                                                allowable=allow, event="two-sided", **settings)
        m2 = mc if allow is None else monte_carlo(evaluations=ev, seed=seed, allowable=allow,
                                                  event="two-sided", allowable_mode="sampled")
        m1 = monte_carlo(evaluations=ev, seed=seed, allowable=allow, event="one-sided",
                         allowable_mode="sampled")
        lin = monte_carlo(evaluations=lin_ev, seed=seed, allowable=allow, event="two-sided",
                          allowable_mode="sampled")
        nc = normality_check(fosm=f, monte_carlo=m2)
        # paired indicator differences on the same samples and the same allowable draws
        I = m2.allowable_draws()[ok]
        d, dlo, dhi = paired_diff(inside(Y, I, "two-sided"), inside(Ylin, I, "two-sided"))
        t = nc.to_frame()
        t["R_fosm_one_sided"] = f.table["R_one_sided"]
        t["beta_fosm"] = f.table["beta_generalized"]
        t["R_mc_one_sided"] = m1.table["reliability"]
        t["R_mc_one_sided_lo"] = m1.table["reliability_lo"]
        t["R_mc_one_sided_hi"] = m1.table["reliability_hi"]
        t["R_lin"] = lin.table["reliability"]
        t["nonlin_diff"], t["nonlin_lo"], t["nonlin_hi"] = d, dlo, dhi
        t["mc_mean_lo"], t["mc_mean_hi"] = mc.table["mean_lo"], mc.table["mean_hi"]
        t["mc_std_lo"], t["mc_std_hi"] = mc.table["std_lo"], mc.table["std_hi"]
        t["sigma_i_over_sigma_I"] = f.table["std"] / f.table["allowable_std"].replace(0, np.nan)
        t["mu_I"], t["sigma_I"] = f.table["allowable_mean"], f.table["allowable_std"]
        wc = m2.whole_cycle.copy()
        wc_lin = lin.whole_cycle["reliability"]
        if allow is None:
            # Paper allowable: P_f ~ 1e-3 is invisible to a few hundred 0/1 indicators. Integrate
            # the allowable's normal exactly per sample instead (conditional Monte Carlo: same
            # probability, far smaller variance); keep the binomial numbers as *_binomial.
            for c in ("R_mc", "R_mc_lo", "R_mc_hi", "diff", "diff_lo", "diff_hi", "R_lin",
                      "nonlin_diff", "nonlin_lo", "nonlin_hi", "R_mc_one_sided",
                      "R_mc_one_sided_lo", "R_mc_one_sided_hi"):
                t[c + "_binomial"] = t[c]
            mu_I, sd_I = t["mu_I"].to_numpy(), t["sigma_I"].to_numpy()
            pm = conditional_terms(Y, mu_I, sd_I, "two-sided")
            pl = conditional_terms(Ylin, mu_I, sd_I, "two-sided")
            t["R_mc"], t["R_mc_lo"], t["R_mc_hi"] = mean_ci(pm)
            t["diff"] = t["R_fosm"] - t["R_mc"]
            t["diff_lo"], t["diff_hi"] = t["R_fosm"] - t["R_mc_hi"], t["R_fosm"] - t["R_mc_lo"]
            t["R_lin"] = pl.mean(axis=0)
            t["nonlin_diff"], t["nonlin_lo"], t["nonlin_hi"] = mean_ci(pm - pl, clip=False)
            t["R_mc_one_sided"], t["R_mc_one_sided_lo"], t["R_mc_one_sided_hi"] = mean_ci(
                conditional_terms(Y, mu_I, sd_I, "one-sided"))
            t["estimator"] = "conditional MC (allowable integrated per sample)"
            wcc = whole_cycle_conditional(Y, ev.output_index, mu_I, sd_I)
            for c in ("reliability", "reliability_lo", "reliability_hi"):
                wc[c + "_binomial"] = wc[c]
                wc[c] = wcc[c]
            wc_lin = whole_cycle_conditional(Ylin, ev.output_index, mu_I, sd_I)["reliability"]
        else:
            t["estimator"] = "binomial (Wilson)"
        per_angle[name] = t
        wc["R_min_point_mc"] = [
            t.xs(g, level="quantity")["R_mc"].min() if g != "all" else t["R_mc"].min()
            for g in wc.index
        ]
        wc["R_min_point_fosm"] = [
            t.xs(g, level="quantity")["R_fosm"].min() if g != "all" else t["R_fosm"].min()
            for g in wc.index
        ]
        wc["R_whole_cycle_lin"] = wc_lin
        res["allowables"][name] = {
            "table": t,
            "whole_cycle": wc,
            "normality": nc,
            "fosm": f,
            "mc": m2,
        }
    # FOSM step sensitivity (dry: the response is not differentiable in practice)
    steps = []
    for step in dry_steps if case.model == "dry" else ():
        kw = {"step": step} if step != "auto" else {"step": "auto", "noise": RTOL}
        fs = fosm(model=model, inputs=inputs, event="two-sided", **kw, **common)
        steps.append((str(step), fs.table["std"], fs.table["mean"]))
    res["steps"] = steps
    res["inputs"] = inputs.describe()
    res["fosm_settings"] = settings
    return res


# ----------------------------------------------------------------------------- figures
def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _q(t, q):
    return t.xs(q, level="quantity")


def plot_reliability(res, name, path):
    """Rows: quantities. Left: probability of exceeding the allowable, 1 − R, on a log scale
    (FOSM line, MC points with their 95 % band, ▼ = MC upper bound where no exceedance was
    seen, and the MC of FOSM's linear model on the same sample). Right: R_FOSM − R_MC with its
    interval, and the paired non-linearity part R_lin − R_MC."""
    plt = _plt()
    t = res["allowables"][name]["table"]
    fig, axes = plt.subplots(3, 2, figsize=(12, 8.5), sharex=True, constrained_layout=True)
    n = int(res["allowables"][name]["mc"].table["n"].iloc[0])
    floor = 1e-5
    from mechrel.uq.plots import reliability_panels

    mc_res = res["allowables"][name]["mc"]
    for row, q in zip(axes, QUANTITIES):
        g = _q(t, q)
        x = g.index.to_numpy(dtype=float)
        a, b = row
        m = _q(mc_res.table, q)
        allow = None
        if {"allowable_mean", "allowable_std"} <= set(m.columns) \
                and m["allowable_mean"].nunique() == 1 and m["allowable_std"].nunique() == 1:
            allow = (float(m["allowable_mean"].iloc[0]), float(m["allowable_std"].iloc[0]),
                     UNITS[q])
        # the shared panel (mechrel.uq.plots): MC band, points, ▼ bounds, FOSM, the allowable
        reliability_panels(None, a, x, fosm=(g["R_fosm"].to_numpy(), "FOSM (normal formula)"),
                           mc=(g["R_mc"].to_numpy(), g["R_mc_lo"].to_numpy(),
                               g["R_mc_hi"].to_numpy(), n, 0.95),
                           allowable=allow, clip=floor)
        lin = 1 - g["R_lin"]
        a.plot(
            x[lin > 0],
            lin[lin > 0],
            "x",
            color="C2",
            ms=5,
            label="MC of FOSM's linear model, same sample",
        )
        a.set_ylabel(f"{q}\n1 − R = P(|i| > I)")
        b.axhline(0, color="k", lw=0.7)
        b.fill_between(x, g["diff_lo"], g["diff_hi"], color="C0", alpha=0.2,
                       label="R_FOSM − R_MC, 95 % interval")
        b.plot(x, g["diff"], "o-", color="C0", ms=3, lw=1)
        b.errorbar(
            x + 2,
            -g["nonlin_diff"],
            yerr=[g["nonlin_hi"] - g["nonlin_diff"], g["nonlin_diff"] - g["nonlin_lo"]],
            fmt="x",
            color="C2",
            ms=4,
            capsize=2,
            label="R_lin − R_MC (non-linearity, paired)",
        )
        b.set_ylabel("difference in R")
        for ax in row:
            ax.grid(alpha=0.3, which="both")
            ax.set_xticks(np.arange(0, 361, 36))
        a.legend(fontsize=7, loc="lower left")
        b.legend(fontsize=7, loc="lower left")
    for ax in axes[-1]:
        ax.set_xlabel("crank angle (deg)")
    allow = (
        "paper's allowable I ~ N(μ_I, σ_I²)"
        if name == "paper"
        else "probe allowable (fixed): "
        + ", ".join(f"{q[:4]}. {v:.3g} {UNITS[q]}" for q, v in res["probe"].items())
    )
    fig.suptitle(f"{CASES[res['case']].label}: FOSM vs Monte Carlo — {allow}", fontsize=10)
    fig.savefig(path, dpi=115)
    plt.close(fig)


def plot_moments(res, path):
    """Mean and std of the error per angle: FOSM (first order) vs MC with intervals; skewness,
    excess kurtosis and the AD p-value."""
    plt = _plt()
    t = res["allowables"]["paper"]["table"]
    fig, axes = plt.subplots(3, 3, figsize=(14, 8.5), sharex=True, constrained_layout=True)
    for row, q in zip(axes, QUANTITIES):
        g = _q(t, q)
        x = g.index.to_numpy(dtype=float)
        a, b, c = row
        a.fill_between(
            x, g["mc_mean_lo"], g["mc_mean_hi"], color="C1", alpha=0.3, label="MC mean, 95 %"
        )
        a.plot(x, g["mc_mean"], "o", color="C1", ms=3)
        a.plot(x, g["mu_i"], "-", color="C0", label="FOSM μ_i = f(μ_X)")
        a.set_ylabel(f"{q}\nerror mean ({UNITS[q]})")
        b.fill_between(
            x, g["mc_std_lo"], g["mc_std_hi"], color="C1", alpha=0.3, label="MC std, 95 %"
        )
        b.plot(x, g["mc_std"], "o", color="C1", ms=3)
        b.plot(x, g["sigma_i"], "-", color="C0", label="FOSM σ_i")
        for k, (step, sd, _) in enumerate(res["steps"]):
            b.plot(x, _q(sd.to_frame(), q).iloc[:, 0], "--", lw=1, color=f"C{k + 3}",
                   label=f"FOSM σ_i, step {step}" + ("σ" if step != "auto" else ""))
        b.set_yscale("log")
        b.set_ylabel(f"error std ({UNITS[q]})")
        c.plot(x, g["skewness"], "o-", ms=3, label="skewness")
        c.plot(x, g["excess_kurtosis"], "s-", ms=3, label="excess kurtosis")
        c.axhline(0, color="k", lw=0.6)
        c2 = c.twinx()
        c2.semilogy(x, np.maximum(g["ad_pvalue"], 1e-12), "v", color="C3", ms=4, label="AD p-value")
        c2.axhline(0.01, color="C3", lw=0.7, ls=":")
        c2.set_ylim(1e-12, 2)
        c2.set_ylabel("AD p-value (▼)", color="C3")
        c.set_ylabel("shape")
        for ax in row:
            ax.grid(alpha=0.3)
            ax.set_xticks(np.arange(0, 361, 72))
        if q == QUANTITIES[0]:
            a.legend(fontsize=7)
            b.legend(fontsize=7)
            c.legend(fontsize=7, loc="upper left")
    for ax in axes[-1]:
        ax.set_xlabel("crank angle (deg)")
    n = int(res["allowables"]["paper"]["mc"].table["n"].iloc[0])
    fig.suptitle(f"{CASES[res['case']].label}: error distribution per angle, FOSM vs Monte Carlo "
                 f"(n = {n})", fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def worst_outputs(t: pd.DataFrame) -> list:
    """Per quantity: the angle of the lowest MC reliability (probe allowable) and the angle of
    the largest AD statistic (if different)."""
    out = []
    for q in QUANTITIES:
        g = _q(t, q)
        g = g[g.index < 360]
        for a in dict.fromkeys([g["R_mc"].idxmin(), g["ad_stat"].idxmax()]):
            out.append((q, float(a)))
    return out


def plot_qq(res, path):
    from mechrel.uq.plots import plot_qq

    plt = _plt()
    nc = res["allowables"]["probe"]["normality"]
    picks = worst_outputs(res["allowables"]["probe"]["table"])
    cols = 3
    rows = int(np.ceil(len(picks) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(4.3 * cols, 4.0 * rows), squeeze=False)
    for ax, lbl in zip(axes.ravel(), picks):
        plot_qq(nc, lbl, ax=ax)
        ax.set_title(f"{lbl[0]} at {lbl[1]:g}°\n" + ax.get_title().split(": ", 1)[-1], fontsize=9)
    for ax in axes.ravel()[len(picks):]:
        ax.axis("off")
    fig.suptitle(
        f"{CASES[res['case']].label}: QQ of MC errors vs FOSM's normal at the worst angles",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_forms(res, path):
    """Signed error vs magnitude, probe allowable: FOSM and MC, one- and two-sided."""
    plt = _plt()
    t = res["allowables"]["probe"]["table"]
    fig, axes = plt.subplots(3, 1, figsize=(9, 8.5), sharex=True, constrained_layout=True)
    for ax, q in zip(axes, QUANTITIES):
        g = _q(t, q)
        x = g.index.to_numpy(dtype=float)
        ax.fill_between(x, g["R_mc_one_sided_lo"], g["R_mc_one_sided_hi"], color="C0", alpha=0.2)
        ax.plot(
            x,
            g["R_mc_one_sided"],
            "o",
            color="C0",
            ms=4,
            label="MC, one-sided P(i < I) (paper's event)",
        )
        ax.plot(
            x,
            g["R_fosm_one_sided"],
            "-",
            color="C0",
            lw=1.2,
            label="FOSM Φ(β), signed error (paper's formula)",
        )
        ax.fill_between(x, g["R_mc_lo"], g["R_mc_hi"], color="C1", alpha=0.2)
        ax.plot(x, g["R_mc"], "s", color="C1", ms=4, label="MC, two-sided P(|i| < I)")
        ax.plot(x, g["R_fosm"], "-", color="C1", lw=1.2, label="FOSM, two-sided")
        ax.set_ylabel(f"{q}: R")
        ax.grid(alpha=0.3)
        ax.set_xticks(np.arange(0, 361, 36))
        ax2 = ax.twinx()
        ax2.bar(x, g["mc_mean"], width=7, color="0.88", zorder=0)
        ax2.axhline(0, color="0.6", lw=0.6)
        ax2.set_ylabel(f"mean error ({UNITS[q]}), bars", color="0.5")
        ax.set_zorder(ax2.get_zorder() + 1)
        ax.patch.set_visible(False)
    axes[0].legend(fontsize=7, loc="lower left")
    axes[-1].set_xlabel("crank angle (deg)")
    fig.suptitle(
        f"{CASES[res['case']].label}: the signed error vs its magnitude (probe allowable)\n"
        "the one-sided event counts every negative error as safe, however large",
        fontsize=10,
    )
    fig.savefig(path, dpi=115)
    plt.close(fig)


def plot_whole_cycle(all_res, path):
    plt = _plt()
    rows = []
    for res in all_res:
        for name in ("paper", "probe"):
            wc = res["allowables"][name]["whole_cycle"]
            for g, r in wc.iterrows():
                rows.append((res["case"], name, g, r))
    groups = list(QUANTITIES) + ["all"]
    fig, axes = plt.subplots(len(all_res), 2, figsize=(12, 3.4 * len(all_res)), squeeze=False,
                             constrained_layout=True)
    for i, res in enumerate(all_res):
        for j, name in enumerate(("paper", "probe")):
            ax = axes[i][j]
            wc = res["allowables"][name]["whole_cycle"].reindex(groups)
            x = np.arange(len(groups))
            w = 0.26
            ax.bar(x - w, wc["R_min_point_fosm"], w, color="C0", label="FOSM: min point-in-time R")
            ax.bar(x, wc["R_min_point_mc"], w, color="C1", label="MC: min point-in-time R")
            ax.bar(
                x + w,
                wc["reliability"],
                w,
                color="C3",
                label="MC: whole-cycle R",
                yerr=[
                    wc["reliability"] - wc["reliability_lo"],
                    wc["reliability_hi"] - wc["reliability"],
                ],
                capsize=3,
            )
            ax.plot(
                x + w,
                wc["R_whole_cycle_lin"],
                "k_",
                ms=14,
                mew=2,
                label="whole-cycle R of FOSM's linear model",
            )
            lo = float(
                np.nanmin(wc[["R_min_point_fosm", "R_min_point_mc", "reliability_lo"]].to_numpy())
            )
            ax.set_ylim(max(0.0, lo - 0.1 * (1 - lo) - 0.005), 1.0)
            ax.set_xticks(x, groups)
            ax.grid(axis="y", alpha=0.3)
            ax.set_title(
                f"{res['case']}, {'paper' if name == 'paper' else 'probe'} allowable", fontsize=9
            )
            if i == 0 and j == 0:
                ax.legend(fontsize=7, loc="lower left")
    fig.suptitle("Whole-cycle reliability (within the allowable at every angle, jointly) vs the "
                 "minimum point-in-time reliability", fontsize=10)
    fig.savefig(path, dpi=115)
    plt.close(fig)


# ----------------------------------------------------------------------------- report
def summary_rows(res):
    rows = []
    for name in ("paper", "probe"):
        t = res["allowables"][name]["table"]
        t = t[t.index.get_level_values("crank_angle") < 360]
        for q in QUANTITIES:
            g = _q(t, q)
            k = g["diff"].abs().idxmax()
            outside = (g["diff_lo"] > 0) | (g["diff_hi"] < 0)
            nonlin = (g["nonlin_lo"] > 0) | (g["nonlin_hi"] < 0)
            wc = res["allowables"][name]["whole_cycle"].loc[q]
            rows.append(
                {
                    "case": res["case"],
                    "allowable": name,
                    "quantity": q,
                    "max_sigma_i/sigma_I": g["sigma_i_over_sigma_I"].max()
                    if name == "paper"
                    else np.nan,
                    "max|R_FOSM-R_MC|": abs(g.loc[k, "diff"]),
                    "at": k,
                    "R_FOSM_there": g.loc[k, "R_fosm"],
                    "R_MC_there": g.loc[k, "R_mc"],
                    "MC_CI_there": f"[{g.loc[k, 'R_mc_lo']:.4f}, {g.loc[k, 'R_mc_hi']:.4f}]",
                    "angles_FOSM_outside_CI": f"{int(outside.sum())}/{len(g)}",
                    "angles_nonlinearity_significant": f"{int(nonlin.sum())}/{len(g)}",
                    "angles_AD_rejects": f"{int((g['ad_pvalue'] < 0.01).sum())}/{len(g)}",
                    "max|skew|": g["skewness"].abs().max(),
                    "max|exkurt|": g["excess_kurtosis"].abs().max(),
                    "min_R_point_MC": g["R_mc"].min(),
                    "whole_cycle_R_MC": wc["reliability"],
                    "whole_cycle_CI": f"[{wc['reliability_lo']:.4f}, {wc['reliability_hi']:.4f}]",
                    "min_R_point_FOSM": g["R_fosm"].min(),
                    "max_R_one_sided_minus_two_sided_MC": (g["R_mc_one_sided"] - g["R_mc"]).max(),
                }
            )
    return rows


def write_report(out, all_res, args, wall):
    summ = pd.DataFrame([r for res in all_res for r in summary_rows(res)])
    summ.to_csv(out / "summary.csv", index=False)
    lines = [
        "# FOSM vs Monte Carlo on the nine-bar",
        "",
        f"Command: `python studies/fosm_vs_mc.py --out {args.out} --n {args.n} --rule {args.rule} "
        f"--jobs {args.jobs}" + (" --quick" if args.quick else "") + f"`; wall time {wall:.0f} s.",
        "",
        "Inputs (per case, see reliability_paper.py): clearance truncnormal CV 10 %, viscosity "
        "lognormal CV 15 % (lubricated), speed N(ω, 0.1²) rad/s. Probe allowables (fixed, FOSM "
        "R = 0.90 at the worst angle): "
        + "; ".join(
            f"{res['case']}: "
            + ", ".join(f"{q} {v:.4g} {UNITS[q]}" for q, v in res["probe"].items())
            for res in all_res
        )
        + ".",
        "",
        "Paper allowable: MC = conditional Monte Carlo (the allowable's normal integrated "
        "per sample, normal 95 % interval); probe allowable: binomial with Wilson 95 % interval. "
        "`max|R_FOSM-R_MC|` with the MC reliability and its 95 % Wilson interval at that angle; "
        "`angles_FOSM_outside_CI`: angles where R_FOSM lies outside the MC interval; "
        "`angles_nonlinearity_significant`: angles where the paired difference between the "
        "simulator and FOSM's linear model on the same sample is non-zero at 95 %; "
        "`angles_AD_rejects`: Anderson–Darling at 1 %.",
        "",
        markdown_table(summ),
        "",
    ]
    for res in all_res:
        wc = res["allowables"]["probe"]["whole_cycle"]
        wcp = res["allowables"]["paper"]["whole_cycle"]
        lines += [f"## {res['case']}: whole cycle", "",
                  "paper allowable:", "", markdown_table(wcp.reset_index()), "",
                  "probe allowable:", "", markdown_table(wc.reset_index()), ""]
        if res["steps"]:
            t = res["allowables"]["paper"]["table"]
            lines += [
                "FOSM σ_i by step (median over angles, relative to the MC std): "
                + "; ".join(
                    f"step {s}: {np.nanmedian(sd.to_numpy() / t['mc_std'].to_numpy()):.2f}"
                    for s, sd, _ in res["steps"]
                )
                + f"; ±1σ secant (used): {np.nanmedian(t['sigma_i'] / t['mc_std']):.2f}.",
                "",
            ]
        if res["n_failed"]:
            lines += [f"Failed samples: {res['n_failed']} ({res['failure_counts']}).", ""]
    lines.append("Figures: " + ", ".join(f"`{p.name}`" for p in sorted(out.glob("*.png"))) + ".")
    (out / "report.md").write_text("\n".join(lines) + "\n")
    return summ


def _cases(text: str) -> list[str]:
    """Argparse type of ``--cases``: comma-separated keys of ``CASES``."""
    keys = [k.strip() for k in text.split(",")]
    bad = [k for k in keys if k not in CASES]
    if bad:
        raise argparse.ArgumentTypeError(f"unknown case {', '.join(map(repr, bad))}; allowed: "
                                         f"comma-separated cases from {', '.join(CASES)}")
    return keys


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="results/fosm_vs_mc")
    ap.add_argument("--n", type=sample_count, default=None,
                    help="Monte Carlo samples per case (default 512; --quick 64)")
    ap.add_argument("--rule", default="sobol", choices=("sobol", "random", "latin_hypercube"))
    ap.add_argument("--seed", type=int, default=SEED)
    ap.add_argument("--cases", type=_cases, default="lub-3pi,dry-3pi",
                    help=f"comma-separated cases of reliability_paper.py ({', '.join(CASES)})")
    ap.add_argument("--quick", action="store_true", help="64 samples per case")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--cycles", type=float, default=2.0)
    ap.add_argument("--no-progress", action="store_true")
    args = ap.parse_args(argv)
    if args.n is None:
        args.n = 64 if args.quick else 512
    return report_errors(run, args, ap.prog)


def run(args) -> int:
    """The study for parsed arguments: figures, tables, report.md and summary.json in OUT."""
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    all_res = []
    for key in args.cases:
        res = analyse_case(key, n=args.n, rule=args.rule, seed=args.seed, n_jobs=args.jobs,
                           cache=out / "evaluations.sqlite", progress=not args.no_progress,
                           cycles=args.cycles, dry_steps=(0.25, "auto"))
        all_res.append(res)
        for name in ("paper", "probe"):
            t = res["allowables"][name]["table"]
            t.reset_index().to_csv(out / f"per_angle_{res['case']}_{name}.csv", index=False)
            res["allowables"][name]["whole_cycle"].reset_index().to_csv(
                out / f"whole_cycle_{res['case']}_{name}.csv", index=False)
            plot_reliability(res, name, out / f"fosm_vs_mc_{res['case']}_{name}.png")
        plot_moments(res, out / f"moments_{res['case']}.png")
        plot_qq(res, out / f"qq_{res['case']}.png")
        plot_forms(res, out / f"signed_vs_magnitude_{res['case']}.png")
    plot_whole_cycle(all_res, out / "whole_cycle.png")
    wall = time.perf_counter() - t0
    summ = write_report(out, all_res, args, wall)
    (out / "summary.json").write_text(json.dumps(
        {"argv": sys.argv, "n": args.n, "rule": args.rule, "seed": args.seed, "wall_time": wall,
         "cases": {r["case"]: {"probe_allowable": r["probe"], "inputs": r["inputs"],
                               "fosm_settings": r["fosm_settings"], "n_failed": r["n_failed"],
                               "provenance_mc": r["allowables"]["paper"]["mc"].provenance}
                   for r in all_res}}, indent=2, default=str) + "\n")
    with pd.option_context("display.width", 250, "display.max_columns", 30):
        print(summ.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    print(f"wrote {out}/ in {wall:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
