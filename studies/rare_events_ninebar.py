#!/usr/bin/env python
"""Whole-cycle failure probability of the lubricated nine-bar at tight-to-loose allowables.

The default study (nine-bar-lubricated: clearances, viscosity and crank speed uncertain; the
second cycle, radau at rtol 1e-5), one quantity of the slider (``--quantity``, default the
velocity error). Failure: the error's magnitude exceeds a fixed allowable I anywhere in the
cycle, max over the cycle |e| > I (the cycle extreme found on the integrator's solution).

* P_f against I from about 1e-1 down to 1e-6: subset simulation (Au & Beck; conditional
  sampling, p0 = 0.1, ``--n-per-level`` samples per level) against crude Monte Carlo
  (``--n-mc`` iid samples, Wilson 95 % intervals) where Monte Carlo resolves it. All subset
  runs use one seed: their levels are the same quantiles of the cycle extreme whatever I (the
  intermediate thresholds of g = I − Y are I minus quantiles of Y), so with the evaluation cache
  the runs for every I of the grid cost one run to the deepest I plus each run's last level.
  The grid's deepest allowable is found from the first run's levels (log P_f linear in I,
  extrapolated), then refined.
* The same curve by active learning (``active_learning``, ``--method ak``): one Kriging
  surrogate of the cycle extreme, refined near each allowable's level set; each allowable's run
  starts from the runs of the one before (``initial=``), so the curve costs the simulations of
  the first run plus the few each further level adds (its own cache, OUT/ak_evaluations.sqlite,
  so that its count is its own).
* Per crank angle: FORM and SORM (Hohenbichler–Rackwitz) on g = I_θ − |e(θ)|, with I_θ the
  Monte Carlo 1 − ``--angle-pf`` quantile of |e(θ)| (so that Monte Carlo resolves P_f there),
  against the Monte Carlo estimate with its interval, and each method's model evaluations.

Every model evaluation is cached in OUT/evaluations.sqlite (a rerun resumes). Writes
``curve.csv``, ``per_angle.csv``, ``rare_events_ninebar.png``, ``report.md`` and
``summary.json`` into OUT.

    python studies/rare_events_ninebar.py --out results/rare_events_ninebar [--quick] [--jobs 2]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from mechrel.cli.args import positive_integer, report_errors, sample_count
from mechrel.errors import StudyError

sys.path.insert(0, str(Path(__file__).resolve().parent))
from reliability_paper import markdown_table  # noqa: E402

SEED = 20221014
UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s²"}
# The integrated error is noisy (~1e-5..1e-4 of its size): finite-difference step 0.05 in
# standard normal units. The surface criterion |g| <= tol |g(0)| is relative to g at the mean,
# small here (I_θ at a 0.95 quantile), so tol = 1e-2: a β error of about 1e-2·|g(0)|/|∇g|.
FORM_SETTINGS = {"step": 0.05, "tol": 1e-2}
P0 = 0.1
DEEPEST = 1e-6


def _setup(quantity):
    from mechrel.study.study import load_study

    study = load_study("nine-bar-lubricated", overrides={"quantities": [quantity]})
    return study.model(), study.uncertain_inputs()


def monte_carlo(model, inputs, n, *, seed, common):
    """Cycle extreme and per-angle |e| of ``n`` iid samples (failed samples dropped, counted)."""
    from mechrel.uq import evaluate

    X = inputs.sample(n, rule="random", seed=seed)
    t0 = time.perf_counter()
    ev = evaluate(model, X, **common)
    Y = pd.DataFrame(ev.Y[ev.ok], columns=model.output_index)
    return Y, {"n": int(n), "n_failed": int(ev.n_failed), "n_model_calls": int(ev.n_model_calls),
               "wall_time": time.perf_counter() - t0}


def subset_at(model, inputs, quantity, allowable, *, n_per_level, seed, common, max_levels=10):
    from mechrel.uq import LimitState, subset_simulation

    ls = LimitState.exceedance([(quantity, "max_abs")], float(allowable), kind="abs")
    return subset_simulation(model=model, inputs=inputs, limit_state=ls, seed=seed,
                             n_per_level=n_per_level, p0=P0, max_levels=max_levels, **common)


def level_curve(res, allowable):
    """(y_i, P(Y > y_i)) of the intermediate levels: y_i = I − b_i at P = p0^(i+1)."""
    lv = res.levels
    inner = lv.iloc[:-1]
    y = allowable - inner["threshold"].to_numpy()
    p = P0 ** (inner.index.to_numpy() + 1.0)
    return y, p


def find_deepest(model, inputs, quantity, start, *, n_per_level, seed, common, target,
                 max_tries=8):
    """An allowable with P_f between target/10 and target by subset simulation: extrapolate
    log P_f linearly in I from the levels of the last run; bisect when a guess overshoots
    (more than ``max_levels`` levels)."""
    from mechrel.errors import StudyError

    lo, hi = start, None  # lo: P_f(lo) > target; hi: beyond reach
    allowable, tries = start, []
    for _ in range(max_tries):
        try:
            r = subset_at(model, inputs, quantity, allowable, n_per_level=n_per_level, seed=seed,
                          common=common)
        except StudyError as exc:
            tries.append((allowable, None, str(exc)[:120]))
            hi = allowable
            allowable = 0.5 * (lo + hi)
            continue
        tries.append((allowable, r.pf, ""))
        if target / 10 <= r.pf <= target:
            return allowable, r, tries
        if r.pf > target:
            lo = allowable
            y, p = level_curve(r, allowable)
            y, p = np.append(y, allowable), np.append(p, r.pf)
            k = max(len(y) - 3, 0)
            slope = np.polyfit(y[k:], np.log10(p[k:]), 1)[0] if len(y) - k >= 2 else None
            step = ((np.log10(target) - 0.5 - np.log10(r.pf)) / slope
                    if slope is not None and slope < 0 else 0.5 * abs(allowable))
            allowable = allowable + step
            if hi is not None and allowable >= hi:
                allowable = 0.5 * (lo + hi)
        else:
            hi = allowable
            allowable = 0.5 * (lo + hi)
    raise StudyError(f"find_deepest: no allowable with P_f in [{target / 10:g}, {target:g}] "
                     f"after {max_tries} tries {tries}; allowed: more tries or a larger "
                     "n_per_level")


def wilson(k, n):
    from mechrel.uq.problem.allowables import binomial_interval

    lo, hi = binomial_interval(np.asarray(k), n, confidence_level=0.95, method="wilson")
    return np.asarray(lo), np.asarray(hi)


def curve(model, inputs, quantity, Y_mc, deepest, *, n_points, n_per_level, seed, common):
    """P_f(I) on a grid from the MC 0.9 quantile to ``deepest``: subset and MC per point."""
    y_mc = Y_mc[(quantity, "max_abs")].to_numpy()
    grid = np.linspace(np.quantile(y_mc, 0.9), deepest, n_points)
    rows = []
    for allowable in grid:
        t0 = time.perf_counter()
        r = subset_at(model, inputs, quantity, allowable, n_per_level=n_per_level, seed=seed,
                      common=common)
        k = int((y_mc > allowable).sum())
        lo, hi = wilson(k, len(y_mc))
        rows.append({"allowable": allowable, "pf_subset": r.pf, "cov_subset": r.cov,
                     "pf_subset_lo": float(r.table["pf_lo"].iloc[0]),
                     "pf_subset_hi": float(r.table["pf_hi"].iloc[0]),
                     "n_evaluations_subset": r.n_evaluations,
                     "new_simulations": _new(r),
                     "wall_time_subset": time.perf_counter() - t0,
                     "pf_mc": k / len(y_mc), "pf_mc_lo": float(lo), "pf_mc_hi": float(hi),
                     "k_mc": k, "n_mc": len(y_mc)})
    return pd.DataFrame(rows)


def ak_curve(model, inputs, quantity, grid, *, seed, common, tolerance=0.1, batch_size=4):
    """P_f(I) by active learning at each allowable of ``grid`` (loosest first), each run seeded
    with the previous run's simulations."""
    from mechrel.uq import LimitState, active_learning

    rows, prev = [], None
    for allowable in sorted(grid):
        ls = LimitState.exceedance([(quantity, "max_abs")], float(allowable), kind="abs")
        t0 = time.perf_counter()
        r = active_learning(model=model, inputs=inputs, limit_state=ls, seed=seed, initial=prev,
                            tolerance=tolerance, batch_size=batch_size, **common)
        t = r.to_frame().iloc[0]
        rows.append({"allowable": allowable, "pf_ak": t["pf"], "pf_ak_lo": t["pf_lo"],
                     "pf_ak_hi": t["pf_hi"], "converged_ak": bool(t["converged"]),
                     "population_ak": t["population"], "n_evaluations_ak": int(t["n_evaluations"]),
                     "new_simulations_ak": _new(r), "wall_time_ak": time.perf_counter() - t0,
                     "warnings_ak": len(r.warnings)})
        prev = r
    return pd.DataFrame(rows)


def cached_simulations(path) -> int:
    """Simulations in the evaluation cache: every distinct sample this study ran."""
    import sqlite3

    if not Path(path).exists():
        return 0
    with sqlite3.connect(path) as db:
        return int(db.execute("select count(*) from evaluations").fetchone()[0])


def _new(result):
    """Simulations a result ran (its evaluations not found in the cache)."""
    ev = result.evaluations
    return 0 if ev is None else int(ev.n_model_calls)


def per_angle(model, inputs, quantity, Y_mc, *, angle_pf, angles, common):
    """FORM and SORM per crank angle against Monte Carlo at I_θ = MC (1 − angle_pf) quantile."""
    from mechrel.errors import StudyError
    from mechrel.uq import LimitState, form, sorm

    rows = []
    for angle in angles:
        e = np.abs(Y_mc[(quantity, angle)].to_numpy())
        allowable = float(np.quantile(e, 1 - angle_pf))
        k = int((e > allowable).sum())
        lo, hi = wilson(k, len(e))
        row = {"crank_angle": angle, "allowable": allowable, "pf_mc": k / len(e),
               "pf_mc_lo": float(lo), "pf_mc_hi": float(hi)}
        ls = LimitState.exceedance([(quantity, angle)], allowable, kind="abs")
        t0 = time.perf_counter()
        try:
            fr = form(model=model, inputs=inputs, limit_state=ls, **FORM_SETTINGS, **common)
            row.update(pf_form=fr.pf, beta_form=fr.beta, n_evaluations_form=fr.n_evaluations,
                       new_simulations_form=_new(fr), wall_time_form=time.perf_counter() - t0)
            t0 = time.perf_counter()
            sr = sorm(model=model, inputs=inputs, limit_state=ls, design_point=fr,
                      curvature_step=0.25, **FORM_SETTINGS, **common)
            row.update(pf_sorm=sr.pf, n_evaluations_sorm=sr.n_evaluations - fr.n_evaluations,
                       wall_time_sorm=time.perf_counter() - t0)
            imp = fr.importance
            row.update({f"alpha2_{k}": float(v) for k, v in imp.items()})
        except StudyError as exc:
            row["error"] = str(exc)[:200]
        rows.append(row)
    return pd.DataFrame(rows)


def plot(curve_t, angle_t, quantity, path):
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    unit = UNITS[quantity]
    per_angle_ran = len(angle_t) > 0
    fig, axes = plt.subplots(1, 2 if per_angle_ran else 1,
                             figsize=(12 if per_angle_ran else 6.5, 4.6))
    a1, a2 = (axes if per_angle_ran else (axes, None))
    c = curve_t
    if "pf_subset" in c:
        a1.errorbar(c["allowable"], c["pf_subset"],
                    yerr=[c["pf_subset"] - c["pf_subset_lo"], c["pf_subset_hi"] - c["pf_subset"]],
                    fmt="o-", capsize=3, label="subset simulation (±1.96 c.o.v.)")
    if "pf_ak" in c:
        a1.errorbar(c["allowable"], c["pf_ak"],
                    yerr=[c["pf_ak"] - c["pf_ak_lo"], c["pf_ak_hi"] - c["pf_ak"]],
                    fmt="D--", capsize=3, mfc="none",
                    label=f"active learning (95 % interval), {int(c['new_simulations_ak'].sum())} "
                          "simulations for the curve")
    m = c["k_mc"] > 0
    a1.errorbar(c["allowable"][m], c["pf_mc"][m],
                yerr=[c["pf_mc"][m] - c["pf_mc_lo"][m], c["pf_mc_hi"][m] - c["pf_mc"][m]],
                fmt="s", capsize=3,
                label=f"Monte Carlo, n = {int(c['n_mc'].iloc[0])} (Wilson 95 %)")
    a1.set_yscale("log")
    a1.set_xlabel(f"allowable |{quantity} error| over the cycle ({unit})")
    a1.set_ylabel("whole-cycle P_f")
    a1.set_title("whole cycle: P(max over the cycle |e| > I)")
    a1.grid(True, which="both", alpha=0.3)
    a1.legend(fontsize=8)
    t = angle_t
    if a2 is None:
        fig.tight_layout()
        fig.savefig(path, dpi=130)
        plt.close(fig)
        return
    a2.errorbar(t["crank_angle"], t["pf_mc"],
                yerr=[t["pf_mc"] - t["pf_mc_lo"], t["pf_mc_hi"] - t["pf_mc"]], fmt="s", capsize=3,
                label="Monte Carlo (Wilson 95 %)")
    if "pf_form" in t:
        a2.plot(t["crank_angle"], t["pf_form"], "o-", label="FORM")
    if "pf_sorm" in t:
        a2.plot(t["crank_angle"], t["pf_sorm"], "^--", label="SORM (Hohenbichler)")
    a2.set_yscale("log")
    a2.set_xlabel("crank angle (°)")
    a2.set_ylabel("P(|e(θ)| > I_θ)")
    a2.set_title("per angle, I_θ at Monte Carlo's quantile")
    a2.grid(True, which="both", alpha=0.3)
    a2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="results/rare_events_ninebar")
    ap.add_argument("--quantity", default="velocity", choices=tuple(UNITS))
    ap.add_argument("--n-mc", type=sample_count, default=None,
                    help="Monte Carlo samples (default 2000; --quick 200)")
    ap.add_argument("--n-per-level", type=sample_count, default=None,
                    help="subset simulation samples per level (default 500; --quick 100)")
    ap.add_argument("--points", type=positive_integer, default=10, help="allowables on the curve")
    ap.add_argument("--angle-pf", type=float, default=0.05,
                    help="per-angle allowables at Monte Carlo's 1 − this quantile")
    ap.add_argument("--angle-stride", type=positive_integer, default=1,
                    help="every k-th analysis angle for FORM/SORM (default all 20)")
    ap.add_argument("--deepest", type=float, default=None,
                    help=f"smallest P_f of the curve (default {DEEPEST:g}; --quick 1e-3)")
    ap.add_argument("--methods", nargs="+", default=["subset", "form", "ak"],
                    choices=("subset", "form", "ak"),
                    help="what to run besides Monte Carlo (default all)")
    ap.add_argument("--allowable-max", type=float, default=None,
                    help="the curve's tightest allowable when subset simulation does not run "
                         "(then required; the quantity's unit)")
    ap.add_argument("--seed", type=int, default=SEED)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--no-progress", action="store_true")
    args = ap.parse_args(argv)
    args.n_mc = args.n_mc or (200 if args.quick else 2000)
    args.n_per_level = args.n_per_level or (100 if args.quick else 500)
    args.deepest = args.deepest or (1e-3 if args.quick else DEEPEST)
    return report_errors(run, args, ap.prog)


def run(args) -> int:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    model, inputs = _setup(args.quantity)
    from mechrel.study.runner import warm_up
    warm_up(model, progress=not args.no_progress)
    common = {"n_jobs": args.jobs, "cache": out / "evaluations.sqlite",
              "progress": not args.no_progress}
    q = args.quantity
    ss = np.random.SeedSequence(args.seed)
    s_mc, s_subset = (int(c.generate_state(1)[0]) for c in ss.spawn(2))
    timings = {}

    t0 = time.perf_counter()
    Y_mc, mc_info = monte_carlo(model, inputs, args.n_mc, seed=s_mc, common=common)
    timings["monte_carlo"] = time.perf_counter() - t0
    y = Y_mc[(q, "max_abs")].to_numpy()

    sims_of = {"monte_carlo": cached_simulations(common["cache"])}
    if "subset" in args.methods:
        t0 = time.perf_counter()
        deepest, deep_res, tries = find_deepest(model, inputs, q, float(np.quantile(y, 0.99)),
                                                n_per_level=args.n_per_level, seed=s_subset,
                                                common=common, target=args.deepest)
        timings["subset_deepest"] = time.perf_counter() - t0
        sims_of["subset_search"] = cached_simulations(common["cache"]) - sum(sims_of.values())
        t0 = time.perf_counter()
        curve_t = curve(model, inputs, q, Y_mc, deepest, n_points=args.points,
                        n_per_level=args.n_per_level, seed=s_subset, common=common)
        timings["subset_grid"] = time.perf_counter() - t0
        sims_of["subset_grid"] = cached_simulations(common["cache"]) - sum(sims_of.values())
    else:
        if args.allowable_max is None:
            raise StudyError("--allowable-max: required when subset simulation does not run; "
                             "allowed: the curve's tightest allowable (e.g. 0.1 for velocity)")
        deepest, deep_res, tries = args.allowable_max, None, []
        grid = np.linspace(np.quantile(y, 0.9), deepest, args.points)
        k = np.array([int((y > a).sum()) for a in grid])
        lo, hi = wilson(k, len(y))
        curve_t = pd.DataFrame({"allowable": grid, "pf_mc": k / len(y), "pf_mc_lo": lo,
                                "pf_mc_hi": hi, "k_mc": k, "n_mc": len(y)})
    if "ak" in args.methods:
        t0 = time.perf_counter()
        ak_cache = out / "ak_evaluations.sqlite"
        ak_t = ak_curve(model, inputs, q, curve_t["allowable"].to_numpy(), seed=s_subset,
                        common={**common, "cache": ak_cache, "progress": False})
        timings["ak_curve"] = time.perf_counter() - t0
        sims_of["ak_curve"] = cached_simulations(ak_cache)
        curve_t = curve_t.merge(ak_t, on="allowable")

    angles = [a for a in model.output_index.get_level_values("crank_angle")
              if not isinstance(a, str) and a < 360.0][:: args.angle_stride]
    t0 = time.perf_counter()
    angle_t = (per_angle(model, inputs, q, Y_mc, angle_pf=args.angle_pf, angles=angles,
                         common={**common, "progress": False}) if "form" in args.methods
               else pd.DataFrame({"crank_angle": [], "pf_mc": [], "pf_mc_lo": [], "pf_mc_hi": []}))
    timings["form_sorm_per_angle"] = time.perf_counter() - t0
    sims_of["form_sorm_per_angle"] = (cached_simulations(common["cache"])
                                      - sum(v for k, v in sims_of.items() if k != "ak_curve"))
    wall = time.perf_counter() - t_start

    curve_t.to_csv(out / "curve.csv", index=False)
    angle_t.to_csv(out / "per_angle.csv", index=False)
    plot(curve_t, angle_t, q, out / "rare_events_ninebar.png")
    both = curve_t[curve_t["k_mc"] >= 5]

    def overlap(m):
        if f"pf_{m}" not in both:
            return None
        return int(((both["pf_mc_lo"] <= both[f"pf_{m}_hi"])
                    & (both[f"pf_{m}_lo"] <= both["pf_mc_hi"])).sum())
    for c in ("pf_form", "pf_sorm", "n_evaluations_form", "n_evaluations_sorm"):
        if c not in angle_t:
            angle_t[c] = np.nan
    ok_a = angle_t.dropna(subset=["pf_form"])
    ratio_form = (ok_a["pf_form"] / ok_a["pf_mc"]).replace([np.inf], np.nan)
    ratio_sorm = (ok_a["pf_sorm"] / ok_a["pf_mc"]).replace([np.inf], np.nan)
    in_form = ((ok_a["pf_form"] >= ok_a["pf_mc_lo"]) & (ok_a["pf_form"] <= ok_a["pf_mc_hi"]))
    in_sorm = ((ok_a["pf_sorm"] >= ok_a["pf_mc_lo"]) & (ok_a["pf_sorm"] <= ok_a["pf_mc_hi"]))
    sims = cached_simulations(common["cache"])
    summary = {
        "quantity": q, "unit": UNITS[q], "seed": args.seed, "n_mc": args.n_mc,
        "n_per_level": args.n_per_level, "p0": P0, "mc": mc_info,
        "deepest_allowable": deepest, "deepest_pf": deep_res.pf if deep_res else None,
        "deepest_cov": deep_res.cov if deep_res else None,
        "deepest_levels": int(len(deep_res.levels)) if deep_res else None,
        "deepest_n_evaluations": deep_res.n_evaluations if deep_res else None,
        "ak_simulations": sims_of.get("ak_curve"),
        "search": [list(t) for t in tries],
        "simulations": sims, "simulations_by_step": sims_of, "timings_s": timings,
        "wall_time_s": wall,
        "subset_vs_mc": {"points_with_5_mc_failures": int(len(both)),
                         "intervals_overlap": overlap("subset"),
                         "ak_intervals_overlap": overlap("ak")},
        "per_angle": {"angles": len(angle_t), "form_converged": int(len(ok_a)),
                      "form_inside_mc_interval": int(in_form.sum()),
                      "sorm_inside_mc_interval": int(in_sorm.sum()),
                      "form_over_mc_median": float(np.nanmedian(ratio_form)) if len(ok_a) else None,
                      "sorm_over_mc_median": float(np.nanmedian(ratio_sorm)) if len(ok_a) else None,
                      "form_evaluations_median": float(ok_a["n_evaluations_form"].median())
                      if len(ok_a) else None,
                      "sorm_extra_evaluations_median": float(ok_a["n_evaluations_sorm"].median())
                      if len(ok_a) else None},
        "args": vars(args) | {"out": str(args.out)},
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2, default=str))
    lines = [f"# Whole-cycle P_f of the lubricated nine-bar ({q} error)", "",
             f"Monte Carlo: {args.n_mc} iid samples ({mc_info['n_failed']} failed), "
             f"{timings['monte_carlo']:.0f} s."
             + (f" Subset simulation: N = {args.n_per_level} per "
                f"level, p0 = {P0}; deepest allowable {deepest:.4g} {UNITS[q]}: P_f = "
                f"{deep_res.pf:.3g} (c.o.v. {deep_res.cov:.2f}, {len(deep_res.levels)} levels, "
                f"{deep_res.n_evaluations} model evaluations); the whole grid "
                f"{timings['subset_grid']:.0f} s after the search "
                f"({timings['subset_deepest']:.0f} s)." if deep_res else "")
             + (f" Active learning: the whole curve {sims_of['ak_curve']} simulations, "
                f"{timings['ak_curve']:.0f} s." if "ak_curve" in sims_of else ""),
             "",
             markdown_table(curve_t, ".3g"), "",
             f"Per angle (I_θ at Monte Carlo's {1 - args.angle_pf:g} quantile), "
             f"{timings['form_sorm_per_angle']:.0f} s:", "",
             markdown_table(angle_t, ".3g"), "",
             f"Total {wall:.0f} s, {sims} simulations run (the rest from the cache)."]
    (out / "report.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
