"""``mechrel simulate``: simulate a scene, print a summary, write its table and figure."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import OutputError
from .args import add_set_option

EPILOG = """\
examples:
  mechrel scenes                               list the embedded scenes
  mechrel scenes nine-bar                      describe one scene
  mechrel simulate slider-crank                kinematics of the ideal slider-crank
  mechrel simulate nine-bar-lubricated --out results/nine-bar.csv
  mechrel simulate nine-bar --set joints.C1.model=dry --set joints.C1.clearance=0.3e-3
  mechrel draw my-scene.toml --out my-scene.png     check a scene file before simulating it
  mechrel animate nine-bar-lubricated --out nine-bar.gif

SCENE is an embedded scene name or a path to a TOML scene file (format: docs/scenes.md).
All values are SI units (m, kg, s, rad, Pa, Pa s).
"""


def _summary_lines(result) -> list[str]:
    import numpy as np

    from ..outputs import display
    from ..simulation.extremes import CLOSURE_LIMIT

    st = result.stats
    lines = [f"scene {result.scene.name} ({result.method}): {result.time.size} samples over "
             f"{result.time[-1]:.4g} s",
             f"  solver {st['integrator']}"
             + (" on the reduced equations" if st.get("formulation") == "reduced" else "")
             + f": {st.get('n_steps', 0)} steps, "
             f"{st.get('n_rhs', 0)} rhs evaluations, {st.get('n_rejected', 0)} rejected"
             + (f" ({st['n_newton_rejected']} by Newton)" if st.get("n_newton_rejected") else "")
             + ", "
             f"{st.get('n_impacts', 0)} impacts; max constraint violation "
             f"{st['max_position_violation']:.2e}; wall {st['wall_time']:.3f} s"]
    for name, q in result.outputs.items():
        kind = result.scene.outputs[name].kind
        lines.append(f"  output {name} ({kind}):")
        for qty, values in q.items():
            unit, scale = display(qty)
            v = values * scale
            line = f"    {qty} {v.min():.4g} … {v.max():.4g} {unit}"
            if qty == "displacement":
                line += f" (stroke {np.ptp(v):.3f} {unit})"
            lines.append(line)
        if result.ideal is not None:
            for qty in q:
                unit, scale = display(qty)
                e = result.error(name, qty) * scale
                lines.append(f"    {qty} error {e.min():.4g} … {e.max():.4g} {unit}")
        if result.extremes is not None and name in result.extremes:
            # the output grid misses what happens between its instants (an impact): the
            # extremes over the analysed cycle found on the integrator's solution
            # over the cycle driver's last cycle, or over the whole span without one (no
            # crank angle then: the instant is given in seconds)
            cyclic = result.crank_angle is not None
            lines.append(f"    error extremes over the {'last cycle' if cyclic else 'run'}, on "
                         "the solution:")
            for qty, d in result.extremes[name].items():
                unit, scale = display(qty)
                at = (f"{d['max_abs_angle']:.2f}°" if cyclic
                      else f"t = {d['max_abs_time']:.6g} s")
                lines.append(f"      {qty} error {d['min'] * scale:.4g} … "
                             f"{d['max'] * scale:.4g} {unit}, max |error| "
                             f"{d['max_abs'] * scale:.4g} {unit} at {at}")
                if d["closure"] > CLOSURE_LIMIT:  # (NaN: not a window of one whole cycle)
                    lines.append(
                        f"        the cycle does not close: its error at the end differs from "
                        f"that at the start by {100 * d['closure']:.2g} % of its span, so these "
                        "extremes include the start transient"
                        + (f" (analysis.cycles = {result.scene.analysis.cycles:g}; more "
                           "cycles settle it, e.g. --set analysis.cycles=2)"
                           if result.scene.analysis.cycles == 1 else
                           " or a response that does not repeat (more cycles tell which)"))
    for name, orb in result.orbits.items():
        lines.append(f"  joint {name}: max eccentricity ratio {orb['eps'].max():.4f}")
    if result.energy:
        b = result.energy["balance"]
        scale = max(abs(result.energy["input_work"]).max(), result.energy["kinetic"].max())
        lines.append(f"  energy balance residual {abs(b).max():.3e} J "
                     f"({abs(b).max() / scale:.2e} of the energy scale)")
    return lines


def _siblings(out: Path) -> tuple[Path, ...]:
    """The files a run writes beside its table ``out``: figure, provenance, orbits."""
    return (out.with_suffix(".png"), out.with_suffix(".json"),
            out.with_name(out.stem + "-orbits" + out.suffix))


def _cmd_simulate(args) -> int:
    from ..io import write_json, write_table
    from ..io.figures import plot_simulation
    from ..io.results import result_set
    from ..io.tables import check_table_path
    from ..scene import load_scene
    from ..simulation import simulate
    from .terminal import say

    scene = load_scene(args.scene, overrides=args.overrides)
    if args.out:
        out = check_table_path(args.out)  # before the simulation, not after it
        for sibling in _siblings(out):
            if sibling.is_dir():
                raise OutputError(f"--out: {str(sibling)!r}, which this run writes beside "
                                  f"{out.name}, is a folder; allowed: a file name (remove or "
                                  "rename the folder)")
    from ..warmup import warm_up

    # announces a cold cache's compilation, of the kernel of the integrator the run uses
    warm_up(scene, integrator=args.integrator, progress=not args.no_progress)
    result = simulate(scene, integrator=args.integrator, progress=not args.no_progress,
                      extremes=bool(scene.clearance_joints))
    say(*_summary_lines(result))
    if args.out:
        out = Path(args.out)
        png, meta_json, orbits = _siblings(out)
        # one set: table, figure, provenance and orbits replace an earlier run's together
        with result_set(out.parent, out.name, known=[p.name for p in _siblings(out)],
                        what="--out") as stage:
            write_table(result.to_frame(), stage / out.name)
            plot_simulation(result, stage / png.name)
            meta = {"provenance": dict(result.provenance), "stats": dict(result.stats),
                    "overrides": list(args.overrides), "warnings": list(result.warnings)}
            if result.extremes is not None:
                meta["extremes"] = {o: {qty: dict(d) for qty, d in qs.items()}
                                    for o, qs in result.extremes.items()}
            write_json(meta, stage / meta_json.name, relative_to=out.parent)
            written = [out, png, meta_json]
            if result.orbits:
                write_table(result.orbits_frame(), stage / orbits.name)
                written.append(orbits)
        say(f"wrote {', '.join(map(str, written))}")
    return 0


def register(sub) -> None:
    """Add the ``mechrel simulate`` subcommand to ``sub``, the parser's subparsers action
    (one entry of :data:`mechrel.cli.main.COMMANDS`).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        What ``parser.add_subparsers()`` returned.

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser(prog="mechrel")
    >>> register(parser.add_subparsers(dest="command"))
    >>> parser.parse_args(["simulate", "slider-crank"]).command
    'simulate'
    """
    p = sub.add_parser(
        "simulate", help="simulate a scene and print a summary",
        description="Simulate a scene over its analysis span (kinematic analysis for ideal "
                    "driven mechanisms, forward dynamics with clearance joints) and print a "
                    "summary; --out writes the table, a figure (.png) and provenance (.json).",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scene", metavar="SCENE", help="embedded scene name or path to a .toml file")
    add_set_option(p, "override a scene value by its dotted path, e.g. "
                      "joints.C1.clearance=0.3e-3 (repeatable)")
    p.add_argument("--integrator", help="override solver.integrator (rk4, dopri5, radau, "
                                        "scipy-radau, bdf, lsoda)")
    p.add_argument("--out", metavar="FILE.csv|FILE.parquet", help="write the results table")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_simulate)
