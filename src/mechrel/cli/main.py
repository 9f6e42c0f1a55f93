"""The ``mechrel`` command."""

from __future__ import annotations

import argparse
import sys
import threading
import warnings
from pathlib import Path

from ..errors import Interrupted, MechrelError, MechrelWarning, OutputError

EPILOG = """\
examples:
  mechrel scenes                               list the embedded scenes
  mechrel scenes nine-bar                      describe one scene
  mechrel simulate slider-crank                kinematics of the ideal slider-crank
  mechrel simulate nine-bar-lubricated --out results/nine-bar.csv
  mechrel simulate nine-bar --set joints.C1.model=dry --set joints.C1.clearance=0.3e-3

SCENE is an embedded scene name or a path to a TOML scene file (format: docs/scenes.md).
All values are SI units (m, kg, s, rad, Pa, Pa s).
"""


def _add_scene_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", metavar="SCENE", help="embedded scene name or path to a .toml file")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="PATH=VALUE",
                   help="override a scene value by its dotted path, e.g. "
                        "joints.C1.clearance=0.3e-3 (repeatable)")


def _cmd_scenes(args) -> int:
    from ..scene import list_scenes, load_scene

    if args.name:
        scene = load_scene(args.name)
        print(f"{scene.name}: {scene.description}")
        print(f"  bodies:  {', '.join(scene.bodies)}")
        print("  joints:  " + ", ".join(
            f"{j.name} ({j.type}{', ' + j.model + ' clearance' if j.is_clearance else ''})"
            for j in scene.joints.values()))
        print("  drivers: " + (", ".join(
            f"{d.name} ({d.law}, {d.speed:g} rad/s)" for d in scene.drivers.values()) or "none"))
        print(f"  outputs: {', '.join(scene.outputs)}")
        return 0
    for name, description in list_scenes().items():
        first = description.strip().splitlines()[0] if description.strip() else ""
        print(f"{name:28s} {first}")
    return 0


def _summary_lines(result) -> list[str]:
    st = result.stats
    lines = [f"scene {result.scene.name} ({result.method}): {result.time.size} samples over "
             f"{result.time[-1]:.4g} s",
             f"  solver {st['integrator']}: {st.get('n_steps', 0)} steps, "
             f"{st.get('n_rhs', 0)} rhs evaluations, {st.get('n_rejected', 0)} rejected, "
             f"{st.get('n_impacts', 0)} impacts; max constraint violation "
             f"{st['max_position_violation']:.2e}; wall {st['wall_time']:.3f} s"]
    for name, q in result.outputs.items():
        d = q["displacement"]
        lines.append(f"  output {name}: displacement {d.min() * 1e3:.3f} … {d.max() * 1e3:.3f} mm "
                     f"(stroke {(d.max() - d.min()) * 1e3:.3f} mm), peak |acceleration| "
                     f"{abs(q['acceleration']).max():.4g} m/s²")
        if result.ideal is not None:
            for qty, unit, scale in (("displacement", "mm", 1e3), ("velocity", "m/s", 1.0),
                                     ("acceleration", "m/s²", 1.0)):
                e = result.error(name, qty) * scale
                lines.append(f"    {qty} error {e.min():.4g} … {e.max():.4g} {unit}")
    for name, orb in result.orbits.items():
        lines.append(f"  joint {name}: max eccentricity ratio {orb['eps'].max():.4f}")
    if result.energy:
        b = result.energy["balance"]
        scale = max(abs(result.energy["input_work"]).max(), result.energy["kinetic"].max())
        lines.append(f"  energy balance residual {abs(b).max():.3e} J "
                     f"({abs(b).max() / scale:.2e} of the energy scale)")
    return lines


def _cmd_simulate(args) -> int:
    from ..io import write_json, write_table
    from ..io.figures import plot_simulation
    from ..io.tables import check_table_path
    from ..scene import load_scene
    from ..simulation import simulate

    scene = load_scene(args.scene, overrides=args.overrides)
    if args.out:
        out = check_table_path(args.out)  # before the simulation, not after it
        for sibling in (out.with_suffix(".png"), out.with_suffix(".json"),
                        out.with_name(out.stem + "-orbits" + out.suffix)):
            if sibling.is_dir():
                raise OutputError(f"--out: {str(sibling)!r}, which this run writes beside "
                                  f"{out.name}, is a folder; allowed: a file name (remove or "
                                  "rename the folder)")
    result = simulate(scene, integrator=args.integrator, progress=not args.no_progress)
    print("\n".join(_summary_lines(result)))
    if args.out:
        out = Path(args.out)
        write_table(result.to_frame(), out)
        plot_simulation(result, out.with_suffix(".png"))
        meta = {"provenance": dict(result.provenance), "stats": dict(result.stats),
                "overrides": list(args.overrides)}
        write_json(meta, out.with_suffix(".json"))
        if result.orbits:
            write_table(result.orbits_frame(), out.with_name(out.stem + "-orbits" + out.suffix))
        print(f"wrote {out}, {out.with_suffix('.png')}, {out.with_suffix('.json')}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    parser = argparse.ArgumentParser(
        prog="mechrel",
        description="Dynamic response errors and accuracy reliability of planar mechanisms "
                    "with clearance joints (dry contact, lubricated journal bearings).",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"mechrel {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("scenes", help="list the embedded scenes, or describe one",
                       description="List the embedded scenes, or describe one.")
    p.add_argument("name", nargs="?", help="scene to describe")
    p.set_defaults(func=_cmd_scenes)

    p = sub.add_parser(
        "simulate", help="simulate a scene and print a summary",
        description="Simulate a scene over its analysis span (kinematic analysis for ideal "
                    "driven mechanisms, forward dynamics with clearance joints) and print a "
                    "summary; --out writes the table, a figure (.png) and provenance (.json).",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    _add_scene_args(p)
    p.add_argument("--integrator", help="override solver.integrator (rk4, dopri5, radau, "
                                        "scipy-radau, bdf, lsoda)")
    p.add_argument("--out", metavar="FILE.csv|FILE.parquet", help="write the results table")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_simulate)

    for register in _extra_commands():
        register(sub)
    return parser


def _extra_commands():
    """Subcommands defined by other packages of mechrel (studies, uq)."""
    regs = []
    try:
        from ..studies.cli import register_commands
        regs.append(register_commands)
    except ImportError:
        pass
    return regs


def _raise_interrupted(signum, frame):
    raise Interrupted(signum)


def _interrupted_line(exc: KeyboardInterrupt, args) -> str:
    """One line for an interrupt: by what, and what of the run is kept."""
    import signal

    name = signal.Signals(exc.signum).name if isinstance(exc, Interrupted) else "Ctrl-C"
    line = f"mechrel: interrupted ({name})"
    out = getattr(args, "out", None)
    if args.command in ("reliability", "sensitivity") and out and not args.no_cache:
        line += (f"; the finished model evaluations are kept in {Path(out) / 'evaluations.sqlite'}"
                 ": the same command resumes from them")
    return line


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """mechrel's own warnings as one line ``mechrel: warning: ...``; others as Python shows
    them."""
    if issubclass(category, MechrelWarning):
        print(f"mechrel: warning: {message}", file=sys.stderr if file is None else file)
    else:
        _python_showwarning(message, category, filename, lineno, file, line)


_python_showwarning = warnings.showwarning


def main(argv=None) -> int:
    """The command line. A :class:`~mechrel.errors.MechrelError` is one line on stderr and exit
    code 2; Ctrl-C and SIGTERM stop the run promptly (running integrations at their next step,
    worker processes at once) with one line, exit code 128 + the signal number (130, 143)."""
    import signal

    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    on_main = threading.current_thread() is threading.main_thread()
    old_term = signal.signal(signal.SIGTERM, _raise_interrupted) if on_main else None
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning
            return args.func(args)
    except MechrelError as exc:
        print(f"mechrel: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        print(_interrupted_line(exc, args), file=sys.stderr)
        return 128 + (exc.signum if isinstance(exc, Interrupted) else signal.SIGINT)
    except BrokenPipeError:  # e.g. `mechrel simulate ... | head`: the reader has gone
        import os
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no error at exit
        return 128 + signal.SIGPIPE
    finally:
        if on_main:
            signal.signal(signal.SIGTERM, old_term)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
