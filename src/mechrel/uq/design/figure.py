"""The figure of a design for reliability: the cost against the target's failure probability
(the trade-off curve), through the optimum, with the independent verification at the optimum.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["plot_tradeoff"]


def plot_tradeoff(*results: Any, labels: Any = None, title: str | None = None, ax: Any = None):
    """Cost against P_f = 1 − R of one or more :class:`~mechrel.uq.DesignResult`.

    Each result's trade-off curve (the optimum cost at targets P_f × 0.1 … × 10 on the method's
    estimate: filled markers where the optimum met the target, open where no design within the
    bounds did), its optimum (a star at the target's P_f) and its verification (the
    independent run's P_f with its interval, a horizontal bar at the optimum's cost). The P_f
    axis is logarithmic and reversed: reliability grows to the right.

    Parameters
    ----------
    *results : DesignResult
        One curve each (e.g. the whole-cycle and the per-angle allocation side by side).
    labels : sequence of str, optional
        One per result (default: the first constraint's label).
    title : str, optional
        The figure's title.
    ax : matplotlib Axes, optional
        Draw there (default: a new figure).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs, design_for_reliability
    >>> r = design_for_reliability(
    ...     model=FunctionModel(lambda X: X, ["x"], ["e"], vectorized=True),
    ...     inputs=UncertainInputs.from_specs({"x": Normal(0.0, 0.1)}),
    ...     variables={"t": {"kind": "std", "input": "x", "lower": 0.01, "upper": 1.0}},
    ...     cost="1/t", constraints=0.99, allowable=1.0, method="mc", n=4000, seed=3,
    ...     tradeoff=3, verify={"n": 4000}, progress=False)
    >>> fig = plot_tradeoff(r)
    >>> len(fig.axes[0].lines) >= 2
    True
    """
    import matplotlib.pyplot as plt

    if ax is None:
        fig, ax = plt.subplots(figsize=(6.4, 4.2))
    else:
        fig = ax.figure
    labels = list(labels) if labels is not None else [None] * len(results)
    for i, (r, lab) in enumerate(zip(results, labels)):
        color = f"C{i}"
        row = r.constraints.iloc[0]
        lab = lab or str(r.constraints.index[0])
        t = r.tradeoff
        if len(t):
            ok = t["feasible"].to_numpy(dtype=bool)
            ax.plot(t["pf_target"], t["cost"], "-", color=color, lw=1.2, label=lab)
            ax.plot(t["pf_target"][ok], t["cost"][ok], "o", color=color, ms=4)
            ax.plot(t["pf_target"][~ok], t["cost"][~ok], "o", mfc="none", color=color, ms=4)
        ax.plot([row["pf_target"]], [r.cost], "*", color=color, ms=12,
                label=None if len(t) else lab)
        if row["verify_method"] != "none" and np.isfinite(row["verify_pf"]):
            lo, hi = row["verify_pf_lo"], row["verify_pf_hi"]
            ax.errorbar([max(row["verify_pf"], lo)], [r.cost],
                        xerr=[[max(row["verify_pf"], lo) - lo], [hi - max(row["verify_pf"], lo)]],
                        fmt="s", color=color, mfc="white", ms=5, capsize=3,
                        label=f"verified ({row['verify_method']})")
        if row["basis"] == "per-angle" and np.isfinite(row.get("whole_cycle_pf", np.nan)):
            ax.errorbar([row["whole_cycle_pf"]], [r.cost],
                        xerr=[[row["whole_cycle_pf"] - row["whole_cycle_pf_lo"]],
                              [row["whole_cycle_pf_hi"] - row["whole_cycle_pf"]]],
                        fmt="D", color=color, ms=5, capsize=3,
                        label="its whole-cycle P_f")
    ax.set_xscale("log")
    lo, hi = ax.get_xlim()
    if not hi > lo * 1.5:  # one point (no trade-off curve): a decade around it
        mid = np.sqrt(lo * hi)
        ax.set_xlim(mid / 3.0, mid * 3.0)
    ax.invert_xaxis()
    ax.set_xlabel("failure probability 1 − R (target)")
    ax.set_ylabel("cost")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    return fig
