"""Plots render (Agg) with labelled axes for FOSM, Monte Carlo, QQ and Sobol' results."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402

from mechrel.errors import StudyError  # noqa: E402
from mechrel.uq import (  # noqa: E402
    FunctionModel,
    Normal,
    UncertainInputs,
    fosm,
    ishigami_inputs,
    ishigami_model,
    monte_carlo,
    normality_check,
    polynomial_chaos,
    sobol_indices,
)
from mechrel.uq.plots import CLIP, plot_qq, plot_reliability, plot_sobol  # noqa: E402

ANGLES = np.arange(0.0, 360.0, 18.0)


def _slider_errors(x):
    t = np.deg2rad(ANGLES)
    d = 1e-3 * (x[0] * np.sin(t) + 0.5 * x[1] * np.cos(2 * t)) + 4e-3
    v = 0.05 * (x[0] * np.cos(t) - x[1] * np.sin(2 * t))
    a = 5.0 * (-x[0] * np.sin(t) + x[1] * np.cos(2 * t)) + 8.0
    return np.concatenate([d, v, a])


@pytest.fixture(scope="module")
def results():
    idx = pd.MultiIndex.from_product([["displacement", "velocity", "acceleration"], ANGLES],
                                     names=["quantity", "crank_angle"])
    inputs = UncertainInputs.from_specs({"joints.C1.clearance": Normal(1.0, 0.3),
                                         "joints.C2.clearance": Normal(1.0, 0.3)})
    model = FunctionModel(_slider_errors, inputs.names, idx)
    f = fosm(model=model, inputs=inputs)
    mc = monte_carlo(model=model, inputs=inputs, n=1000, seed=1)
    return f, mc, normality_check(fosm=f, monte_carlo=mc)


def test_reliability_and_comparison_plots(results):
    import matplotlib.pyplot as plt

    f, mc, norm = results
    fig = plot_reliability(f)
    assert len(fig.axes) == 6  # (β, 1 − R) per quantity
    assert fig.axes[-1].get_xlabel() == "crank angle (deg)"
    # β is dimensionless: no unit on its axis (the allowable's legend entry carries the unit)
    assert fig.axes[0].get_ylabel() == "β = Φ⁻¹(R), displacement"
    fig3 = plot_reliability(f, mc)
    # a legend in every panel, naming the sample count, the allowable and its cap, and the
    # whole-cycle R of Monte Carlo
    for ax in fig3.axes:
        assert ax.get_legend() is not None
    texts = [t.get_text() for ax in fig3.axes for t in ax.get_legend().get_texts()]
    assert "Monte Carlo (n = 1000)" in texts
    assert any(t.startswith("allowable I ~ N(0.012, 0.004²) m: cap β = μ_I/σ_I = 3.00")
               for t in texts)
    assert any(t.startswith("whole cycle (MC): R = ") for t in texts)
    fig4 = plot_qq(norm, ("acceleration", 90.0))
    assert "FOSM normal quantile" in fig4.axes[0].get_xlabel()
    for fg in (fig, fig3, fig4):
        fg.canvas.draw()
        plt.close(fg)
    with pytest.raises(StudyError, match="expected FOSMResult or MonteCarloResult"):
        plot_reliability(object())


def test_reliability_beyond_the_clip_is_drawn_as_clipped(results):
    # R = 1 to double precision has no finite β and no point on a log axis of 1 − R: it is
    # drawn at the edge with an open marker and a label that says so
    import matplotlib.pyplot as plt

    from mechrel.uq import Allowable

    inputs = UncertainInputs.from_specs({"joints.C1.clearance": Normal(1.0, 0.3),
                                         "joints.C2.clearance": Normal(1.0, 0.3)})
    f = fosm(evaluations=results[0].evaluations, inputs=inputs, allowable=Allowable(1e3, 0.0))
    clipped = (f.table["reliability"] > 1 - CLIP).to_numpy()
    assert clipped.any(), "the fixture has no R beyond the clip to draw"
    fig = plot_reliability(f)
    texts = [t.get_text() for ax in fig.axes for t in ax.get_legend().get_texts()]
    assert any("(clipped)" in t for t in texts)
    plt.close(fig)


def test_monte_carlo_without_an_exceedance_is_drawn_as_a_bound_in_both_panels(results):
    # R = 1 observed (no sample beyond the allowable): no finite β and no 1 − R to draw, only
    # the interval's end: ▲ at β = Φ⁻¹(R_lo) on the left, ▼ at 1 − R_lo on the right (before,
    # the β panel drew nothing for Monte Carlo at those angles)
    import matplotlib.pyplot as plt
    from scipy import special

    from mechrel.uq import Allowable

    inputs = UncertainInputs.from_specs({"joints.C1.clearance": Normal(1.0, 0.3),
                                         "joints.C2.clearance": Normal(1.0, 0.3)})
    mc = monte_carlo(evaluations=results[1].evaluations, inputs=inputs,
                     allowable=Allowable(1e3, 0.0))
    assert (mc.table["reliability"] == 1.0).all()
    lo = mc.table.xs("velocity", level="quantity")["reliability_lo"].to_numpy()
    fig = plot_reliability(mc)
    ax_beta, ax_pf = fig.axes[2], fig.axes[3]  # velocity: (β, 1 − R)
    lines = {ln.get_label(): ln for ln in ax_beta.get_lines()}
    bound = lines["MC lower bound (no exceedance seen)"]
    np.testing.assert_allclose(bound.get_xdata(), ANGLES)
    np.testing.assert_allclose(bound.get_ydata(), special.ndtri(lo), rtol=1e-12)
    # the Wilson interval's lower end at k = n: n / (n + z²), z = Φ⁻¹(0.975)
    z = special.ndtri(0.975)
    np.testing.assert_allclose(bound.get_ydata(), special.ndtri(1000 / (1000 + z * z)),
                               rtol=1e-9)
    upper = {ln.get_label(): ln for ln in ax_pf.get_lines()}["MC upper bound (no exceedance seen)"]
    np.testing.assert_allclose(upper.get_ydata(), 1 - lo, rtol=1e-12)
    plt.close(fig)


def test_sobol_plots():
    import matplotlib.pyplot as plt

    s = sobol_indices(model=ishigami_model(), inputs=ishigami_inputs(), n=256, seed=0)
    p = polynomial_chaos(model=ishigami_model(), inputs=ishigami_inputs(), order=4, seed=0)
    for r in (s, p):
        fig = plot_sobol(r)
        fig.canvas.draw()
        assert "Sobol' index" in fig.axes[0].get_ylabel()
        plt.close(fig)
    with pytest.raises(StudyError, match=r"expected a SobolResult or PCEResult"):
        plot_sobol(object())
