"""Figures of the uncertainty results (matplotlib; every function returns the Figure).

One panel per output ``quantity`` (their units differ), crank angle in degrees on the x axis
when the output index has a ``crank_angle`` level (the output position otherwise).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from mechrel.errors import StudyError
from mechrel.outputs import QUANTITY_INFO

__all__ = ["plot_reliability", "reliability_panels", "plot_qq", "plot_sobol", "plot_whole_cycle",
           "plot_design_points"]

# SI unit of every quantity, from the output kinds' table
UNITS = {name: q.unit for name, q in QUANTITY_INFO.items()}


def _plt():
    import matplotlib.pyplot as plt

    return plt


def _panels(index: pd.Index) -> list[tuple[str, np.ndarray]]:
    """[(quantity label, positions)] — one panel per quantity, or one for everything; the
    positions of the analysis angles only (not the cycle extremes)."""
    from .problem.allowables import per_angle_mask

    angle = per_angle_mask(index)
    if isinstance(index, pd.MultiIndex) and "quantity" in index.names:
        q = np.asarray(index.get_level_values("quantity").astype(str))
        return [(u, np.flatnonzero((q == u) & angle)) for u in dict.fromkeys(q.tolist())]
    return [("", np.flatnonzero(angle))]


def _xvalues(index: pd.Index, pos: np.ndarray) -> tuple[np.ndarray, str]:
    if isinstance(index, pd.MultiIndex) and "crank_angle" in index.names:
        # only the analysis angles are numbers (the cycle extremes are labelled by name)
        angles = np.asarray(index.get_level_values("crank_angle"), dtype=object)[pos]
        return angles.astype(float), "crank angle (deg)"
    if not isinstance(index, pd.MultiIndex) and index.dtype.kind in "if":
        return np.asarray(index, dtype=float)[pos], str(index.name or "output")
    return np.arange(len(pos), dtype=float), "output"


def _new_axes(n: int, axes: Any, height: float = 3.0):
    plt = _plt()
    if axes is None:
        fig, axs = plt.subplots(n, 1, figsize=(7.5, height * n), sharex=True, squeeze=False)
        return fig, list(axs[:, 0])
    axs = list(np.atleast_1d(axes))
    if len(axs) != n:
        raise StudyError(f"axes: need {n} axes (one per quantity), got {len(axs)}")
    return axs[0].figure, axs


CLIP = 1e-7
"""Smallest probability of exceeding the allowable drawn on the log axis (and largest index,
Φ⁻¹(1 − CLIP) ≈ 5.2): values beyond it, R = 1 to double precision among them, are drawn at the
edge with an open marker and labelled as clipped, not as data."""


def _kind(result: Any) -> str:
    from .estimators.fosm import FOSMResult
    from .estimators.monte_carlo import MonteCarloResult

    if isinstance(result, (FOSMResult, MonteCarloResult)) and result.table is None:
        raise StudyError(f"plot_reliability: a {type(result).__name__} run with limit_state= has one "
                         "P_f, no reliability per output; allowed: results run with allowable=")
    if isinstance(result, FOSMResult):
        return "fosm"
    if isinstance(result, MonteCarloResult):
        return "surrogate" if "surrogate" in result.provenance else "mc"
    raise StudyError(f"plot_reliability: expected FOSMResult or MonteCarloResult results, got "
                     f"{type(result).__name__}")


def reliability_panels(ax_beta: Any, ax_pf: Any, x: np.ndarray, *, fosm: Any = None,
                       mc: Any = None, surrogate: Any = None, allowable: Any = None,
                       whole_cycle: Any = None, clip: float = CLIP) -> None:
    """Draw one quantity's reliability on two axes.

    The index β = Φ⁻¹(R) on ``ax_beta`` and the probability of exceeding the allowable 1 − R on a
    log scale on ``ax_pf``. Values beyond ``clip`` are drawn at the edge with open markers and
    say so; both axes get a legend.

    Parameters
    ----------
    ax_beta, ax_pf : matplotlib.axes.Axes or None
        The axes of β and of 1 − R; either may be None to skip it.
    x : ndarray
        The abscissae (crank angles in degrees, or output positions).
    fosm : tuple, optional
        ``(R, label)`` of FOSM.
    mc : tuple, optional
        ``(R, R_lo, R_hi, n, confidence_level)`` of Monte Carlo.
    surrogate : tuple, optional
        ``(R, label)`` of Monte Carlo on a surrogate.
    allowable : tuple, optional
        ``(mu_I, sigma_I)``, drawn as the cap Φ(μ_I/σ_I) that no design reaches (R of a zero
        error, σ_I > 0) and named in the legend (the quantity's unit).
    whole_cycle : tuple, optional
        ``(R, lo, hi)`` of the whole cycle.
    clip : float, default CLIP
        The smallest probability drawn on the log axis.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> fig, (a, b) = plt.subplots(1, 2)
    >>> reliability_panels(a, b, np.array([0.0, 90.0]), fosm=(np.array([0.9, 0.99]), "FOSM"))
    >>> b.get_yscale()
    'log'
    >>> plt.close(fig)
    """
    from scipy import special

    bmax = float(special.ndtri(1 - clip))

    def beta_of(R, color, style, label, ms):
        """β of R on ``ax_beta``; beyond ±bmax at the edge with open markers, not as data."""
        if ax_beta is None:
            return
        over, under = R > 1 - clip, R < clip
        inside = ~(over | under)
        ax_beta.plot(x, np.where(inside, special.ndtri(np.clip(R, clip, 1 - clip)), np.nan),
                     style, color=color, ms=ms, label=label)
        name = label.split(" (")[0]
        if over.any():
            ax_beta.plot(x[over], np.full(over.sum(), bmax), "^", mfc="none", color=color, ms=6,
                         label=f"{name}: β above {bmax:.1f} (clipped)")
        if under.any():
            ax_beta.plot(x[under], np.full(under.sum(), -bmax), "v", mfc="none", color=color,
                         ms=6, label=f"{name}: β below −{bmax:.1f} (clipped)")

    def draw(R, style, color, label, ms=4):
        R = np.asarray(R, dtype=float)
        beta_of(R, color, style, label, ms)
        if ax_pf is not None:
            pf = 1 - R
            over = pf < clip
            ax_pf.semilogy(x, np.where(over, np.nan, pf), style, color=color, ms=ms, label=label)
            if over.any():
                ax_pf.plot(x[over], np.full(over.sum(), clip), "v", mfc="none", color=color,
                           ms=6, label=f"{label.split(' (')[0]}: 1 − R below {clip:g} (clipped)")

    if mc is not None:
        R, lo, hi, n, level = mc
        R, lo, hi = (np.asarray(v, dtype=float) for v in (R, lo, hi))
        band = f"MC {100 * level:.0f} % interval"
        if ax_beta is not None:
            ax_beta.fill_between(x, special.ndtri(np.clip(lo, clip, 1 - clip)),
                                 special.ndtri(np.clip(hi, clip, 1 - clip)), color="C1",
                                 alpha=0.2, label=band)
        seen = R < 1  # an exceedance was observed; elsewhere only an upper bound on 1 − R
        label = f"Monte Carlo (n = {n})"
        beta_of(np.where(seen, R, np.nan), "C1", "s--", label, 3)
        if ax_beta is not None and (~seen).any():
            # R = 1 observed: β = ∞ is no estimate, the interval's lower end is (as ▼ on 1 − R)
            ax_beta.plot(x[~seen], special.ndtri(np.clip(lo[~seen], clip, 1 - clip)), "^",
                         ms=5, color="C1", label="MC lower bound (no exceedance seen)")
        if ax_pf is not None:
            ax_pf.fill_between(x, np.maximum(1 - hi, clip), np.maximum(1 - lo, clip),
                               color="C1", alpha=0.25, label=band)
            ax_pf.semilogy(x, np.where(seen, 1 - R, np.nan), "s--", ms=3, color="C1",
                           label=label)
            if (~seen).any():
                ax_pf.plot(x[~seen], 1 - lo[~seen], "v", ms=5, color="C1",
                           label="MC upper bound (no exceedance seen)")
    if fosm is not None:
        draw(fosm[0], "o-", "C0", fosm[1])
    if surrogate is not None:
        draw(surrogate[0], "-", "C2", surrogate[1], ms=0)
    if allowable is not None:
        mu_I, sd_I, unit = allowable
        text = f"allowable I ~ N({mu_I:.3g}, {sd_I:.3g}²) {unit}".rstrip()
        if sd_I > 0:
            cap = float(special.ndtr(mu_I / sd_I))
            # the cap is drawn where it is on the axis; beyond the clip it is only named
            if ax_beta is not None:
                label = f"{text}: cap β = μ_I/σ_I = {mu_I / sd_I:.2f}"
                if mu_I / sd_I <= bmax:
                    ax_beta.axhline(mu_I / sd_I, color="0.4", ls=":", lw=1, label=label)
                else:
                    ax_beta.plot([], [], " ", label=label + " (off the axis)")
            if ax_pf is not None:
                label = (f"cap: 1 − Φ(μ_I/σ_I) = {1 - cap:.2g} (zero error)"
                         + ("" if ax_beta is not None else f", {text}"))
                if 1 - cap >= clip:
                    ax_pf.axhline(1 - cap, color="0.4", ls=":", lw=1, label=label)
                else:
                    ax_pf.plot([], [], " ", label=label + " (off the axis)")
        else:
            (ax_beta if ax_beta is not None else ax_pf).plot([], [], " ",
                                                             label=f"{text} (fixed)")
    if whole_cycle is not None and ax_pf is not None:
        R, lo, hi = whole_cycle
        ax_pf.plot([], [], " ", label=f"whole cycle (MC): R = {R:.4f} [{lo:.4f}, {hi:.4f}]")
    for ax in (ax_beta, ax_pf):
        if ax is not None:
            ax.grid(alpha=0.3, which="both")
            ax.legend(fontsize=7, loc="best")


def plot_reliability(*results: Any, title: str | None = None):
    """Plot the reliability of every quantity over the crank angle.

    From any of a FOSM result, a Monte Carlo result and a Monte Carlo result on a PCE surrogate
    (same ``event``). One row per quantity: left the reliability index β = Φ⁻¹(R) of the
    event's R, right the probability of exceeding the allowable 1 − R on a log scale, where
    methods differ near R = 1. Monte Carlo shows its sample count and confidence band (where no
    exceedance was seen, only a bound: ▲ the lower bound of β, ▼ the upper bound of 1 − R), the
    allowable is named with its cap Φ(μ_I/σ_I), the whole-cycle R of Monte Carlo is given, and
    values beyond :data:`CLIP` are drawn as clipped.

    Parameters
    ----------
    *results : FOSMResult or MonteCarloResult
        At most one of each kind (FOSM, Monte Carlo, Monte Carlo on a surrogate).
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.

    Raises
    ------
    StudyError
        If no result, two of a kind, a result of another type, or results of different events
        are given.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from mechrel.uq import Allowable, Normal, UncertainInputs, fosm, linear_model
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
    >>> r = fosm(model=linear_model([0.0, 0.0], [[1.0], [2.0]], ["x"]), inputs=inputs,
    ...          allowable=Allowable(0.4, 0.0), progress=False)
    >>> fig = plot_reliability(r, title="y = x, 2x")
    >>> len(fig.axes) >= 2
    True
    >>> plt.close(fig)
    """
    plt = _plt()
    by = {}
    for r in results:
        k = _kind(r)
        if k in by:
            raise StudyError(f"plot_reliability: two {k} results; pass at most one of each")
        by[k] = r
    if not by:
        raise StudyError("plot_reliability: pass at least one FOSMResult or MonteCarloResult")
    events = {r.event for r in by.values()}
    if len(events) > 1:
        raise StudyError(f"plot_reliability: the results have different events {sorted(events)}; "
                         "compute them with the same event")
    event = events.pop()
    first = next(iter(by.values()))
    index = first.table.index
    for r in by.values():
        if not r.table.index.equals(index):
            raise StudyError("plot_reliability: the results have different outputs")
    panels = _panels(index)
    fig, axes = plt.subplots(len(panels), 2, figsize=(11.5, 2.9 * len(panels) + 0.7),
                             sharex=True, constrained_layout=True, squeeze=False)
    xlabel = "output"
    for row, (q, pos) in zip(axes, panels):
        x, xlabel = _xvalues(index, pos)
        t = first.table
        allowable = None
        if {"allowable_mean", "allowable_std"} <= set(t.columns):
            mu_I, sd_I = t["allowable_mean"].to_numpy()[pos], t["allowable_std"].to_numpy()[pos]
            if np.ptp(mu_I) == 0 and np.ptp(sd_I) == 0:
                allowable = (float(mu_I[0]), float(sd_I[0]), UNITS.get(q, ""))
        kw = {"allowable": allowable}
        if "fosm" in by:
            kw["fosm"] = (by["fosm"].table["reliability"].to_numpy()[pos], f"FOSM ({event})")
        if "surrogate" in by:
            kw["surrogate"] = (by["surrogate"].table["reliability"].to_numpy()[pos],
                               "PCE surrogate")
        if "mc" in by:
            m = by["mc"]
            t = m.table
            kw["mc"] = (t["reliability"].to_numpy()[pos], t["reliability_lo"].to_numpy()[pos],
                        t["reliability_hi"].to_numpy()[pos], int(t["n"].iloc[pos[0]]),
                        m.confidence_level)
            wc = m.whole_cycle
            if q in wc.index:
                kw["whole_cycle"] = tuple(float(wc.loc[q, c]) for c in
                                          ("reliability", "reliability_lo", "reliability_hi"))
        reliability_panels(row[0], row[1], x, **kw)
        row[0].set_ylabel(f"β = Φ⁻¹(R), {q}" if q else "β = Φ⁻¹(R)")  # β has no unit
        row[1].set_ylabel(f"1 − R, {q}" if q else "1 − R")
    for ax in axes[-1]:
        ax.set_xlabel(xlabel)
        if xlabel.startswith("crank angle"):
            ax.set_xticks(np.arange(0, 361, 36))
    axes[0][0].set_title(f"reliability index Φ⁻¹(R) ({event})")
    axes[0][1].set_title("probability of exceeding the allowable")
    if title:
        fig.suptitle(title)
    return fig


def plot_qq(normality: Any, output: Any, *, ax: Any = None):
    """QQ plot of the Monte Carlo errors of one output against FOSM's normal N(μ_i, σ_i²).

    Parameters
    ----------
    normality : NormalityResult
        The comparison of FOSM and Monte Carlo.
    output : hashable or int
        An output label or position.
    ax : matplotlib.axes.Axes, optional
        The axes to draw on (default: a new figure).

    Returns
    -------
    matplotlib.figure.Figure
        The figure (the output's unit on both axes).

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from mechrel.uq import (Allowable, Normal, UncertainInputs, fosm, linear_model,
    ...                         monte_carlo, normality_check)
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
    >>> model, allow = linear_model([0.0], [[1.0]], ["x"]), Allowable(0.2, 0.0)
    >>> nc = normality_check(fosm=fosm(model=model, inputs=inputs, allowable=allow, progress=False),
    ...                      monte_carlo=monte_carlo(model=model, inputs=inputs, n=256, seed=1,
    ...                                              allowable=allow, progress=False))
    >>> fig = plot_qq(nc, 0)
    >>> fig.axes[0].get_xlabel()
    'FOSM normal quantile'
    >>> plt.close(fig)
    """
    plt = _plt()
    q = normality.qq(output)
    if ax is None:
        fig, ax = plt.subplots(figsize=(4.8, 4.5))
    else:
        fig = ax.figure
    ax.plot(q["fosm_quantile"], q["mc_quantile"], ".", ms=3, label="MC samples")
    lo = float(np.nanmin([q["fosm_quantile"].min(), q["mc_quantile"].min()]))
    hi = float(np.nanmax([q["fosm_quantile"].max(), q["mc_quantile"].max()]))
    ax.plot([lo, hi], [lo, hi], "k--", lw=1, label="y = x (FOSM exact)")
    row = normality.table.iloc[_pos(normality.table.index, output)]
    unit = ""
    if isinstance(output, tuple) and output and output[0] in UNITS:
        unit = f" ({UNITS[output[0]]})"
    ax.set_xlabel(f"FOSM normal quantile{unit}")
    ax.set_ylabel(f"Monte Carlo error quantile{unit}")
    ax.set_title(f"{_label(normality.table.index, output)}: KS p={row['ks_pvalue']:.2g}, "
                 f"AD p={row['ad_pvalue']:.2g}", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _label(index: pd.Index, output: Any) -> str:
    lbl = index[_pos(index, output)]
    if isinstance(lbl, tuple) and isinstance(index, pd.MultiIndex) and "crank_angle" in index.names:
        parts = [f"{v:g}°" if n == "crank_angle" and not isinstance(v, str) else str(v)
                 for n, v in zip(index.names, lbl)]
        return " at ".join(parts)
    return str(lbl)


def _pos(index: pd.Index, output: Any) -> int:
    from ._common import resolve_outputs_safe

    return resolve_outputs_safe(index, output)


def plot_sobol(result: Any, output: Any = None, *, title: str | None = None):
    """Bar charts of first- and total-order Sobol' indices, one panel per output.

    Parameters
    ----------
    result : SobolResult or PCEResult
        The indices (a SobolResult's with confidence intervals).
    output : hashable or int, optional
        One output label or position (default: every output).
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.

    Raises
    ------
    StudyError
        If ``result`` is of another type, or a PCE has no Sobol' indices (correlated inputs).

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from mechrel.uq import Normal, UncertainInputs, linear_model, polynomial_chaos
    >>> inputs = UncertainInputs.from_specs({"a": Normal(0.0, 1.0), "b": Normal(0.0, 1.0)})
    >>> r = polynomial_chaos(model=linear_model([0.0], [[1.0, 2.0]], ["a", "b"]), inputs=inputs,
    ...                      order=1, seed=1, progress=False)
    >>> fig = plot_sobol(r)
    >>> len(fig.axes)
    1
    >>> plt.close(fig)
    """
    plt = _plt()
    from .surrogates.pce import PCEResult
    from .estimators.sobol import SobolResult

    if isinstance(result, SobolResult):
        s1, st, c1, ct = result.first, result.total, result.first_conf, result.total_conf
        src = f"Saltelli/SALib, N={result.n_blocks_used}"
    elif isinstance(result, PCEResult):
        if result.sobol_first is None:
            raise StudyError("plot_sobol: this PCE has no Sobol' indices (correlated inputs)")
        s1, st, c1, ct = result.sobol_first, result.sobol_total, None, None
        src = f"PCE order {result.order}"
    else:
        raise StudyError(f"plot_sobol: expected a SobolResult or PCEResult, got {type(result).__name__}")
    rows = range(len(s1.index)) if output is None else [_pos(s1.index, output)]
    names = list(s1.columns)
    x = np.arange(len(names))
    long = max(len(n) for n in names) > 8
    fig, axes = plt.subplots(1, len(rows), figsize=(max(4.5, 0.9 * len(names) + 2) * len(rows), 3.8),
                             constrained_layout=True, squeeze=False)
    w = 0.38
    for ax, k in zip(axes[0], rows):
        ax.bar(x - w / 2, s1.iloc[k].to_numpy(), w, yerr=None if c1 is None else c1.iloc[k].to_numpy(),
               capsize=3, label="first order S_i")
        ax.bar(x + w / 2, st.iloc[k].to_numpy(), w, yerr=None if ct is None else ct.iloc[k].to_numpy(),
               capsize=3, label="total order S_Ti")
        ax.set_xticks(x, names, rotation=30 if long else 0, ha="right" if long else "center")
        defined = s1.iloc[k].to_numpy(dtype=float)
        defined = defined[np.isfinite(defined)]
        ax.set_ylim(min(0.0, float(defined.min()) - 0.05) if defined.size else 0.0, 1.05)
        if not defined.size:  # a measure that does not vary with the inputs: no variance
            ax.text(0.5, 0.5, "undefined: this measure does not vary with the inputs",
                    transform=ax.transAxes, ha="center", va="center", fontsize=8)
        ax.set_title(f"{_label(s1.index, k).replace('peak_abs_', 'peak |error|: ')} — {src}",
                     fontsize=9)
        ax.grid(axis="y", alpha=0.3)
        ax.legend(fontsize=8)
    axes[0][0].set_ylabel("Sobol' index (share of variance)")
    if title:
        fig.suptitle(title)
    return fig


_MARKERS = {"monte_carlo": "o", "sampling": "s", "approximation": "D"}


def plot_whole_cycle(estimates: pd.DataFrame, *, target: float | None = None, title: str | None = None,
                     min_failures: int = 10):
    """The whole-cycle failure probability, every method side by side: the headline figure of a
    reliability study (``whole_cycle.png``).

    One row per group (each quantity, then ``all``: any quantity beyond its allowable anywhere in
    the cycle); per method a marker at its P_f (log scale) with its interval where it has one:
    ● Monte Carlo (open when it saw fewer than ``min_failures`` failures; ◀ at its upper bound
    when it saw none), ■ a sampling rare-event method, ◆ an approximation without an interval
    (FORM, SORM). A dashed line marks the target, if given.

    Parameters
    ----------
    estimates : pandas.DataFrame
        :func:`mechrel.study.rare.whole_cycle_estimates`: ``method``, ``group``, ``pf``,
        ``pf_lo``, ``pf_hi``, ``kind``, ``n_failures``.
    target : float, optional
        The largest acceptable P_f (1 − the target reliability).
    title : str, optional
        The figure's title.
    min_failures : int, default 10
        Monte Carlo with fewer failures is drawn open (its interval is wide).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> est = pd.DataFrame({"method": ["mc", "mc", "form"], "group": ["velocity", "all", "all"],
    ...                     "pf": [0.02, 0.03, 0.02], "pf_lo": [0.015, 0.024, np.nan],
    ...                     "pf_hi": [0.026, 0.037, np.nan],
    ...                     "kind": ["monte_carlo", "monte_carlo", "approximation"],
    ...                     "n_failures": [40.0, 60.0, np.nan]})
    >>> fig = plot_whole_cycle(est, target=1e-2)
    >>> fig.axes[0].get_xscale(), [t.get_text() for t in fig.axes[0].get_yticklabels()]  # from the bottom
    ('log', ['all', 'velocity'])
    """
    plt = _plt()
    groups = [g for g in dict.fromkeys(estimates["group"]) if g != "all"] + (
        ["all"] if "all" in set(estimates["group"]) else [])
    methods = list(dict.fromkeys(estimates["method"]))
    fig, ax = plt.subplots(figsize=(9.0, 1.4 + 0.55 * len(groups) * max(1, len(methods)) ** 0.5))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    span = 0.6
    positive = estimates["pf"][estimates["pf"] > 0]
    floor = float(positive.min()) / 10 if len(positive) else 1e-6
    for j, m in enumerate(methods):
        color = colors[j % len(colors)]
        off = (j - (len(methods) - 1) / 2) * span / max(1, len(methods))
        first = True
        for _i, r in estimates[estimates["method"] == m].iterrows():
            y = len(groups) - 1 - groups.index(r["group"]) + off
            pf, lo, hi = float(r["pf"]), float(r["pf_lo"]), float(r["pf_hi"])
            weak = r["kind"] == "monte_carlo" and float(r["n_failures"]) < min_failures
            marker = _MARKERS.get(r["kind"], "o")
            face = "none" if weak or r["kind"] == "approximation" else color
            label = m if first else None
            first = False
            if pf <= 0 and np.isfinite(hi):
                ax.plot([hi], [y], marker="<", color=color, ls="none", label=label)
                ax.plot([max(floor, 1e-300), hi], [y, y], color=color, lw=1, ls=":")
                continue
            if np.isfinite(lo) and np.isfinite(hi):
                ax.plot([max(lo, floor), hi], [y, y], color=color, lw=2, alpha=0.7)
            ax.plot([pf], [y], marker=marker, color=color, markerfacecolor=face, ls="none", ms=7, label=label)
    if target is not None:
        ax.axvline(target, color="k", ls="--", lw=1, label=f"target P_f = {target:.3g}")
    ax.set_xscale("log")
    ax.set_yticks(range(len(groups)))
    ax.set_yticklabels(list(reversed(groups)))
    ax.set_ylim(-0.7, len(groups) - 0.3)
    ax.set_xlabel("whole-cycle failure probability P_f (beyond the allowable at any instant)")
    ax.grid(True, axis="x", which="both", alpha=0.3)
    ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=8,
              title="● MC  ■ sampling\n◆ approximation", title_fontsize=7)
    ax.set_title(title or "whole-cycle failure probability by method (bars: intervals)")
    fig.tight_layout()
    return fig


def plot_design_points(form_result: Any, *, extremes: pd.DataFrame | None = None,
                       allowables: dict | None = None, title: str | None = None):
    """Where the whole cycle's risk sits and what drives it: the rare-event figure of a study
    (``rare_events.png``).

    Left: each design point of FORM's system (:attr:`~mechrel.uq.FORMResult.design_points`) at
    the middle of its cycle sector (or in order, for members without a sector), its β on the y
    axis, ▲ for an error beyond +allowable, ▼ beyond −allowable, one colour per quantity.
    Middle: the importance factors α² of each design point, stacked per input. Right (with
    ``extremes``, the Monte Carlo samples' cycle extremes): P_f against the allowable, the
    fraction of samples whose largest |error| over the cycle exceeds a fixed allowable a, per
    quantity, a in units of the study's allowable ``allowables[q]``.

    Parameters
    ----------
    form_result : FORMResult
        FORM's result (or SORM's or importance sampling's ``.form``).
    extremes : pandas.DataFrame, optional
        One row per sample, a column ``(quantity, "max_abs")`` per quantity.
    allowables : dict, optional
        ``{quantity: allowable (mean)}``, the unit of the right panel's x axis.
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs, form
    >>> inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
    >>> tie = FunctionModel(lambda X: 3.5 - abs(X[:, 0]), ["x1", "x2"], ["g"], vectorized=True)
    >>> import warnings
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")
    ...     fig = plot_design_points(form(model=tie, inputs=inputs))
    >>> len(fig.axes)
    2
    """
    from .problem.allowables import parse_sector

    plt = _plt()
    dps = form_result.design_points
    panels = 3 if extremes is not None else 2
    fig, axs = plt.subplots(1, panels, figsize=(4.2 * panels, 3.8))
    ax = axs[0]
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    comps = list(dict.fromkeys(dps["component"]))
    xs = []
    for k, r in dps.iterrows():
        out = r["output"]
        sec = parse_sector(out[-1]) if isinstance(out, tuple) else None
        x = 0.5 * (sec[1] + sec[2]) if sec else float(k)
        xs.append(x)
        marker = "^" if r["sign"] == "+" else ("v" if r["sign"] == "-" else "o")
        c = colors[comps.index(r["component"]) % len(colors)]
        ax.plot([x], [r["beta"]], marker=marker, color=c, ls="none", ms=8,
                label=str(r["component"]) if comps.index(r["component"]) == comps.index(r["component"])
                and r["component"] not in [lbl.get_label() for lbl in ax.lines[:-1]] else None)
        ax.annotate(f"{r['pf_mode']:.1e}", (x, r["beta"]), textcoords="offset points", xytext=(4, 4), fontsize=7)
    sectors = any(isinstance(o, tuple) and parse_sector(o[-1]) for o in dps["output"])
    ax.set_xlabel("crank angle of the sector (deg)" if sectors else "design point")
    if sectors:
        ax.set_xlim(0, 360)
        ax.set_xticks(range(0, 361, 90))
    ax.set_ylabel("β of the design point (P_mode annotated)")
    ax.set_title("design points (▲ +allowable, ▼ −allowable)", fontsize=9)
    ax.grid(True, alpha=0.3)
    if len(comps) > 1:
        ax.legend(fontsize=7)
    ax = axs[1]
    imp = form_result.points["importance"].unstack("input")
    bottom = np.zeros(len(imp))
    for j, name in enumerate(imp.columns):
        ax.bar(np.arange(len(imp)), imp[name].to_numpy(), bottom=bottom, label=str(name),
               color=colors[j % len(colors)])
        bottom += imp[name].to_numpy()
    ax.set_xticks(np.arange(len(imp)))
    ax.set_xticklabels([f"{x:g}°" if sectors else str(k) for k, x in zip(imp.index, xs)], fontsize=7,
                       rotation=45)
    ax.set_ylabel("importance α²")
    ax.set_ylim(0, 1)
    ax.set_title("what drives each design point", fontsize=9)
    ax.legend(fontsize=6, loc="upper right")
    if extremes is not None:
        ax = axs[2]
        for j, q in enumerate(dict.fromkeys(c[0] for c in extremes.columns)):
            if (q, "max_abs") not in extremes.columns:
                continue
            v = np.sort(extremes[(q, "max_abs")].dropna().to_numpy())
            if v.size == 0:
                continue
            unit = float((allowables or {}).get(q, 1.0)) or 1.0
            p = 1.0 - np.arange(1, v.size + 1) / v.size
            keep = p > 0
            ax.step(v[keep] / unit, p[keep], where="post", color=colors[j % len(colors)], label=q)
        ax.axvline(1.0, color="k", ls="--", lw=1, label="study allowable")
        ax.set_yscale("log")
        ax.set_xlabel("fixed allowable a / the study's allowable" if allowables else "fixed allowable a")
        ax.set_ylabel("P(max over the cycle |error| > a)")
        ax.set_title(f"P_f against the allowable ({len(extremes)} MC samples)", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig
