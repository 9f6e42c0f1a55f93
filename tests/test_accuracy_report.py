"""The accuracy-vs-time report on a cheap scene."""

import numpy as np

from mechrel.scene import load_scene
from mechrel.studies.accuracy import accuracy_report


def test_report_orders_errors_and_recommends_fastest_meeting_target():
    # Ideal slider-crank forward dynamics over a quarter revolution: pointwise errors converge.
    # Outputs every 0.1 rad (1.9e-4 s): RK4 never steps past an output instant, so its steps
    # must stay below that spacing to be what the test says they are.
    scene = load_scene("slider-crank", overrides={"analysis.cycles": 0.25,
                                                  "analysis.sample_step_angle": 0.1})
    cands = [("rk4", {"step": 1.6e-4}), ("rk4", {"step": 4e-5}),
             ("dopri5", {"rtol": 1e-5, "atol": 1e-8}), ("dopri5", {"rtol": 1e-9, "atol": 1e-12})]
    rep = accuracy_report(scene, candidates=cands, target=1e-6, repeats=1)
    t = rep.table.set_index(["integrator", "setting"])
    assert (rep.table["failed"] == "").all()
    # RK4 is 4th order: a 4x smaller step lowers the error by ~4^4 = 256; require > 50 to
    # leave room for the output-sampling and Baumgarte contributions.
    rk = rep.table[rep.table["integrator"] == "rk4"]["measure"].to_numpy()
    assert rk[0] / rk[1] > 50
    dp = rep.table[rep.table["integrator"] == "dopri5"]["measure"].to_numpy()
    assert dp[1] < dp[0]
    ok = rep.table[rep.table["measure"] <= 1e-6]
    assert rep.recommended is not None
    assert rep.recommended["wall_time"] == ok["wall_time"].min()
    assert rep.recommended["measure"] <= 1e-6
    assert np.isfinite(t["wall_time"]).all()
