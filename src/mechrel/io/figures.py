"""Figures of simulation results."""

from __future__ import annotations


import numpy as np


def _axis(result):
    if result.crank_angle is not None:
        return result.crank_angle, "crank angle (deg)"
    return result.time, "time (s)"


def plot_simulation(result, path=None, *, output: str | None = None):
    """Every quantity of every output (or of ``output`` only) over the analysis span, in the
    display units of the output kinds' table (:data:`mechrel.outputs.OUTPUT_KINDS`); with an
    ideal counterpart, the ideal curves and the errors; and the journal orbits inside their
    clearance circles.

    Parameters
    ----------
    result : mechrel.simulation.SimulationResult
        The simulation.
    path : str or os.PathLike, optional
        Save the figure there (format from the suffix).
    output : str, optional
        Plot this output only.

    Returns
    -------
    matplotlib.figure.Figure
        The figure, one row per (output, quantity).

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> from mechrel.simulation import simulate
    >>> fig = plot_simulation(simulate(load_scene("slider-crank")))
    >>> len(fig.axes), fig.axes[0].get_ylabel()   # displacement, velocity, acceleration
    (3, 'displacement (mm)')
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from ..outputs import display

    names = [output] if output is not None else list(result.outputs)
    rows = [(name, qty) for name in names for qty in result.outputs[name]]
    x, xlabel = _axis(result)
    has_err = result.ideal is not None
    n_orbit = len(result.orbits)
    ncols = 2 if has_err else 1
    fig = plt.figure(figsize=(6.5 * ncols + (4 if n_orbit else 0), 2.4 * len(rows) + 0.8),
                     constrained_layout=True)
    gs = fig.add_gridspec(len(rows), ncols + (1 if n_orbit else 0))
    for row, (name, qty) in enumerate(rows):
        unit, scale = display(qty)
        ax = fig.add_subplot(gs[row, 0])
        ax.plot(x, result.outputs[name][qty] * scale, lw=1.2, label="with clearance" if has_err
                else name)
        if has_err:
            ax.plot(x, result.ideal[name][qty] * scale, lw=1.0, ls="--", color="k",
                    label="ideal")
        ax.set_ylabel(f"{qty} ({unit})", fontsize=8)
        ax.grid(alpha=0.3)
        if row == 0 or rows[row - 1][0] != name:
            ax.set_title(f"{result.scene.name}: {name}")
            ax.legend(loc="best", fontsize=8)
        if row == len(rows) - 1:
            ax.set_xlabel(xlabel)
        if has_err:
            ax = fig.add_subplot(gs[row, 1])
            ax.plot(x, result.error(name, qty) * scale, lw=1.0, color="C3")
            ax.axhline(0.0, color="k", lw=0.5)
            ax.set_ylabel(f"{qty} error ({unit})", fontsize=8)
            ax.grid(alpha=0.3)
            if row == 0:
                ax.set_title("error = with clearance − ideal")
            if row == len(rows) - 1:
                ax.set_xlabel(xlabel)
    if n_orbit:
        sub = gs[:, ncols].subgridspec(n_orbit, 1)
        for k, (name, orb) in enumerate(result.orbits.items()):
            ax = fig.add_subplot(sub[k])
            c = np.hypot(orb["ex"], orb["ey"]) / np.maximum(orb["eps"], 1e-300)
            cl = float(np.nanmedian(c[orb["eps"] > 0])) if np.any(orb["eps"] > 0) else 1.0
            phi = np.linspace(0, 2 * np.pi, 200)
            ax.plot(cl * 1e3 * np.cos(phi), cl * 1e3 * np.sin(phi), color="k", lw=0.8)
            ax.plot(orb["ex"] * 1e3, orb["ey"] * 1e3, lw=0.8, color="C2")
            ax.set_aspect("equal")
            ax.set_title(f"journal orbit {name} (max ε = {np.max(orb['eps']):.3f})", fontsize=9)
            ax.set_xlabel("e_x (mm)")
            ax.set_ylabel("e_y (mm)")
    if path is not None:
        from .tables import save_figure
        save_figure(fig, path, dpi=130)
        plt.close(fig)
    return fig
