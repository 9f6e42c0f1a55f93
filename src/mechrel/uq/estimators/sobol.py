"""Variance-based (Sobol') sensitivity indices with SALib (Saltelli sampling + Sobol' analysis).

Design: ``SALib.sample.sobol.sample`` on the unit hypercube (scrambled Sobol' sequence, seeded),
mapped column-wise through the marginal inverse CDFs, so any marginal of
:class:`~mechrel.uq.problem.inputs.UncertainInputs` works. The inputs must be independent: Sobol'
indices of correlated inputs are not the classical decomposition (``StudyError`` otherwise).
Rows come in blocks, one per base sample: ``A, AB_1 … AB_d, [BA_1 … BA_d,] B`` (``d + 2`` rows,
``2d + 2`` with second order); ``N`` blocks in total.

Analysis: ``SALib.analyze.sobol.analyze`` per output (first order: Saltelli 2010; total:
Jansen), with bootstrap confidence intervals (``num_resamples``, ``confidence_level``; the
``*_conf`` columns are half-widths). SALib's bootstrap is seeded from ``seed``.

Failed samples
--------------
A Saltelli block is only usable whole (every estimator combines A, B and AB_j of the same base
sample). A block containing a failed row (model failure, or a non-finite reduced output) is
dropped entirely; the number of dropped blocks and the failure reasons are reported in the
result. If more than ``max_failure_fraction`` of the blocks would be dropped the analysis
refuses: dropping blocks conditions the design on "the model works", which biases the indices
when failures depend on the inputs — only acceptable when rare. The refusal (also when fewer
than 2 complete blocks remain) is a :class:`~mechrel.uq.SampleFailuresError`, a
``StudyError`` that carries the raw evaluations.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from mechrel.errors import StudyError

from .._docs import fill_doc
from ..._checks import ARGS
from .._common import (
    CountedByProvenance,
    SampleFailuresError,
    check_inputs,
    check_memory,
    emit_warnings,
    exclusive_source,
    executor_kwargs,
    failure_message,
    make_provenance,
    run,
)
from ..execution.executor import Evaluations
from ..problem.inputs import UncertainInputs, as_seed_sequence, child_seed, seed_record
from ..problem.model import check_model
from ..results import OutputViews

__all__ = ["sobol_design", "sobol_indices", "SobolResult", "peak_abs"]


def peak_abs(Y: np.ndarray, index: pd.Index, level: str = "quantity"):
    """Reducer: peak |error| over the cycle, one scalar per ``quantity``.

    Use with ``sobol_indices(reducer=peak_abs)`` or ``Evaluations.reduce(peak_abs)``. When the
    outputs include the cycle extremes (``max_abs`` in the ``crank_angle`` level, found on the
    integrator's solution), that is the peak; otherwise the largest |error| at the analysis
    angles. Without a ``level`` level in the index: the peak over all outputs.

    Parameters
    ----------
    Y : ndarray, shape (n, n_out)
        Outputs, one row per sample.
    index : pandas.Index
        The outputs' labels.
    level : str, default "quantity"
        The index level grouping the outputs.

    Returns
    -------
    Y_reduced : ndarray, shape (n, n_groups)
        The peak |error| per group.
    index : pandas.Index
        Its labels, ``peak_abs_QUANTITY`` (``peak_abs`` without groups).

    Examples
    --------
    >>> import numpy as np
    >>> import pandas as pd
    >>> from mechrel.uq import peak_abs
    >>> idx = pd.MultiIndex.from_tuples([("velocity", 0.0), ("velocity", 90.0)],
    ...                                 names=["quantity", "crank_angle"])
    >>> Y, labels = peak_abs(np.array([[0.1, -0.3], [0.2, 0.1]]), idx)
    >>> Y.tolist(), list(labels)
    ([[0.3], [0.2]], ['peak_abs_velocity'])
    """
    from ..problem.allowables import per_angle_mask, whole_cycle_column

    if isinstance(index, pd.MultiIndex) and level in index.names:
        labels = np.asarray(index.get_level_values(level))
        angle = per_angle_mask(index)
        uniq = list(dict.fromkeys(labels.tolist()))
        cols = []
        for u in uniq:
            col = whole_cycle_column(index, str(u), "two-sided") if level == "quantity" else None
            cols.append(np.abs(Y[:, col]) if col is not None else
                        np.max(np.abs(Y[:, (labels == u) & angle]), axis=1))
        return np.column_stack(cols), pd.Index([f"peak_abs_{u}" for u in uniq], name="output")
    return np.max(np.abs(Y), axis=1)[:, None], pd.Index(["peak_abs"], name="output")


def _problem(d: int, names) -> dict:
    return {"num_vars": d, "names": list(names), "bounds": [[0.0, 1.0]] * d}


def _block_size(d: int, calc_second_order: bool) -> int:
    return 2 * d + 2 if calc_second_order else d + 2


def sobol_design(inputs: UncertainInputs, *, n: int, calc_second_order: bool = False, seed: Any = None) -> np.ndarray:
    """Saltelli design ((d + 2)·n rows, or (2d + 2)·n with second order) for ``inputs``.

    ``n`` is SALib's N (base samples; a power of 2 keeps the Sobol' sequence balanced).

    Parameters
    ----------
    inputs : UncertainInputs
        Independent uncertain inputs.
    n : int
        Base samples, an integer >= 2.
    calc_second_order : bool, default False
        Also the blocks of the second-order indices.
    seed : int >= 0, SeedSequence or None
        The study's seed (the same one passed to :func:`sobol_indices`).

    Returns
    -------
    ndarray
        The design, in the inputs' units.

    Raises
    ------
    StudyError
        Correlated inputs, or a bad ``n``.

    Examples
    --------
    >>> from mechrel.uq import Normal, UncertainInputs
    >>> u = UncertainInputs.from_specs({"a": Normal(1.0, 0.1), "b": Normal(2.0, 0.2)})
    >>> sobol_design(u, n=8, seed=1).shape  # (d + 2) n rows
    (32, 2)
    """
    from SALib.sample import sobol as sobol_sample

    inputs = check_inputs(inputs, None)
    if not inputs.independent:
        raise StudyError(
            "sobol_indices: the inputs are correlated; classical Sobol' indices need independent "
            "inputs (remove the correlation, or study the correlated group as one factor)"
        )
    n = ARGS.sample_count("n", n)
    check_memory(n * _block_size(inputs.d, calc_second_order), inputs.d, "n", n)
    ss = as_seed_sequence(seed)
    U = sobol_sample.sample(_problem(inputs.d, inputs.names), n, calc_second_order=calc_second_order,
                            scramble=True, seed=np.random.default_rng(child_seed(ss, 0)))
    return inputs.from_unit(U)


@dataclass(frozen=True, eq=False)
class SobolResult(OutputViews, CountedByProvenance):
    """Sobol' indices (frozen). DataFrames are outputs × inputs; ``*_conf`` are CI half-widths.

    Parameters
    ----------
    first, first_conf : DataFrame
        First-order indices S1 and their confidence half-widths.
    total, total_conf : DataFrame
        Total-order indices ST and their confidence half-widths.
    second : dict or None
        Second-order indices per output (when computed).
    n_base : int
        Saltelli base samples N (N (d + 2) model runs, N (2d + 2) with second order).
    n_blocks_used, n_blocks_dropped : int
        Saltelli blocks analysed, and dropped because a sample of theirs failed.
    failure_counts : dict
        ``{reason: count}`` of the failed samples.
    evaluations : Evaluations
        The model runs.
    provenance : dict
        How the result was made.
    warnings : tuple of str
        Caveats of the estimate.

    Examples
    --------
    >>> from mechrel.uq import Normal, UncertainInputs, linear_model, sobol_indices
    >>> inputs = UncertainInputs.from_specs({"a": Normal(0.0, 1.0), "b": Normal(0.0, 1.0)})
    >>> r = sobol_indices(model=linear_model([0.0], [[1.0, 2.0]], ["a", "b"]), inputs=inputs,
    ...                   n=256, seed=1, progress=False)
    >>> list(r.total.columns), r.n_base, r.evaluations.n  # n (d + 2) runs
    (['a', 'b'], 256, 1024)
    """

    first: pd.DataFrame
    first_conf: pd.DataFrame
    total: pd.DataFrame
    total_conf: pd.DataFrame
    second: dict | None
    n_base: int
    n_blocks_used: int
    n_blocks_dropped: int
    failure_counts: dict
    evaluations: Evaluations
    provenance: dict = field(repr=False)
    warnings: tuple[str, ...] = ()

    def to_frame(self) -> pd.DataFrame:
        """A long table of the indices.

        Returns
        -------
        pandas.DataFrame
            Indexed by (output…, input); columns ``S1``, ``S1_conf``, ``ST``, ``ST_conf``
            (dimensionless; ``_conf`` the half-widths of the bootstrap confidence intervals).

        Examples
        --------
        For y = a + 2 b with independent standard normals, S1 = ST = (1/5, 4/5):

        >>> from mechrel.uq import Normal, UncertainInputs, linear_model
        >>> inputs = UncertainInputs.from_specs({"a": Normal(0.0, 1.0), "b": Normal(0.0, 1.0)})
        >>> r = sobol_indices(model=linear_model([0.0], [[1.0, 2.0]], ["a", "b"]), inputs=inputs,
        ...                   n=1024, seed=1, progress=False)
        >>> df = r.to_frame()
        >>> list(df.columns), bool(abs(df["ST"].iloc[1] - 0.8) < 0.05)
        (['S1', 'S1_conf', 'ST', 'ST_conf'], True)
        """
        parts = {}
        for col, df in (("S1", self.first), ("S1_conf", self.first_conf), ("ST", self.total), ("ST_conf", self.total_conf)):
            parts[col] = df.stack()
        out = pd.DataFrame(parts)
        names = list(self.first.index.names) + ["input"]
        out.index = out.index.set_names(names)
        return out


def _check_saltelli(X: np.ndarray, d: int, step: int) -> None:
    if X.shape[0] % step:
        raise StudyError(
            f"sobol_indices: evaluations have {X.shape[0]} rows, not a multiple of the Saltelli block "
            f"size {step}; evaluate sobol_design(...) with the same calc_second_order"
        )
    blocks = X.reshape(-1, step, d)
    A, B = blocks[:, 0, :], blocks[:, -1, :]
    for j in range(d):
        ab = blocks[:, 1 + j, :]
        expect = A.copy()
        expect[:, j] = B[:, j]
        if not np.array_equal(ab, expect):
            raise StudyError(
                "sobol_indices: evaluations.X is not a Saltelli design in SALib's block order "
                "(A, AB_1..AB_d, [BA_1..BA_d], B); evaluate sobol_design(...) unchanged"
            )


@fill_doc
def sobol_indices(
    *,
    model: Any = None,
    inputs: UncertainInputs,
    n: int | None = None,
    evaluations: Evaluations | None = None,
    outputs: Any = None,
    reducer: Callable | None = None,
    calc_second_order: bool = False,
    num_resamples: int = 100,
    confidence_level: float = 0.95,
    seed: Any = None,
    max_failure_fraction: float = 0.05,
    n_jobs: int = 1,
    backend: str = "loky",
    cache: Any = None,
    progress: bool = True,
    chunk_size: int | None = None,
) -> SobolResult:
    """First- and total-order Sobol' indices per output (SALib), with bootstrap intervals.

    ``model=`` evaluates ``sobol_design(inputs, n=n, calc_second_order=..., seed=seed)``
    (``n`` base samples, default 2¹³); ``evaluations=`` analyses a precomputed one (checked to
    be a Saltelli design; ``n``, if given, must match it).
    ``outputs`` selects outputs (labels, mask or positions) and/or ``reducer`` maps the outputs
    to scalar measures first (e.g. :func:`peak_abs`, the peak |error| per quantity).

    Parameters
    ----------
    model : Model, optional
        The model evaluated at the Saltelli design (exclusive with ``evaluations``).
    inputs : UncertainInputs
        The uncertain inputs; they must be independent.
    n : int, optional
        Base samples, an integer >= 2 (a power of 2 keeps the Sobol' sequence balanced);
        n (d + 2) model runs.
    evaluations : Evaluations, optional
        Precomputed evaluations of :func:`sobol_design`.
    outputs : labels, mask or positions, optional
        The outputs analysed (default: all).
    reducer : callable, optional
        ``reducer(Y, output_index) -> (Y', index')``: scalar measures analysed instead.
    calc_second_order : bool, default False
        Also the second-order indices (n (2d + 2) runs).
    num_resamples : int >= 2, default 100
        Bootstrap resamples of the intervals.
    confidence_level : float in (0, 1), default 0.95
        Of the bootstrap intervals.
    seed : int >= 0, SeedSequence or None
        The study's seed.
    max_failure_fraction : float in [0, 1], default 0.05
        Refuse above this fraction of failed Saltelli blocks.
    %(executor)s

    Returns
    -------
    SobolResult
        S1, ST (and S2) with their interval half-widths; ``.to_frame()``.

    Raises
    ------
    StudyError
        A bad argument, correlated inputs, or evaluations that are not a Saltelli design.
    SampleFailuresError
        Too many failed blocks.

    Examples
    --------
    y = a + 2 b with independent standard normal a, b: the variance shares are 1/5 and 4/5,
    first and total indices alike (an additive model):

    >>> from mechrel.uq import Normal, UncertainInputs, linear_model, sobol_indices
    >>> inputs = UncertainInputs.from_specs({"a": Normal(0.0, 1.0), "b": Normal(0.0, 1.0)})
    >>> r = sobol_indices(model=linear_model([0.0], [[1.0, 2.0]], ["a", "b"]), inputs=inputs,
    ...                   n=1024, seed=1, progress=False)
    >>> t = r.to_frame()
    >>> bool(abs(t["ST"].iloc[1] - 0.8) < 3 * t["ST_conf"].iloc[1])
    True
    """
    from SALib.analyze import sobol as sobol_analyze

    t0 = time.perf_counter()
    exclusive_source(model, evaluations, what="sobol_indices")
    if model is not None:
        names = check_model(model)[0]
    else:
        assert evaluations is not None  # exclusive_source: exactly one
        names = evaluations.input_names
    inputs = check_inputs(inputs, names)
    ARGS.fraction("confidence_level", confidence_level, open_lo=True, open_hi=True)
    ARGS.fraction("max_failure_fraction", max_failure_fraction)
    num_resamples = ARGS.integer("num_resamples", num_resamples, ge=2)
    ss = as_seed_sequence(seed)
    d = inputs.d
    step = _block_size(d, calc_second_order)
    if model is not None:
        X = sobol_design(inputs, n=2**13 if n is None else n, calc_second_order=calc_second_order, seed=ss)
        ev = run(model, X, executor_kwargs(n_jobs, backend, cache, progress, chunk_size))
    else:
        if not inputs.independent:
            raise StudyError("sobol_indices: the inputs are correlated; classical Sobol' indices need independent inputs")
        assert evaluations is not None  # exclusive_source: exactly one
        ev = evaluations
        _check_saltelli(ev.X, d, step)
        if n is not None and ev.n != n * step:
            raise StudyError(
                f"sobol_indices: n={n} base samples need {n * step} rows, evaluations have {ev.n} "
                f"({ev.n // step} blocks); pass n=None or the n used for sobol_design"
            )
    raw = ev
    if outputs is not None:
        ev = ev.select_outputs(outputs)
    if reducer is not None:
        ev = ev.reduce(reducer)
    n_blocks = ev.n // step
    block_ok = ev.ok.reshape(n_blocks, step).all(axis=1)
    n_drop = int((~block_ok).sum())
    if n_drop > max_failure_fraction * n_blocks:
        raise SampleFailuresError(
            f"sobol_indices: {n_drop} of {n_blocks} Saltelli blocks contain a failed sample "
            f"({failure_message(ev)}), more than max_failure_fraction={max_failure_fraction}; "
            "dropping them would bias the indices. Fix the failing region or narrow the inputs.", raw
        )
    n_used = n_blocks - n_drop
    if n_used < 2:
        raise SampleFailuresError(f"sobol_indices: need at least 2 complete Saltelli blocks, got {n_used}"
                                  + (f" ({failure_message(ev)})" if ev.n_failed else ""), raw)
    keep_rows = np.repeat(block_ok, step)
    Y = ev.Y[keep_rows]
    problem = _problem(d, inputs.names)
    analyze_seed = int(child_seed(ss, 1).generate_state(1)[0]) + 1  # SALib ignores seed 0
    res = {k: np.full((Y.shape[1], d), np.nan) for k in ("S1", "S1_conf", "ST", "ST_conf")}
    second: dict[str, list] | None = {"S2": [], "S2_conf": []} if calc_second_order else None
    constant = []
    for k in range(Y.shape[1]):
        y = Y[:, k]
        if np.ptp(y) == 0:
            constant.append(str(ev.output_index[k]))
            continue  # constant output: zero variance, indices undefined (NaN, listed in provenance)
        r = sobol_analyze.analyze(problem, y, calc_second_order=calc_second_order, num_resamples=num_resamples,
                                  conf_level=confidence_level, print_to_console=False, seed=analyze_seed)
        for key in res:
            res[key][k] = r[key]
        if second is not None:
            second["S2"].append(pd.DataFrame(r["S2"], index=list(inputs.names), columns=list(inputs.names)))
            second["S2_conf"].append(pd.DataFrame(r["S2_conf"], index=list(inputs.names), columns=list(inputs.names)))
    frames = {key: pd.DataFrame(v, index=ev.output_index, columns=pd.Index(list(inputs.names), name="input"))
              for key, v in res.items()}
    prov = make_provenance(
        method="sobol_indices", seed=seed_record(ss), evaluations=[raw], inputs=inputs,
        wall_time=time.perf_counter() - t0,
        settings={"n_base": ev.n // step, "calc_second_order": calc_second_order, "num_resamples": num_resamples,
                  "confidence_level": confidence_level, "estimators": "SALib: first order Saltelli 2010, total Jansen",
                  "outputs": None if outputs is None else repr(outputs),
                  "reducer": None if reducer is None else getattr(reducer, "__name__", repr(reducer)),
                  "failure_strategy": "drop whole Saltelli blocks with a failed sample",
                  "n_blocks_dropped": n_drop, "max_failure_fraction": max_failure_fraction,
                  "constant_outputs": constant},
    )
    notes = emit_warnings(sobol_warnings(frames, n_used))
    return SobolResult(frames["S1"], frames["S1_conf"], frames["ST"], frames["ST_conf"], second,
                       n_blocks, n_used, n_drop, ev.failure_counts(), raw, prov, notes)


CONF_LIMIT = 0.1
"""Largest half-width of a Sobol' index's confidence interval at which the sample size counts
as sufficient: indices are fractions of the variance in [0, 1], and an interval wider than
±0.1 cannot rank inputs whose shares differ by less than that."""


def sobol_warnings(frames: dict, n_blocks: int) -> list[str]:
    """Indices outside [0, 1] by more than their confidence half-width (the estimator has not
    converged), and intervals wider than ±:data:`CONF_LIMIT` (too few samples)."""
    out = []
    for key, name in (("S1", "first-order"), ("ST", "total")):
        v = frames[key].to_numpy()
        c = np.abs(frames[key + "_conf"].to_numpy())
        outside = np.isfinite(v) & ((v < -c) | (v > 1 + c))
        if outside.any():
            i, j = np.argwhere(outside)[0]
            out.append(f"sobol: {int(outside.sum())} {name} indices lie outside [0, 1] by more "
                       f"than their confidence interval (e.g. {frames[key].columns[j]} on "
                       f"{frames[key].index[i]}: {v[i, j]:.3f} ± {c[i, j]:.3f}): the estimator "
                       f"has not converged at N = {n_blocks}; raise N")
        wide = np.isfinite(c) & (c > CONF_LIMIT)
        if wide.any():
            out.append(f"sobol: {int(wide.sum())} {name} indices have a confidence half-width "
                       f"above {CONF_LIMIT:g} (max {np.nanmax(c):.3f}) at N = {n_blocks}: too "
                       "few samples to rank the inputs; raise N (the width falls as 1/sqrt(N))")
    return out
