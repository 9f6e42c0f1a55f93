"""The film's viscous shear torques (lubricant.shear_torque): Petroff, moment balance,
dissipation, frame invariance, and off by default."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mechrel.errors import SceneError
from mechrel.forces import film_shear_torques, pack_params
from mechrel.forces.joint import clearance_force
from mechrel.scene import load_scene

MU, R_S, C, L = 0.1, 0.0145, 5e-4, 0.04


def params(bearing="long", shear=True):
    return pack_params(model="lubricated", clearance=C, bearing_radius=R_S + C, length=L,
                       stiffness=1e10, restitution=0.9, viscosity=MU, bearing=bearing,
                       shear_torque=shear)


def test_petroff_at_the_centre_and_moment_balance():
    TS, TB = film_shear_torques(0.0, 0.0, 30.0, 5.0, MU, R_S, L, C)
    petroff = 2 * math.pi * MU * R_S**3 * L * 25.0 / C  # Petroff: τ = μ R Δω / c over 2πRL, arm R
    assert TS == pytest.approx(-petroff, rel=1e-14) and TB == pytest.approx(petroff, rel=1e-14)
    for eps, Ft in ((0.5, 3.0), (0.95, -40.0)):
        TS, TB = film_shear_torques(eps, Ft, 30.0, 5.0, MU, R_S, L, C)
        assert TS + TB + eps * C * Ft == pytest.approx(0.0, abs=1e-15 * abs(TS))


e_st = st.tuples(st.floats(0.0, 0.97), st.floats(-math.pi, math.pi))
v_st = st.floats(-0.2, 0.2)
w_st = st.floats(-60.0, 60.0)


@settings(max_examples=150, deadline=None)
@given(e=e_st, vx=v_st, vy=v_st, wB=w_st, wS=w_st,
       bearing=st.sampled_from(["long", "short", "finite"]))
def test_film_power_is_dissipative(e, vx, vy, wB, wS, bearing):
    # P = F·v + M_S ω_S + M_B ω_B ≤ 0: pressure and Couette dissipation (rounding: 1e-12 of
    # the largest term)
    r, a = e[0] * C, e[1]
    ex, ey = r * math.cos(a), r * math.sin(a)
    Fx, Fy, MS, MB, _ = clearance_force(ex, ey, vx, vy, wB, wS, 0.0, params(bearing))
    terms = (Fx * vx, Fy * vy, MS * wS, MB * wB)
    assert sum(terms) <= 1e-12 * max(map(abs, terms)) + 1e-300


def test_rigid_rotation_of_the_joint_costs_no_power_and_default_is_off():
    e = np.array([2e-4, -1e-4])
    Om = 17.0
    v = Om * np.array([-e[1], e[0]])
    for bearing in ("long", "short", "finite"):
        Fx, Fy, MS, MB, _ = clearance_force(*e, *v, Om, Om, 0.0, params(bearing))
        P = Fx * v[0] + Fy * v[1] + (MS + MB) * Om
        assert abs(P) <= 1e-12 * (abs(MS) + abs(MB) + 1e-30) * Om + 1e-300
        # default: no film moment at all (the paper's model)
        out = clearance_force(*e, 0.01, 0.02, 3.0, -9.0, 0.0, params(bearing, shear=False))
        assert out[2] == 0.0 and out[3] == 0.0


def test_scene_switch():
    sc = load_scene("nine-bar-lubricated", overrides={"joints.C1.lubricant.shear_torque": True})
    assert sc.joints["C1"].lubricant.shear_torque is True
    assert load_scene("nine-bar-lubricated").joints["C1"].lubricant.shear_torque is False
    with pytest.raises(SceneError, match=r'joints\.C1\.lubricant\.shear_torque = "yes": expected '
                                         r"true or false, got a string; allowed: true or false"):
        load_scene("nine-bar-lubricated", overrides={"joints.C1.lubricant.shear_torque": "yes"})
