"""What accuracy costs for the estimators on the mechanism model: FOSM, Monte Carlo (N),
polynomial chaos (order) and Sobol' (N) against a high-sample reference.

The model
---------
The default study (``load_study("nine-bar-lubricated")``: clearance, viscosity and crank speed
uncertain; two cycles, the second analysed; slider errors every 18°, 3 × 21 outputs) with the
scene's ``radau`` at ``--rtol`` (default 1e-5, atol = 1e-3 rtol) instead of 1e-7: ≈ 30 % cheaper
per evaluation, and ``mechrel accuracy nine-bar-lubricated`` measures its pointwise error at
≈ 1e-3 of the error curves' range, far below the spread the inputs cause (measured on 8
samples: the outputs at rtol 1e-5 and 1e-8 differ by at most 0.3–0.5 % of the reference
standard deviation at the worst angles). Every estimator evaluates through one persistent
cache, so the reference samples are computed once and a rerun of the script only analyses.

The tolerance
-------------
The paper's allowables (0.012 ± 0.004 m, 0.3 ± 0.1 m/s, 18 ± 6 m/s²) are 10–100 × the errors of
the lubricated nine-bar, so every reliability is Φ(3) (the allowable's own spread) and no
estimator can be told apart. The benchmark therefore uses a **fixed tolerance per quantity**
(``Allowable(T_q, 0)``, ``allowable_mode="fixed"``, two-sided |e| ≤ T_q) with T_q the reference
sample's ``--quantile`` (default 0.9) quantile of the peak |error| over the cycle, rounded to two
significant digits: the whole-cycle reliability is then ≈ 0.9 and the failure probabilities are
resolvable with a few thousand samples.

Reference
---------
* reliability, moments: Monte Carlo on ``--n-ref`` scrambled Sobol' points (seed 1);
* Sobol' indices of the peak |error| per quantity: a regression PCE of order ``--ref-order`` on
  the same reference points (≈ 24 points per term at order 6), validated by its leave-one-out
  error, by a fit on half the points predicting the other half, and by the change of the indices
  from order ``ref-order − 1``.

Estimators (seed 2, independent of the reference)
-------------------------------------------------
FOSM (2d + 1 = 7 evaluations, automatic step from the model's rtol), Monte Carlo with N = 32 …
1024 Sobol' points (nested: the N = 32 design is the first 32 points of the N = 1024 one, so
they cost 1024 evaluations together, but each N is analysed alone), PCE orders 1–4 (regression,
oversampling 2, Sobol' points; reliability by Monte Carlo on the surrogate, 2¹⁵ points; indices
by a PCE of the same order on the peak |error|), Sobol' (Saltelli, N base samples, (d + 2)·N
evaluations, ``reducer=peak_abs``).

Errors (absolute, against the reference)
----------------------------------------
* ``R_min``: max over quantities of |min_θ R̂(θ) − min_θ R_ref(θ)| (the worst point-in-time
  reliability of the cycle);
* ``R_point``: max over all 63 outputs of |R̂ − R_ref|;
* ``R_cycle``: max over quantities of |R̂_cycle − R_cycle,ref| (P(|e| ≤ T at every angle));
  FOSM has no whole-cycle estimate;
* ``moments``: max over quantities, at the reference's worst angle, of |μ̂ − μ| / σ_ref and
  |σ̂ − σ| / σ_ref;
* ``sobol``: max over quantities and inputs of |Ŝ1 − S1_ref| and |ŜT − ST_ref|.

Cost
----
Number of model evaluations (exact), and wall time = evaluations × the measured wall time per
evaluation of the reference run (its evaluation wall time / its model calls, with ``--jobs``
workers) + the estimator's own analysis time (its provenance wall time when all its evaluations
come from the cache). The machine is shared: absolute seconds are noisy, ratios are not.

Run (≈ 15 min on 2 busy cores the first time, ≈ 1 min from the cache; the defaults were
sized for that: larger designs via ``--n-ref``, ``--mc-n``, ``--sobol-n``)::

    python benchmarks/bench_estimators.py --jobs 2 --cache results/estimators/evaluations.sqlite
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from mechrel.study.study import load_study  # noqa: E402
from mechrel.uq import (Allowable, MechanismModel, evaluate, fosm, monte_carlo,  # noqa: E402
                        monte_carlo_design, peak_abs, polynomial_chaos, sobol_indices)

FIGDIR = Path(__file__).resolve().parents[1] / "docs" / "figures" / "performance"
REF_SEED, EST_SEED = 1, 2


def build(rtol):
    st = load_study("nine-bar-lubricated")
    ov = dict(st.scene_overrides)
    ov.update({"solver.rtol": rtol, "solver.atol": rtol * 1e-3})
    model = MechanismModel(st.scene, dict(st.paths), output=st.output, quantities=st.quantities,
                           angle_step=st.angle_step, cycles=st.cycles, overrides=ov)
    return st, model, st.uncertain_inputs()


def rel_frame(table):
    """Point-in-time reliabilities as a (quantity, angle) Series."""
    return table["reliability"]


def metrics(ref, *, R=None, Rcycle=None, mean=None, std=None, S=None):
    out = {}
    qs = ref["quantities"]
    if R is not None:
        out["R_point"] = float(np.max(np.abs(R.values - ref["R"].values)))
        out["R_min"] = float(max(abs(R.loc[q].min() - ref["R"].loc[q].min()) for q in qs))
    if Rcycle is not None:
        out["R_cycle"] = float(max(abs(Rcycle[q] - ref["Rcycle"][q]) for q in qs))
    if mean is not None:
        e = []
        for q in qs:
            a = ref["worst"][q]
            s = ref["std"].loc[(q, a)]
            e += [abs(mean.loc[(q, a)] - ref["mean"].loc[(q, a)]) / s,
                  abs(std.loc[(q, a)] - s) / s]
        out["moments"] = float(max(e))
    if S is not None:
        out["sobol"] = float(np.max(np.abs(S.values - ref["S"].loc[S.index, S.columns].values)))
    return out


def pce_indices(res, names):
    f = res.to_frame()
    rows = {}
    for out in f.index:
        q = str(out[0] if isinstance(out, tuple) else out).removeprefix("peak_abs_")
        rows[q] = {**{("S1", n): f.loc[out, f"S1_{n}"] for n in names},
                   **{("ST", n): f.loc[out, f"ST_{n}"] for n in names}}
    return pd.DataFrame(rows).T


def sobol_frame(res, names):
    f = res.to_frame()
    rows = {}
    for (out, inp), r in f.iterrows():
        q = str(out[0] if isinstance(out, tuple) else out).removeprefix("peak_abs_")
        rows.setdefault(q, {})[("S1", inp)] = r["S1"]
        rows[q][("ST", inp)] = r["ST"]
    return pd.DataFrame(rows).T


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rtol", type=float, default=1e-5)
    ap.add_argument("--n-ref", type=int, default=2048)
    ap.add_argument("--ref-order", type=int, default=6)
    ap.add_argument("--quantile", type=float, default=0.9)
    ap.add_argument("--mc-n", type=int, nargs="*", default=[32, 64, 128, 256, 512, 1024])
    ap.add_argument("--pce-orders", type=int, nargs="*", default=[1, 2, 3, 4])
    ap.add_argument("--sobol-n", type=int, nargs="*", default=[16, 32, 64, 128])
    ap.add_argument("--replicates", type=int, default=4,
                    help="independent seeds per estimator setting (medians and ranges plotted)")
    ap.add_argument("--replicate-max-evals", type=int, default=400,
                    help="settings costing more evaluations run with one seed only")
    ap.add_argument("--replot", action="store_true",
                    help="redraw the figures from --out (estimators.csv, reference.json)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--cache", default="results/estimators/evaluations.sqlite")
    ap.add_argument("--out", default="results/estimators")
    ap.add_argument("--figdir", default=str(FIGDIR))
    a = ap.parse_args(argv)
    out = Path(a.out)
    if a.replot:
        agg = aggregate(pd.read_csv(out / "estimators.csv"))
        agg.to_csv(out / "estimators_summary.csv", index=False)
        return plot(agg, json.loads((out / "reference.json").read_text()), Path(a.figdir))
    out.mkdir(parents=True, exist_ok=True)
    Path(a.cache).parent.mkdir(parents=True, exist_ok=True)
    st, model, inputs = build(a.rtol)
    names = list(inputs.names)
    kw = dict(n_jobs=a.jobs, cache=a.cache, progress=False)

    # warm the numba cache in the parent before the pool starts, and time one evaluation
    x0 = np.asarray(inputs.mean, dtype=float)
    model.evaluate(x0)
    t, c = time.perf_counter(), time.process_time()
    model.evaluate(x0)
    one = {"wall": time.perf_counter() - t, "cpu": time.process_time() - c}
    print("one evaluation (in-process, warm):", one, flush=True)

    # ---------------- reference
    X_ref = monte_carlo_design(inputs, n=a.n_ref, rule="sobol", seed=REF_SEED)
    ev_ref = evaluate(model, X_ref, **kw)
    # the throughput is stored next to the cache: a run from a full cache has nothing to time
    pe_file = Path(str(a.cache) + ".per_eval.json")
    if ev_ref.n_model_calls >= 4 * a.jobs:
        per_eval = ev_ref.wall_time / ev_ref.n_model_calls
        pe_file.write_text(json.dumps(
            {"wall_per_eval": per_eval, "jobs": a.jobs, "calls": ev_ref.n_model_calls,
             "wall": ev_ref.wall_time, "one": one}))
    elif pe_file.exists():
        per_eval = json.loads(pe_file.read_text())["wall_per_eval"]
    else:
        per_eval = one["wall"] / a.jobs
        print(f"no timed reference run: assuming {per_eval:.3f} s per evaluation "
              "(one in-process evaluation / jobs)", flush=True)
    (out / "per_eval.json").write_text(json.dumps({"wall_per_eval": per_eval}))
    print(f"reference: {ev_ref.n} samples, {ev_ref.n_model_calls} computed in "
          f"{ev_ref.wall_time:.0f} s; {per_eval:.3f} s/evaluation with {a.jobs} jobs", flush=True)
    idx = ev_ref.output_index
    qs = list(dict.fromkeys(idx.get_level_values("quantity")))
    peaks = ev_ref.reduce(peak_abs)
    T = {}
    for k, q in enumerate(peaks.output_index):
        qq = str(q[0] if isinstance(q, tuple) else q).removeprefix("peak_abs_")
        v = float(np.quantile(peaks.Y[:, k], a.quantile))
        T[qq] = float(f"{v:.2g}")
    allow = {q: Allowable(T[q], 0.0) for q in qs}
    mc_kw = dict(allowable=allow, allowable_mode="fixed", progress=False)
    mref = monte_carlo(evaluations=ev_ref, seed=REF_SEED, **mc_kw)
    R_ref = rel_frame(mref.table)
    worst = {q: float(R_ref.loc[q].idxmin()) for q in qs}
    ref = {"quantities": qs, "R": R_ref, "mean": mref.table["mean"], "std": mref.table["std"],
           "Rcycle": {q: float(mref.whole_cycle.loc[q, "reliability"]) for q in qs},
           "worst": worst}
    # Sobol' reference: high-order PCE on the peak |error|, validated
    pref = polynomial_chaos(evaluations=peaks, inputs=inputs, order=a.ref_order, progress=False)
    pref_lo = polynomial_chaos(evaluations=peaks, inputs=inputs, order=a.ref_order - 1,
                               progress=False)
    half = a.n_ref // 2
    from mechrel.uq import Evaluations
    ph = polynomial_chaos(evaluations=Evaluations.from_arrays(
        peaks.X[:half], peaks.Y[:half], input_names=peaks.input_names,
        output_index=peaks.output_index), inputs=inputs, order=a.ref_order, progress=False)
    pred = ph.predict(peaks.X[half:])
    holdout = (np.mean((pred - peaks.Y[half:]) ** 2, axis=0) / np.var(peaks.Y[half:], axis=0))
    ref["S"] = pce_indices(pref, names)
    S_lo = pce_indices(pref_lo, names)
    # surrogate cross-check of the reliability reference
    pr = polynomial_chaos(evaluations=ev_ref, inputs=inputs, order=a.ref_order, progress=False)
    prr = pr.reliability(n=2 ** 16, seed=3, **mc_kw)
    R_se = float(np.max(mref.table["reliability_hi"] - mref.table["reliability_lo"]) / 2)
    noise = {q: float(model.output_noise) for q in qs}
    refinfo = {
        "T": T, "worst_angle": worst, "R_min_ref": {q: float(R_ref.loc[q].min()) for q in qs},
        "R_cycle_ref": ref["Rcycle"], "R_ci_halfwidth_max": R_se,
        "mean_worst": {q: float(ref["mean"].loc[(q, worst[q])]) for q in qs},
        "std_worst": {q: float(ref["std"].loc[(q, worst[q])]) for q in qs},
        "skew_worst": {q: float(mref.table["skewness"].loc[(q, worst[q])]) for q in qs},
        "kurt_worst": {q: float(mref.table["excess_kurtosis"].loc[(q, worst[q])]) for q in qs},
        "S_ref": {f"{q}|{k[0]}|{k[1]}": float(v) for q, r in ref["S"].iterrows()
                  for k, v in r.items()},
        "S_ref_change_from_lower_order": float(np.max(np.abs(ref["S"].values - S_lo.values))),
        "pce_ref_loo": pref.to_frame()["loo_error"].to_dict(),
        "pce_ref_holdout_rel_mse": dict(zip(map(str, peaks.output_index), holdout.tolist())),
        "pce_surrogate_vs_mc_ref": metrics(ref, R=prr.table["reliability"],
                                           Rcycle={q: float(prr.whole_cycle.loc[q, "reliability"])
                                                   for q in qs}),
        "rtol": a.rtol, "noise": noise, "per_eval": per_eval, "n_ref": a.n_ref,
    }
    print(json.dumps(refinfo, indent=1, default=str), flush=True)
    (out / "reference.json").write_text(json.dumps(refinfo, indent=1, default=str))

    rows = []

    def record(method, setting, res_prov, n_evals, seed, extra_time=0.0, **m):
        analysis = res_prov["wall_time"] if res_prov.get("n_computed", 0) == 0 else None
        row = {"method": method, "setting": setting, "seed": seed, "n_evals": n_evals,
               "wall_est": n_evals * per_eval + (analysis or 0.0) + extra_time,
               "wall_provenance": res_prov["wall_time"], "computed": res_prov.get(
                   "n_computed", 0), **metrics(ref, **m)}
        rows.append(row)
        print(row, flush=True)
        pd.DataFrame(rows).to_csv(out / "estimators.csv", index=False)

    def analysed(fn):
        """Run an estimator twice: the first fills the cache, the second (all cached) gives
        the analysis time."""
        fn()
        return fn()

    # ---------------- FOSM (deterministic: one run)
    f = analysed(lambda: fosm(model=model, inputs=inputs, allowable=allow, **kw))
    record("FOSM", "2d+1", f.provenance, f.provenance["n_evaluations"], seed=None,
           R=f.table["reliability"], mean=f.table["mean"], std=f.table["std"])
    seeds = [EST_SEED + r for r in range(a.replicates)]

    def seeds_for(n_evals):
        return seeds if n_evals <= a.replicate_max_evals else seeds[:1]

    # ---------------- MC
    for n in a.mc_n:
        for sd in seeds_for(n):
            r = analysed(lambda: monte_carlo(model=model, inputs=inputs, n=n, rule="sobol",
                                             seed=sd, **mc_kw, n_jobs=a.jobs, cache=a.cache))
            record("MC", f"N={n}", r.provenance, n, seed=sd, R=r.table["reliability"],
                   Rcycle={q: float(r.whole_cycle.loc[q, "reliability"]) for q in qs},
                   mean=r.table["mean"], std=r.table["std"])
    # ---------------- PCE
    for k in a.pce_orders:
        for sd in seeds:
            p = analysed(lambda: polynomial_chaos(model=model, inputs=inputs, order=k, seed=sd,
                                                  **kw))
            t0 = time.perf_counter()
            pr = p.reliability(n=2 ** 15, seed=3, **mc_kw)
            pp = polynomial_chaos(evaluations=p.evaluations.reduce(peak_abs), inputs=inputs,
                                  order=k, progress=False)
            extra = time.perf_counter() - t0
            pf = p.to_frame()
            record("PCE", f"order {k}", p.provenance, p.provenance["n_evaluations"],
                   seed=sd, extra_time=extra, R=pr.table["reliability"],
                   Rcycle={q: float(pr.whole_cycle.loc[q, "reliability"]) for q in qs},
                   mean=pf["mean"], std=pf["std"], S=pce_indices(pp, names))
    # ---------------- Sobol'
    for n in a.sobol_n:
        for sd in seeds_for((len(names) + 2) * n):
            s = analysed(lambda: sobol_indices(model=model, inputs=inputs, n=n, seed=sd,
                                               reducer=peak_abs, **kw))
            record("Sobol", f"N={n}", s.provenance, s.provenance["n_evaluations"],
                   seed=sd, S=sobol_frame(s, names))
    table = pd.DataFrame(rows)
    table.to_csv(out / "estimators.csv", index=False)
    agg = aggregate(table)
    agg.to_csv(out / "estimators_summary.csv", index=False)
    plot(agg, refinfo, Path(a.figdir))
    print(agg.to_string(float_format=lambda v: f"{v:.3g}"))


METRICS = ["R_min", "R_point", "R_cycle", "moments", "sobol"]


def aggregate(table):
    """Median, min and max of each error over the seeds of one method and setting."""
    g = table.groupby(["method", "setting"], sort=False)
    agg = g.agg(n_evals=("n_evals", "first"), wall_est=("wall_est", "median"),
                n_seeds=("n_evals", "size")).reset_index()
    for m in METRICS:
        if m in table:
            agg[m] = g[m].median().values
            agg[m + "_min"] = g[m].min().values
            agg[m + "_max"] = g[m].max().values
    return agg


def plot(table, refinfo, figdir):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figdir.mkdir(parents=True, exist_ok=True)
    style = {"FOSM": ("C3", "s"), "MC": ("C0", "o"), "PCE": ("C2", "^"), "Sobol": ("C1", "D")}
    panels = [("R_min", "worst point-in-time reliability,\n"
                        "|R̂_min − R_min,ref| (max over quantities)"),
              ("R_cycle", "whole-cycle reliability,\n"
                          "|R̂_cycle − R_cycle,ref| (max over quantities)"),
              ("moments", "mean and std at the worst angle,\nmax |error| / σ_ref"),
              ("sobol", "Sobol' indices of the peak |error|,\nmax |Ŝ − S_ref| (S1 and ST)")]
    for xcol, xlabel, fname in [("n_evals", "model evaluations", "estimators_vs_evaluations.png"),
                                ("wall_est", "wall time (s): evaluations × "
                                 f"{refinfo.get('per_eval', float('nan')):.3f} s + analysis",
                                 "estimators_vs_time.png")]:
        fig, axes = plt.subplots(2, 2, figsize=(11, 9), constrained_layout=True)
        for ax, (col, title) in zip(axes.flat, panels):
            for meth, grp in table.groupby("method", sort=False):
                if col not in grp or grp[col].isna().all():
                    continue
                g = grp.dropna(subset=[col])
                c, m = style[meth]
                y = np.maximum(g[col].values, 1e-4)
                lo = y - np.maximum(g[col + "_min"].values, 1e-4)
                hi = np.maximum(g[col + "_max"].values, 1e-4) - y
                ax.errorbar(g[xcol], y, yerr=[lo, hi], marker=m, color=c, label=meth, ms=7,
                            capsize=3, lw=1.5)
                ax.set_xscale("log")
                ax.set_yscale("log")
                for _, r in g.iterrows():
                    lab = r["setting"].replace("order ", "p=")
                    if r["n_seeds"] == 1 and meth != "FOSM":
                        lab += "*"
                    ax.annotate(lab, (r[xcol], max(r[col], 1e-4)), fontsize=7,
                                xytext=(4, -12) if meth == "FOSM" else (4, 3),
                                textcoords="offset points", color=c)
            if col.startswith("R_"):
                ax.axhline(refinfo["R_ci_halfwidth_max"], color="k", ls=":", lw=1,
                           label="reference: binomial 95 % half-width")
                ax.axhline(max(refinfo["pce_surrogate_vs_mc_ref"][col if col != "R_min"
                                                                   else "R_min"], 1e-4),
                           color="k", ls="--", lw=1, label="reference: MC vs its PCE surrogate")
            if col == "sobol":
                ax.axhline(max(refinfo["S_ref_change_from_lower_order"], 1e-4), color="grey",
                           ls="-.", lw=1, label="Sobol' reference: change from PCE order p−1")
            ax.set_title(title, fontsize=10)
            ax.set_xlabel(xlabel)
            ax.set_ylabel("absolute error")
            ax.grid(alpha=0.3, which="both")
        handles = {}
        for ax in axes.flat:
            for h, lab in zip(*ax.get_legend_handles_labels()):
                handles.setdefault(lab, h)
        fig.legend(list(handles.values()), list(handles.keys()), loc="outside lower center",
                   ncol=4, fontsize=9)
        fig.suptitle("nine-bar-lubricated study: estimator error against cost, median and range "
                     "over 4 seeds (* one seed)\n"
                     f"(reference: {refinfo['n_ref']} Sobol' points; tolerance T = "
                     + ", ".join(f"{v:g}" for v in refinfo["T"].values()) + " SI"
                     + ("" if xcol == "n_evals" else "; per evaluation: measured wall time with "
                        "2 workers") + ")", fontsize=11)
        fig.savefig(figdir / fname, dpi=120)
        plt.close(fig)


if __name__ == "__main__":
    main()
