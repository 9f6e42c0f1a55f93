#!/usr/bin/env python
"""The paper's §5 on the reconstructed nine-bar: reliability index and reliability of the
slider's displacement, velocity and acceleration per crank angle (every 18°), FOSM.

Chen, Wang & Gao (2022), §5: dry vs lubricated clearance joints at 3π and 5π rad/s (Figs.
18–29), oil viscosity 100/200/400 cP (Figs. 30–35), radial clearance 0.3/0.5/0.7 mm (Figs.
36–41), allowable errors I ~ N(0.012, 0.004²) m, N(0.3, 0.1²) m/s, N(18, 6²) m/s².

The paper does not say where the spread σ_i of the actual error comes from. Here it is the
first-order propagation (FOSM, 2d + 1 simulations per case) of a stated input distribution,
the default study's, centred on each case's nominal values:

* radial clearance of C1 and C2 (one tolerance class for both): truncated normal, std 10 % of
  the nominal, truncated at ±30 %;
* oil viscosity (lubricated cases only; one oil in both joints): lognormal, 15 % coefficient of
  variation (a few kelvin of temperature spread);
* crank speed (both motors, opposite senses): normal, std 0.1 rad/s.

Finite-difference steps: lubricated cases ``step="auto"`` with the solver's relative tolerance
as the output noise (h_j = rtol^(1/3)·|μ_j|); dry cases a ±1σ secant (``step=1.0``), because dry
contact is chaotic and a local derivative of the error is not defined (docs/uq.md).

Reported forms (all from the same μ_i, σ_i):
``beta_signed``/``R_signed``  the paper's eq. (28) applied to the signed error, Φ((μ_I − μ_i)/s);
``beta_mag``/``R_mag``        the same formula on the magnitude, Φ((μ_I − |μ_i|)/s);
``R_two``/``beta_two``        the two-sided P(|i| < I) (exact under the normal assumptions) and
                              its generalised index Φ⁻¹(R_two). Figures show the two-sided form.

The geometry is a reconstruction (docs/scenes.md): compare trends with the paper, not values.

    python studies/reliability_paper.py --out results/reliability_paper [--quick] [--jobs 2]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import norm

from mechrel.cli.args import report_errors

PI = math.pi
QUANTITIES = ("displacement", "velocity", "acceleration")
UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s²"}
ALLOW = {"displacement": (0.012, 0.004), "velocity": (0.3, 0.1), "acceleration": (18.0, 6.0)}
CLEARANCE_CV = 0.10      # std / nominal of the radial clearance
CLEARANCE_TRUNC = 0.30   # truncation at nominal · (1 ± 0.3)
VISCOSITY_CV = 0.15      # lognormal coefficient of variation
SPEED_STD = 0.1          # rad/s
RTOL = 1e-7              # the default solver tolerance of both clearance models (simulation.py)
DRY_STEP = 1.0           # FOSM secant half-width in input standard deviations for dry contact


@dataclass(frozen=True)
class Case:
    key: str
    model: str          # "dry" | "lubricated"
    speed: float        # rad/s (crank 2; crank 1 turns at -speed)
    viscosity: float    # Pa s
    clearance: float    # m

    @property
    def label(self) -> str:
        if self.model == "dry":
            return f"dry, {self.speed / PI:g}π rad/s"
        return (f"lubricated, {self.speed / PI:g}π rad/s, {self.viscosity * 1e3:g} cP, "
                f"{self.clearance * 1e3:g} mm")


CASES = {c.key: c for c in (
    Case("dry-3pi", "dry", 3 * PI, 0.1, 0.5e-3),
    Case("lub-3pi", "lubricated", 3 * PI, 0.1, 0.5e-3),
    Case("dry-5pi", "dry", 5 * PI, 0.1, 0.5e-3),
    Case("lub-5pi", "lubricated", 5 * PI, 0.1, 0.5e-3),
    Case("lub-200cP", "lubricated", 3 * PI, 0.2, 0.5e-3),
    Case("lub-400cP", "lubricated", 3 * PI, 0.4, 0.5e-3),
    Case("lub-0.3mm", "lubricated", 3 * PI, 0.1, 0.3e-3),
    Case("lub-0.7mm", "lubricated", 3 * PI, 0.1, 0.7e-3),
)}

# (key, title, {case: legend label})
COMPARISONS = (
    ("speed3", "Dry vs lubricated at ω = 3π rad/s (paper Figs. 18–23)",
     {"dry-3pi": "dry contact", "lub-3pi": "lubricated"}),
    ("speed5", "Dry vs lubricated at ω = 5π rad/s (paper Figs. 24–29)",
     {"dry-5pi": "dry contact", "lub-5pi": "lubricated"}),
    ("viscosity", "Oil viscosity, lubricated, 3π rad/s, 0.5 mm (paper Figs. 30–35)",
     {"lub-3pi": "100 cP", "lub-200cP": "200 cP", "lub-400cP": "400 cP"}),
    ("clearance", "Radial clearance, lubricated, 3π rad/s, 100 cP (paper Figs. 36–41)",
     {"lub-0.3mm": "0.3 mm", "lub-3pi": "0.5 mm", "lub-0.7mm": "0.7 mm"}),
)
QUICK_CASES = ("dry-3pi", "lub-3pi")

# Every minimum the paper prints in §5.1–5.3: (comparison, case, quantity, angle°, β, R).
PAPER_MINIMA = (
    ("speed3", "dry-3pi", "displacement", 162, 2.021, 0.9784),
    ("speed3", "lub-3pi", "displacement", 162, 2.014, 0.9780),
    ("speed3", "dry-3pi", "velocity", 180, 1.614, 0.9464),
    ("speed3", "lub-3pi", "velocity", 180, 2.013, 0.9780),
    ("speed3", "dry-3pi", "acceleration", 270, -0.1706, 0.4325),
    ("speed3", "lub-3pi", "acceleration", 270, 1.675, 0.9530),
    ("speed5", "lub-5pi", "displacement", 162, 2.213, 0.9865),
    ("speed5", "dry-5pi", "displacement", 144, 2.214, 0.9866),
    ("speed5", "lub-5pi", "velocity", 270, 1.710, 0.9564),
    ("speed5", "dry-5pi", "velocity", 162, 1.172, 0.8581),   # misprint: Φ(1.072) = 0.8581
    ("speed5", "lub-5pi", "acceleration", 270, 0.08237, 0.5329),
    ("speed5", "dry-5pi", "acceleration", 180, -0.7213, 0.2358),
    ("viscosity", "lub-3pi", "displacement", 162, 2.014, 0.9780),
    ("viscosity", "lub-200cP", "displacement", 162, 2.043, 0.9795),
    ("viscosity", "lub-400cP", "displacement", 162, 2.091, 0.9817),
    ("viscosity", "lub-3pi", "velocity", 180, 2.013, 0.9780),
    ("viscosity", "lub-200cP", "velocity", 180, 2.263, 0.9882),
    ("viscosity", "lub-400cP", "velocity", 198, 2.539, 0.9945),
    ("viscosity", "lub-3pi", "acceleration", 270, 1.675, 0.9530),
    ("viscosity", "lub-200cP", "acceleration", 252, 2.051, 0.9798),
    ("viscosity", "lub-400cP", "acceleration", 252, 2.389, 0.9916),
    ("clearance", "lub-0.3mm", "displacement", 180, 2.187, 0.9859),
    ("clearance", "lub-3pi", "displacement", 162, 2.014, 0.9780),
    ("clearance", "lub-0.7mm", "displacement", 162, 1.832, 0.9666),
    ("clearance", "lub-0.3mm", "velocity", 180, 2.736, 0.9969),
    ("clearance", "lub-3pi", "velocity", 180, 2.013, 0.9780),
    ("clearance", "lub-0.7mm", "velocity", 180, 1.304, 0.9039),
    ("clearance", "lub-0.3mm", "acceleration", 252, 2.437, 0.9927),
    ("clearance", "lub-3pi", "acceleration", 270, 1.675, 0.9530),
    ("clearance", "lub-0.7mm", "acceleration", 270, 0.5269, 0.7009),
)

# The paper's §4 error ranges [min, max] over the simulated time (Figs. 6–17), per case.
PAPER_RANGES = {
    "dry-3pi": {
        "displacement": (-4.047e-3, 7.72e-4),
        "velocity": (-0.2039, 0.2427),
        "acceleration": (-365.0, 576.0),
    },
    "lub-3pi": {
        "displacement": (-4.097e-3, 6.802e-4),
        "velocity": (-0.1229, 0.1385),
        "acceleration": (-14.01, 24.01),
    },
    "dry-5pi": {
        "displacement": (-3.444e-3, 7.966e-4),
        "velocity": (-0.3324, 0.3054),
        "acceleration": (-581.8, 1386.0),
    },
    "lub-5pi": {
        "displacement": (-3.449e-3, 7.691e-4),
        "velocity": (-0.2114, 0.1911),
        "acceleration": (-42.8, 107.6),
    },
    "lub-200cP": {
        "displacement": (-4.018e-3, 6.222e-4),
        "velocity": (-0.09714, 0.1037),
        "acceleration": (-4.82, 11.25),
    },
    "lub-400cP": {
        "displacement": (-3.892e-3, 5.274e-4),
        "velocity": (-0.06477, 0.06576),
        "acceleration": (-1.504, 6.338),
    },
    "lub-0.3mm": {
        "displacement": (-3.496e-3, -1.617e-4),
        "velocity": (-0.04091, 0.04001),
        "acceleration": (-1.532, 5.624),
    },
    "lub-0.7mm": {
        "displacement": (-4.832e-3, 1.58e-3),
        "velocity": (-0.1834, 0.2430),
        "acceleration": (-64.92, 100.5),
    },
}


# ----------------------------------------------------------------------------- model & inputs
def case_model(case: Case, *, cycles: float = 2.0, overrides: dict | None = None):
    """The MechanismModel of one case: inputs clearance (both joints), viscosity (lubricated
    only, both joints) and speed (both cranks, opposite senses). ``overrides``: further fixed
    scene values (e.g. ``joints.C1.lubricant.bearing``), applied after the case's."""
    from mechrel.uq.problem.mechanism import MechanismModel

    targets = {"clearance": ["joints.C1.clearance", "joints.C2.clearance"]}
    if case.model == "lubricated":
        targets["viscosity"] = ["joints.C1.lubricant.viscosity", "joints.C2.lubricant.viscosity"]
    targets["speed"] = ["drivers.crank2.speed", "-drivers.crank1.speed"]
    overrides = {"joints.C1.clearance": case.clearance, "joints.C2.clearance": case.clearance,
                 "joints.C1.lubricant.viscosity": case.viscosity,
                 "joints.C2.lubricant.viscosity": case.viscosity,
                 "drivers.crank2.speed": case.speed, "drivers.crank1.speed": -case.speed,
                 **(overrides or {})}
    scene = "nine-bar-dry" if case.model == "dry" else "nine-bar-lubricated"
    return MechanismModel(scene, targets, output="slider", cycles=cycles, overrides=overrides)


def case_inputs(case: Case):
    """The stated input distribution, centred on the case's nominal values."""
    from mechrel.uq import UncertainInputs

    c = case.clearance
    specs = {"clearance": {"distribution": "truncnormal", "mean": c, "std": CLEARANCE_CV * c,
                           "lower": (1 - CLEARANCE_TRUNC) * c, "upper": (1 + CLEARANCE_TRUNC) * c}}
    if case.model == "lubricated":
        specs["viscosity"] = {"distribution": "lognormal", "mean": case.viscosity,
                              "std": VISCOSITY_CV * case.viscosity}
    specs["speed"] = {"distribution": "normal", "mean": case.speed, "std": SPEED_STD}
    return UncertainInputs.from_specs(specs)


def fosm_settings(case: Case) -> dict:
    return {"step": DRY_STEP} if case.model == "dry" else {"step": "auto", "noise": RTOL}


def forms_table(t: pd.DataFrame) -> pd.DataFrame:
    """The three readings of the paper's formula from FOSM's μ_i, σ_i (see module doc), in
    the paper's symbols (``mu_i``, ``sigma_i``, ``mu_I``, ``sigma_I``)."""
    mu_i, sigma_i = t["mean"], t["std"]
    mu_I, sigma_I = t["allowable_mean"], t["allowable_std"]
    s = np.hypot(sigma_I, sigma_i)
    out = pd.DataFrame(index=t.index)
    out["mu_i"], out["sigma_i"] = mu_i, sigma_i
    out["mu_I"], out["sigma_I"] = mu_I, sigma_I
    out["beta_signed"] = (mu_I - mu_i) / s
    out["R_signed"] = norm.cdf(out["beta_signed"])
    out["beta_mag"] = (mu_I - mu_i.abs()) / s
    out["R_mag"] = norm.cdf(out["beta_mag"])
    out["R_two"] = t["R_two_sided"]
    out["beta_two"] = norm.ppf(t["R_two_sided"])
    return out


# ----------------------------------------------------------------------------- paper checks
def paper_consistency() -> pd.DataFrame:
    """Per printed (β, R): Φ(β) − R, and which reading of μ_i the §4 error ranges allow.

    With σ_i ≥ 0 and s = sqrt(σ_I² + σ_i²) ≥ σ_I, a printed β fixes μ_i = μ_I − β s. The
    *signed* reading needs μ_i inside the §4 range [lo, hi] of the signed error; the
    *magnitude* reading needs |μ_i| ≤ max(|lo|, |hi|). ``sigma_i_min_*`` is the smallest σ_i
    for which that is possible (0: possible with a negligible σ_i)."""
    rows = []
    for comp, key, q, ang, beta, R in PAPER_MINIMA:
        mu_I, sd_I = ALLOW[q]
        lo, hi = PAPER_RANGES[key][q]

        def sigma_min(i_lo, i_hi):
            # s = (mu_I - i)/beta for i in [i_lo, i_hi]; need s >= sd_I
            ends = sorted(((mu_I - i_lo) / beta, (mu_I - i_hi) / beta))
            if ends[1] < sd_I:
                return np.inf
            return math.sqrt(max(ends[0], sd_I) ** 2 - sd_I ** 2)

        rows.append({
            "comparison": comp, "case": key, "quantity": q, "angle": ang, "beta": beta, "R": R,
            "Phi_beta": norm.cdf(beta), "Phi_beta_minus_R": norm.cdf(beta) - R,
            "beta_from_R": norm.ppf(R),
            "implied_mu_i_if_sigma_i_0": mu_I - beta * sd_I,
            "paper_range_lo": lo, "paper_range_hi": hi,
            "sigma_i_min_signed": sigma_min(lo, hi),
            "sigma_i_min_magnitude": sigma_min(0.0, max(abs(lo), abs(hi))),
        })
    df = pd.DataFrame(rows)
    df["misprint"] = df["Phi_beta_minus_R"].abs() > 5e-3
    return df


# ----------------------------------------------------------------------------- run
def run_cases(keys, *, n_jobs: int, cycles: float, cache, progress: bool):
    from mechrel.uq import fosm

    results, tables = {}, []
    for key in keys:
        case = CASES[key]
        t0 = time.perf_counter()
        model, inputs = case_model(case, cycles=cycles), case_inputs(case)
        r = fosm(model=model, inputs=inputs, event="two-sided", n_jobs=n_jobs, cache=cache,
                 progress=progress, **fosm_settings(case))
        results[key] = r
        ft = forms_table(r.table)
        ft.insert(0, "case", key)
        tables.append(ft.reset_index())
        imp = r.importance().groupby(level="quantity").mean()
        print(
            f"  {key:10s} FOSM: {r.evaluations.n} points ({r.evaluations.n_model_calls} simulated) "
            f"in {time.perf_counter() - t0:.1f} s; mean σ_i² shares: "
            + "; ".join(
                f"{q[:4]} " + ", ".join(f"{c} {imp.loc[q, c]:.2f}" for c in imp.columns)
                for q in QUANTITIES
            ),
            flush=True,
        )
    return results, pd.concat(tables, ignore_index=True)


def our_minima(long: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (key, q), g in long.groupby(["case", "quantity"], sort=False):
        g = g[g["crank_angle"] < 360]          # 360° repeats 0°
        k = g["beta_two"].idxmin()
        k1 = g["beta_signed"].idxmin()
        rows.append({"case": key, "quantity": q, "angle": g.loc[k, "crank_angle"],
                     "beta_two": g.loc[k, "beta_two"], "R_two": g.loc[k, "R_two"],
                     "beta_mag": g.loc[k, "beta_mag"], "R_mag": g.loc[k, "R_mag"],
                     "mu_i": g.loc[k, "mu_i"], "sigma_i": g.loc[k, "sigma_i"],
                     "angle_signed": g.loc[k1, "crank_angle"],
                     "beta_signed": g.loc[k1, "beta_signed"], "R_signed": g.loc[k1, "R_signed"],
                     "err_min": g["mu_i"].min(), "err_max": g["mu_i"].max(),
                     "sigma_i_over_sigma_I_max": (g["sigma_i"] / g["sigma_I"]).max()})
    return pd.DataFrame(rows)


def side_by_side(mins: pd.DataFrame, keys) -> pd.DataFrame:
    ours = mins.set_index(["case", "quantity"])
    rows = []
    for comp, key, q, ang, beta, R in PAPER_MINIMA:
        if key not in keys:
            continue
        o = ours.loc[(key, q)]
        rows.append(
            {
                "comparison": comp,
                "case": key,
                "quantity": q,
                "paper_angle": ang,
                "paper_beta": beta,
                "paper_R": R,
                "ours_angle": o["angle"],
                "ours_beta": o["beta_two"],
                "ours_R": o["R_two"],
                "ours_beta_signed_min": o["beta_signed"],
                "ours_angle_signed": o["angle_signed"],
            }
        )
    return pd.DataFrame(rows)


TIE = 0.03   # |Δβ| below which two cases' minima are called a tie (FD/solver noise level)


def _tie(betas) -> bool:
    b = np.sort(np.asarray(betas, dtype=float))
    return bool(np.any(np.diff(b) < TIE))


def trends(mins: pd.DataFrame, keys) -> pd.DataFrame:
    """Per comparison and quantity: the cases ordered by their minimum β, paper vs ours."""
    ours = mins.set_index(["case", "quantity"])["beta_two"]
    paper = {(k, q): b for _, k, q, _, b, _ in PAPER_MINIMA}
    rows = []
    for comp, _, labels in COMPARISONS:
        cases = [c for c in labels if c in keys]
        if len(cases) < 2:
            continue
        for q in QUANTITIES:
            p_order = sorted(cases, key=lambda c: paper[(c, q)])
            o_order = sorted(cases, key=lambda c: ours[(c, q)])
            rows.append(
                {
                    "comparison": comp,
                    "quantity": q,
                    "paper_lowest_to_highest": " < ".join(labels[c] for c in p_order),
                    "ours_lowest_to_highest": " < ".join(labels[c] for c in o_order),
                    "same_order": p_order == o_order,
                    "near_tie": _tie([paper[(c, q)] for c in cases])
                    or _tie([ours[(c, q)] for c in cases]),
                    "paper_betas": ", ".join(f"{labels[c]} {paper[(c, q)]:.3f}" for c in cases),
                    "ours_betas": ", ".join(f"{labels[c]} {ours[(c, q)]:.3f}" for c in cases),
                }
            )
    # speed: the paper's claim "lower speed, higher reliability" (lubricated and dry)
    for model in ("lub", "dry"):
        a, b = f"{model}-3pi", f"{model}-5pi"
        if a in keys and b in keys:
            for q in QUANTITIES:
                rows.append(
                    {
                        "comparison": f"speed ({model})",
                        "quantity": q,
                        "paper_lowest_to_highest": " < ".join(
                            x for _, x in sorted(((paper[(a, q)], "3π"), (paper[(b, q)], "5π")))
                        ),
                        "ours_lowest_to_highest": " < ".join(
                            x for _, x in sorted(((ours[(a, q)], "3π"), (ours[(b, q)], "5π")))
                        ),
                        "same_order": (paper[(a, q)] < paper[(b, q)])
                        == (ours[(a, q)] < ours[(b, q)]),
                        "near_tie": _tie([paper[(a, q)], paper[(b, q)]])
                        or _tie([ours[(a, q)], ours[(b, q)]]),
                        "paper_betas": f"3π {paper[(a, q)]:.3f}, 5π {paper[(b, q)]:.3f}",
                        "ours_betas": f"3π {ours[(a, q)]:.3f}, 5π {ours[(b, q)]:.3f}",
                    }
                )
    return pd.DataFrame(rows)


# ----------------------------------------------------------------------------- figures
def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def plot_comparison(long, title, labels, path, paper_rows):
    """One figure per comparison, like the paper's: rows = quantities, columns = β and R."""
    plt = _plt()
    fig, axes = plt.subplots(3, 2, figsize=(11, 8.6), sharex=True, constrained_layout=True)
    markers = ("o", "s", "^", "D")
    for row, q in zip(axes, QUANTITIES):
        for j, (key, lab) in enumerate(labels.items()):
            g = long[(long["case"] == key) & (long["quantity"] == q)]
            for ax, col in zip(row, ("beta_two", "R_two")):
                ax.plot(g["crank_angle"], g[col], marker=markers[j], ms=4, lw=1.4,
                        color=f"C{j}", label=lab)
        # the paper's printed minima (its geometry) in the panel titles, so that our curves
        # keep their own scale
        pr = [(labels[k], a, b, r) for _, k, qq, a, b, r in paper_rows if qq == q and k in labels]
        head = ("β = Φ⁻¹(R), two-sided P(|i| < I), FOSM\n", "R = P(|i| < I), FOSM\n") \
            if q == QUANTITIES[0] else ("", "")
        import textwrap
        row[0].set_title(head[0] + textwrap.fill("paper's min β: " + "; ".join(
            f"{l} {b:.4g} at {a}°" for l, a, b, _ in pr), 75), fontsize=8)
        row[1].set_title(head[1] + textwrap.fill("paper's min R: " + "; ".join(
            f"{l} {r:.4g} at {a}°" for l, a, _, r in pr), 75), fontsize=8)
        row[0].set_ylabel(f"{q}\nreliability index β")
        row[1].set_ylabel(f"{q}\nreliability R")
        for ax in row:
            ax.grid(alpha=0.3)
            ax.set_xticks(np.arange(0, 361, 36))
    h, lbl = axes[0][0].get_legend_handles_labels()
    fig.legend(h, lbl, loc="outside lower center", ncol=len(lbl), fontsize=9)
    for ax in axes[-1]:
        ax.set_xlabel("crank angle θ₁ (deg), last simulated cycle")
    fig.suptitle(title + "\nreconstructed geometry: compare trends, not values", fontsize=11)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_errors(long, keys, path):
    """Nominal signed errors (FOSM's μ_i) at the 18° analysis points, per comparison."""
    plt = _plt()
    comps = [(k, t, {c: l for c, l in labels.items() if c in keys}) for k, t, labels in COMPARISONS]
    comps = [c for c in comps if len(c[2]) >= 2]
    fig, axes = plt.subplots(3, len(comps), figsize=(max(7.0, 4.2 * len(comps)), 8), sharex=True,
                             squeeze=False, constrained_layout=True)
    for col, (_ck, title, labels) in enumerate(comps):
        for row, q in enumerate(QUANTITIES):
            ax = axes[row][col]
            for j, (key, lab) in enumerate(labels.items()):
                g = long[(long["case"] == key) & (long["quantity"] == q)]
                ax.errorbar(g["crank_angle"], g["mu_i"], yerr=g["sigma_i"], marker="o", ms=3,
                            lw=1.2, capsize=2, color=f"C{j}", label=lab)
            ax.axhline(0, color="k", lw=0.6)
            ax.grid(alpha=0.3)
            ax.set_xticks(np.arange(0, 361, 72))
            if col == 0:
                ax.set_ylabel(f"{q} error ({UNITS[q]})")
            if row == 0:
                ax.set_title(title.split(" (paper")[0], fontsize=9)
                ax.legend(fontsize=7)
        axes[-1][col].set_xlabel("crank angle (deg)")
    fig.suptitle("Slider error (clearance − ideal) at the analysis points: μ_i ± σ_i (FOSM)")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_forms(long, key, path):
    """The paper's formula on the signed error vs on the magnitude vs two-sided, one case."""
    plt = _plt()
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True, constrained_layout=True)
    for ax, q in zip(axes, QUANTITIES):
        g = long[(long["case"] == key) & (long["quantity"] == q)]
        ax.plot(
            g["crank_angle"],
            g["beta_signed"],
            "o-",
            ms=4,
            label="Φ(β) on the signed error (eq. 28 literally)",
        )
        ax.plot(
            g["crank_angle"],
            g["beta_mag"],
            "s-",
            ms=4,
            label="Φ(β) on |error| (what the paper's numbers are)",
        )
        ax.plot(g["crank_angle"], g["beta_two"], "k--", lw=1, label="Φ⁻¹(P(|i| < I)), two-sided")
        ax2 = ax.twinx()
        ax2.bar(g["crank_angle"], g["mu_i"], width=8, color="0.85", zorder=0)
        ax2.set_ylabel(f"μ_i ({UNITS[q]}), bars", color="0.5")
        ax.set_zorder(ax2.get_zorder() + 1)
        ax.patch.set_visible(False)
        ax.set_ylabel(f"{q}: β")
        ax.grid(alpha=0.3)
        ax.set_xticks(np.arange(0, 361, 36))
    axes[0].legend(fontsize=8, loc="lower left")
    axes[-1].set_xlabel("crank angle (deg)")
    fig.suptitle(f"{CASES[key].label}: which form?\nthe signed-error β exceeds μ_I/σ_I = 3 "
                 "wherever the error is negative", fontsize=10)
    fig.savefig(path, dpi=120)
    plt.close(fig)


# ----------------------------------------------------------------------------- report
def markdown_table(df: pd.DataFrame, floatfmt: str = ".4g") -> str:
    """``df`` as a Markdown table (floats as ``floatfmt``), for the studies' reports."""
    cols = list(df.columns)
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for _, r in df.iterrows():
        cells = []
        for c in cols:
            v = r[c]
            if isinstance(v, (float, np.floating)):
                cells.append(format(v, floatfmt) if np.isfinite(v) else str(v))
            else:
                cells.append(str(v))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def write_report(out: Path, long, mins, sbs, trend, cons, keys, wall, args):
    gap = (long["R_mag"] - long["R_two"]).abs().groupby(long["case"]).max()
    ratio = (long["sigma_i"] / long["sigma_I"]).groupby(long["case"]).max()
    small = ratio[ratio < 0.5].index
    big = ratio[ratio >= 0.5].index
    lines = [
        "# The paper's §5 on the reconstructed nine-bar (FOSM)",
        "",
        f"Command: `python studies/reliability_paper.py --out {args.out}"
        + (" --quick" if args.quick else "")
        + f" --jobs {args.jobs}`; wall time {wall:.0f} s; "
        f"cases: {', '.join(keys)}; analysed cycle: {args.cycles:g} (the last).",
        "",
        "Input distribution (centred on each case): clearance truncnormal, std 10 % of nominal, "
        "±30 %; "
        "viscosity lognormal, CV 15 % (lubricated only); speed normal, std 0.1 rad/s. FOSM steps: "
        "lubricated `auto` (noise = rtol = 1e-7); dry ±1σ secant.",
        "",
        "## Which form do the paper's numbers use?",
        "",
        f"All {len(cons)} printed (β, R) pairs ({len(cons.drop_duplicates(['case', 'quantity']))} "
        "distinct) satisfy R = Φ(β) to within "
        f"{cons.loc[~cons['misprint'], 'Phi_beta_minus_R'].abs().max():.1e} except one: "
        + "; ".join(
            f"{r.case} {r.quantity} β = {r.beta}, R = {r.R} (Φ(β) = {r.Phi_beta:.4f}; "
            f"Φ⁻¹(R) = {r.beta_from_R:.4f}, a digit misprint of 1.072)"
            for r in cons[cons["misprint"]].drop_duplicates(["case", "quantity"]).itertuples()
        )
        + ". The form is the one-sided eq. (28).",
        "",
        "It is applied to the error's *magnitude*: with σ_i = 0 the printed β implies "
        "|μ_i| = μ_I − βσ_I, inside the §4 ranges of |error| for every case; read as the *signed* "
        "error it needs a σ_i as large as the error's whole range where the §4 displacement error "
        "is (almost) all negative (column `sigma_i_min_signed`, e.g. "
        + ", ".join(
            f"{r.case} {r.quantity} ≥ {r.sigma_i_min_signed * 1e3:.1f} mm"
            for r in cons[(cons["quantity"] == "displacement")].drop_duplicates("case").itertuples()
        )
        + "). On the magnitude, with σ_i ≪ σ_I, the one-sided Φ(β) equals the two-sided "
        f"P(|i| < I) to {gap[small].max():.1e} in our cases with max σ_i/σ_I < 0.5 "
        f"({', '.join(small)})"
        + (
            "; where σ_i is comparable to σ_I or larger ("
            + ", ".join(f"{k}: σ_i/σ_I up to {ratio[k]:.1f}" for k in big)
            + ") "
            f"they differ by up to {gap[big].max():.2f}: the one-sided form then misses the other "
            "tail"
            if len(big)
            else ""
        )
        + ". The figures show the two-sided form.",
        "",
        markdown_table(
            cons[
                [
                    "case",
                    "quantity",
                    "angle",
                    "beta",
                    "R",
                    "Phi_beta_minus_R",
                    "implied_mu_i_if_sigma_i_0",
                    "paper_range_lo",
                    "paper_range_hi",
                    "sigma_i_min_signed",
                    "sigma_i_min_magnitude",
                ]
            ]
        ),
        "",
        "## Minima: paper vs this reconstruction",
        "",
        "`ours_*`: FOSM two-sided at the angle of the minimum; `ours_beta_signed_min`: the "
        "minimum of the literal signed-error reading (and its angle).",
        "",
        markdown_table(sbs),
        "",
        "## Trends (cases ordered by their minimum β)",
        "",
        markdown_table(trend.drop(columns=[])),
        "",
        "## Our minima and error ranges per case",
        "",
        markdown_table(mins),
        "",
        "Figures: " + ", ".join(f"`{p.name}`" for p in sorted(out.glob("*.png"))) + ".",
    ]
    (out / "report.md").write_text("\n".join(lines) + "\n")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="results/reliability_paper", help="output folder")
    ap.add_argument("--quick", action="store_true",
                    help=f"only the 3π dry vs lubricated comparison ({', '.join(QUICK_CASES)})")
    ap.add_argument("--jobs", type=int, default=2, help="parallel worker processes (default 2)")
    ap.add_argument("--cycles", type=float, default=2.0,
                    help="simulated cycles; the last is analysed (default 2, as the default study)")
    ap.add_argument("--no-cache", action="store_true", help="do not use OUT/evaluations.sqlite")
    ap.add_argument("--no-progress", action="store_true")
    args = ap.parse_args(argv)
    return report_errors(run, args, ap.prog)


def run(args) -> int:
    """The study for parsed arguments: figures, tables, report.md and summary.json in OUT."""
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    keys = list(QUICK_CASES) if args.quick else list(CASES)
    t0 = time.perf_counter()
    print(f"reliability_paper: {len(keys)} cases, FOSM, n_jobs = {args.jobs}", flush=True)
    results, long = run_cases(keys, n_jobs=args.jobs, cycles=args.cycles,
                              cache=None if args.no_cache else out / "evaluations.sqlite",
                              progress=not args.no_progress)
    mins = our_minima(long)
    sbs = side_by_side(mins, keys)
    trend = trends(mins, keys)
    cons = paper_consistency()
    long.to_csv(out / "fosm_per_angle.csv", index=False)
    mins.to_csv(out / "our_minima.csv", index=False)
    sbs.to_csv(out / "minima_vs_paper.csv", index=False)
    trend.to_csv(out / "trends.csv", index=False)
    cons.to_csv(out / "paper_consistency.csv", index=False)
    for ck, title, labels in COMPARISONS:
        lab = {k: v for k, v in labels.items() if k in keys}
        if len(lab) >= 2:
            plot_comparison(long, title, lab, out / f"fig_{ck}.png",
                            [r for r in PAPER_MINIMA if r[0] == ck])
    plot_errors(long, keys, out / "errors.png")
    plot_forms(long, "lub-3pi", out / "forms_lub-3pi.png")
    if "dry-3pi" in keys:
        plot_forms(long, "dry-3pi", out / "forms_dry-3pi.png")
    wall = time.perf_counter() - t0
    import json

    prov = {
        k: {
            "model_cache_key": r.provenance["model_cache_key"],
            "inputs": r.provenance["inputs"],
            "settings": r.provenance["settings"],
            "n_model_calls": r.provenance["n_computed"],
        }
        for k, r in results.items()
    }
    (out / "summary.json").write_text(
        json.dumps(
            {
                "argv": sys.argv,
                "cases": keys,
                "wall_time": wall,
                "versions": next(iter(results.values())).provenance["versions"],
                "provenance": prov,
            },
            indent=2,
            default=str,
        )
        + "\n"
    )
    write_report(out, long, mins, sbs, trend, cons, keys, wall, args)
    print(sbs.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    print(trend[["comparison", "quantity", "paper_lowest_to_highest", "ours_lowest_to_highest",
                 "same_order", "near_tie"]].to_string(index=False))
    print(f"wrote {out}/ (report.md, *.csv, *.png) in {wall:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
