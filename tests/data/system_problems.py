"""The whole-cycle and system test problems shared by ``tests/test_uq_system.py`` and
``benchmarks/bench_system_reliability.py`` (which also writes this folder's
``slider_crank_whole_cycle.json``, the references of ``slider_crank``): a fixture, not a test.

* ``slider_crank``: the whole cycle of an offset slider-crank's displacement error under crank,
  rod and offset tolerances, with the limit states at the allowables ``ALLOWABLES``
  (P_f ≈ 1e-3 and 1e-6).
* ``four_branch``: the four-branch series system; ``four_branch_exact`` its P_f by a 1-D
  directional integral.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import integrate

from mechrel.uq import LimitState, Normal, UncertainInputs
from mechrel.uq.problem.allowables import parse_sector
from mechrel.uq.problem.analytic import slider_crank_tolerance_model

ALLOWABLES = {"1e-3": 0.18e-3, "1e-6": 0.26e-3}


def slider_crank():
    """The whole-cycle test problem: model, inputs, {level: limit state}."""
    model = slider_crank_tolerance_model(
        quantities=["displacement"], angle_step=18.0, points_per_sector=8
    )
    inputs = UncertainInputs.from_specs(
        {
            "crank": Normal(0.05, 0.02e-3),
            "rod": Normal(0.12, 0.02e-3),
            "offset": Normal(0.0, 0.1e-3),
        }
    )
    sectors = [lbl for lbl in model.output_index if parse_sector(lbl[1])]
    states = {
        k: LimitState.exceedance(sectors, a, kind="abs", name="displacement")
        for k, a in ALLOWABLES.items()
    }
    return model, inputs, states


def four_branch(X, k=6.0):
    """The four-branch series system (Waarts 2000; Schueremans & Van Gemert 2005), k = 6."""
    x1, x2 = X[:, 0], X[:, 1]
    return np.minimum.reduce(
        [
            3 + (x1 - x2) ** 2 / 10 - (x1 + x2) / 2**0.5,
            3 + (x1 - x2) ** 2 / 10 + (x1 + x2) / 2**0.5,
            (x1 - x2) + k / 2**0.5,
            (x2 - x1) + k / 2**0.5,
        ]
    )


def four_branch_exact(k=6.0) -> float:
    """P_f of the four-branch system by directional integration in 2-D: along the ray r·(cos t,
    sin t) the failure set is a union of intervals of r (each branch is a quadratic in r), whose
    probability under the χ₂ law of r is Σ (e^{−r_a²/2} − e^{−r_b²/2}); integrated over t."""

    def ray(t):
        c, s = math.cos(t), math.sin(t)
        roots = [0.0, 50.0]
        for sign in (1, -1):  # 3 + r²(c−s)²/10 ∓ r (c+s)/√2 = 0
            a, b = (c - s) ** 2 / 10, -sign * (c + s) / 2**0.5
            if abs(a) < 1e-15:
                if b != 0:
                    roots.append(-3.0 / b)
            else:
                disc = b * b - 12 * a
                if disc > 0:
                    roots += [(-b - math.sqrt(disc)) / (2 * a), (-b + math.sqrt(disc)) / (2 * a)]
        for sign in (1, -1):
            d = sign * (c - s)
            if d != 0:
                roots.append(-k / 2**0.5 / d)
        rs = sorted(r for r in roots if 0 <= r <= 50)
        p = 0.0
        for lo, hi in zip(rs[:-1], rs[1:]):
            mid = 0.5 * (lo + hi)
            if four_branch(np.array([[mid * c, mid * s]]), k)[0] <= 0:
                p += math.exp(-lo * lo / 2) - math.exp(-hi * hi / 2)
        return p

    val, _err = integrate.quad(
        ray,
        0.0,
        2 * math.pi,
        limit=400,
        epsabs=1e-13,
        points=[math.pi / 4, 3 * math.pi / 4, 5 * math.pi / 4, 7 * math.pi / 4],
    )
    return val / (2 * math.pi)
