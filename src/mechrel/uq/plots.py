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

__all__ = ["plot_reliability", "plot_fosm_vs_mc", "plot_qq", "plot_sobol"]

# SI unit of every quantity, from the output kinds' table
UNITS = {name: q.unit for name, q in QUANTITY_INFO.items()}


def _plt():
    import matplotlib.pyplot as plt

    return plt


def _panels(index: pd.Index) -> list[tuple[str, np.ndarray]]:
    """[(quantity label, positions)] — one panel per quantity, or one for everything; the
    positions of the analysis angles only (not the cycle extremes)."""
    from .reliability import per_angle_mask

    angle = per_angle_mask(index)
    if isinstance(index, pd.MultiIndex) and "quantity" in index.names:
        q = np.asarray(index.get_level_values("quantity").astype(str))
        return [(u, np.flatnonzero((q == u) & angle)) for u in dict.fromkeys(q.tolist())]
    return [("", np.flatnonzero(angle))]


def _xvalues(index: pd.Index, pos: np.ndarray) -> tuple[np.ndarray, str]:
    if isinstance(index, pd.MultiIndex) and "crank_angle" in index.names:
        return np.asarray(index.get_level_values("crank_angle"), dtype=float)[pos], "crank angle (deg)"
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


def _title(q: str) -> str:
    return f"{q} ({UNITS[q]})" if q in UNITS else q


def plot_reliability(result: Any, *, what: str = "reliability", axes: Any = None):
    """Reliability (``what="reliability"``) or reliability index (``what="beta"``) vs crank angle,
    for a FOSM or Monte Carlo result (MC: with its confidence band; its β is Φ⁻¹(R))."""
    from scipy import special

    from .first_order import FOSMResult
    from .montecarlo import MonteCarloResult

    if what not in ("reliability", "beta"):
        raise StudyError(f"what: got {what!r}; allowed: ['reliability', 'beta']")
    if not isinstance(result, (FOSMResult, MonteCarloResult)):
        raise StudyError(f"plot_reliability: expected a FOSMResult or MonteCarloResult, got {type(result).__name__}")
    t = result.table
    panels = _panels(t.index)
    fig, axs = _new_axes(len(panels), axes)
    is_mc = isinstance(result, MonteCarloResult)
    for ax, (q, pos) in zip(axs, panels):
        x, xlabel = _xvalues(t.index, pos)
        if what == "reliability":
            y = t["reliability"].to_numpy()[pos]
        else:
            y = t["beta_generalized"].to_numpy()[pos] if not is_mc else special.ndtri(t["reliability"].to_numpy()[pos])
        label = ("Monte Carlo" if is_mc else "FOSM") + f" ({result.form})"
        if what == "beta" and (is_mc or result.form == "two-sided"):
            label += ", Φ⁻¹(R)"
        ax.plot(x, y, "o-" if is_mc else "s-", ms=4, label=label)
        if is_mc:
            lo, hi = t["reliability_lo"].to_numpy()[pos], t["reliability_hi"].to_numpy()[pos]
            if what == "beta":
                lo, hi = special.ndtri(lo), special.ndtri(hi)
            ax.fill_between(x, lo, hi, alpha=0.25, label=f"{100 * result.confidence_level:.0f}% interval")
        elif what == "beta" and result.form == "two-sided":
            ax.plot(x, t["beta"].to_numpy()[pos], "--", lw=1, label="paper's β (one-sided)")
        ax.set_ylabel("reliability R" if what == "reliability" else "reliability index β")
        ax.set_title(_title(q) if q else "")
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8)
    axs[-1].set_xlabel(xlabel)
    fig.tight_layout()
    return fig


def plot_fosm_vs_mc(fosm: Any, monte_carlo: Any, *, axes: Any = None):
    """FOSM reliability vs Monte Carlo (same form) with the Monte Carlo confidence band."""
    if fosm.form != monte_carlo.form:
        raise StudyError(
            f"plot_fosm_vs_mc: FOSM form {fosm.form!r} differs from Monte Carlo form {monte_carlo.form!r}; "
            "compute both with the same form"
        )
    t_f, t_m = fosm.table, monte_carlo.table
    if not t_f.index.equals(t_m.index):
        raise StudyError("plot_fosm_vs_mc: the two results have different outputs")
    panels = _panels(t_f.index)
    fig, axs = _new_axes(len(panels), axes)
    for ax, (q, pos) in zip(axs, panels):
        x, xlabel = _xvalues(t_f.index, pos)
        ax.fill_between(x, t_m["reliability_lo"].to_numpy()[pos], t_m["reliability_hi"].to_numpy()[pos],
                        color="C1", alpha=0.25, label=f"MC {100 * monte_carlo.confidence_level:.0f}% interval")
        ax.plot(x, t_m["reliability"].to_numpy()[pos], "o", color="C1", ms=4, label=f"Monte Carlo (n={int(t_m['n'].iloc[0])})")
        ax.plot(x, t_f["reliability"].to_numpy()[pos], "-", color="C0", lw=1.5, label="FOSM")
        ax.set_ylabel(f"reliability R ({fosm.form})")
        ax.set_title(_title(q) if q else "")
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8)
    axs[-1].set_xlabel(xlabel)
    fig.tight_layout()
    return fig


def plot_qq(normality: Any, output: Any, *, ax: Any = None):
    """QQ plot of the Monte Carlo errors of one output against FOSM's normal N(μ_i, σ_i²)."""
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


def plot_sobol(result: Any, output: Any = None, *, ax: Any = None):
    """Bar chart of first- and total-order Sobol' indices of one output (default: the first),
    from a SobolResult (with confidence intervals) or a PCEResult."""
    plt = _plt()
    from .pce import PCEResult
    from .sobol import SobolResult

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
    k = 0 if output is None else _pos(s1.index, output)
    label = s1.index[k]
    names = list(s1.columns)
    x = np.arange(len(names))
    if ax is None:
        fig, ax = plt.subplots(figsize=(max(4.5, 0.9 * len(names) + 2), 3.6))
    else:
        fig = ax.figure
    w = 0.38
    ax.bar(x - w / 2, s1.iloc[k].to_numpy(), w, yerr=None if c1 is None else c1.iloc[k].to_numpy(),
           capsize=3, label="first order S_i")
    ax.bar(x + w / 2, st.iloc[k].to_numpy(), w, yerr=None if ct is None else ct.iloc[k].to_numpy(),
           capsize=3, label="total order S_Ti")
    ax.set_xticks(x, names, rotation=30 if max(len(n) for n in names) > 8 else 0, ha="right" if max(len(n) for n in names) > 8 else "center")
    ax.set_ylabel("Sobol' index (share of variance)")
    ax.set_ylim(min(0.0, float(np.nanmin(s1.iloc[k]) - 0.05)), 1.05)
    ax.set_title(f"{_label(s1.index, k)} — {src}", fontsize=9)
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
