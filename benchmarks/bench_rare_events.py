"""Rare events: error against model evaluations for FOSM, FORM, SORM, importance sampling and
subset simulation, and the cost of a Python call per sample (row-wise against vectorised model).

Problems (failure: g ≤ 0), each with an exact or published P_f
----------------------------------------------------------------
``lognormal R-S``   g = R − S, R ~ LN(mean 10, std 1.5), S ~ LN(3, 0.6): P_f = Φ(−β),
                    β = (μ_lnR − μ_lnS)/√(σ_lnR² + σ_lnS²) = 4.890, P_f = 5.04e-7 (exact).
``parabola``        g = 4.5 − u₂ + 0.1 u₁², u standard normal (β = 4.5, curvature κ = 0.2):
                    P_f = ∫ φ(v) Φ(−4.5 − 0.1 v²) dv = 2.430e-6 (quadrature, rel. error 1e-12).
``four-branch``     the series system of Waarts (2000), k = 7: P_f = 2.2228e-3 (as tabulated in
                    OpenTURNS' otbenchmark).
``RP25``            Rozsas & Slobbe (2019): g = max(x₁² − 8x₂ + 16, −16x₁ + x₂ + 32), a parallel
                    system of two branches: P_f = 4.1486e-5 (otbenchmark's value).

Methods: mean-value FOSM (β = g(μ)/σ_g with σ_g from central differences: 2d + 1 evaluations),
FORM (iHLRF), SORM (Tvedt, from FORM's design point), importance sampling around FORM's
design point (n = 250 … 2000) and subset simulation (conditional sampling, p₀ = 0.1,
N = 500 … 3000 per level). Sampling methods are repeated over ``--reps`` seeds; the table gives
the median and the 90 % quantile of |P̂/P_f − 1|, the mean reported c.o.v. and the evaluations.

Call overhead: :func:`mechrel.uq.evaluate` of the same analytic function over ``--rows`` rows,
row-wise (one Python call per row) against ``FunctionModel(vectorized=True)`` (one call per
chunk), interleaved ``--repeat`` times in one process; medians.

Run: ``python benchmarks/bench_rare_events.py --out results/rare_events`` (≈ 1–2 min).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import integrate, special, stats

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import git_state  # noqa: E402

from mechrel.uq import FunctionModel, LogNormal, Normal, UncertainInputs, evaluate  # noqa: E402
from mechrel.uq import LimitState, form, importance_sampling, sorm, subset_simulation  # noqa: E402

SQ2 = math.sqrt(2.0)


def _rs(X):
    return X[:, 0] - X[:, 1]


def _parabola(X):
    return 4.5 - X[:, 1] + 0.1 * X[:, 0] ** 2


def _four_branch(X):
    a, b = X[:, 0], X[:, 1]
    q = 3 + 0.1 * (a - b) ** 2
    return np.column_stack([q - (a + b) / SQ2, q + (a + b) / SQ2, a - b + 7 / SQ2, b - a + 7 / SQ2])


def _rp25(X):
    return np.column_stack([X[:, 0] ** 2 - 8 * X[:, 1] + 16, -16 * X[:, 0] + X[:, 1] + 32])


def problems():
    ln = UncertainInputs.from_specs({"R": LogNormal(10.0, 1.5), "S": LogNormal(3.0, 0.6)})
    (mr, sr), (ms, ss) = ln.marginals[0].log_params, ln.marginals[1].log_params
    std = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
    par = integrate.quad(
        lambda v: stats.norm.pdf(v) * stats.norm.sf(4.5 + 0.1 * v * v),
        -np.inf,
        np.inf,
        epsabs=0,
        epsrel=1e-12,
    )[0]
    b4 = [f"b{i}" for i in range(1, 5)]
    return [
        (
            "lognormal R-S",
            FunctionModel(_rs, ln.names, ["g"], key="rs", vectorized=True),
            ln,
            None,
            float(special.ndtr(-(mr - ms) / math.hypot(sr, ss))),
        ),
        (
            "parabola",
            FunctionModel(_parabola, std.names, ["g"], key="par", vectorized=True),
            std,
            None,
            par,
        ),
        (
            "four-branch",
            FunctionModel(_four_branch, std.names, b4, key="4b", vectorized=True),
            std,
            LimitState.series(*(LimitState.margin(b) for b in b4)),
            2.2228e-3,
        ),
        (
            "RP25",
            FunctionModel(_rp25, std.names, ["g1", "g2"], key="rp25", vectorized=True),
            std,
            LimitState.parallel(LimitState.margin("g1"), LimitState.margin("g2")),
            4.148566293759747e-05,
        ),
    ]


def mean_value_fosm(model, inputs, ls) -> tuple[float, int]:
    """β = g(μ)/σ_g, σ_g² = ∇gᵀ Σ ∇g by central differences (step 1e-4 σ)."""
    mu, sd = inputs.mean, inputs.std
    d = len(mu)
    X = np.tile(mu, (2 * d + 1, 1))
    for j in range(d):
        X[1 + 2 * j, j] += 1e-4 * sd[j]
        X[2 + 2 * j, j] -= 1e-4 * sd[j]
    ev = evaluate(model, X, progress=False)
    g = (ls or LimitState.margin()).bind(ev.output_index)(ev.Y)
    grad = (g[1::2] - g[2::2]) / (2e-4 * sd)
    beta = g[0] / math.sqrt(float(grad @ inputs.covariance @ grad))
    return float(special.ndtr(-beta)), ev.n


def run(reps: int) -> pd.DataFrame:
    rows = []
    for name, model, inputs, ls, pf in problems():
        kw = dict(model=model, inputs=inputs, limit_state=ls)
        with np.errstate(divide="ignore"):
            p, n = mean_value_fosm(model, inputs, ls)
        rows.append(
            (name, pf, "FOSM (mean value)", 2 * inputs.d + 1, n, p / pf - 1, p / pf - 1, np.nan)
        )
        try:
            fr = form(**kw)
            rows.append(
                (name, pf, "FORM", 0, fr.n_evaluations, fr.pf / pf - 1, fr.pf / pf - 1, np.nan)
            )
            so = sorm(**kw, design_point=fr, formula="tvedt")
            rows.append(
                (
                    name,
                    pf,
                    "SORM (Tvedt)",
                    0,
                    so.n_evaluations,
                    so.pf / pf - 1,
                    so.pf / pf - 1,
                    np.nan,
                )
            )
        except Exception as e:  # noqa: BLE001 - a benchmark records what fails
            print(f"{name}: FORM/SORM failed: {e}")
            rows.append(
                (name, pf, f"FORM failed: {type(e).__name__}", 0, np.nan, np.nan, np.nan, np.nan)
            )
            fr = None
        if fr is not None:
            for n_is in (250, 500, 1000, 2000):
                res = [
                    importance_sampling(**kw, n=n_is, seed=s, design_point=fr, progress=False)
                    for s in range(reps)
                ]
                err = np.abs([r.pf / pf - 1 for r in res])
                rows.append(
                    (
                        name,
                        pf,
                        "IS",
                        n_is,
                        res[0].n_evaluations,
                        float(np.median(err)),
                        float(np.quantile(err, 0.9)),
                        float(np.mean([r.cov for r in res])),
                    )
                )
        for N in (500, 1000, 2000, 3000):
            res = [subset_simulation(**kw, n_per_level=N, seed=s) for s in range(reps)]
            err = np.abs([r.pf / pf - 1 for r in res])
            rows.append(
                (
                    name,
                    pf,
                    "subset",
                    N,
                    float(np.mean([r.n_evaluations for r in res])),
                    float(np.median(err)),
                    float(np.quantile(err, 0.9)),
                    float(np.mean([r.cov for r in res])),
                )
            )
        print(f"{name} done", flush=True)
    return pd.DataFrame(
        rows,
        columns=[
            "problem",
            "pf_ref",
            "method",
            "setting",
            "n_evaluations",
            "rel_error_median",
            "rel_error_q90",
            "cov_mean",
        ],
    )


def _rowwise(x):
    return np.array([x[0] - x[1] + 0.1 * x[0] ** 2])


def _batch(X):
    return X[:, 0] - X[:, 1] + 0.1 * X[:, 0] ** 2


def overhead(rows: int, repeat: int) -> pd.DataFrame:
    X = np.random.default_rng(0).standard_normal((rows, 2))
    models = {
        "row-wise": FunctionModel(_rowwise, ["a", "b"], ["g"], key="o"),
        "vectorized": FunctionModel(_batch, ["a", "b"], ["g"], key="o", vectorized=True),
    }
    times = {k: [] for k in models}
    ref = None
    for _ in range(repeat):
        for k, m in models.items():  # interleaved
            t0 = time.perf_counter()
            ev = evaluate(m, X, progress=False)
            times[k].append(time.perf_counter() - t0)
            if ref is None:
                ref = ev.Y
            # same numbers up to the last bit (numpy's scalar and array arithmetic may round
            # differently)
            assert np.allclose(ev.Y, ref, rtol=4 * np.finfo(float).eps, atol=0)
    return pd.DataFrame(
        {
            k: {"median_s": float(np.median(v)), "us_per_row": 1e6 * float(np.median(v)) / rows}
            for k, v in times.items()
        }
    ).T


def plot(df: pd.DataFrame, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    probs = list(dict.fromkeys(df["problem"]))
    fig, axes = plt.subplots(1, len(probs), figsize=(4 * len(probs), 3.6), sharey=True)
    for ax, p in zip(np.atleast_1d(axes), probs):
        d = df[df["problem"] == p]
        for (meth, mk), col in zip(
            (
                ("FOSM (mean value)", "s"),
                ("FORM", "o"),
                ("SORM (Tvedt)", "D"),
                ("IS", "^-"),
                ("subset", "v-"),
            ),
            ("C0", "C1", "C2", "C3", "C4"),
        ):
            s = d[d["method"] == meth]
            ax.loglog(
                s["n_evaluations"],
                np.maximum(np.abs(s["rel_error_median"]), 1e-16),
                mk,
                color=col,
                label=meth,
            )
        ax.axhline(0.1, color="grey", lw=0.8, ls=":")
        ax.set_title(f"{p} (P_f = {d['pf_ref'].iloc[0]:.3g})")
        ax.set_xlabel("model evaluations")
    np.atleast_1d(axes)[0].set_ylabel("|P̂_f / P_f − 1| (median over seeds)")
    np.atleast_1d(axes)[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "rare_events_error.png", dpi=120)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="results/rare_events")
    ap.add_argument("--reps", type=int, default=20)
    ap.add_argument("--rows", type=int, default=20000)
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    df = run(a.reps)
    df.to_csv(out / "rare_events.csv", index=False)
    plot(df, out)
    ov = overhead(a.rows, a.repeat)
    ov.to_csv(out / "call_overhead.csv")
    pd.set_option("display.width", 160)
    print(df.to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    print(ov.to_string(float_format=lambda v: f"{v:.3g}"))
    ratio = ov.loc["row-wise", "median_s"] / ov.loc["vectorized", "median_s"]
    print(f"row-wise / vectorized = {ratio:.1f}")
    print(f"git {git_state()}, {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
