"""Normality check of FOSM against Monte Carlo."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import special

from mechrel.errors import StudyError
from mechrel.uq import (
    Allowable,
    FunctionModel,
    Normal,
    UncertainInputs,
    fosm,
    monte_carlo,
    normality_check,
)

Z4 = 1 - 2 * special.ndtr(-4.0)
INPUTS = UncertainInputs.from_specs({"x": Normal(0.5, 1.0), "w": Normal(0.0, 0.3)})
ALLOW = Allowable(2.0, 0.5)


def _square_and_line(x):
    """'square': x² (chi-square-like, far from normal); 'line': 0.4x + w (exactly normal)."""
    return np.array([x[0] ** 2, 0.4 * x[0] + x[1]])


def _run(event="two-sided"):
    model = FunctionModel(_square_and_line, INPUTS.names, ["square", "line"])
    f = fosm(model=model, inputs=INPUTS, allowable=ALLOW, event=event)
    mc = monte_carlo(model=model, inputs=INPUTS, n=4000, seed=17, allowable=ALLOW,
                     confidence_level=Z4)
    return f, mc, normality_check(fosm=f, monte_carlo=mc)


def test_non_normal_output_is_flagged_and_fosm_misses_the_interval():
    f, mc, res = _run()
    sq = res.table.loc["square"]
    # FOSM linearises at x = 0.5: μ_i = 0.25, σ_i = 2·0.5·1 = 1; the truth is μ = 1.25, skewed
    assert sq["fosm_mean"] == pytest.approx(0.25, rel=1e-10)
    assert sq["fosm_std"] == pytest.approx(1.0, rel=1e-8)
    assert sq["flag"]
    assert sq["ks_pvalue"] < 1e-6 and sq["ad_pvalue"] < 1e-6
    assert sq["skewness"] > 1.5 and sq["excess_kurtosis"] > 2
    # R_fosm − R_mc lies outside the (z = 4) interval of the difference
    assert sq["diff_lo"] > 0 or sq["diff_hi"] < 0
    assert "R_fosm outside MC interval" in sq["flag_reason"]
    # the exactly normal output passes: tests at α = 0.01 and R_fosm inside the z = 4 interval
    ln = res.table.loc["line"]
    assert not ln["flag"], ln["flag_reason"]
    assert ln["diff_lo"] <= 0 <= ln["diff_hi"]
    assert list(res.flagged.index) == ["square"]


def test_the_comparison_uses_fosms_event():
    f, mc, res = _run(event="one-sided")
    assert res.event == "one-sided"
    again = monte_carlo(evaluations=mc.evaluations, seed=mc.seed, allowable=ALLOW,
                        event="one-sided", confidence_level=Z4)
    np.testing.assert_array_equal(res.table["R_mc"], again.table["reliability"])
    np.testing.assert_array_equal(res.table["R_fosm"], f.table["R_one_sided"])


def test_qq_data():
    _, mc, res = _run()
    qq = res.qq("square")
    assert len(qq) == mc.evaluations.n_ok
    assert np.all(np.diff(qq["mc_quantile"]) >= 0)
    np.testing.assert_allclose(qq["fosm_quantile"], 0.25 + 1.0 * qq["standard_normal"], rtol=1e-8)
    assert res.qq(1)["mc_quantile"].iloc[0] < 0  # by position; the line is negative in its tail
    with pytest.raises(StudyError, match=r"output: 'nope' is neither a label"):
        res.qq("nope")
