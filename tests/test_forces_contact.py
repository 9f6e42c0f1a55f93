"""Contact stiffness and the Lankarani–Nikravesh normal force, including 1-DOF impacts."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from mechrel.errors import SceneError
from mechrel.forces import contact_energy, contact_stiffness, ln_normal_force

E, NU = 206e9, 0.3            # paper Table 2
R_B, CL = 0.015, 0.5e-3       # bearing radius, radial clearance
R_S = R_B - CL


def test_conformal_vs_paper_stiffness_ratio():
    kc = contact_stiffness(R_B, R_S, E, NU, E, NU, conformal=True)
    kp = contact_stiffness(R_B, R_S, E, NU, E, NU, conformal=False)
    # K ∝ sqrt(R_B R_S / (R_B ∓ R_S)): the ratio is sqrt((R_B + R_S)/(R_B − R_S)) = sqrt(59)
    assert kc / kp == pytest.approx(math.sqrt(59.0), rel=1e-14)
    assert kc / kp == pytest.approx(7.6811457478686, rel=1e-12)
    # absolute values: 4/(3 (σ_B+σ_S)) = 4 E / (6 (1 − ν²)) = 1.50915e11 N/m²
    pref = 4.0 * E / (6.0 * (1.0 - NU**2))
    assert kc == pytest.approx(pref * math.sqrt(0.015 * 0.0145 / 0.0005), rel=1e-14)
    assert kc == pytest.approx(9.9535773897591e10, rel=1e-12)
    assert kp == pytest.approx(1.2958454007361e10, rel=1e-12)
    # default is conformal
    assert contact_stiffness(R_B, R_S, E, NU, E, NU) == kc


@pytest.mark.parametrize(
    "args, field",
    [
        ((0.015, 0.0, E, NU, E, NU), "R_S"),
        ((0.015, 0.016, E, NU, E, NU), "R_B"),
        ((0.015, 0.0145, -1.0, NU, E, NU), "E_B"),
        ((0.015, 0.0145, E, NU, 0.0, NU), "E_S"),
        ((0.015, 0.0145, E, 0.7, E, NU), "nu_B"),
        ((0.015, 0.0145, E, 0.5, E, NU), "nu_B"),  # the scene's rule: (-1, 0.5), open at 0.5
        ((0.015, 0.0145, E, NU, E, float("nan")), "nu_S"),
    ],
)
def test_contact_stiffness_errors(args, field):
    with pytest.raises(SceneError, match=field) as info:
        contact_stiffness(*args)
    assert info.value.path == field
    assert "allowed" in str(info.value)


@given(
    delta=st.floats(-1e-3, 1e-3),
    ddot=st.floats(-100.0, 100.0),
    vimp=st.floats(1e-6, 100.0),
    K=st.floats(1e6, 1e12),
    ce=st.floats(1e-3, 1.0),
)
@settings(max_examples=500, deadline=None)
def test_normal_force_never_pulls(delta, ddot, vimp, K, ce):
    f = ln_normal_force(delta, ddot, vimp, K, 1.5, ce)
    assert f >= 0.0 and math.isfinite(f)
    if delta <= 0.0:
        assert f == 0.0
    else:
        # elastic part exact when δ̇ = 0, and damping adds while approaching
        f0 = ln_normal_force(delta, 0.0, vimp, K, 1.5, ce)
        assert f0 == pytest.approx(K * delta**1.5, rel=1e-15)
        if ddot > 0:
            assert f >= f0


def test_normal_force_formula_and_clip():
    K, d, v = 1e10, 2e-6, 0.1
    ce = 0.9
    expect = K * d**1.5 * (1 + 0.75 * (1 - ce**2) * 0.05 / v)
    assert ln_normal_force(d, 0.05, v, K, 1.5, ce) == pytest.approx(expect, rel=1e-15)
    # fast separation with a small captured speed: the bracket is negative -> clipped to 0
    assert ln_normal_force(d, -10.0, 1e-3, K, 1.5, ce) == 0.0
    assert contact_energy(d, K, 1.5) == pytest.approx(K * d**2.5 / 2.5, rel=1e-15)
    assert contact_energy(-d, K, 1.5) == 0.0


# ---------------------------------------------------------------------------------------------
# 1-DOF impact: m δ̈ = −F_N(δ, δ̇; δ̇⁻ = v_in) while δ > 0, starting at δ = 0 with δ̇ = v_in.
# In the scaled variables δ/δ_max, t/t_c the LN impact depends on c_e (and n) only, so one
# (m, K, v) suffices. Effective restitution e = −δ̇(exit)/v_in.
# ---------------------------------------------------------------------------------------------

def impact_restitution(ce, m=1.0, K=1e10, n=1.5, v_in=0.1):
    def rhs(t, y):
        return [y[1], -ln_normal_force(y[0], y[1], v_in, K, n, ce) / m]

    def exit_(t, y):
        return y[0]

    exit_.terminal = True
    exit_.direction = -1
    tc = (m / K) ** (1 / (n + 1)) * v_in ** ((1 - n) / (n + 1))  # contact time scale
    dmax = (v_in**2 * m * (n + 1) / (2 * K)) ** (1 / (n + 1))
    sol = solve_ivp(rhs, (0.0, 100 * tc), [0.0, v_in], method="DOP853", rtol=1e-12,
                    atol=[1e-10 * dmax, 1e-10 * v_in], events=exit_, first_step=1e-4 * tc)
    assert sol.status == 1, "no rebound found"
    return -sol.y_events[0][0][1] / v_in


def test_elastic_impact_dissipates_nothing():
    # c_e = 1: pure Hertz spring, conservative; DOP853 at rtol 1e-12 conserves energy to ~1e-11
    assert impact_restitution(1.0) == pytest.approx(1.0, abs=1e-9)


@pytest.mark.parametrize("ce", [0.999, 0.99])
def test_energy_loss_matches_ln_prediction_to_first_order(ce):
    # LN's hysteresis factor 3(1−c_e²)/4 comes from evaluating the loss integral with the
    # undamped (elastic) velocity history, so the predicted loss ΔE = ½ m v² (1 − c_e²) is exact
    # to first order in (1 − c_e²); the relative error is itself O(1 − c_e²). Measured: it is
    # −κ (1 − c_e²) with κ → 0.75 as c_e → 1 (0.749 at 0.999, 0.740 at 0.99). We assert
    # κ ∈ [0.70, 0.80], i.e. the law is first-order accurate with its known coefficient.
    e = impact_restitution(ce)
    rel = ((1 - e**2) - (1 - ce**2)) / (1 - ce**2)
    kappa = -rel / (1 - ce**2)
    assert 0.70 <= kappa <= 0.80


def test_restitution_known_accuracy_at_ce_09():
    # The paper's c_e = 0.9: the LN law overpredicts the loss (the true velocities in the
    # restitution phase are lower than the elastic ones it assumes), so the effective
    # restitution exceeds c_e. Measured: 0.9132 (ΔE 12.6 % below ½ m v² (1 − c_e²)). The
    # first-order bound on the relative energy error is κ (1 − c_e²) ≈ 0.75 × 0.19 = 0.1425.
    e = impact_restitution(0.9)
    rel = abs((1 - e**2) - (1 - 0.81)) / (1 - 0.81)
    assert 0.9 < e < 0.92
    assert rel <= 0.1425
    # scale invariance of the LN impact (only c_e matters): another m, K, v gives the same e
    # to solver accuracy
    assert impact_restitution(0.9, m=0.3, K=3e9, v_in=1.7) == pytest.approx(e, abs=1e-8)
