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
from mechrel.uq.plots import plot_fosm_vs_mc, plot_qq, plot_reliability, plot_sobol  # noqa: E402

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
    inputs = UncertainInputs.from_specs({"joints.C1.clearance": Normal(1.0, 0.3), "joints.C2.clearance": Normal(1.0, 0.3)})
    model = FunctionModel(_slider_errors, inputs.names, idx)
    f = fosm(model=model, inputs=inputs)
    mc = monte_carlo(model=model, inputs=inputs, n=1000, seed=1)
    return f, mc, normality_check(fosm=f, monte_carlo=mc)


def test_reliability_and_comparison_plots(results):
    import matplotlib.pyplot as plt

    f, mc, norm = results
    fig = plot_reliability(f, what="beta")
    assert len(fig.axes) == 3
    assert fig.axes[-1].get_xlabel() == "crank angle (deg)"
    assert fig.axes[0].get_title() == "displacement (m)"
    assert fig.axes[0].get_ylabel() == "reliability index β"
    fig2 = plot_reliability(mc)
    fig3 = plot_fosm_vs_mc(f, mc)
    assert fig3.axes[0].get_legend() is not None
    fig4 = plot_qq(norm, ("acceleration", 90.0))
    assert "FOSM normal quantile" in fig4.axes[0].get_xlabel()
    for fg in (fig, fig2, fig3, fig4):
        fg.canvas.draw()
        plt.close(fg)


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
