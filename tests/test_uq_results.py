"""The shared shape of the per-output results (:mod:`mechrel.uq.results`): the per-angle and
cycle-extreme views, on any output table (properties) and on every per-output result."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mechrel.errors import StudyError
from mechrel.uq import (
    Allowable,
    FunctionModel,
    Normal,
    OutputViews,
    UncertainInputs,
    cycle_extremes,
    fosm,
    monte_carlo,
    normality_check,
    per_angle,
    polynomial_chaos,
    sobol_indices,
)
from mechrel.uq.problem.allowables import EXTREME_STATS, sector_label

# an output label of a mechanism model: an analysis angle (a float, or an int as a user may
# write it), a whole-cycle statistic, or a sector extreme
ANGLE = st.one_of(st.floats(0.0, 360.0, allow_nan=False), st.integers(0, 360))
SECTOR = st.builds(lambda s, lo, w: sector_label(s, lo, lo + w), st.sampled_from(["max", "min"]),
                   st.integers(0, 340), st.integers(1, 20))
LABEL = st.one_of(ANGLE, st.sampled_from(EXTREME_STATS), SECTOR)


@st.composite
def output_tables(draw):
    """A table indexed by (quantity, crank_angle) labels in any order, unique."""
    def key(t):
        return t[0], t[1] if isinstance(t[1], str) else float(t[1])

    labels = draw(st.lists(st.tuples(st.sampled_from(["displacement", "velocity"]), LABEL),
                           max_size=25, unique_by=key))
    idx = pd.MultiIndex.from_arrays([[q for q, _ in labels],
                                     pd.Index([a for _, a in labels], dtype=object)],
                                    names=["quantity", "crank_angle"])
    return pd.DataFrame({"value": np.arange(len(labels), dtype=float)}, index=idx)


@settings(max_examples=200, deadline=None)
@given(output_tables())
def test_the_two_views_partition_the_table_in_order(table):
    a, e = per_angle(table), cycle_extremes(table)
    assert len(a) + len(e) == len(table)
    # every row once, in the table's order: the values are the row numbers
    assert sorted(a["value"].tolist() + e["value"].tolist()) == table["value"].tolist()
    assert a["value"].is_monotonic_increasing and e["value"].is_monotonic_increasing
    # angles are floats equal to the labels; the extremes are the string labels, level renamed
    assert a.index.get_level_values("crank_angle").dtype == np.float64
    orig = table.index.get_level_values("crank_angle")
    by_value = dict(zip(table["value"], orig))
    assert [float(by_value[v]) for v in a["value"]] == \
        a.index.get_level_values("crank_angle").tolist()
    assert list(e.index.names) == ["quantity", "statistic"]
    assert all(isinstance(s, str) for s in e.index.get_level_values("statistic"))
    assert a.index.get_level_values("quantity").tolist() == \
        [table.index[int(v)][0] for v in a["value"]]
    # the input is not changed
    assert table.index.get_level_values("crank_angle").dtype == object


@settings(max_examples=100, deadline=None)
@given(output_tables())
def test_without_sectors_the_extremes_are_the_whole_cycle_statistics(table):
    e, whole = cycle_extremes(table), cycle_extremes(table, sectors=False)
    assert set(whole.index.get_level_values("statistic")) <= set(EXTREME_STATS)
    assert set(whole["value"]) <= set(e["value"])
    dropped = e[~e["value"].isin(whole["value"])]
    assert all(s not in EXTREME_STATS for s in dropped.index.get_level_values("statistic"))


def test_a_series_and_an_index_without_angles():
    idx = pd.MultiIndex.from_tuples([("v", 0.0), ("v", "max")], names=["quantity", "crank_angle"])
    s = pd.Series([1.0, 2.0], index=idx, name="x")
    assert per_angle(s).tolist() == [1.0] and per_angle(s).name == "x"
    assert cycle_extremes(s).index.tolist() == [("v", "max")]
    # no crank_angle level: nothing to separate, every row is kept by per_angle
    flat = pd.DataFrame({"mean": [1.0, 2.0]}, index=pd.Index(["y1", "y2"], name="output"))
    pd.testing.assert_frame_equal(per_angle(flat), flat)
    assert cycle_extremes(flat).empty and list(cycle_extremes(flat).columns) == ["mean"]
    # an empty per-angle part keeps the level names
    idx = pd.MultiIndex.from_tuples([("v", "max_abs")], names=["quantity", "crank_angle"])
    only = pd.DataFrame({"m": [1.0]}, index=idx)
    assert per_angle(only).empty and per_angle(only).index.names == ["quantity", "crank_angle"]


@pytest.mark.parametrize("view", [per_angle, cycle_extremes])
def test_a_wrong_argument_is_named(view):
    with pytest.raises(StudyError, match=rf"^{view.__name__}: got ndarray; allowed: a pandas "
                                         "DataFrame or Series"):
        view(np.zeros(3))


# ------------------------------------------------------------------- on every per-output result
IDX = pd.MultiIndex.from_tuples([("velocity", 0.0), ("velocity", 90.0), ("velocity", "max"),
                                 ("velocity", "max_abs")], names=["quantity", "crank_angle"])
INPUTS = UncertainInputs.from_specs({"a": Normal(1.0, 0.1), "b": Normal(2.0, 0.1)})


def _f(X):
    y0, y1 = X[:, 0] + 0.5 * X[:, 1], X[:, 0] * X[:, 1]
    return np.column_stack([y0, y1, np.maximum(y0, y1), np.maximum(np.abs(y0), np.abs(y1))])


MODEL = FunctionModel(_f, ["a", "b"], IDX, vectorized=True)
ALLOW = Allowable(3.0, 0.1)


def _results():
    f = fosm(model=MODEL, inputs=INPUTS, allowable=ALLOW, progress=False)
    mc = monte_carlo(model=MODEL, inputs=INPUTS, n=256, seed=1, allowable=ALLOW, progress=False)
    return {
        "fosm": f, "monte_carlo": mc,
        "pce": polynomial_chaos(model=MODEL, inputs=INPUTS, order=2, seed=1, progress=False),
        "sobol": sobol_indices(model=MODEL, inputs=INPUTS, n=64, seed=1, progress=False),
        "normality": normality_check(fosm=f, monte_carlo=mc),
    }


@pytest.fixture(scope="module")
def results():
    with pytest.warns():  # FOSM's and the normality check's caveats at the extremes
        return _results()


@pytest.mark.parametrize("key", ["fosm", "monte_carlo", "pce", "sobol", "normality"])
def test_every_per_output_result_has_the_views(results, key):
    r = results[key]
    assert isinstance(r, OutputViews)
    t, a, e = r.to_frame(), r.per_angle(), r.cycle_extremes()
    assert len(a) + len(e) == len(t)
    assert a.index.get_level_values("crank_angle").dtype == np.float64
    assert set(a.index.get_level_values("crank_angle")) == {0.0, 90.0}
    assert set(e.index.get_level_values("statistic")) == {"max", "max_abs"}
    # the same numbers as the table's rows, in order
    mask = np.array([not isinstance(x, str) for x in t.index.get_level_values("crank_angle")])
    for view, rows in ((a, t[mask]), (e, t[~mask])):
        pd.testing.assert_frame_equal(view.reset_index(drop=True), rows.reset_index(drop=True))
    if key == "sobol":  # the long table keeps its input level
        assert a.index.names == ["quantity", "crank_angle", "input"]


def test_monte_carlos_max_abs_row_is_its_whole_cycle_estimate(results):
    mc = results["monte_carlo"]
    row = mc.cycle_extremes().loc[("velocity", "max_abs")]
    assert row["reliability"] == mc.whole_cycle.loc["velocity", "reliability"]


# --------------------------------------------------------------------- one vocabulary, old names
def test_the_tables_speak_one_vocabulary(results):
    cols = {k: set(r.to_frame().columns) for k, r in results.items()}
    for k in ("fosm", "monte_carlo", "pce"):
        assert {"mean", "std"} <= cols[k], k
    for k in ("fosm", "monte_carlo"):
        assert {"allowable_mean", "allowable_std"} <= cols[k], k
    assert {"mean_lo", "mean_hi", "std_lo", "std_hi", "reliability_lo", "reliability_hi"} \
        <= cols["monte_carlo"]
    assert {"fosm_mean", "fosm_std", "mc_mean", "mc_std"} <= cols["normality"]
    old = {"mu_i", "sigma_i", "mu_I", "sigma_I", "mu_g", "sigma_g"}
    assert not any(old & c for c in cols.values())


@pytest.mark.parametrize("key, old, new", [
    ("fosm", "mu_i", "mean"), ("fosm", "sigma_i", "std"), ("fosm", "mu_I", "allowable_mean"),
    ("fosm", "sigma_I", "allowable_std"), ("monte_carlo", "mu_I", "allowable_mean"),
    ("monte_carlo", "sigma_I", "allowable_std"), ("normality", "mu_i", "fosm_mean"),
    ("normality", "sigma_i", "fosm_std"),
])
def test_an_old_column_name_reads_the_new_column_with_a_warning(results, key, old, new):
    r = results[key]
    message = rf"^column '{old}' is renamed '{new}'; the old name goes in the release after 0\.1$"
    for table in (r.table, r.to_frame(), r.per_angle()):
        want = table[new]
        with pytest.warns(FutureWarning, match=message):
            pd.testing.assert_series_equal(table[old], want)
        with pytest.warns(FutureWarning, match=message):
            both = table[[old, "flag" if key == "normality" else "n" if key == "monte_carlo"
                          else "beta"]]
        pd.testing.assert_series_equal(both.iloc[:, 0], want)
        with pytest.warns(FutureWarning, match=message):
            pd.testing.assert_series_equal(table.loc[:, old], want)
        with pytest.warns(FutureWarning, match=message):
            pd.testing.assert_series_equal(table.loc[table.index[1:], old], want.iloc[1:])
        with pytest.warns(FutureWarning, match=message):
            pd.testing.assert_series_equal(getattr(table, old), want)
        assert old not in table.columns and old not in table


def test_the_new_names_and_unknown_names_behave_as_in_pandas(results):
    import warnings

    t = results["fosm"].table
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning for the new names or other columns
        t["mean"], t[["std", "beta"]], t.loc[:, "reliability"], t.beta  # noqa: B018
        t.loc[t.index[0]]  # noqa: B018 - a row key is not a column
    with pytest.raises(KeyError, match="mu_x"):
        t["mu_x"]  # noqa: B018
    with pytest.raises(AttributeError, match="mu_x"):
        t.mu_x  # noqa: B018


def test_the_limit_state_table_of_fosm_reads_its_old_names():
    from mechrel.uq import LimitState

    inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
    g = FunctionModel(lambda X: 3.0 - X[:, 0] - X[:, 1], ["x1", "x2"], ["g"], vectorized=True)
    r = fosm(model=g, inputs=inputs, limit_state=LimitState.margin(), progress=False)
    t = r.to_frame()
    assert t["mean"].iloc[0] == 3.0 and t["std"].iloc[0] == pytest.approx(2**0.5, rel=1e-9)
    with pytest.warns(FutureWarning, match="column 'mu_g' is renamed 'mean'"):
        assert t["mu_g"].iloc[0] == 3.0
    with pytest.warns(FutureWarning, match="column 'sigma_g' is renamed 'std'"):
        assert t["sigma_g"].iloc[0] == t["std"].iloc[0]


# ------------------------------------------------------------------- one result type per function
def _limit_state_runs():
    from mechrel.uq import LimitState

    inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    model = FunctionModel(lambda X: X[:, 0], ["x"], ["y"], vectorized=True)
    ls = LimitState.exceedance(["y"], 2.0, kind="upper")
    return (fosm(model=model, inputs=inputs, limit_state=ls, progress=False),
            monte_carlo(model=model, inputs=inputs, limit_state=ls, n=512, seed=1,
                        progress=False))


def test_fosm_and_monte_carlo_return_one_type_whatever_the_failure_definition(results):
    from mechrel.uq import FOSMResult, MonteCarloResult

    f_ls, mc_ls = _limit_state_runs()
    assert type(results["fosm"]) is type(f_ls) is FOSMResult
    assert type(results["monte_carlo"]) is type(mc_ls) is MonteCarloResult
    # the limit state's part is pf_table; the per-output part is table; one of them is None
    for per_output, on_g in ((results["fosm"], f_ls), (results["monte_carlo"], mc_ls)):
        assert per_output.pf_table is None and on_g.table is None
        pd.testing.assert_frame_equal(on_g.to_frame(), on_g.pf_table)
        assert on_g.pf == on_g.pf_table["pf"].iloc[0] and on_g.beta == on_g.pf_table["beta"].iloc[0]
        with pytest.raises(StudyError, match=r"\.pf: the result was run with allowable= .*"
                                             r"allowed: limit_state="):
            per_output.pf  # noqa: B018
        with pytest.raises(StudyError, match=r"run with limit_state=, it has no per-output table"):
            on_g.per_angle()
    assert f_ls.pf == pytest.approx(0.022750131948179195, rel=1e-9)  # Φ(−2), exact for linear g
    assert mc_ls.cov == mc_ls.pf_table["cov"].iloc[0]


def test_a_limit_state_result_is_refused_where_outputs_are_needed():
    from mechrel.uq.plots import plot_reliability

    f_ls, mc_ls = _limit_state_runs()
    with pytest.raises(StudyError, match=r"^normality_check: fosm= was run with limit_state="):
        normality_check(fosm=f_ls, monte_carlo=mc_ls)
    with pytest.raises(StudyError, match=r"^plot_reliability: a FOSMResult run with limit_state="):
        plot_reliability(f_ls)


@pytest.mark.parametrize("old, new", [("FOSMPfResult", "FOSMResult"),
                                      ("MonteCarloPfResult", "MonteCarloResult")])
def test_the_old_result_names_are_deprecated_aliases(old, new):
    import mechrel.uq as uq

    with pytest.warns(FutureWarning, match=rf"^mechrel\.uq\.{old} is {new} .*pf_table"):
        alias = getattr(uq, old)
    assert alias is getattr(uq, new)
    assert old not in uq.__all__
    f_ls, mc_ls = _limit_state_runs()
    assert isinstance(f_ls if new == "FOSMResult" else mc_ls, alias)  # isinstance checks hold


def test_the_whole_cycle_estimates_read_a_limit_state_result():
    from mechrel.study.rare import whole_cycle_estimates

    f_ls, mc_ls = _limit_state_runs()
    est = whole_cycle_estimates({"fosm": f_ls, "mc": mc_ls}).set_index("method")
    assert est.loc["fosm", "pf"] == f_ls.pf and est.loc["fosm", "kind"] == "approximation"
    assert est.loc["mc", "pf"] == mc_ls.pf and est.loc["mc", "kind"] == "sampling"
    assert est.loc["mc", "pf_lo"] == mc_ls.pf_table["pf_lo"].iloc[0]
