#!/usr/bin/env python
"""Which Kriging library for active learning: fit time and accuracy, 50–500 points, 3–10 inputs.

Each library fits an anisotropic Matérn-5/2 Gaussian process with a constant or linear trend
by maximum likelihood on n points of a smooth limit state in d standard-normal inputs,

    g(u) = 3 − u_1 + 0.3 Σ_{j≥2} sin(u_j) + 0.1 u_2²,

and predicts 2000 new points. Reported per (library, d, n): the median fit time over
``--reps`` fits (interleaved: the libraries take turns within each repetition) and Q² = 1 −
MSE/Var on the test points. The libraries other than mechrel's own are optional: install them
in a separate folder (``pip install --target DIR scikit-learn openturns smt``) and pass
``--extra DIR`` (appended to sys.path after the project's packages).

    python benchmarks/bench_gp_libraries.py --extra /tmp/gplibs [--reps 3]

The table in docs/uq.md ("The Kriging library") comes from this script.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings

import numpy as np


def g(U):
    return 3.0 - U[:, 0] + 0.3 * np.sin(U[:, 1:]).sum(1) + 0.1 * U[:, 1] ** 2


def fit_mechrel(X, y):
    from mechrel.uq.surrogates.kriging import fit_kriging

    gp = fit_kriging(X, y, trend="linear")
    return gp.predict


def fit_sklearn(X, y):
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel

    d = X.shape[1]
    k = (ConstantKernel(1.0, (1e-3, 1e3)) * Matern(np.ones(d), (1e-2, 1e3), nu=2.5)
         + WhiteKernel(1e-8, (1e-10, 1e-1)))
    gp = GaussianProcessRegressor(k, normalize_y=True, n_restarts_optimizer=0, random_state=0)
    gp.fit(X, y)
    return gp.predict


def fit_openturns(X, y):
    import openturns as ot

    d = X.shape[1]
    cov = ot.MaternModel([1.0] * d, 2.5)
    basis = ot.LinearBasisFactory(d).build()
    algo = ot.KrigingAlgorithm(ot.Sample(X), ot.Sample(y[:, None]), cov, basis)
    algo.run()
    meta = algo.getResult().getMetaModel()
    return lambda Z: np.asarray(meta(ot.Sample(Z)))[:, 0]


def fit_smt(X, y):
    from smt.surrogate_models import KRG

    sm = KRG(corr="matern52", poly="linear", print_global=False, theta0=[1e-1] * X.shape[1])
    sm.set_training_values(X, y)
    sm.train()
    return lambda Z: sm.predict_values(Z)[:, 0]


LIBS = {"mechrel": fit_mechrel, "scikit-learn": fit_sklearn, "openturns": fit_openturns,
        "smt": fit_smt}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--extra", default=None, help="folder with the optional libraries")
    p.add_argument("--reps", type=int, default=3)
    p.add_argument("--n", type=int, nargs="*", default=[50, 100, 200, 500])
    p.add_argument("--d", type=int, nargs="*", default=[3, 6, 10])
    p.add_argument("--give-up", type=float, default=60.0,
                   help="drop a library for larger n once one fit took longer (s)")
    a = p.parse_args(argv)
    if a.extra:
        sys.path.append(a.extra)
    libs = {}
    for name, f in LIBS.items():
        try:
            f(np.random.default_rng(0).standard_normal((12, 2)), np.arange(12.0) ** 1.5)
            libs[name] = f
        except ImportError as exc:
            print(f"# {name}: not installed ({exc})")
    warnings.simplefilter("ignore")
    print("library,d,n,fit_s_median,fit_s_min,fit_s_max,Q2")
    slow = {}
    for d in a.d:
        for n in a.n:
            rng = np.random.default_rng(1000 * d + n)
            X = rng.standard_normal((n, d)) * 1.5
            y = g(X)
            Xt = rng.standard_normal((2000, d)) * 1.5
            yt = g(Xt)
            times = {k: [] for k in libs}
            q2 = {}
            for _ in range(a.reps):
                for name, f in libs.items():
                    if name in slow and n > slow[name]:
                        continue
                    t0 = time.perf_counter()
                    pred = f(X, y)
                    times[name].append(time.perf_counter() - t0)
                    q2[name] = 1.0 - np.mean((pred(Xt) - yt) ** 2) / np.var(yt)
            for name in libs:
                if not times[name]:
                    print(f"{name},{d},{n},,,,  # skipped: a fit took > {a.give_up:g} s "
                          f"at n = {slow[name]}")
                    continue
                t = np.array(times[name])
                if t.max() > a.give_up:
                    slow.setdefault(name, n)
                print(f"{name},{d},{n},{np.median(t):.3f},{t.min():.3f},{t.max():.3f},{q2[name]:.4f}",
                      flush=True)


if __name__ == "__main__":
    main()
