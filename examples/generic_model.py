"""A plain Python model with uncertain inputs through mechrel's estimators.

    python examples/generic_model.py --out results/examples

The estimators of :mod:`mechrel.uq` take any model, not only a mechanism. Here the model is the
tip deflection of a cantilever beam of length L = 0.5 m and rectangular section b × h under a
tip load P, δ = 4 P L³ / (E b h³) (Euler–Bernoulli), whose output is the *error* of the
deflection against its design value δ₀ = 15.625 mm (P = 1 kN, E = 200 GPa, b = h = 20 mm). The
load, the modulus and the section height are uncertain; the allowable error is I ~ N(2 mm,
(0.2 mm)²) on |δ − δ₀|. The script estimates the reliability P(|δ − δ₀| < I) by FOSM, Monte
Carlo (with its 95 % interval) and a polynomial chaos surrogate, reports the PCE's Sobol'
indices, plots the error distribution and the three reliabilities, and prints them.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from scipy import stats  # noqa: E402

from mechrel.uq import (  # noqa: E402
    Allowable, FunctionModel, LogNormal, Normal, UncertainInputs, Uniform, fosm, monte_carlo,
    polynomial_chaos,
)

L, B = 0.5, 0.02  # m
DELTA0 = 4 * 1000.0 * L**3 / (200e9 * B * 0.02**3)  # m, the design deflection (15.625 mm)


def deflection_error(x: np.ndarray) -> np.ndarray:
    """Tip deflection minus its design value (m), for x = (P [N], E [Pa], h [m])."""
    P, E, h = x
    return np.array([4.0 * P * L**3 / (E * B * h**3) - DELTA0])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="results/examples", help="output directory")
    ap.add_argument("--seed", type=int, default=2026, help="the study's seed")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    model = FunctionModel(deflection_error, ("P", "E", "h"),
                          pd.Index(["tip_deflection"], name="output"), key="cantilever v1")
    inputs = UncertainInputs.from_specs({
        "P": Normal(1000.0, 100.0),               # N
        "E": LogNormal(200e9, 10e9),              # Pa
        "h": Uniform(19.6e-3, 20.4e-3),           # m
    })
    allowable = Allowable(2e-3, 0.2e-3)          # m
    common = {"model": model, "inputs": inputs, "allowable": allowable, "progress": False}

    fo = fosm(**common)
    mc = monte_carlo(**common, n=20_000, seed=args.seed)
    pce = polynomial_chaos(model=model, inputs=inputs, order=3, seed=args.seed, progress=False)
    pce_rel = pce.reliability(n=200_000, seed=args.seed, allowable=allowable)

    r_fo = fo.reliability.iloc[0]
    row = mc.table.iloc[0]
    r_pce = pce_rel.reliability.iloc[0]
    print(f"design deflection δ0 = {DELTA0 * 1e3:.3f} mm; allowable |δ − δ0| < I, "
          f"I ~ N({allowable.mean * 1e3:g} mm, ({allowable.std * 1e3:g} mm)²)")
    print(f"error: FOSM mean {fo.table['mean'].iloc[0] * 1e3:+.4f} mm, std "
          f"{fo.table['std'].iloc[0] * 1e3:.4f} mm; Monte Carlo mean "
          f"{row['mean'] * 1e3:+.4f} mm, std {row['std'] * 1e3:.4f} mm; PCE mean "
          f"{pce.mean.iloc[0] * 1e3:+.4f} mm, std {pce.std.iloc[0] * 1e3:.4f} mm")
    print(f"reliability: FOSM {r_fo:.4f}; Monte Carlo {row['reliability']:.4f} "
          f"[{row['reliability_lo']:.4f}, {row['reliability_hi']:.4f}] (n = 20000, 95 %); "
          f"PCE surrogate {r_pce:.4f} (n = 200000)")
    s1 = pce.sobol_first.iloc[0]
    st = pce.sobol_total.iloc[0]
    print("Sobol' indices (PCE): " + ", ".join(
        f"{name}: S1 {s1[name]:.3f}, ST {st[name]:.3f}" for name in inputs.names))

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
    X = inputs.sample(20_000, "random", seed=args.seed)
    err = np.array([deflection_error(x)[0] for x in X]) * 1e3
    ax1.hist(err, bins=80, density=True, alpha=0.5, label="Monte Carlo samples")
    grid = np.linspace(err.min(), err.max(), 300)
    ax1.plot(grid, stats.norm.pdf(grid, fo.table["mean"].iloc[0] * 1e3,
                                  fo.table["std"].iloc[0] * 1e3), "k-", label="FOSM normal")
    surrogate = pce.predict(X)[:, 0] * 1e3
    ax1.hist(surrogate, bins=80, density=True, histtype="step", color="C3",
             label="PCE surrogate (order 3)")
    for s in (-1, 1):
        ax1.axvline(s * allowable.mean * 1e3, color="grey", ls="--", lw=0.8)
    ax1.set_xlabel("deflection error δ − δ0 (mm)")
    ax1.set_ylabel("density (1/mm)")
    ax1.legend(fontsize=8)
    names = ["FOSM", "Monte Carlo\n(n = 20000, 95 %)", "PCE surrogate\n(n = 200000)"]
    values = [r_fo, row["reliability"], r_pce]
    yerr = [[0.0, row["reliability"] - row["reliability_lo"], 0.0],
            [0.0, row["reliability_hi"] - row["reliability"], 0.0]]
    for k, (v, color) in enumerate(zip(values, ["C0", "C1", "C3"])):
        ax2.errorbar([k], [v], yerr=[[yerr[0][k]], [yerr[1][k]]], fmt="o", color=color,
                     capsize=5, ms=7)
        ax2.annotate(f"{v:.4f}", (k, v), textcoords="offset points", xytext=(10, -3),
                     fontsize=8)
    ax2.set_xticks(range(3), names)
    ax2.set_xlim(-0.5, 2.7)
    ax2.set_ylim(min(values) - 0.02, max(values) + 0.02)
    ax2.set_ylabel("reliability P(|δ − δ0| < I)")
    ax2.grid(alpha=0.3, axis="y")
    fig.suptitle("A generic model through mechrel.uq: cantilever tip deflection", fontsize=10)
    path = out / "generic_model.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
