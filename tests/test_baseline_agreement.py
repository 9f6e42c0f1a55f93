"""mechrel's compiled right-hand side against the independent NumPy implementation of
``benchmarks/baseline_numpy.py`` at random states of every scene type.

The baseline re-derives the constraints, Jacobian, γ, Baumgarte terms, the augmented solve and
the dry / lubricated / transition force laws from docs/mechanics.md and docs/reference.md (it shares
only the scene arrays of ``compile_scene`` with mechrel), so agreement here checks both.

States: the ideal mechanism's kinematics at a random crank angle, perturbed (10 µm, 1 mm/s) so
that the Baumgarte terms act, with every clearance joint moved into a chosen regime: a free
journal, penetrations from 1 nm to 50 µm (with and without a recorded impact speed), the
transition band, the film at ε from 0.001 to beyond ε_max (clamped), approaching and
separating, eccentricity rates from 0.1 mm/s to 3 m/s in random directions, and friction slip
below, inside and above the c_d ramp [v0, v1]; a test asserts that every branch was visited.

Tolerance: 1e-9, relative, norm-wise per block (accelerations, multipliers, generalised forces,
powers). Both codes evaluate the same formulas in a different order, so they differ by
rounding only; the forward error of each is bounded by about cond(S)·u for the Schur /
augmented solve (cond(S) ≤ 4e5 over these states, measured, so ≤ 1e-10) plus the
amplification of rounding in the force laws (cancellation in e = r_S − r_B and 1 − ε², ≤ 1e2·u
in norm). 1e-9 therefore leaves a margin of 10 over the worst bound while any modelling
difference (a sign, a factor, a missing term) shows up at 1e-6 or far above: the last test
checks that the comparison detects a 1e-6 change in one film parameter. Observed: ≤ 1e-13.
"""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from mechrel.mechanics.applied import applied_forces
from mechrel.mechanics.constraints import constraint_terms, constraints
from mechrel.mechanics.dynamics import accelerations, make_workspace, rhs
from mechrel.mechanics.kinematics import _jacobian_into

_PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "baseline_numpy.py"
_spec = importlib.util.spec_from_file_location("baseline_numpy", _PATH)
baseline_numpy = importlib.util.module_from_spec(_spec)
sys.modules.setdefault("baseline_numpy", baseline_numpy)
_spec.loader.exec_module(baseline_numpy)
Baseline = baseline_numpy.Baseline

TOL = 1e-9
N_STATES = 40

SCENES = {
    "nine-bar ideal": ("nine-bar", {}),
    "slider-crank ideal": ("slider-crank", {}),
    "nine-bar dry": ("nine-bar-dry", {}),
    "slider-crank dry": ("slider-crank-dry", {}),
    "nine-bar lubricated": ("nine-bar-lubricated", {}),
    "slider-crank lubricated": ("slider-crank-lubricated", {}),
    "nine-bar transition": ("nine-bar", {"joints.C1.model": "transition",
                                         "joints.C2.model": "transition"}),
    "slider-crank transition": ("slider-crank", {"joints.C.model": "transition"}),
    # a translational joint between moving bodies (the block in the turning lever)
    "whitworth lubricated": ("whitworth", {}),
    "whitworth dry": ("whitworth", {"joints.A.model": "dry"}),
}


def _unit(angle):
    return np.array([math.cos(angle), math.sin(angle)])


def random_states(bl: Baseline, rng: np.random.Generator, n_states: int, regimes: dict):
    """(t, y, hist) tuples; ``regimes`` counts which force-law branches were visited."""
    _, q0 = bl.initial_state()
    grid = np.linspace(0.0, bl.cs.period, 73)
    Qk, Vk, _ = bl.ideal_kinematics(q0, grid)  # a continuous path around one cycle
    n = bl.n
    out = []
    for k in rng.integers(0, grid.size, n_states):
        t = float(grid[k]) + rng.uniform(-1e-3, 1e-3) * bl.cs.period
        q = Qk[k] + rng.normal(0.0, 1e-5, n)
        v = Vk[k] + rng.normal(0.0, 1e-3, n)
        hist = np.zeros(bl.n_hist)
        for jt in bl.joints:
            c = jt.p["clearance"]
            if jt.model == "lubricated":
                band = rng.integers(3)
                eps = (rng.uniform(0.001, jt.p["eps0"]), rng.uniform(jt.p["eps0"], 0.99),
                       rng.uniform(0.99, 1.2))[band]
                regimes[("film ε band", int(band))] = regimes.get(("film ε band", int(band)), 0) + 1
                r = eps * c
            elif jt.model == "dry":
                r = c + (-0.5 * c if rng.random() < 0.25
                         else 10 ** rng.uniform(-9, math.log10(5e-5)))
            else:
                e1 = jt.p["e1"]
                r = c + (rng.uniform(-0.5 * c, 0.0), rng.uniform(0.0, e1),
                         rng.uniform(e1, 3.0 * e1))[rng.integers(3)]
                s = min(1.0, max(0.0, (r - c) / jt.p["e1"]))
                key = ("transition weight", "0" if s == 0 else ("1" if s == 1 else "blend"))
                regimes[key] = regimes.get(key, 0) + 1
            n_dir = _unit(rng.uniform(0.0, 2.0 * math.pi))
            e_target = r * n_dir
            e_rate = 10 ** rng.uniform(-4.0, 0.5) * _unit(rng.uniform(0.0, 2.0 * math.pi))
            if jt.model != "lubricated" and jt.p["friction_coefficient"] > 0:
                # slip v_T = ė·t + ω_S R_S − ω_B R_B: a third of the states put it in the
                # c_d ramp [v0, v1] (or just outside), the rest leave it as it comes
                wB = v[3 * jt.b + 2] if jt.b >= 0 else 0.0
                wS = v[3 * jt.j + 2] if jt.j >= 0 else 0.0
                t_dir = np.array([-n_dir[1], n_dir[0]])
                rot = wS * jt.p["journal_radius"] - wB * jt.p["bearing_radius"]
                slip = e_rate @ t_dir + rot
                if rng.random() < 1.0 / 3.0:
                    slip = rng.choice([-1.0, 1.0]) * math.exp(rng.uniform(
                        math.log(0.1 * jt.p["v0"]), math.log(10.0 * jt.p["v1"])))
                    e_rate = (e_rate @ n_dir) * n_dir + (slip - rot) * t_dir
                if r > c:
                    cd = abs(slip)
                    key = ("friction c_d", "0" if cd < jt.p["v0"] else
                           ("1" if cd > jt.p["v1"] else "ramp"))
                    regimes[key] = regimes.get(key, 0) + 1
            if jt.model != "dry":
                key = ("ε̇ sign", "approach" if e_rate @ n_dir >= 0 else "separation")
                regimes[key] = regimes.get(key, 0) + 1
            bx, by, bvx, bvy = bl._point(q, v, jt.b, jt.sb)
            sx, sy, svx, svy = bl._point(q, v, jt.j, jt.sj)
            # move the journal body so that e and ė take the chosen values
            q[3 * jt.j:3 * jt.j + 2] += e_target - np.array([sx - bx, sy - by])
            v[3 * jt.j:3 * jt.j + 2] += e_rate - np.array([svx - bvx, svy - bvy])
            if jt.hist >= 0 and r > c:
                recorded = rng.random() < 0.5
                if recorded:
                    hist[jt.hist] = 10 ** rng.uniform(-5.0, 0.5)
                key = ("contact", "recorded δ̇⁻" if recorded else "δ̇⁻ from δ̇")
                regimes[key] = regimes.get(key, 0) + 1
        y = np.concatenate([q, v, rng.normal(0.0, 1.0, 2)])
        out.append((t, y, hist))
    return out


def _rel(a, b):
    scale = np.max(np.abs(b)) if b.size else 0.0
    return np.max(np.abs(a - b)) / scale if scale > 0 else np.max(np.abs(a - b), initial=0.0)


@pytest.fixture(scope="module")
def cases():
    """{label: (Baseline, states)} and the branch counts, built once for the module."""
    regimes: dict = {}
    out = {}
    for label, (scene, over) in SCENES.items():
        bl = Baseline(scene, over)
        rng = np.random.default_rng(sum(map(ord, label)))  # fixed seed per scene
        out[label] = (bl, random_states(bl, rng, N_STATES, regimes))
    return out, regimes


@pytest.mark.parametrize("label", list(SCENES))
def test_rhs_matches_numpy_baseline(label, cases):
    bl, states = cases[0][label]
    sys_ = bl.cs.dynamic
    n = bl.n
    worst = {}
    for t, y, hist in states:
        q, v = y[:n], y[n:2 * n]
        # constraints, Jacobian and γ
        phi1, phit1, J1 = bl.constraints(q, t)
        phi2, phit2, J2 = constraints(q, t, sys_)
        # γ and Φ_q's sparse rows as the right-hand side and the kinematic analysis form them:
        # the stabilised c = γ − 2α Φ̇ − β² Φ and the rows scattered into a dense matrix
        ws = make_workspace(sys_)
        constraint_terms(t, q, v, sys_, ws)
        g1 = bl.gamma(q, v, t) - 2 * bl.alpha * (J1 @ v + phit1) - bl.beta ** 2 * phi1
        g2 = ws.c.copy()
        J3 = np.empty_like(J2)
        _jacobian_into(ws, sys_.row_body, J3)
        # generalised forces
        Q1, p1 = bl.applied(t, q, v, hist)
        Q2 = np.zeros(n)
        p2, _ = applied_forces(t, q, v, hist, sys_, Q2)
        # accelerations, multipliers, powers and the full right-hand side
        a1, lam1, pin1, pcl1 = bl.accelerations(t, y, hist)
        a2, lam2, pin2, pcl2 = accelerations(t, y, hist, sys_)
        f1, f2 = bl.rhs(t, y, hist), rhs(t, y, hist, sys_)
        # scales of the two powers: sums of the magnitudes of their terms
        pin_scale = sum(abs(lam2[len(lam2) - len(bl.dyn["dr"]) + k] * v[3 * i + 2])
                        for k, (i, _, _) in enumerate(bl.dyn["dr"]))
        pcl_scale = 0.0
        for jt in bl.joints:
            bx, by, bvx, bvy = bl._point(q, v, jt.b, jt.sb)
            sx, sy, svx, svy = bl._point(q, v, jt.j, jt.sj)
            wB = v[3 * jt.b + 2] if jt.b >= 0 else 0.0
            wS = v[3 * jt.j + 2] if jt.j >= 0 else 0.0
            Fx, Fy, MS, MB = bl.clearance_force(jt, sx - bx, sy - by, svx - bvx, svy - bvy, wB,
                                                wS, hist[jt.hist] if jt.hist >= 0 else 0.0)
            pcl_scale += (abs(Fx * (svx - bvx)) + abs(Fy * (svy - bvy)) + abs(MS * wS)
                          + abs(MB * wB))
        checks = {
            "Φ": _rel(phi1, phi2) if np.max(np.abs(phi2)) > 0 else 0.0,
            "Φ_t": np.max(np.abs(phit1 - phit2), initial=0.0),
            "Φ_q": _rel(J1, J2), "Φ_q (sparse rows)": _rel(J1, J3),
            "γ − 2α Φ̇ − β² Φ": _rel(g1, g2), "Q": _rel(Q1, Q2),
            "q̈": _rel(a1, a2), "λ": _rel(lam1, lam2),
            "q̇ rows of rhs": np.max(np.abs(f1[:n] - f2[:n])),
            "q̈ rows of rhs": _rel(f1[n:2 * n], f2[n:2 * n]),
            "driver power": abs(pin1 - pin2) / max(pin_scale, 1e-300),
            "clearance power": abs(pcl1 - pcl2) / pcl_scale if pcl_scale > 0 else abs(pcl1 - pcl2),
            "power (rhs)": abs(f1[2 * n + 1] - f2[2 * n + 1]) / pcl_scale if pcl_scale > 0 else
            abs(f1[2 * n + 1] - f2[2 * n + 1]),
            "clearance power (applied)": (abs(p1 - p2) / pcl_scale if pcl_scale > 0
                                          else abs(p1 - p2)),
        }
        for key, val in checks.items():
            worst[key] = max(worst.get(key, 0.0), float(val))
    bad = {k: v for k, v in worst.items() if not v <= TOL}
    assert not bad, f"{label}: NumPy baseline and compiled rhs differ (relative): {bad}"


def test_every_force_law_branch_was_exercised(cases):
    """The random states visit every branch of the force laws."""
    regimes = cases[1]
    needed = [("film ε band", 0), ("film ε band", 1), ("film ε band", 2),
              ("transition weight", "0"), ("transition weight", "blend"),
              ("transition weight", "1"), ("ε̇ sign", "approach"), ("ε̇ sign", "separation"),
              ("contact", "recorded δ̇⁻"), ("contact", "δ̇⁻ from δ̇"),
              ("friction c_d", "0"), ("friction c_d", "ramp"), ("friction c_d", "1")]
    missing = [k for k in needed if regimes.get(k, 0) == 0]
    assert not missing, f"branches never visited: {missing} (visited: {regimes})"


def test_contact_stiffness_recomputed_equals_packed():
    bl = Baseline("nine-bar-dry")
    from mechrel.forces.params import P_K
    for k, jt in enumerate(bl.joints):
        assert jt.p["stiffness"] == pytest.approx(bl.cs.dynamic.cl_p[k, P_K], rel=1e-12)


def test_comparison_detects_a_small_model_change():
    """A 1e-6 relative change of the viscosity in the baseline must fail the 1e-9 criterion."""
    bl = Baseline("nine-bar-lubricated")
    rng = np.random.default_rng(7)
    states = random_states(bl, rng, 5, {})
    for jt in bl.joints:
        jt.p["viscosity"] *= 1.0 + 1e-6
    n = bl.n
    worst = max(_rel(bl.rhs(t, y, h)[n:2 * n], rhs(t, y, h, bl.cs.dynamic)[n:2 * n])
                for t, y, h in states)
    assert worst > 10 * TOL
