"""Modified Coulomb friction with Ambrósio's dynamic correction c_d."""

from __future__ import annotations

import math

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from mechrel.forces import dynamic_correction, friction_force

V0, V1 = 1e-4, 1e-2


@pytest.mark.parametrize(
    "v, expect",
    [
        (0.0, 0.0),
        (0.5 * V0, 0.0),
        (V0, 0.0),                      # lower end of the ramp
        (0.5 * (V0 + V1), 0.5),         # midpoint
        (V0 + 0.25 * (V1 - V0), 0.25),  # quarter point
        (V1, 1.0),                      # upper end
        (2 * V1, 1.0),
        (1e3, 1.0),
    ],
)
def test_dynamic_correction_piecewise(v, expect):
    # exact at the ends (x/x == 1); the interior points carry one rounding of v − v0
    assert dynamic_correction(v, V0, V1) == pytest.approx(expect, rel=1e-14, abs=0)
    if v in (0.0, V0, V1, 2 * V1):
        assert dynamic_correction(v, V0, V1) == expect


@given(v=st.floats(0.0, 1.0), v0=st.floats(0.0, 0.1), dv=st.floats(1e-6, 0.1))
@settings(max_examples=300, deadline=None)
def test_dynamic_correction_is_a_monotone_ramp(v, v0, dv):
    v1 = v0 + dv
    cd = dynamic_correction(v, v0, v1)
    assert 0.0 <= cd <= 1.0
    assert dynamic_correction(min(v * 1.01 + 1e-9, 1.0), v0, v1) >= cd


@given(
    fn=st.floats(0.0, 1e6),
    vt=st.floats(-10.0, 10.0),
    cf=st.floats(0.0, 1.0),
)
@settings(max_examples=500, deadline=None)
def test_friction_opposes_slip_and_is_bounded(fn, vt, cf):
    ft = friction_force(fn, vt, cf, V0, V1)
    assert math.isfinite(ft)
    assert abs(ft) <= cf * fn * (1 + 1e-15)
    assert ft * vt <= 0.0  # never drives the slip (dissipative)
    assume(fn > 0 and cf > 0 and abs(vt) > V0)
    assert math.copysign(1.0, ft) == -math.copysign(1.0, vt)


def test_friction_zero_and_finite_at_zero_slip():
    for vt in (0.0, -0.0, 1e-300, -5e-324, 0.5 * V0):
        ft = friction_force(100.0, vt, 0.05, V0, V1)
        assert ft == 0.0
    # full Coulomb above v1, linear in between
    assert friction_force(100.0, 1.0, 0.05, V0, V1) == pytest.approx(-5.0, rel=1e-15)
    assert friction_force(100.0, -1.0, 0.05, V0, V1) == pytest.approx(5.0, rel=1e-15)
    mid = 0.5 * (V0 + V1)
    assert friction_force(100.0, -mid, 0.05, V0, V1) == pytest.approx(2.5, rel=1e-13)
