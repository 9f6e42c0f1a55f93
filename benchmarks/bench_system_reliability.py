"""Whole-cycle and system reliability: every rare-event method against independent references.

The problems (``tests/data/system_problems.py`` and below):

* ``slider-crank``: the whole cycle of an offset slider-crank's displacement error under crank,
  rod and offset tolerances (:func:`~mechrel.uq.problem.analytic.slider_crank_tolerance_model`,
  20 sectors of 18°, 8 intervals each): the error peaks at several crank angles with either
  sign, a series system of 40 members with 6–8 design points. Allowables 0.18 mm (P_f ≈ 1e-3)
  and 0.26 mm (P_f ≈ 1e-6).
* ``two-points``: g = 3.5 − |u₁| (one opaque margin, two design points): P_f = 2Φ(−3.5).
* ``four-branch``: the four-branch series system (k = 6), P_f by a 1-D directional integral.
* ``parallel``: two linear components of β = 3, independent: P_f = Φ(−3)².

``--reference`` recomputes the slider-crank references and writes
``tests/data/slider_crank_whole_cycle.json`` (crude Monte Carlo at 1e-3: 4·10⁶ samples; at
1e-6 a long mixture importance sampling, 4·10⁵ samples, and a long subset simulation,
2·10⁴ per level, which agree within their intervals). Without it, the script runs each method
over ``--seeds`` seeds on each problem and prints the median ratio to the reference, the spread,
the mean reported c.o.v. and the coverage of the 95 % intervals (docs/uq.md, "The whole cycle
as a series system"). ``--subset-coverage`` measures the coverage of
subset simulation's interval variants on five problems (the choice of its c.o.v.).

    python benchmarks/bench_system_reliability.py --seeds 40
    python benchmarks/bench_system_reliability.py --subset-coverage --seeds 200
    python benchmarks/bench_system_reliability.py --reference
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy import integrate, special

from mechrel.uq import (
    FunctionModel,
    LimitState,
    Normal,
    UncertainInputs,
    form,
    importance_sampling,
    sorm,
    subset_simulation,
)

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "tests" / "data" / "slider_crank_whole_cycle.json"
sys.path.insert(0, str(ROOT / "tests" / "data"))  # the problems are the tests' fixture
from system_problems import (  # noqa: E402
    ALLOWABLES,
    four_branch,
    four_branch_exact,
    slider_crank,
)


STD2 = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})


def _tie(X):
    return 3.5 - np.abs(X[:, 0])


def _parallel(X):
    return np.column_stack([3.0 - X[:, 0], 3.0 - X[:, 1]])


def problems():
    """{name: (model, inputs, limit_state, reference P_f)}."""
    out = {}
    model, inputs, states = slider_crank()
    ref = json.loads(REFERENCE.read_text()) if REFERENCE.exists() else {}
    for k, ls in states.items():
        out[f"slider-crank {k}"] = (model, inputs, ls, ref.get(k, {}).get("pf", float("nan")))
    out["two-points"] = (
        FunctionModel(_tie, ["x1", "x2"], ["g"], vectorized=True),
        STD2,
        None,
        2 * special.ndtr(-3.5),
    )
    out["four-branch"] = (
        FunctionModel(four_branch, ["x1", "x2"], ["g"], vectorized=True),
        STD2,
        None,
        four_branch_exact(),
    )
    par = FunctionModel(_parallel, ["x1", "x2"], ["a", "b"], vectorized=True)
    out["parallel"] = (
        par,
        STD2,
        LimitState.parallel(LimitState.margin("a"), LimitState.margin("b")),
        special.ndtr(-3.0) ** 2,
    )
    return out


def reference() -> None:
    model, inputs, states = slider_crank()
    k = model.output_index.get_loc(("displacement", "max_abs"))
    out = {}
    t0 = time.perf_counter()
    n, chunk = 4_000_000, 50_000
    X = inputs.sample(n, seed=20261128)
    m = np.concatenate([model.func(X[i : i + chunk])[:, k] for i in range(0, n, chunk)])
    p = float(np.mean(m >= ALLOWABLES["1e-3"]))
    out["1e-3"] = {
        "pf": p,
        "cov": math.sqrt((1 - p) / (n * p)),
        "allowable": ALLOWABLES["1e-3"],
        "how": f"crude Monte Carlo, {n} samples (seed 20261128)",
        "seconds": time.perf_counter() - t0,
    }
    print("1e-3", out["1e-3"])
    t0 = time.perf_counter()
    ls = states["1e-6"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        f = form(model=model, inputs=inputs, limit_state=ls)
        imp = importance_sampling(
            model=model,
            inputs=inputs,
            limit_state=ls,
            design_point=f,
            n=400_000,
            seed=20261128,
            progress=False,
        )
        sub = subset_simulation(
            model=model, inputs=inputs, limit_state=ls, n_per_level=20_000, seed=20261128
        )
    out["1e-6"] = {
        "pf": imp.pf,
        "cov": imp.cov,
        "allowable": ALLOWABLES["1e-6"],
        "how": "mixture importance sampling, 400000 samples (seed 20261128), checked by subset "
        f"simulation with 20000 per level: {sub.pf:.4g} (c.o.v. {sub.cov:.3f})",
        "subset_pf": sub.pf,
        "subset_cov": sub.cov,
        "seconds": time.perf_counter() - t0,
    }
    print("1e-6", out["1e-6"])
    REFERENCE.write_text(json.dumps(out, indent=1) + "\n")


METHODS = ("form", "sorm", "is", "subset")


def run(name, model, inputs, ls, ref, seeds):
    rows = {m: [] for m in METHODS}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        f = form(model=model, inputs=inputs, limit_state=ls)
        try:
            s = sorm(model=model, inputs=inputs, limit_state=ls, design_point=f)
            rows["sorm"].append((s.pf, np.nan, np.nan, np.nan, s.n_evaluations, len(s.warnings)))
        except Exception as exc:  # a parallel system: SORM refuses
            print(f"  sorm: {exc}"[:120])
        rows["form"].append((f.pf, np.nan, np.nan, np.nan, f.n_evaluations, len(f.warnings)))
        for seed in range(seeds):
            i = importance_sampling(
                model=model,
                inputs=inputs,
                limit_state=ls,
                design_point=f,
                n=2000,
                seed=seed,
                progress=False,
            )
            t = i.to_frame().iloc[0]
            rows["is"].append(
                (
                    i.pf,
                    t["pf_lo"],
                    t["pf_hi"],
                    i.cov,
                    i.n_evaluations - f.n_evaluations,
                    len(i.warnings),
                )
            )
            u = subset_simulation(
                model=model, inputs=inputs, limit_state=ls, n_per_level=1000, seed=seed
            )
            t = u.to_frame().iloc[0]
            rows["subset"].append(
                (u.pf, t["pf_lo"], t["pf_hi"], u.cov, u.n_evaluations, len(u.warnings))
            )
    print(f"{name}: reference P_f = {ref:.4g}")
    for m in METHODS:
        r = np.array(rows[m], dtype=float)
        if not r.size:
            continue
        ratio = r[:, 0] / ref
        cover = (
            np.mean((r[:, 1] <= ref) & (ref <= r[:, 2])) if np.isfinite(r[:, 1]).all() else np.nan
        )
        print(
            f"  {m:6s} median P_f/ref {np.median(ratio):.3f} (q10 {np.quantile(ratio, 0.1):.3f}, "
            "q90 "
            f"{np.quantile(ratio, 0.9):.3f}); observed c.o.v. {np.std(r[:, 0]) / ref:.3f}, mean "
            "reported "
            f"{np.nanmean(r[:, 3]):.3f}; coverage {cover:.2f} ({len(r)} runs); evaluations "
            f"{np.median(r[:, 4]):.0f}; runs with warnings {int(np.sum(r[:, 5] > 0))}"
        )


def subset_coverage(seeds: int) -> None:
    """The coverage of subset simulation's 95 % interval, and of the intervals it could report
    (docstring of :mod:`mechrel.uq.estimators.subset`), over ``seeds`` runs at N = 1000 on five
    problems: a linear margin at β = 3.09 (d = 2) and 4.75 (d = 10), two design points, the
    β = 4.5 paraboloid and the four-branch system."""
    from scipy import stats

    from mechrel.uq.estimators.subset import ADJACENT_CORRELATION

    def lin(beta, d):
        names = [f"x{i}" for i in range(d)]
        return (
            FunctionModel(
                lambda X: beta * math.sqrt(d) - X.sum(axis=1), names, ["g"], vectorized=True
            ),
            UncertainInputs.from_specs({n: Normal(0.0, 1.0) for n in names}),
            special.ndtr(-beta),
        )

    parab = integrate.quad(
        lambda x: (
            math.exp(-x * x / 2) / math.sqrt(2 * math.pi) * special.ndtr(-(4.5 + 0.1 * x * x))
        ),
        -12,
        12,
        epsabs=1e-16,
    )[0]
    cases = {
        "linear 1e-3, d = 2": lin(3.09, 2),
        "linear 1e-6, d = 10": lin(4.75, 10),
        "two design points": (
            FunctionModel(_tie, ["x1", "x2"], ["g"], vectorized=True),
            STD2,
            2 * special.ndtr(-3.5),
        ),
        "paraboloid 4.5": (
            FunctionModel(
                lambda X: 4.5 - X[:, 1] + 0.1 * X[:, 0] ** 2, ["x1", "x2"], ["g"], vectorized=True
            ),
            STD2,
            parab,
        ),
        "four-branch": (
            FunctionModel(four_branch, ["x1", "x2"], ["g"], vectorized=True),
            STD2,
            four_branch_exact(),
        ),
    }
    z = stats.norm.ppf(0.975)
    for name, (model, inputs, ref) in cases.items():
        pf, lv = [], []
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for seed in range(seeds):
                r = subset_simulation(
                    model=model, inputs=inputs, n_per_level=1000, seed=1000 + seed
                )
                pf.append(r.pf)
                lv.append(r.levels["cov"].to_numpy())
        pf = np.array(pf)

        def cover(delta, log):
            if log:
                s_ = np.sqrt(np.log1p(delta**2))
                lo, hi = pf * np.exp(-z * s_), pf * np.exp(z * s_)
            else:
                lo, hi = np.maximum(pf * (1 - z * delta), 0), pf * (1 + z * delta)
            return np.mean((lo <= ref) & (ref <= hi))

        ab = np.array([math.sqrt(np.sum(c**2)) for c in lv])
        adj = np.array(
            [
                math.sqrt(np.sum(c**2) + 2 * ADJACENT_CORRELATION * np.sum(c[:-1] * c[1:]))
                for c in lv
            ]
        )
        full = np.array([np.sum(c) for c in lv])
        print(
            f"{name}: P_f {ref:.4g}, mean P̂/P_f {pf.mean() / ref:.3f}, observed c.o.v. "
            f"{pf.std() / ref:.3f}; "
            f"uncorrelated δ {ab.mean():.3f} (normal {cover(ab, False):.3f}, lognormal "
            f"{cover(ab, True):.3f}); "
            f"adjacent ρ = {ADJACENT_CORRELATION} δ {adj.mean():.3f} (lognormal "
            f"{cover(adj, True):.3f}, "
            f"mechrel's); full δ {full.mean():.3f} (lognormal {cover(full, True):.3f}); {seeds} "
            "seeds"
        )


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "--reference", action="store_true", help="recompute the slider-crank references"
    )
    ap.add_argument(
        "--subset-coverage",
        action="store_true",
        help="the coverage of subset simulation's intervals on five problems",
    )
    ap.add_argument("--seeds", type=int, default=40)
    ap.add_argument("--only", default=None, help="a problem name (substring)")
    a = ap.parse_args()
    if a.reference:
        reference()
        return
    if a.subset_coverage:
        subset_coverage(a.seeds)
        return
    for name, (model, inputs, ls, ref) in problems().items():
        if a.only and a.only not in name:
            continue
        run(name, model, inputs, ls, ref, a.seeds)


if __name__ == "__main__":
    main()
