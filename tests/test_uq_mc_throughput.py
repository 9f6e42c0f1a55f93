"""What Monte Carlo of a vectorised model does not do (issue 35): copy the design it drew or
the status of a run without failures, cut a cheap batch into chunks of 1 000 rows, or make
(n, n_out) temporaries to count the samples inside their allowables; and the numbers that
stay the same for it: the counts of the boolean formulas, the bits of a sample, the results
for any chunk size and worker count.

Cost: a few Monte Carlo runs of a closed-form model at 7·10⁴ samples and one start of two
loky workers (shared with the other executor tests when they run in the same process).
"""

from __future__ import annotations

import pickle

import numpy as np
import pandas as pd
import pytest
from scipy import special

from mechrel.errors import StudyError
from mechrel.uq import (Allowable, Evaluations, FunctionModel, LogNormal, Normal, TruncNormal,
                        UncertainInputs, Uniform, evaluate, monte_carlo)
from mechrel.uq.estimators._tally import tally
from mechrel.uq.execution.executor import VECTORIZED_CHUNK, default_chunk_size
from mechrel.uq.problem.inputs import _U_EPS

TH = np.radians(np.arange(0.0, 360.0, 45.0))


def _slider_error(X):
    """The slider-crank's closed-form slider position error at 8 crank angles (m), for crank
    length, rod length and pivot height; NaN rows where the pivot is 2.3 σ high (1 %)."""
    r, l, e = X[:, :1], X[:, 1:2], X[:, 2:3]
    S, C = np.sin(TH), np.cos(TH)
    Y = r * C + np.sqrt(l * l - (r * S - e) ** 2) - (0.05 * C + np.sqrt(0.12**2 - (0.05 * S) ** 2))
    Y[X[:, 2] > 2.326e-5] = np.nan
    return Y


INPUTS = UncertainInputs.from_specs({"r": Normal(0.05, 2e-5), "l": Normal(0.12, 3e-5),
                                     "e": Normal(0.0, 1e-5)})
LABELS = pd.MultiIndex.from_product([["position"], np.degrees(TH)],
                                    names=["quantity", "crank_angle"])


def _model(vectorized=True):
    f = _slider_error if vectorized else (lambda x: _slider_error(x[None, :])[0])
    return FunctionModel(f, ["r", "l", "e"], LABELS, key="slider", vectorized=vectorized)


# ----------------------------------------------------------------------------- chunks

def test_default_chunk_size_depends_on_the_rows_and_the_kind_of_model_only():
    # about 64 chunks; a row-by-row model's at most 1 000 rows, a vectorised one's more
    for n in (1, 63, 64, 65, 6_400, 64_000):  # up to 64 000 rows: the same chunks as before
        assert default_chunk_size(n, True) == default_chunk_size(n) == max(1, -(-n // 64))
    assert default_chunk_size(10**5) == 1000
    assert default_chunk_size(10**5, vectorized=True) == 1563  # ceil(10⁵ / 64)
    assert default_chunk_size(10**6, vectorized=True) == VECTORIZED_CHUNK == 8192  # < 10⁶/64
    X = INPUTS.sample(70_000, "random", 1)
    assert evaluate(_model(), X, progress=False).settings["chunk_size"] == 1094
    assert evaluate(_model(), X[:640], progress=False).settings["chunk_size"] == 10


def test_a_model_caps_its_default_chunk_with_max_chunk_rows():
    # a simulation model's rows cost milliseconds: its chunks stay at most 1 000 rows (the
    # progress and resume steps), vectorised or not
    from mechrel.uq.problem.mechanism import MechanismModel

    assert MechanismModel.vectorized and MechanismModel.max_chunk_rows == 1000
    assert default_chunk_size(10**6, True, MechanismModel.max_chunk_rows) == 1000
    assert default_chunk_size(6_400, True, 50) == 50 and default_chunk_size(640, True, 50) == 10
    model = _model()
    model.max_chunk_rows = 700
    X = INPUTS.sample(70_000, "random", 1)
    assert evaluate(model, X, progress=False).settings["chunk_size"] == 700


def test_monte_carlo_of_a_vectorised_model_is_the_same_for_any_chunk_size_and_worker_count():
    # 7·10⁴ samples: the default chunk of a vectorised model (1 094 rows) is not the 1 000 of
    # the row-wise rule; 1 % of the rows fail (NaN rows)
    kw = dict(inputs=INPUTS, n=70_000, seed=11, allowable=Allowable(1e-5, 2e-6), progress=False)
    ref = monte_carlo(model=_model(), **kw)
    assert ref.n_failed == pytest.approx(700, rel=0.15)  # 1 % failing, the binomial's 4 σ
    runs = [monte_carlo(model=_model(), chunk_size=cs, **kw) for cs in (1000, 4096, 37, 70_000)]
    runs.append(monte_carlo(model=_model(), n_jobs=2, chunk_size=5000, **kw))
    for r in runs:
        assert r.evaluations.Y.tobytes() == ref.evaluations.Y.tobytes()
        assert r.to_frame().equals(ref.to_frame()) and r.whole_cycle.equals(ref.whole_cycle)
        assert r.failure_counts == ref.failure_counts
    # the same numbers row by row (the model's function on one row at a time)
    rows = monte_carlo(model=_model(vectorized=False), **{**kw, "n": 3000})
    part = monte_carlo(model=_model(), **{**kw, "n": 3000})
    assert rows.to_frame().equals(part.to_frame()) and rows.whole_cycle.equals(part.whole_cycle)


# ----------------------------------------------------------------------------- copies

def test_a_read_only_design_is_kept_as_it_is_a_writable_one_is_copied():
    X = INPUTS.sample(1000, "random", 2)
    ev = evaluate(_model(), X, progress=False)
    assert ev.X is not X and not np.shares_memory(ev.X, X) and X.flags.writeable
    X[0, 0] = 1.0  # the caller's array stays the caller's
    assert ev.X[0, 0] != 1.0 and not ev.X.flags.writeable
    frozen = INPUTS.sample(1000, "random", 2)
    frozen.setflags(write=False)
    again = evaluate(_model(), frozen, progress=False)
    assert again.X is frozen  # read-only already: not copied
    assert again.Y.tobytes() == evaluate(_model(), frozen.copy(), progress=False).Y.tobytes()
    # Monte Carlo's evaluations keep the design it drew (that of monte_carlo_design), uncopied
    r = monte_carlo(model=_model(), inputs=INPUTS, n=500, seed=3, allowable=Allowable(1e-5, 0),
                    progress=False)
    from mechrel.uq import monte_carlo_design

    assert np.array_equal(r.evaluations.X, monte_carlo_design(INPUTS, n=500, seed=3))
    assert not r.evaluations.X.flags.writeable and r.evaluations.X.flags.owndata


def test_status_of_a_run_without_failures_is_one_read_only_value_without_memory():
    X = INPUTS.sample(2000, "random", 4)
    X[:, 2] = np.minimum(X[:, 2], 0.0)  # no failing row
    ev = evaluate(_model(), X, progress=False)
    assert ev.n_failed == 0 and ev.status.strides == (0,) and not ev.status.flags.writeable
    assert ev.status.shape == (2000,) and ev.status.dtype == np.dtype("<U6")
    assert list(ev.status) == ["ok"] * 2000 and ev.ok.all() and ev.reasons == (None,) * 2000
    with pytest.raises(ValueError, match="read-only"):
        ev.status[0] = "failed"
    # it behaves as the array it stands for: rows picked, pickled, compared, saved
    assert ev.subset([0, 5]).status.tolist() == ["ok", "ok"]
    back = pickle.loads(pickle.dumps(ev))
    assert back.status.tolist() == ev.status.tolist() and back.ok.all()
    # with failures: a status array of its own, read-only, "failed" at the failed rows
    bad = evaluate(_model(), INPUTS.sample(2000, "random", 4), progress=False)
    assert 0 < bad.n_failed and bad.status.strides == (24,) and not bad.status.flags.writeable
    assert np.array_equal(bad.status == "failed", ~bad.ok)
    assert np.array_equal(~bad.ok, np.isnan(bad.Y).all(axis=1))


def test_evaluations_still_refuse_a_non_finite_output_in_an_ok_row():
    Y = np.ones((4, 2))
    ok = np.full(4, "ok")
    Evaluations(np.zeros((4, 1)), Y * 1e308, ok, (None,) * 4, ("x",), pd.Index(["a", "b"]))
    for bad in (np.inf, -np.inf, np.nan):  # the sum of 1e308s overflows: checked entry-wise
        Yb = Y.copy()
        Yb[2, 1] = bad
        with pytest.raises(StudyError, match="rows marked 'ok' contain non-finite outputs; "
                                             "mark them 'failed' with a reason"):
            Evaluations(np.zeros((4, 1)), Yb, ok, (None,) * 4, ("x",), pd.Index(["a", "b"]))
    one = np.broadcast_to(np.array("failed"), (4,))  # a status of one value, as a view
    ev = Evaluations(np.zeros((4, 1)), Y * np.nan, one, ("r",) * 4, ("x",), pd.Index(["a", "b"]))
    assert ev.n_failed == 4 and not ev.ok.any()
    with pytest.raises(StudyError, match="one of 'ok'/'failed' per row"):
        Evaluations(np.zeros((4, 1)), Y, np.broadcast_to(np.array("fine"), (4,)), (None,) * 4,
                    ("x",), pd.Index(["a", "b"]))


# ----------------------------------------------------------------------------- sampling

MIXED = {"n": Normal(1.0, 0.1), "t": TruncNormal(0.5e-3, 0.05e-3, 0.35e-3, 0.65e-3),
         "u": Uniform(-1.0, 2.0), "g": LogNormal(0.1, 0.015)}


@pytest.mark.parametrize("rule", ["random", "latin_hypercube", "sobol"])
@pytest.mark.parametrize("corr", [None, {("n", "u"): 0.4, ("g", "t"): -0.3}],
                         ids=["independent", "correlated"])
def test_a_sample_is_bitwise_the_inverse_cdfs_of_its_unit_points(rule, corr):
    inputs = UncertainInputs.from_specs(MIXED, correlation=corr)
    u = inputs.unit_sample(256, rule, 5)
    keep = u.copy()
    X = inputs.sample(256, rule, 5)
    uc = np.clip(u, _U_EPS, 1.0 - _U_EPS)
    if corr is None:  # SciPy's inverse CDF, or for a normal ndtri(u)·std + mean (norm.ppf's)
        ref = np.column_stack([
            m.scipy().ppf(uc[:, j]) if type(m) is not Normal
            else m.mean + m.std * special.ndtri(uc[:, j])
            for j, m in enumerate(inputs.marginals)])
    else:
        ref = inputs.from_standard_normal(special.ndtri(uc))
    assert X.tobytes() == ref.tobytes()
    assert inputs.from_unit(u).tobytes() == X.tobytes()
    assert np.array_equal(u, keep)  # from_unit leaves the caller's points as they were
    if corr is None:
        assert np.array_equal(X[:, 0], inputs.marginals[0].scipy().ppf(uc[:, 0]))


def test_from_unit_still_names_a_wrong_shape():
    with pytest.raises(StudyError, match=r"from_unit: expected shape \(n, 4\), got \(3, 2\)"):
        UncertainInputs.from_specs(MIXED).from_unit(np.full((3, 2), 0.5))


# ----------------------------------------------------------------------------- counts

def _boolean_formulas(Y, rows, ok, mu, sd, xi, col, two_sided, member):
    """The counts as Monte Carlo formed them before: an (n, k) boolean array of the event."""
    I = mu[None, :] + sd[None, :] * xi[:, col] if xi is not None else mu
    with np.errstate(invalid="ignore"):
        inside = (np.abs(Y) if two_sided else Y) <= I
    inside &= ok[:, None]
    inside = inside[rows]
    per_group = np.stack([np.all(inside[:, m], axis=1) for m in member], axis=1)
    return inside.sum(axis=0), per_group.sum(axis=0), int(per_group.all(axis=1).sum())


@pytest.mark.parametrize("seed", range(6))
def test_tally_counts_what_the_boolean_formulas_count(seed):
    rng = np.random.default_rng(seed)
    n, k = 3000, 7
    Y = rng.standard_normal((n, k)) * rng.uniform(0.5, 2.0, k)
    mu = rng.uniform(0.5, 2.0, k)
    sd = np.where(rng.random(k) < 0.3, 0.0, rng.uniform(0.0, 0.5, k))
    groups = np.array([0, 0, 0, 1, 1, 2, 2])
    xi = rng.standard_normal((n, 3)) if seed % 2 else None
    col = groups if xi is not None else np.zeros(k, dtype=int)
    # outputs exactly on the allowable (|y| = I: inside), just above it, and failed rows
    I = mu[None, :] + sd[None, :] * xi[:, col] if xi is not None else np.broadcast_to(mu, Y.shape)
    on, above = rng.random((n, k)) < 0.05, rng.random((n, k)) < 0.05
    Y[on] = (np.sign(Y) * I)[on]
    Y[above] = (np.sign(Y) * np.nextafter(I, np.inf))[above]
    ok = rng.random(n) > 0.03
    Y[~ok] = np.nan
    member = np.zeros((4, k), dtype=bool)
    member[0, :3] = member[1, 3:5] = True
    member[2, 6] = True  # one column: a cycle extreme's event
    # member[3]: no column, an event that always holds
    for rows in (ok, np.ones(n, dtype=bool)):
        for two_sided in (True, False):
            got = tally(Y, rows, ok, mu, sd, xi, col, two_sided, member)
            want = _boolean_formulas(Y, rows, ok, mu, sd, xi, col, two_sided, member)
            assert np.array_equal(got[0], want[0]) and got[0].dtype == want[0].dtype
            assert np.array_equal(got[1], want[1]) and got[2] == want[2]
    assert 0 < got[2] < n  # the events are not all empty or all full


def test_tally_takes_an_output_on_its_allowable_as_inside_and_nan_as_outside():
    Y = np.array([[1.0, -1.0], [np.nextafter(1.0, 2.0), 0.0], [np.nan, 0.0]])
    mu, sd = np.ones(2), np.zeros(2)
    member = np.ones((1, 2), dtype=bool)
    ok = np.ones(3, dtype=bool)
    k, kg, kj = tally(Y, ok, ok, mu, sd, None, np.zeros(2, int), True, member)
    assert k.tolist() == [1, 3] and kg.tolist() == [1] and kj == 1
    k, kg, kj = tally(Y, ok, ok, mu, sd, None, np.zeros(2, int), False, member)
    assert k.tolist() == [1, 3] and kj == 1  # -1 <= 1 one-sided too


def test_a_batch_row_whose_sum_overflows_is_ok_and_the_models_array_is_not_written():
    # the failed rows are found by the rows' sums (a product with ones): an overflowing sum of
    # finite entries is looked at entry by entry, and stays a success
    given = np.array([[1e308, 1e308], [1.0, np.inf], [np.nan, np.nan], [2.0, 3.0]])
    seen = []

    def f(X):
        Y = given[X[:, 0].astype(int)].copy()
        seen.append(Y)
        return Y

    model = FunctionModel(f, ["i"], ["a", "b"], key="overflow", vectorized=True)
    ev = evaluate(model, np.arange(4.0)[:, None], chunk_size=4, progress=False)
    assert ev.ok.tolist() == [True, False, False, True]
    assert ev.reasons == (None, "non-finite output (1 of 2 entries)",
                          "non-finite output (2 of 2 entries)", None)
    assert ev.Y[0].tolist() == [1e308, 1e308] and np.isnan(ev.Y[1:3]).all()
    assert seen[0][1].tolist() == [1.0, np.inf]  # the model's array as it gave it
