"""Sensitivity of a loaded journal's motion to the parameters the paper does not give.

Rig: one journal (mass m, free in x, y) in a fixed bearing (ω_B = 0) with the paper's joint
(R_B = 15 mm, c = 0.5 mm, L = 40 mm, steel, c_e = 0.9, c_f = 0.05, 100 cP), a prescribed journal
spin ω_S(t) and an applied load. Contact onsets are located with solve_ivp events and the impact
speed is captured exactly as docs/architecture.md prescribes (hist = max(δ̇, floor) at the located
onset, 0 after separation). The journal path e(t) of each variant is compared with the default's.

Run ``python tests/test_forces_sensitivity.py`` to print the tables quoted in docs/forces.md.
The v0/v1 and floor rigs take a few seconds each and are marked slow.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from mechrel.forces import P_FLOOR, clearance_force, contact_stiffness, pack_params

C, RB, LEN = 5e-4, 0.015, 0.04
K = contact_stiffness(RB, RB - C, 206e9, 0.3, 206e9, 0.3)
COMMON = dict(clearance=C, bearing_radius=RB, length=LEN, stiffness=K, restitution=0.9,
              friction_coefficient=0.05, viscosity=0.1)


def simulate(p, load, omega_S, T, y0, ts, m=1.0, method="Radau", rtol=1e-8):
    """Journal path e(ts) (2 × len(ts)), RHS evaluations, number of located contact onsets."""
    floor = p[P_FLOOR]
    hist = 0.0

    def rhs(t, y, hist):
        fx, fy, _, _, _ = clearance_force(y[0], y[1], y[2], y[3], 0.0, omega_S(t), hist, p)
        lx, ly = load(t)
        return [y[2], y[3], (fx + lx) / m, (fy + ly) / m]

    def gap(t, y, hist):
        return math.hypot(y[0], y[1]) - C

    t, y = 0.0, np.asarray(y0, dtype=float)
    inside = gap(t, y, hist) > 0.0
    out, nfev, onsets = [], 0, 0
    while t < T:
        gap.terminal = True
        gap.direction = -1.0 if inside else 1.0
        sol = solve_ivp(rhs, (t, T), y, method=method, rtol=rtol, atol=[1e-13, 1e-13, 1e-9, 1e-9],
                        args=(hist,), events=gap, dense_output=True, max_step=1e-3)
        if sol.status < 0:
            raise RuntimeError(sol.message)
        nfev += sol.nfev
        sel = ts[(ts >= t) & (ts <= sol.t[-1])]
        if len(sel):
            out.append((sel, sol.sol(sel)[:2]))
        t, y = sol.t[-1], sol.y[:, -1].copy()
        if sol.status == 1:
            if inside:  # separation: forget the impact
                hist, inside = 0.0, False
            else:       # located onset: capture the (floored) approach speed
                n = y[:2] / math.hypot(y[0], y[1])
                hist, inside = max(float(n @ y[2:]), floor), True
                onsets += 1
        if onsets > 5000:
            raise RuntimeError("too many contact onsets")
    path = np.full((2, len(ts)), np.nan)
    for sel, e in out:
        path[:, np.searchsorted(ts, sel)] = e
    return path, nfev, onsets


def deviation(path, ref):
    """Largest distance between two journal paths, as a fraction of c."""
    return float(np.nanmax(np.hypot(*(path - ref))) / C)


# --------------------------------------------------------------------- λ, ε0 (film correction) --
# Transition model, reversing load 200 N sin(3π t) along y, journal released at rest from
# ε = 0.5, one cycle (2/3 s). With a slow spin (0.3 rad/s, like a pin joint near a dead centre)
# the journal is pushed through the bearing centre region (min ε ≈ 0.03) at t ≈ 1/3 s; with
# ω_S = 3π it orbits around the centre instead and the correction hardly acts.

def lam_rig(lam, eps0, spin=0.3, T=2 / 3):
    ts = np.linspace(0.0, T, 1001)
    p = pack_params(model="transition", lam=lam, eps0=eps0, **COMMON)
    path, _, _ = simulate(p, lambda t: (0.0, -200.0 * math.sin(3 * math.pi * t)),
                          lambda t: spin, T, [0.0, -0.5 * C, 0.0, 0.0], ts)
    return ts, path


LAM_VARIANTS = [(2.0, 0.1), (1.0, 0.2), (0.0, 0.1), (0.5, 0.1), (1.0, 0.05)]


def test_film_correction_acts_only_during_centre_crossings():
    ts, ref = lam_rig(1.0, 0.1)
    assert np.nanmin(np.hypot(*ref)[(ts > 0.2) & (ts < 0.5)]) < 0.05 * C  # the path does cross
    for lam, eps0 in LAM_VARIANTS[:2]:
        _, path = lam_rig(lam, eps0)
        # During the crossing the correction changes the squeeze resistance for ε < ε0 and the
        # path shifts (measured 3 % of c for λ = 2, 8 % for ε0 = 0.2; docs/forces.md): bounded
        # at 15 %. Once the load presses the journal out again (t > 0.5 s) the film's damping has
        # erased the difference (measured ≤ 3e-4 c): bounded at 1e-3 c.
        assert deviation(path, ref) < 0.15
        late = ts > 0.5
        assert deviation(path[:, late], ref[:, late]) < 1e-3


# -------------------------------------------------------------------- v0, v1 (friction c_d) ---
# Dry model, constant load 100 N pressing the journal down, spin reversing ω_S = 3π cos(10π t):
# friction drags the journal up the wall and back (friction angle atan 0.05 ≈ 2.9°).

def friction_rig(v0, v1, T=0.2):
    ts = np.linspace(0.0, T, 2001)
    p = pack_params(model="dry", v0=v0, v1=v1, **COMMON)
    d0 = (100.0 / K) ** (2 / 3)  # static penetration
    return ts, simulate(p, lambda t: (0.0, -100.0),
                        lambda t: 3 * math.pi * math.cos(10 * math.pi * t),
                        T, [0.0, -(C + d0), 0.0, 0.0], ts, method="RK45", rtol=1e-7)[0]


V_VARIANTS = [(0.0, 1e-2), (1e-3, 1e-2), (1e-5, 1e-3), (1e-4, 3e-2)]


@pytest.mark.slow
def test_friction_ramp_sensitivity():
    _, ref = friction_rig(1e-4, 1e-2)
    devs = {v: deviation(friction_rig(*v)[1], ref) for v in V_VARIANTS}
    # v0 ≤ 1e-3 m/s is nearly invisible (the dead band is crossed quickly at each slip
    # reversal): measured ≤ 0.2 % of c, bounded at 1 %
    assert devs[(0.0, 1e-2)] < 0.01 and devs[(1e-3, 1e-2)] < 0.01
    # v1 sets how much of the slip reversal sees reduced friction: a tenfold change moves the
    # journal by a few % of c (measured 4.0 % and 4.5 %); bounded at 10 %.
    assert devs[(1e-5, 1e-3)] < 0.10 and devs[(1e-4, 3e-2)] < 0.10


# ------------------------------------------------------------------- impact-speed floor ---------
# Dry model, journal released at rest from ε = 0.5 under 100 N: it bounces (23 located onsets,
# captured speeds 0.22 m/s down to 2.9 mm/s) and stays in persistent contact after the last one.

def floor_rig(floor, T=0.15):
    ts = np.linspace(0.0, T, 1501)
    p = pack_params(model="dry", impact_speed_floor=floor, **COMMON)
    return simulate(p, lambda t: (0.0, -100.0), lambda t: 0.0, T, [0.0, -0.5 * C, 0.0, 0.0], ts,
                    method="RK45", rtol=1e-7)


@pytest.mark.slow
def test_impact_floor_sensitivity():
    ref, _, n_ref = floor_rig(1e-3)
    # a floor below every captured speed never acts: the same computation bit for bit
    path, _, n = floor_rig(1e-4)
    assert n == n_ref and deviation(path, ref) == 0.0
    # 1e-2 m/s acts on the last onset (2.9 mm/s), i.e. on the damping of the persistent
    # contact that follows: measured 8e-4 c; bounded at 1 % of c
    path, _, n = floor_rig(1e-2)
    assert n == n_ref and deviation(path, ref) < 0.01


if __name__ == "__main__":  # pragma: no cover - prints the tables of docs/forces.md
    for spin in (0.3, 3 * math.pi):
        ts, ref = lam_rig(1.0, 0.1, spin)
        mid = (ts > 0.2) & (ts < 0.5)
        print(f"spin {spin:.3f} rad/s: min eps during t in (0.2, 0.5) s: "
              f"{np.nanmin(np.hypot(*ref)[mid]) / C:.3f}")
        print("lam eps0  max|de|/c  max|de|/c for t > 0.5 s")
        for lam, eps0 in LAM_VARIANTS:
            _, path = lam_rig(lam, eps0, spin)
            late = ts > 0.5
            print(f"{lam:.1f} {eps0:.2f}  {deviation(path, ref):.4f}     "
                  f"{deviation(path[:, late], ref[:, late]):.1e}")
    _, ref = friction_rig(1e-4, 1e-2)
    print("v0 v1  max|de|/c  max contact angle (deg)")
    print(f"1e-4 1e-2 (default) {np.degrees(np.nanmax(np.arctan2(ref[0], -ref[1]))):.3f}")
    for v in V_VARIANTS:
        _, path = friction_rig(*v)
        print(v, f"{deviation(path, ref):.4f}",
              f"{np.degrees(np.nanmax(np.arctan2(path[0], -path[1]))):.3f}")
    ref, nf, n = floor_rig(1e-3)
    print("floor  max|de|/c  onsets  nfev")
    print(f"1e-3 (default)  -  {n} {nf}")
    for fl in (1e-4, 1e-2):
        path, nf, n = floor_rig(fl)
        print(fl, f"{deviation(path, ref):.2e}", n, nf)
