"""Sobol' indices (SALib): Ishigami, failure strategy, reducers, precomputed designs."""

from __future__ import annotations


import numpy as np
import pandas as pd
import pytest

from mechrel.errors import StudyError
from mechrel.uq import (
    FunctionModel,
    ModelFailure,
    Normal,
    UncertainInputs,
    Uniform,
    evaluate,
    ishigami,
    ishigami_indices,
    ishigami_inputs,
    ishigami_model,
    peak_abs,
    sobol_design,
    sobol_indices,
)
from mechrel.uq import SampleFailuresError


def test_ishigami_first_and_total_order():
    """N = 2¹³ base samples (65 536 runs): SALib's estimators on a scrambled Sobol' design are
    accurate to a few 1e-3 here (bootstrap half-widths ≈ 0.02 overstate it: they assume iid
    sampling); the brief's tolerance 0.02 therefore leaves a margin yet fails for any wrong
    mapping of inputs (e.g. normal instead of uniform inputs moves S1 of x1 by > 0.1)."""
    ref = ishigami_indices()
    res = sobol_indices(model=ishigami_model(), inputs=ishigami_inputs(), n=2**13, seed=42)
    np.testing.assert_allclose(res.first.to_numpy()[0], ref["first"], atol=0.02)
    np.testing.assert_allclose(res.total.to_numpy()[0], ref["total"], atol=0.02)
    assert np.all(res.first_conf.to_numpy() > 0) and np.all(res.total_conf.to_numpy() < 0.05)
    assert res.n_blocks_dropped == 0 and res.n_blocks_used == 2**13
    assert res.provenance["n_evaluations"] == 5 * 2**13
    long = res.to_frame()
    assert list(long.columns) == ["S1", "S1_conf", "ST", "ST_conf"] and len(long) == 3


def _ishigami_failing(x):
    if x[0] > 3.0:
        raise ModelFailure("mechanism locks near the dead point")
    return ishigami(x)


def test_failed_samples_drop_whole_blocks_and_are_reported():
    inputs = ishigami_inputs()
    model = FunctionModel(_ishigami_failing, inputs.names, ["y"])
    n = 2**10
    res = sobol_indices(model=model, inputs=inputs, n=n, seed=1, max_failure_fraction=0.15)
    X = res.evaluations.X.reshape(n, 5, 3)
    # a block fails iff A or B has x1 > 3 (rows AB_j copy x1 from A, except AB_1 from B)
    expect = int(np.sum((X[:, 0, 0] > 3.0) | (X[:, -1, 0] > 3.0)))
    assert res.n_blocks_dropped == expect > 0
    assert res.n_blocks_used == n - expect
    assert res.failure_counts == {"mechanism locks near the dead point": res.evaluations.n_failed}
    assert np.all(np.isfinite(res.first.to_numpy()))  # no NaN propagation
    # refuse when the dropped share exceeds the threshold; the message gives counts and reasons
    with pytest.raises(SampleFailuresError,
                       match=rf"{expect} of {n} Saltelli blocks contain a failed sample "
                       r"\(\d+ of \d+ samples failed \(\d+× mechanism locks") as info:
        sobol_indices(evaluations=res.evaluations, inputs=inputs, n=n, max_failure_fraction=0.01)
    assert info.value.evaluations is res.evaluations  # the raw evaluations, every sample


def _always_locks(x):
    raise ModelFailure("mechanism locks near the dead point")


def test_fewer_than_two_complete_blocks_is_a_refusal_even_at_threshold_one():
    # every block dropped and the threshold allows it: this used to reach SALib with no rows
    # (a ValueError from numpy)
    inputs = ishigami_inputs()
    model = FunctionModel(_always_locks, inputs.names, ["y"])
    with pytest.raises(SampleFailuresError,
                       match=r"sobol_indices: need at least 2 complete Saltelli blocks, got 0 "
                                                  r"\(40 of 40 samples failed") as info:
        sobol_indices(model=model, inputs=inputs, n=8, seed=1, max_failure_fraction=1.0,
                      progress=False)
    assert info.value.evaluations.n == 40


def _grid(x):
    ang = np.deg2rad([0.0, 90.0, 180.0, 270.0])
    return np.concatenate([1e-3 * (x[0] * np.sin(ang) + 0.1 * x[1]),
                           0.1 * (x[1] * np.cos(ang) + 0.3 * x[2])])


def test_reducer_and_output_selection():
    idx = pd.MultiIndex.from_product([["displacement", "velocity"], [0.0, 90.0, 180.0, 270.0]],
                                     names=["quantity", "crank_angle"])
    inputs = UncertainInputs.from_specs({"a": Normal(0, 1), "b": Normal(0, 1), "c": Uniform(-1, 1)})
    model = FunctionModel(_grid, inputs.names, idx)
    X = sobol_design(inputs, n=256, seed=3)
    ev = evaluate(model, X, progress=False)
    res = sobol_indices(evaluations=ev, inputs=inputs, n=256, reducer=peak_abs, seed=3)
    assert list(res.first.index) == ["peak_abs_displacement", "peak_abs_velocity"]
    # displacement does not depend on c at all: its total index is ~0
    assert abs(res.total.loc["peak_abs_displacement", "c"]) < 0.01
    sel = sobol_indices(evaluations=ev, inputs=inputs, n=256, outputs=[("velocity", 0.0)], seed=3)
    # velocity at 0°: y = 0.1 (b + 0.3 c), Var shares b: 1/(1 + 0.09/3)
    assert sel.first.loc[("velocity", 0.0), "b"] == pytest.approx(1 / (1 + 0.03), abs=0.05)
    # same design & seed → the model path gives identical numbers
    direct = sobol_indices(model=model, inputs=inputs, n=256, reducer=peak_abs, seed=3)
    pd.testing.assert_frame_equal(direct.first, res.first)
    pd.testing.assert_frame_equal(direct.total_conf, res.total_conf)


def test_argument_errors():
    inputs = ishigami_inputs()
    corr = UncertainInputs.from_specs({"x1": Normal(0, 1), "x2": Normal(0, 1), "x3": Normal(0, 1)},
                                      correlation={("x1", "x2"): 0.5})
    with pytest.raises(StudyError, match=r"the inputs are correlated; classical Sobol' indices "
                                         r"need independent inputs"):
        sobol_indices(model=ishigami_model(), inputs=corr, n=64)
    X = inputs.sample(5 * 63, seed=1)
    ev = evaluate(ishigami_model(), X, progress=False)
    with pytest.raises(StudyError, match=r"evaluations\.X is not a Saltelli design"):
        sobol_indices(evaluations=ev, inputs=inputs, n=63)
    with pytest.raises(StudyError, match=r"not a multiple of the Saltelli block size 8"):
        sobol_indices(evaluations=ev, inputs=inputs, n=64, calc_second_order=True)
    with pytest.raises(StudyError,
                       match=r"outputs: labels \['z'\] are not in the model's output_index"):
        sobol_indices(model=ishigami_model(), inputs=inputs, n=64, outputs=["z"])
