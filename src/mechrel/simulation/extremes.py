"""The cycle extremes: each output's largest and smallest error over the analysis window
(the last cycle of the cycle driver), found on the integrator's solution log
(docs/mechanics.md, "Cycle extremes"), and per sector of the cycle."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..errors import SimulationError
from ..mechanics.system import CompiledScene

from .times import _crank_angle

# Points of the integrator's continuous extension logged inside each step for the cycle
# extremes, beside the step's end (docs/mechanics.md, "Cycle extremes"): the four-bar's peak
# acceleration errors change by < 1e-3 (relative) from 3 to 15 points (tests/test_extremes.py).
DENSE_POINTS = 3
# Kinematic-only runs (an ideal scene against a reference design) have no steps: their extremes
# come from this many equal intervals of the window (smooth errors, error of the peak
# ~ (window / KINEMATIC_POINTS)^2 / 8 of its curvature).
KINEMATIC_POINTS = 3600
# The statistics of every output's error over the window, in SimulationResult.extremes:
# the extremes, where they occur, and how far the window's cycle is from closing on itself.
EXTREME_FIELDS = ("max", "max_time", "max_angle", "min", "min_time", "min_angle",
                  "max_abs", "max_abs_time", "max_abs_angle", "closure")

#: How far an analysed cycle may be from closing on itself before a result or a study says so:
#: the error at the cycle's end against that at its start, as a fraction of the error's span
#: over the cycle (``closure`` of :attr:`SimulationResult.extremes`,
#: :meth:`mechrel.uq.MechanismModel.cycle_closure`; docs/studies.md, "Which cycle is
#: analysed"). A periodic response closes to its residual start transient and integration
#: error: at most 3.1e-5 over 64 samples of the default study. The start transient left in a
#: one-cycle analysis misses by 1-94 % (the lubricated nine-bar and slider-crank), a dry
#: slider-crank's impacts by 1-24 % from cycle to cycle.
CLOSURE_LIMIT = 0.05


def analysis_window(compiled: CompiledScene, times: np.ndarray) -> float:
    """Start (s) of the window the cycle extremes cover: the last cycle of the cycle driver
    (one period before the last output instant), or the whole span without a cycle driver.

    Parameters
    ----------
    compiled : CompiledScene
        The compiled scene (its cycle driver and period, s).
    times : ndarray
        The output instants (s).

    Returns
    -------
    float
        The window's start (s).

    Examples
    --------
    >>> from mechrel.simulation import output_times
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-dry")  # two revolutions of 12 ms
    >>> compiled = compile_scene(scene)
    >>> round(analysis_window(compiled, output_times(scene, compiled)), 9)
    0.012
    """
    if compiled.cycle_driver < 0 or compiled.period is None:
        return float(times[0])
    return max(float(times[0]), float(times[-1]) - compiled.period)


def _window_points(times: np.ndarray, t_lo: float, extra_t: np.ndarray):
    """The output instants at or after ``t_lo`` merged with the instants ``extra_t``, sorted,
    duplicates dropped: ``(T, sel, first)`` with ``sel`` the mask of the output instants kept
    and ``first`` the positions in ``concatenate([times[sel], extra_t])`` that make ``T``
    (those of ``np.unique(..., return_index=True)``: of equal instants, the first)."""
    span = max(float(times[-1]) - t_lo, 1.0)
    sel = times >= t_lo - 1e-12 * span
    kept = times[sel]
    extra = np.ascontiguousarray(extra_t, dtype=float)
    T, first, ok = _merge_sorted(kept, extra)
    if not ok:  # not both sorted (or a NaN): the general sort
        T, first = np.unique(np.concatenate([kept, extra]), return_index=True)
    return T, sel, first


@njit(cache=True)
def _merge_sorted(a, b):
    """``np.unique(concatenate([a, b]), return_index=True)`` in one pass when ``a`` and ``b``
    are each non-decreasing and finite (the output instants and an integrator's log);
    ``ok`` False (and nothing else meaningful) otherwise."""
    na, nb = a.shape[0], b.shape[0]
    T = np.empty(na + nb)
    first = np.empty(na + nb, dtype=np.int64)
    for k in range(na):
        if not math.isfinite(a[k]) or (k > 0 and a[k] < a[k - 1]):
            return T[:0], first[:0], False
    for k in range(nb):
        if not math.isfinite(b[k]) or (k > 0 and b[k] < b[k - 1]):
            return T[:0], first[:0], False
    i = j = m = 0
    while i < na or j < nb:
        if j >= nb or (i < na and a[i] <= b[j]):  # of equal instants, a's come first
            x, at = a[i], i
        else:
            x, at = b[j], na + j
        T[m] = x
        first[m] = at
        m += 1
        while i < na and a[i] == x:
            i += 1
        while j < nb and b[j] == x:
            j += 1
    return T[:m].copy(), first[:m].copy(), True


@njit(cache=True)
def _arg_extremes(err):
    """``(finite, argmax, argmin, argmax of |err|)`` of a non-empty ``err`` in one pass: the
    indices ``np.argmax``/``np.argmin`` give (of equal values, the first); ``finite`` False,
    and the indices meaningless, when a value is not finite; ValueError for an empty ``err``
    (as ``np.argmax``)."""
    if err.shape[0] == 0:
        raise ValueError("the cycle extremes of an error at no instant")
    imax = imin = iabs = 0
    hi = lo = err[0]
    big = abs(err[0])
    for i in range(err.shape[0]):
        x = err[i]
        if not math.isfinite(x):
            return False, 0, 0, 0
        if x > hi:
            hi, imax = x, i
        if x < lo:
            lo, imin = x, i
        if abs(x) > big:
            big, iabs = abs(x), i
    return True, imax, imin, iabs


def _extremes_of(scene, compiled, T, outputs, ideal, sectors=None):
    """``({output: {quantity: {field: value}}}, sector extremes or None)`` of the error
    ``outputs − ideal`` at ``T``; with ``sectors`` (degrees), per output and quantity the
    largest and smallest error over each closed sector [k·sectors, (k + 1)·sectors] of the
    window's crank angle (:func:`_sector_extremes`)."""
    angles = _crank_angle(scene, compiled, T)
    # a window of one whole cycle of the cycle driver: its error closes on itself when the
    # response is periodic (otherwise, as for a window of another length, NaN)
    period = compiled.period
    whole = period is not None and abs(float(T[-1] - T[0]) - period) <= 1e-9 * period
    out = {}
    by_sector = {} if sectors else None
    for name, quantities in outputs.items():
        out[name] = {}
        for qty, values in quantities.items():
            err = values - ideal[name][qty]
            finite, imax, imin, iabs = _arg_extremes(err)
            if not finite:
                raise SimulationError(f"output {name}.{qty}: a non-finite error on the "
                                      "solution log (cycle extremes)")
            d = {}
            for key, i in (("max", imax), ("min", imin), ("max_abs", iabs)):
                d[key] = float(abs(err[i]) if key == "max_abs" else err[i])
                d[f"{key}_time"] = float(T[i])
                d[f"{key}_angle"] = float(angles[i]) if angles is not None else math.nan
            span = float(err[imax] - err[imin])
            d["closure"] = (math.nan if not whole else
                            abs(float(err[-1] - err[0])) / span if span > 0 else 0.0)
            out[name][qty] = {k: d[k] for k in EXTREME_FIELDS}
            if sectors:
                by_sector.setdefault(name, {})[qty] = _sector_extremes(err, angles, sectors)
    return out, by_sector


def _sector_extremes(err: np.ndarray, angles: np.ndarray, step: float):
    """``(max, min)`` of ``err`` over the closed sectors [k·step, (k + 1)·step] of the crank
    angle since the window's start (degrees), k = 0 … 360/step − 1: the whole cycle is their
    union, so the cycle's extremes are the sectors' extremes (a point on a boundary counts in
    both sectors)."""
    n = int(round(360.0 / step))
    rel = (angles - angles[0]) / step
    k = np.clip(np.floor(rel + 1e-9).astype(int), 0, n - 1)
    smax = np.full(n, -np.inf)
    smin = np.full(n, np.inf)
    np.maximum.at(smax, k, err)
    np.minimum.at(smin, k, err)
    edge = np.abs(rel - np.round(rel)) <= 1e-9
    prev = np.round(rel).astype(int) - 1
    on = edge & (prev >= 0) & (prev < n)
    np.maximum.at(smax, prev[on], err[on])
    np.minimum.at(smin, prev[on], err[on])
    if not (np.all(np.isfinite(smax)) and np.all(np.isfinite(smin))):
        raise SimulationError(f"sector extremes: a sector of {step:g}° holds no point of the "
                              "solution "
                              "log; allowed: sectors no finer than the output grid")
    return smax, smin
