#!/usr/bin/env python
"""Model-form uncertainty of the lubricated joint: the nine-bar's §4 response errors and §5
reliability with long, short and finite-length bearings side by side.

    python studies/bearing_models.py --out results/bearing_models [--n 200] [--jobs 2] [--quick]

The case is the paper's lubricated nine-bar at 3π rad/s (``nine-bar-lubricated``: C1 and C2
lubricated, 100 cP, radial clearance 0.5 mm, bearing radius 15 mm, so journal diameter
D = 29 mm, bearing length L = 40 mm, L/D = 1.38, the paper's bearing). Only the film model of
both joints changes between the variants (:data:`VARIANTS`):

==================  ==================================================================
``long``            infinitely long bearing (Pinkus–Sternlicht, half-Sommerfeld): the
                    paper's model and the scene's default
``short``           short bearing (Ocvirk), rotation and squeeze, half-Sommerfeld
``finite``          finite-length bearing at the actual L/D (tabulated 2-D Reynolds
                    solutions), half-Sommerfeld
``finite-reynolds`` the same with the Reynolds (Swift–Stieber) cavitation condition
==================  ==================================================================

§4 (deterministic): two revolutions of the crank, the second analysed, outputs every
``--sample-deg`` degrees; the slider's displacement, velocity and acceleration errors (with
clearance − ideal) and the journal orbits of C1 and C2.

§5 (reliability), with the input distribution of ``studies/reliability_paper.py`` (clearance
truncated normal, std 10 %, ±30 %; viscosity lognormal, CV 15 %; crank speed normal, std
0.1 rad/s) and the paper's allowables I ~ N(0.012, 0.004²) m, N(0.3, 0.1²) m/s, N(18, 6²) m/s²:

* FOSM per analysis angle (every 18°, 2d + 1 = 7 simulations per variant), two-sided
  reliability P(|i| < I) and its index β = Φ⁻¹(R), as in ``studies/reliability_paper.py``;
  FOSM is deterministic: its numbers move between runs only by the finite-difference noise
  (the solver tolerance), well below the differences reported here;
* whole-cycle failure probability P_f = 1 − P(max over the cycle of |i| ≤ I) from Monte Carlo
  on the cycle extremes found on the integrator's solution (:class:`~mechrel.uq.MechanismModel`
  with ``extremes=True``), ``--n`` random samples per variant. The same seed is used for every
  variant, so every variant sees the *same* input samples (common random numbers): the
  differences between bearing models are paired and much better resolved than each P_f.
  Reported: the binomial estimate (``monte_carlo``, Wilson 95 % intervals) and the conditional
  estimate P_f = mean_k Φ((max|i_k| − μ_I)/σ_I), the same probability with the allowable's
  normal integrated exactly per sample (smaller variance; normal 95 % intervals), and the
  paired differences to the long bearing with their 95 % intervals.

Outputs (in ``--out``): ``summary.md`` (all tables), ``errors.csv`` (§4 ranges), ``runs.csv``,
``fosm_per_angle.csv``, ``fosm_minima.csv``, ``whole_cycle.csv``, ``whole_cycle_diff.csv``,
``summary.json`` (provenance), figures ``fig_errors.png``, ``fig_orbits.png``,
``fig_beta.png``, ``fig_whole_cycle.png``; Monte Carlo evaluations are cached in
``OUT/evaluations.sqlite`` (a rerun resumes).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from mechrel.cli.args import jobs, report_errors, sample_count

sys.path.insert(0, str(Path(__file__).resolve().parent))
from reliability_paper import (  # noqa: E402
    ALLOW, CASES, QUANTITIES, RTOL, markdown_table, case_inputs, case_model, forms_table,
)

PI = math.pi
SEED = 20221014
Z95 = stats.norm.ppf(0.975)
CASE = CASES["lub-3pi"]
SHOW = {"displacement": ("mm", 1e3), "velocity": ("m/s", 1.0), "acceleration": ("m/s²", 1.0)}


@dataclass(frozen=True)
class Variant:
    key: str
    label: str
    bearing: str
    cavitation: str
    color: str
    style: str

    @property
    def overrides(self) -> dict:
        out = {}
        for j in ("C1", "C2"):
            out[f"joints.{j}.lubricant.bearing"] = self.bearing
            out[f"joints.{j}.lubricant.cavitation"] = self.cavitation
        return out


VARIANTS = (
    Variant("long", "long (paper's model)", "long", "half-sommerfeld", "tab:blue", "-"),
    Variant("short", "short (Ocvirk)", "short", "half-sommerfeld", "tab:orange", "--"),
    Variant("finite", "finite L/D = 1.38", "finite", "half-sommerfeld", "tab:green", "-"),
    Variant("finite-reynolds", "finite, Reynolds cavitation", "finite", "reynolds", "tab:red",
            ":"),
)
BASE = "long"


# ------------------------------------------------------------------------------ §4 response ---

def run_response(v: Variant, sample_deg: float) -> dict:
    from mechrel.scene import load_scene
    from mechrel.simulation import simulate

    ov = {"joints.C1.clearance": CASE.clearance, "joints.C2.clearance": CASE.clearance,
          "joints.C1.lubricant.viscosity": CASE.viscosity,
          "joints.C2.lubricant.viscosity": CASE.viscosity,
          "drivers.crank2.speed": CASE.speed, "drivers.crank1.speed": -CASE.speed,
          **v.overrides, "analysis.cycles": 2,
          "analysis.sample_step_angle": math.radians(sample_deg)}
    scene = load_scene("nine-bar-lubricated", overrides=ov)
    t0 = time.perf_counter()
    res = simulate(scene)
    wall = time.perf_counter() - t0
    keep = res.crank_angle >= 360.0 - 1e-9
    st = res.stats
    out = {"variant": v, "angle": res.crank_angle[keep] - 360.0,
           "errors": {q: res.error("slider", q)[keep] for q in QUANTITIES},
           "orbits": {j: (res.orbits[j]["ex"][keep], res.orbits[j]["ey"][keep])
                      for j in ("C1", "C2")},
           "clearance": {j: scene.joints[j].clearance for j in ("C1", "C2")},
           "stats": {"variant": v.key, "integrator": st["integrator"], "wall_time_s": wall,
                     "n_steps": st["n_steps"], "n_rhs": st["n_rhs"],
                     "n_rejected": st["n_rejected"]}}
    for j in ("C1", "C2"):
        eps = float(res.orbits[j]["eps"][keep].max())
        out["stats"][f"max_eps_{j}"] = eps
        out["stats"][f"min_film_{j}_um"] = (1.0 - eps) * scene.joints[j].clearance * 1e6
    return out


def error_rows(runs) -> pd.DataFrame:
    rows = []
    for key, r in runs.items():
        for q in QUANTITIES:
            e = r["errors"][q]
            k = int(np.argmax(np.abs(e)))
            rows.append({"variant": key, "quantity": q, "min": float(e.min()),
                         "max": float(e.max()), "max_abs": float(np.abs(e).max()),
                         "angle_of_peak_deg": float(r["angle"][k])})
    df = pd.DataFrame(rows)
    base = df[df["variant"] == BASE].set_index("quantity")["max_abs"]
    df["max_abs_over_long"] = df["max_abs"] / df["quantity"].map(base)
    return df


# -------------------------------------------------------------------------- §5 reliability ---

def variant_model(v: Variant, cycles: float):
    return case_model(CASE, cycles=cycles, overrides=v.overrides)


def run_fosm(model, *, n_jobs, cache, progress):
    from mechrel.uq import fosm

    return fosm(model=model, inputs=case_inputs(CASE), event="two-sided",
                step="auto", noise=RTOL, n_jobs=n_jobs, cache=cache, progress=progress)


def run_mc(model, *, n, n_jobs, cache, progress):
    from mechrel.uq import monte_carlo

    return monte_carlo(model=model, inputs=case_inputs(CASE), n=n,
                       rule="random", seed=SEED, event="two-sided", n_jobs=n_jobs, cache=cache,
                       progress=progress)


def fosm_long(results) -> pd.DataFrame:
    """FOSM per analysis angle and at the cycle extreme max|i|, all variants."""
    parts = []
    for key, r in results.items():
        ft = forms_table(r.table)
        ft.insert(0, "variant", key)
        parts.append(ft.reset_index())
    return pd.concat(parts, ignore_index=True)


def fosm_minima(long: pd.DataFrame) -> pd.DataFrame:
    rows = []
    ang = long["crank_angle"].map(lambda a: not isinstance(a, str))
    for (key, q), g in long[ang].groupby(["variant", "quantity"], sort=False):
        g = g[g["crank_angle"].astype(float) < 360]          # 360° repeats 0°
        k = g["beta_two"].idxmin()
        ext = long[(long["variant"] == key) & (long["quantity"] == q)
                   & (long["crank_angle"] == "max_abs")]
        rows.append({"variant": key, "quantity": q, "angle": float(g.loc[k, "crank_angle"]),
                     "beta_min": g.loc[k, "beta_two"], "R_min": g.loc[k, "R_two"],
                     "mu_i": g.loc[k, "mu_i"], "sigma_i": g.loc[k, "sigma_i"],
                     "beta_cycle_fosm": float(ext["beta_two"].iloc[0]) if len(ext) else np.nan,
                     "Pf_cycle_fosm": float(1 - ext["R_two"].iloc[0]) if len(ext) else np.nan})
    df = pd.DataFrame(rows)
    base = df[df["variant"] == BASE].set_index("quantity")
    df["dbeta_min"] = df["beta_min"] - df["quantity"].map(base["beta_min"])
    return df


def conditional_pf(ev) -> dict:
    """Per quantity and "all": per-sample P(fail | x_k) on the cycle extreme max|i| with the
    allowable's normal integrated exactly; "all" = 1 − Π_q P(I_q ≥ max|i_q|) (independent
    allowables per quantity, as monte_carlo draws them)."""
    idx = ev.output_index
    q = np.asarray(idx.get_level_values("quantity")).astype(str)
    a = idx.get_level_values("crank_angle")
    Y = ev.Y[ev.ok]
    out = {}
    R_all = np.ones(Y.shape[0])
    for g in QUANTITIES:
        col = [i for i in range(len(idx)) if q[i] == g and isinstance(a[i], str)
               and a[i] == "max_abs"][0]
        mu_I, sd_I = ALLOW[g]
        R = stats.norm.cdf((mu_I - np.abs(Y[:, col])) / sd_I)
        out[g] = 1.0 - R
        R_all = R_all * R
    out["all"] = 1.0 - R_all
    return out


def mean_ci(x: np.ndarray):
    m = float(x.mean())
    se = float(x.std(ddof=1) / math.sqrt(x.size))
    return m, m - Z95 * se, m + Z95 * se


def whole_cycle_tables(mc, fos_min):
    rows, diffs = [], []
    cond = {k: conditional_pf(r.evaluations) for k, r in mc.items()}
    for key, r in mc.items():
        w = r.whole_cycle
        for g in (*QUANTITIES, "all"):
            m, lo, hi = mean_ci(cond[key][g])
            fo = fos_min[(fos_min["variant"] == key) & (fos_min["quantity"] == g)]
            rows.append({"variant": key, "group": g, "n": int(w.loc[g, "n"]),
                         "Pf_binomial": 1 - w.loc[g, "reliability"],
                         "Pf_binomial_lo": 1 - w.loc[g, "reliability_hi"],
                         "Pf_binomial_hi": 1 - w.loc[g, "reliability_lo"],
                         "Pf_conditional": m, "Pf_conditional_lo": max(lo, 0.0),
                         "Pf_conditional_hi": min(hi, 1.0),
                         "beta_cycle": -stats.norm.ppf(m),
                         "Pf_cycle_fosm": float(fo["Pf_cycle_fosm"].iloc[0]) if len(fo) else np.nan,
                         "n_failed_samples": r.n_failed})
        if key == BASE:
            continue
        # paired: the same input samples (same seed, same n) for both variants
        okb, okv = mc[BASE].evaluations.ok, r.evaluations.ok
        both = okb & okv
        for g in (*QUANTITIES, "all"):
            cb = np.full(okb.size, np.nan)
            cv = np.full(okv.size, np.nan)
            cb[okb] = cond[BASE][g]
            cv[okv] = cond[key][g]
            d = cv[both] - cb[both]
            m, lo, hi = mean_ci(d)
            pb, pv = float(cb[both].mean()), float(cv[both].mean())
            diffs.append({"variant": key, "group": g, "n_paired": int(both.sum()),
                          "Pf_long": pb, "Pf_variant": pv, "dPf": m, "dPf_lo": lo, "dPf_hi": hi,
                          "Pf_ratio": pv / pb if pb > 0 else np.nan,
                          "dbeta_cycle": (-stats.norm.ppf(pv)) - (-stats.norm.ppf(pb)),
                          "corr": float(np.corrcoef(cb[both], cv[both])[0, 1])})
    return pd.DataFrame(rows), pd.DataFrame(diffs)


# --------------------------------------------------------------------------------- figures ---

def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": 10, "axes.titlesize": 10, "legend.fontsize": 9,
                         "axes.grid": True, "grid.alpha": 0.3})
    return plt


def plot_errors(runs, path):
    plt = _plt()
    fig, axes = plt.subplots(3, 1, figsize=(8.0, 8.6), sharex=True, constrained_layout=True)
    for ax, q in zip(axes, QUANTITIES):
        unit, f = SHOW[q]
        for r in runs.values():
            v = r["variant"]
            ax.plot(r["angle"], r["errors"][q] * f, color=v.color, ls=v.style, lw=1.3,
                    label=v.label)
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_ylabel(f"{q} error ({unit})")
    axes[0].legend(loc="best", ncol=2)
    axes[-1].set_xlim(0, 360)
    axes[-1].set_xticks(np.arange(0, 361, 36))
    axes[-1].set_xlabel("crank angle in the analysed (second) revolution (deg)")
    fig.suptitle("Nine-bar, lubricated C1 and C2 (100 cP, c = 0.5 mm, L/D = 1.38), ∓3π rad/s:\n"
                 "slider response error (with clearance − ideal) by bearing model",
                 fontsize=10.5)
    fig.savefig(path, dpi=130)
    plt.close(fig)


def plot_orbits(runs, path):
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(11.0, 6.0), layout="constrained")
    th = np.linspace(0, 2 * PI, 400)
    for ax, j in zip(axes, ("C1", "C2")):
        c = next(iter(runs.values()))["clearance"][j]
        ax.plot(c * 1e3 * np.cos(th), c * 1e3 * np.sin(th), color="0.35", lw=1.0, ls=":")
        for r in runs.values():
            v = r["variant"]
            ex, ey = r["orbits"][j]
            ax.plot(ex * 1e3, ey * 1e3, color=v.color, ls=v.style, lw=1.3,
                    label=f"{v.label}: max ε = {r['stats'][f'max_eps_{j}']:.3f}")
        ax.plot(0, 0, "+", color="k", ms=8)
        ax.set_aspect("equal")
        lim = c * 1e3 * 1.12
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_xlabel("e_x (mm)")
        ax.set_ylabel("e_y (mm)")
        ax.set_title(f"joint {j}")
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), fontsize=8.5, frameon=False)
    fig.suptitle("Journal centre relative to the bearing centre over the analysed revolution "
                 "(dotted: the clearance circle)", fontsize=10)
    fig.savefig(path, dpi=130, bbox_inches="tight")
    plt.close(fig)


def plot_beta(long, variants, path):
    plt = _plt()
    fig, axes = plt.subplots(3, 2, figsize=(11, 8.6), sharex=True, constrained_layout=True)
    ang = long["crank_angle"].map(lambda a: not isinstance(a, str))
    d = long[ang].copy()
    d["crank_angle"] = d["crank_angle"].astype(float)
    for row, q in zip(axes, QUANTITIES):
        base = d[(d["variant"] == BASE) & (d["quantity"] == q)].set_index("crank_angle")
        for v in variants:
            g = d[(d["variant"] == v.key) & (d["quantity"] == q)].set_index("crank_angle")
            row[0].plot(g.index, g["beta_two"], marker="o", ms=3.5, color=v.color, ls=v.style,
                        label=v.label)
            if v.key != BASE:
                row[1].plot(g.index, g["beta_two"] - base["beta_two"], marker="o", ms=3.5,
                            color=v.color, ls=v.style, label=v.label)
        row[1].axhline(0, color="tab:blue", lw=1)
        row[0].set_ylabel(f"{q}\nβ = Φ⁻¹(P(|i| < I))")
        row[1].set_ylabel(f"{q}\nβ − β(long)")
    for ax in axes[-1]:
        ax.set_xticks(np.arange(0, 361, 36))
        ax.set_xlabel("crank angle (deg)")
    axes[0][0].set_title("FOSM two-sided reliability index per crank angle")
    axes[0][1].set_title("shift of β caused by the bearing model alone")
    h, lbl = axes[0][0].get_legend_handles_labels()
    fig.legend(h, lbl, loc="outside lower center", ncol=len(lbl))
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_whole_cycle(wc, variants, path, n):
    plt = _plt()
    groups = (*QUANTITIES, "all")
    fig, axes = plt.subplots(1, len(groups), figsize=(13, 4.4), constrained_layout=True)
    for ax, g in zip(axes, groups):
        for i, v in enumerate(variants):
            r = wc[(wc["variant"] == v.key) & (wc["group"] == g)].iloc[0]
            m = r["Pf_conditional"]
            ax.errorbar([i], [m], yerr=[[m - r["Pf_conditional_lo"]],
                                        [r["Pf_conditional_hi"] - m]],
                        fmt="o", color=v.color, capsize=4, label=v.label if g == "all" else None)
            mb = r["Pf_binomial"]
            ax.errorbar([i + 0.22], [mb], yerr=[[mb - r["Pf_binomial_lo"]],
                                                [r["Pf_binomial_hi"] - mb]],
                        fmt="s", mfc="none", color=v.color, capsize=3, alpha=0.7)
            if np.isfinite(r["Pf_cycle_fosm"]):
                ax.plot([i - 0.22], [r["Pf_cycle_fosm"]], "x", color=v.color, ms=7)
        ax.set_xticks(range(len(variants)))
        ax.set_xticklabels([v.key for v in variants], rotation=25)
        ax.set_title(g if g != "all" else "all three quantities")
        ax.set_ylim(bottom=0)
    axes[0].set_ylabel("whole-cycle P_f = 1 − P(max over the cycle |i| ≤ I)")
    fig.legend(loc="outside lower center", ncol=len(variants))
    fig.suptitle(f"Whole-cycle failure probability by bearing model, Monte Carlo n = {n} on the "
                 "cycle extremes (the same samples for every model)\n● conditional estimate, "
                 "□ binomial, both with 95 % intervals; × FOSM on max|i|", fontsize=10)
    fig.savefig(path, dpi=120)
    plt.close(fig)


# ------------------------------------------------------------------------------------ main ---

def _fmt_rng(lo, hi, q):
    f = SHOW[q][1]
    return f"[{lo * f:.4g}, {hi * f:.4g}]"


def write_summary(out, err, run_rows, fmin, wc, diff, args, wall):
    lines = [
        "# Bearing model (long / short / finite) on the nine-bar: §4 errors and §5 reliability",
        "",
        f"Command: `python studies/bearing_models.py --out {args.out} --n {args.n} --jobs "
        f"{args.jobs} --cycles {args.cycles:g} --sample-deg {args.sample_deg:g}`"
        f"{' --quick' if args.quick else ''}; wall time {wall:.0f} s.",
        "",
        "## §4: slider error ranges over the analysed revolution (mm, m/s, m/s²)",
        "",
        "| variant | quantity | [min, max] | max abs / long | angle of peak (deg) |",
        "|---|---|---|---|---|",
    ]
    for r in err.itertuples():
        lines.append(f"| {r.variant} | {r.quantity} | {_fmt_rng(r.min, r.max, r.quantity)} | "
                     f"{r.max_abs_over_long:.3f} | {r.angle_of_peak_deg:.1f} |")
    lines += [
        "",
        "## Runs",
        "",
        markdown_table(pd.DataFrame(run_rows)),
        "",
        "## §5: FOSM minimum β over the analysis angles, and FOSM on the cycle extreme",
        "",
        markdown_table(fmin),
        "",
        f"## §5: whole-cycle P_f, Monte Carlo n = {args.n} per variant (same samples)",
        "",
        markdown_table(wc),
        "",
        "## Paired differences to the long bearing (conditional estimates)",
        "",
        markdown_table(diff),
        "",
    ]
    (out / "summary.md").write_text("\n".join(lines) + "\n", encoding="utf-8")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="results/bearing_models", help="output folder")
    ap.add_argument("--n", type=sample_count, default=200,
                    help="Monte Carlo samples per bearing model (default 200)")
    ap.add_argument("--jobs", type=jobs, default=2,
                    help="parallel worker processes (default 2)")
    ap.add_argument("--cycles", type=float, default=2.0,
                    help="simulated cycles per sample; the last is analysed (default 2)")
    ap.add_argument("--sample-deg", type=float, default=0.25,
                    help="§4 output sampling in degrees of crank rotation (default 0.25; the "
                         "lubricated ranges are converged to 0.1 %% at 0.25°)")
    ap.add_argument("--quick", action="store_true",
                    help="smoke test: the long and finite bearings only, n = 16")
    ap.add_argument("--no-cache", action="store_true", help="do not use OUT/evaluations.sqlite")
    ap.add_argument("--no-progress", action="store_true")
    args = ap.parse_args(argv)
    if args.quick:
        args.n = min(args.n, 16)
    return report_errors(run, args, ap.prog)


def run(args) -> int:
    variants = tuple(v for v in VARIANTS if not args.quick or v.key in (BASE, "finite"))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    cache = None if args.no_cache else out / "evaluations.sqlite"
    progress = not args.no_progress
    t0 = time.perf_counter()
    # the models first: a bad setting (--cycles) is reported before anything runs
    models = {v.key: variant_model(v, args.cycles) for v in variants}

    # load (or compile) the kernels first, so that the §4 wall times are warm
    from mechrel.scene import load_scene
    from mechrel.simulation import simulate

    simulate(load_scene("nine-bar-lubricated", overrides={"analysis.cycles": 0.01}))
    runs = {}
    for v in variants:
        runs[v.key] = run_response(v, args.sample_deg)
        s = runs[v.key]["stats"]
        print(f"§4 {v.key:16s} {s['wall_time_s']:6.2f} s  steps {s['n_steps']:5d}  max ε C1 "
              f"{s['max_eps_C1']:.4f}  C2 {s['max_eps_C2']:.4f}", flush=True)
    err = error_rows(runs)
    run_rows = [r["stats"] for r in runs.values()]
    err.to_csv(out / "errors.csv", index=False)
    pd.DataFrame(run_rows).to_csv(out / "runs.csv", index=False)
    plot_errors(runs, out / "fig_errors.png")
    plot_orbits(runs, out / "fig_orbits.png")

    fos, mc = {}, {}
    for v in variants:
        t1 = time.perf_counter()
        fos[v.key] = run_fosm(models[v.key], n_jobs=args.jobs, cache=cache, progress=progress)
        print(f"§5 {v.key:16s} FOSM in {time.perf_counter() - t1:.1f} s", flush=True)
    long = fosm_long(fos)
    fmin = fosm_minima(long)
    long.to_csv(out / "fosm_per_angle.csv", index=False)
    fmin.to_csv(out / "fosm_minima.csv", index=False)
    plot_beta(long, variants, out / "fig_beta.png")

    for v in variants:
        t1 = time.perf_counter()
        mc[v.key] = run_mc(models[v.key], n=args.n, n_jobs=args.jobs, cache=cache,
                           progress=progress)
        print(f"§5 {v.key:16s} Monte Carlo n = {args.n} in {time.perf_counter() - t1:.1f} s "
              f"({mc[v.key].n_failed} failed)", flush=True)
    wc, diff = whole_cycle_tables(mc, fmin)
    wc.to_csv(out / "whole_cycle.csv", index=False)
    diff.to_csv(out / "whole_cycle_diff.csv", index=False)
    plot_whole_cycle(wc, variants, out / "fig_whole_cycle.png", args.n)

    wall = time.perf_counter() - t0
    prov = {k: {"fosm": {"model_cache_key": fos[k].provenance["model_cache_key"],
                         "settings": fos[k].provenance["settings"]},
                "monte_carlo": {"model_cache_key": mc[k].provenance["model_cache_key"],
                                "seed": mc[k].provenance["seed"],
                                "settings": mc[k].provenance["settings"],
                                "failure_counts": mc[k].failure_counts}}
            for k in fos}
    (out / "summary.json").write_text(
        json.dumps(
            {
                "argv": sys.argv,
                "variants": [v.key for v in variants],
                "wall_time": wall,
                "versions": next(iter(fos.values())).provenance["versions"],
                "provenance": prov,
            },
            indent=2,
            default=str,
        )
        + "\n"
    )
    write_summary(out, err, run_rows, fmin, wc, diff, args, wall)
    pd.set_option("display.width", 200)
    print(err.to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    print(fmin.to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    print(wc.to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    print(diff.to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    print(f"wrote {out}/ (summary.md, *.csv, *.png) in {wall:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
