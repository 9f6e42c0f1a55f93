#!/usr/bin/env python
"""Active-learning reliability (``active_learning``, ``--method ak``) on analytic problems.

(Exact references; medians, spreads and interval coverage over the seeds.)

Problems (exact references, no sampling error in them):

``four_branch``
    The four-branch series system with k = 6 (Waarts 2000; Echard et al. 2011), two standard
    normal inputs, four components learnt one surrogate each. P_f = 4.4573e-3 by quadrature:
    with p = (x1 + x2)/√2, q = (x1 − x2)/√2 the safe set is |q| < 3, |p| < 3 + 0.2q², so
    P_f = 1 − ∫_{−3}^{3} φ(q)(2Φ(3 + 0.2q²) − 1) dq.
``paraboloid``
    A curved limit state in six standard normal inputs, g = 4.5 − u6 + 0.05 Σ_{j≤5} u_j²:
    P_f = E[Φ(−4.5 − 0.05 χ²₅)] = 1.2713e-6 by quadrature over the χ² density (FORM's Φ(−4.5) =
    3.4e-6 is 2.7× off).
``two_points``
    Two design points of equal β: g = min(4.2 − u1 + 0.1 u2², 4.2 + u1 + 0.1 u2²) in two
    inputs, P_f = 2 E[Φ(−4.2 − 0.1 χ²₁)] (two failure regions a single design point misses half of).

Per problem and setting: for each seed the estimate, its interval, the model calls and the time;
summarised as the median and the 10–90 % range of the relative error and of the calls, and the
coverage (the fraction of intervals holding the exact value).

    python benchmarks/bench_ak.py --seeds 20 --out results/bench_ak.csv
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import integrate, special, stats


def four_branch(X):
    a, b = X[:, 0], X[:, 1]
    s = 3 + 0.1 * (a - b) ** 2
    return np.column_stack([s - (a + b) / 2**0.5, s + (a + b) / 2**0.5,
                            (a - b) + 6 / 2**0.5, (b - a) + 6 / 2**0.5])


def paraboloid(X):
    return (4.5 - X[:, 5] + 0.05 * (X[:, :5] ** 2).sum(1))[:, None]


def two_points(X):
    c = 0.1 * X[:, 1] ** 2
    return np.column_stack([4.2 - X[:, 0] + c, 4.2 + X[:, 0] + c])


def references() -> dict:
    safe = lambda q: stats.norm.pdf(q) * (2 * stats.norm.cdf(3 + 0.2 * q * q) - 1)  # noqa: E731
    fb = 1.0 - integrate.quad(safe, -3, 3, epsabs=1e-15, epsrel=1e-13)[0]
    pb = integrate.quad(lambda t: special.ndtr(-4.5 - 0.05 * t) * stats.chi2.pdf(t, 5), 0, np.inf,
                        epsabs=1e-22, epsrel=1e-12)[0]
    tp = 2 * integrate.quad(lambda t: special.ndtr(-4.2 - 0.1 * t) * stats.chi2.pdf(t, 1), 0,
                            np.inf, epsabs=1e-22, epsrel=1e-12)[0]
    return {"four_branch": fb, "paraboloid": pb, "two_points": tp}


def problem(name):
    from mechrel.uq import FunctionModel, LimitState, Normal, UncertainInputs

    if name == "four_branch":
        d, f, outs = 2, four_branch, ["g1", "g2", "g3", "g4"]
    elif name == "paraboloid":
        d, f, outs = 6, paraboloid, ["g"]
    else:
        d, f, outs = 2, two_points, ["g1", "g2"]
    inputs = UncertainInputs.from_specs({f"u{j + 1}": Normal(0.0, 1.0) for j in range(d)})
    model = FunctionModel(f, inputs.names, outs, vectorized=True, key=name)
    ls = LimitState.series(*(LimitState.margin(o) for o in outs), name=name)
    return model, inputs, ls


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--seeds", type=int, default=20)
    p.add_argument("--problems", nargs="*", default=["four_branch", "paraboloid", "two_points"])
    p.add_argument("--tolerance", type=float, nargs="*", default=[0.1, 0.05])
    p.add_argument("--batch", type=int, nargs="*", default=[1])
    p.add_argument("--out", default="results/bench_ak.csv")
    a = p.parse_args(argv)
    from mechrel.uq import active_learning

    refs = references()
    rows = []
    for name in a.problems:
        model, inputs, ls = problem(name)
        for tol in a.tolerance:
            for batch in a.batch:
                for seed in range(a.seeds):
                    t0, c0 = time.perf_counter(), time.process_time()
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")   # counted from r.warnings
                        r = active_learning(model=model, inputs=inputs, limit_state=ls, seed=seed,
                                            tolerance=tol, batch_size=batch)
                    t = r.to_frame().iloc[0]
                    ref = refs[name]
                    rows.append({
                        "problem": name, "tolerance": tol, "batch": batch, "seed": seed,
                        "reference": ref, "pf": t["pf"], "pf_lo": t["pf_lo"], "pf_hi": t["pf_hi"],
                        "rel_error": t["pf"] / ref - 1,
                        "covered": bool(t["pf_lo"] <= ref <= t["pf_hi"]),
                        "calls": int(t["n_evaluations"]), "converged": bool(t["converged"]),
                        "population": t["population"], "n_population": int(t["n_population"]),
                        "n_warnings": len(r.warnings), "wall_s": time.perf_counter() - t0,
                        "cpu_s": time.process_time() - c0})
                    line = pd.Series(rows[-1]).to_frame().T
                    print(line.to_string(header=len(rows) == 1, index=False), flush=True)
                    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
                    pd.DataFrame(rows).to_csv(a.out, index=False)
    df = pd.DataFrame(rows)
    g = df.groupby(["problem", "tolerance", "batch"])
    summary = pd.DataFrame({
        "reference": g["reference"].first(),
        "median_abs_err": g["rel_error"].apply(lambda e: np.median(np.abs(e))),
        "err_q10": g["rel_error"].quantile(0.1), "err_q90": g["rel_error"].quantile(0.9),
        "median_calls": g["calls"].median(), "calls_min": g["calls"].min(),
        "calls_max": g["calls"].max(),
        "coverage": g["covered"].mean(), "converged": g["converged"].mean(),
        "median_cpu_s": g["cpu_s"].median(), "seeds": g.size()})
    print(summary.to_string())
    summary.to_csv(a.out.replace(".csv", "_summary.csv"))


if __name__ == "__main__":
    main()
