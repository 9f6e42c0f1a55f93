"""Trends of the slider's response errors on the nine-bar (reconstructed geometry), as in the
paper's §4: lubricated below dry, errors growing with clearance and crank speed, falling with
viscosity.

Fast version (default run): one revolution of crank 1, errors analysed from 30° of crank
rotation on. The journals start centred (e = 0), where a joint carries no force, so the first
few degrees are a start transient (the slider's acceleration error is ~8 m/s² at t = 0 in
every lubricated case, then falls below 0.2 m/s² by 10°); from there on the lubricated
response repeats from cycle to cycle (cycle-2 peaks equal cycle-1 peaks to 1 %).

Slow version (``-m slow``): two revolutions, the second analysed, as in
``studies/response_errors.py``; adds the 5π dry/lubricated comparison and the dry joint's
displacement and velocity trends with clearance. The dry joint's acceleration-error peak is
NOT monotone in clearance or speed (a peak of a chaotic impact sequence, docs/reference.md), so it
is not asserted; docs/validation.md discusses it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mechrel.scene import load_scene
from mechrel.simulation import simulate

PI = math.pi
QTY = ("displacement", "velocity", "acceleration")


def speed(w):
    return {"drivers.crank1.speed": -w, "drivers.crank2.speed": w}


def both(field, value):
    return {f"joints.C1.{field}": value, f"joints.C2.{field}": value}


CASES = {
    "dry": ("nine-bar-dry", {}),
    "lub": ("nine-bar-lubricated", {}),
    "dry-5pi": ("nine-bar-dry", speed(5 * PI)),
    "lub-5pi": ("nine-bar-lubricated", speed(5 * PI)),
    "lub-200cP": ("nine-bar-lubricated", both("lubricant.viscosity", 0.2)),
    "lub-400cP": ("nine-bar-lubricated", both("lubricant.viscosity", 0.4)),
    "lub-0.3mm": ("nine-bar-lubricated", both("clearance", 0.3e-3)),
    "lub-0.7mm": ("nine-bar-lubricated", both("clearance", 0.7e-3)),
    "dry-0.3mm": ("nine-bar-dry", both("clearance", 0.3e-3)),
    "dry-0.7mm": ("nine-bar-dry", both("clearance", 0.7e-3)),
}


class Peaks:
    """max |error| of the slider per quantity over the analysed window, one run per case
    (simulated on first use)."""

    def __init__(self, cycles, from_angle):
        self.cycles, self.from_angle, self._cache = cycles, from_angle, {}

    def __call__(self, case, qty):
        if case not in self._cache:
            scene, ov = CASES[case]
            res = simulate(load_scene(scene, overrides={**ov, "analysis.cycles": self.cycles}))
            assert res.stats["status"] == "ok"
            keep = res.crank_angle >= self.from_angle
            self._cache[case] = {q: float(np.abs(res.error("slider", q)[keep]).max())
                                 for q in QTY}
            self._cache[case]["eps"] = max(o["eps"].max() for o in res.orbits.values())
        return self._cache[case][qty]


@pytest.fixture(scope="module")
def fast():
    return Peaks(cycles=1, from_angle=30.0)


@pytest.fixture(scope="module")
def full():
    return Peaks(cycles=2, from_angle=360.0)


def increasing(peaks, cases, qty):
    values = [peaks(c, qty) for c in cases]
    return all(a < b for a, b in zip(values, values[1:])), values


# --------------------------------------------------------------------------------- fast ---

def test_lubricated_acceleration_error_far_below_dry(fast):
    # paper (3π): dry [−365, 576] m/s², lubricated [−14.0, 24.0] m/s²: a factor ~24
    assert fast("lub", "acceleration") < 0.1 * fast("dry", "acceleration")
    assert fast("lub", "velocity") < fast("dry", "velocity")


@pytest.mark.parametrize("qty", QTY)
def test_lubricated_errors_grow_with_clearance(fast, qty):
    ok, values = increasing(fast, ["lub-0.3mm", "lub", "lub-0.7mm"], qty)
    assert ok, values


@pytest.mark.parametrize("qty", QTY)
def test_lubricated_errors_grow_with_crank_speed(fast, qty):
    ok, values = increasing(fast, ["lub", "lub-5pi"], qty)
    assert ok, values


@pytest.mark.parametrize("qty", QTY)
def test_lubricated_errors_fall_with_viscosity(fast, qty):
    ok, values = increasing(fast, ["lub-400cP", "lub-200cP", "lub"], qty)
    assert ok, values


def test_lubricated_journals_stay_inside_their_bearings(fast):
    for case in ("lub", "lub-5pi", "lub-200cP", "lub-400cP", "lub-0.3mm", "lub-0.7mm"):
        assert fast(case, "eps") < 1.0


# --------------------------------------------------------------------------------- slow ---

@pytest.mark.slow
@pytest.mark.parametrize("w", ["", "-5pi"])
def test_full_lubricated_below_dry(full, w):
    # the dry peak is one impact's, depends on the output sampling (1° here) and varies from
    # revolution to revolution and with round-off (chaotic impacts): measured 3.6 vs 100-300
    # m/s² at 3π and 30 vs 160-570 m/s² at 5π over code versions
    assert full(f"lub{w}", "acceleration") < 0.5 * full(f"dry{w}", "acceleration")
    assert full(f"lub{w}", "velocity") < full(f"dry{w}", "velocity")


@pytest.mark.slow
@pytest.mark.parametrize("qty", QTY)
def test_full_lubricated_trends(full, qty):
    for cases in (["lub-0.3mm", "lub", "lub-0.7mm"], ["lub", "lub-5pi"],
                  ["lub-400cP", "lub-200cP", "lub"]):
        ok, values = increasing(full, cases, qty)
        assert ok, (cases, values)


@pytest.mark.slow
@pytest.mark.parametrize("qty", ["displacement", "velocity"])
def test_full_dry_errors_grow_with_clearance(full, qty):
    ok, values = increasing(full, ["dry-0.3mm", "dry", "dry-0.7mm"], qty)
    assert ok, values
