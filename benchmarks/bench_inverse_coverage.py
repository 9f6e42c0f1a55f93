"""The inverse question: how often the intervals of :func:`mechrel.uq.inverse_reliability`
hold the true allowable, over seeds.

Model (closed forms, no quadrature): two quantities of three standard-normal inputs with their
cycle extremes, velocity e(θ) = σ (x1 cos θ + x2 sin θ), whose largest |e| over the cycle is
V = σ √(x1² + x2²), Rayleigh: P(V ≤ r) = 1 − exp(−r²/(2σ²)); acceleration 3 + x3 at every
angle, A = |3 + x3|: P(A ≤ r) = Φ(r − 3) − Φ(−r − 3); the whole cycle's factor k solves
P(V ≤ k s_v) P(A ≤ k s_a) = R_t (independent inputs). σ = 0.02 m/s, s_v = 0.05 m/s,
s_a = 6 m/s².

Subset simulation (``--n-per-level``, p₀ = 0.1, conditional sampling) at ``--target``
(default 0.9999: four levels): per seed, the estimate P̂ at the true allowable is read off the
run's levels, and the 95 % interval is judged with both of Au & Beck's coefficients of
variation: the lower bound √(Σ δ_i²) (levels independent: the forward subset simulation's)
and the upper bound Σ δ_i (levels fully correlated: the inverse method's). The table gives,
per scalar, the coverage of each, the observed standard deviation of ln P̂ at the truth against
the mean σ = √(ln(1 + δ²)) of each bound, and the mean and spread of the allowable's relative
error. Monte Carlo order statistics (``--n-mc`` samples at ``--target-mc``, default 0.99) are
judged the same way (their coverage should be at least the exact binomial one).

Run: ``python benchmarks/bench_inverse_coverage.py --reps 100`` (≈ 3 min on a loaded 2-core
VM; the figures in docs/uq.md, "The inverse question", are from it).
"""

from __future__ import annotations

import argparse
import math
import time
import warnings

import numpy as np
import pandas as pd
from scipy import optimize, special, stats

from mechrel.errors import EstimateWarning
from mechrel.uq import FunctionModel, Normal, UncertainInputs, inverse_reliability
from mechrel.uq.inverse import subset_levels
from mechrel.uq.inverse.order_statistics import order_statistic_ranks

SIGMA, SV, SA = 0.02, 0.05, 6.0
ANGLES = np.deg2rad(np.arange(0.0, 360.0, 30.0))
LABELS = pd.MultiIndex.from_tuples(
    [(q, a) for q in ("velocity", "acceleration")
     for a in [*np.rad2deg(ANGLES).tolist(), "max_abs"]], names=["quantity", "crank_angle"])


def errors(X):
    v = SIGMA * (X[:, :1] * np.cos(ANGLES) + X[:, 1:2] * np.sin(ANGLES))
    a = np.repeat(3.0 + X[:, 2:3], len(ANGLES), axis=1)
    return np.column_stack([v, SIGMA * np.hypot(X[:, 0], X[:, 1]), a, np.abs(3.0 + X[:, 2])])


def cdf_v(r):
    return 1.0 - math.exp(-r * r / (2 * SIGMA * SIGMA)) if r > 0 else 0.0


def cdf_a(r):
    return float(special.ndtr(r - 3.0) - special.ndtr(-r - 3.0))


def exact(target):
    return {"velocity": SIGMA * math.sqrt(-2.0 * math.log(1.0 - target)),
            "acceleration": optimize.brentq(lambda r: cdf_a(r) - target, 1e-9, 30, xtol=1e-14),
            "all": optimize.brentq(lambda k: cdf_v(k * SV) * cdf_a(k * SA) - target, 1e-6, 10,
                                   xtol=1e-14)}


def p_hat(levels, z):
    """P̂(Y ≥ z) from a run's levels: the deepest level whose samples reach below z."""
    for j in range(len(levels.P) - 1, -1, -1):
        d = levels.desc[j]
        if j == 0 or z >= d[-1]:
            return levels.P[j] * float(np.mean(d >= z))
    return math.nan


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--reps", type=int, default=100)
    ap.add_argument("--target", type=float, default=0.9999)
    ap.add_argument("--n-per-level", type=int, default=500)
    ap.add_argument("--target-mc", type=float, default=0.99)
    ap.add_argument("--n-mc", type=int, default=2000)
    args = ap.parse_args(argv)
    model = FunctionModel(errors, ["x1", "x2", "x3"], LABELS, key="bench-inverse",
                          vectorized=True)
    inputs = UncertainInputs.from_specs({k: Normal(0.0, 1.0) for k in ("x1", "x2", "x3")})
    ref = {"velocity": SV, "acceleration": SA}
    truth = exact(args.target)
    z = float(stats.norm.ppf(0.975))
    kept = []  # the _Levels of each scalar of each run, in order
    original = subset_levels._Levels.__init__

    def record(self):
        original(self)
        kept.append(self)

    subset_levels._Levels.__init__ = record
    rows = {k: [] for k in truth}
    t0 = time.perf_counter()
    try:
        for seed in range(args.reps):
            kept.clear()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", EstimateWarning)
                r = inverse_reliability(model=model, inputs=inputs, target=args.target,
                                        method="subset", n_per_level=args.n_per_level,
                                        seed=seed, allowable=ref, progress=False)
            lv = r.details["levels"]
            for k, levels in zip(("velocity", "acceleration", "all"), kept):
                row = r.table.loc[(k, k)] if k != "all" else r.table.loc[("all", "velocity")]
                value = row["allowable"] if k != "all" else row["factor"]
                cov = lv.loc[k, "cov"].to_numpy()
                rows[k].append((math.log(p_hat(levels, truth[k]) / (1 - args.target)),
                                math.sqrt(float(np.sum(cov**2))), float(np.sum(cov)),
                                value / truth[k] - 1))
    finally:
        subset_levels._Levels.__init__ = original
    t_subset = time.perf_counter() - t0
    table = []
    for k, vals in rows.items():
        a = np.array(vals)
        s_lo, s_hi = np.sqrt(np.log1p(a[:, 1] ** 2)), np.sqrt(np.log1p(a[:, 2] ** 2))
        table.append({"scalar": k, "coverage (upper bound)": np.mean(np.abs(a[:, 0]) <= z * s_hi),
                      "coverage (lower bound)": np.mean(np.abs(a[:, 0]) <= z * s_lo),
                      "std ln P̂(truth)": a[:, 0].std(), "mean σ upper": s_hi.mean(),
                      "mean σ lower": s_lo.mean(), "mean rel. error": a[:, 3].mean(),
                      "std rel. error": a[:, 3].std()})
    print(f"subset simulation: R_t = {args.target}, N = {args.n_per_level}, {args.reps} seeds, "
          f"{t_subset:.0f} s")
    print(pd.DataFrame(table).set_index("scalar").round(3).to_string())

    truth_mc = exact(args.target_mc)
    hits = {k: 0 for k in truth_mc}
    t0 = time.perf_counter()
    for seed in range(args.reps):
        r = inverse_reliability(model=model, inputs=inputs, target=args.target_mc, method="mc",
                                n=args.n_mc, seed=seed, allowable=ref, progress=False)
        for k in truth_mc:
            row = r.table.loc[(k, k)] if k != "all" else r.table.loc[("all", "velocity")]
            lo, hi = ((row["allowable_lo"], row["allowable_hi"]) if k != "all"
                      else (row["factor_lo"], row["factor_hi"]))
            hits[k] += lo <= truth_mc[k] <= hi
    _, lo, hi = order_statistic_ranks(args.n_mc, args.target_mc, 0.95)
    binom = (stats.binom.cdf(hi - 1, args.n_mc, args.target_mc)
             - stats.binom.cdf(lo - 1, args.n_mc, args.target_mc))
    print(f"\nMonte Carlo: R_t = {args.target_mc}, n = {args.n_mc}, {args.reps} seeds, "
          f"{time.perf_counter() - t0:.0f} s; exact coverage of the ranks {binom:.3f}")
    print("  coverage: " + ", ".join(f"{k} {v / args.reps:.2f}" for k, v in hits.items()))


if __name__ == "__main__":
    main()
