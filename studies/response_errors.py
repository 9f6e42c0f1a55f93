"""Dynamic response errors of the slider: the study of Chen, Wang & Gao (2022), §4, on mechrel's
nine-bar, plus the slider-crank benchmark with a clearance joint between rod and slider.

    python studies/response_errors.py --out results/response_errors [--quick]

What is simulated
-----------------
Nine-bar (``nine-bar-dry`` / ``nine-bar-lubricated``; RECONSTRUCTED geometry, see
docs/scenes.md), clearance joints C1 and C2, slider output, as in the paper's Figs. 6–17:

=====================  =======================================================  ==========
comparison             cases                                                    paper
=====================  =======================================================  ==========
dry vs lubricated 3π   dry; lubricated 100 cP; c = 0.5 mm; ω1, ω2 = −3π, +3π     §4.1, 6–8
dry vs lubricated 5π   the same at ω1, ω2 = −5π, +5π rad/s                      §4.1, 9–11
viscosity              lubricated 100 / 200 / 400 cP; 0.5 mm; 3π                 §4.2, 12–14
clearance              lubricated 0.3 / 0.5 / 0.7 mm; 100 cP; 3π                 §4.3, 15–17
=====================  =======================================================  ==========

Slider-crank (``slider-crank-dry`` / ``slider-crank-lubricated``, 5000 rpm, joint rod–slider,
bearing 10 mm, journal 9.5 mm, length 40 mm; lubricated with 400 cP): errors and orbits.

Every case runs two revolutions of the driving crank and the SECOND is analysed: the journals
start centred (e = 0), where a joint carries no force, so the first degrees are a start
transient (lubricated: slider acceleration error −8.1 m/s² at t = 0 in every nine-bar case,
gone by 10°; dry: a first free flight across the clearance and an impact). Times in the
figures and tables are measured from the start of the analysed revolution (t − T), like the
paper's time axis over one cycle.

Outputs are sampled every ``--sample-deg`` degrees of crank rotation (default 0.05°, i.e.
0.09 ms at 3π): the dry joint's acceleration spikes last a fraction of a millisecond, and
their sampled peak is a property of the sampling (nine-bar, dry, 3π, second revolution:
[−61, 74] m/s² sampled every 1°, [−719, 304] every 0.05°, [−744, 318] every 0.01°; the
trajectory itself is the same, the dense output only samples it). Lubricated ranges are
converged to 0.1 % at 0.25°. Dry values are also chaotic: round-off-level changes of the code
move them by ~10 % (docs/validation.md).

Integrators: the scene type's default (``mechrel.simulation.DEFAULT_SOLVERS``: DOPRI5 for dry,
rtol = 1e-8, atol = 1e-11; the compiled Radau for lubricated, rtol = 1e-7, atol = 1e-10); wall
time and solver statistics are recorded per case.

Outputs (in ``--out``)
----------------------
``errors.csv``: one row per comparison, case and quantity: min, max and time of the peak of the
error over the analysed revolution (SI units) beside the paper's published range
(:data:`PAPER_RANGES`, transcribed from §4.1–4.3, restated in docs/reference.md and, given a
text copy of the paper, checked against it with ``--paper FILE``). ``runs.csv``: one row per
case: wall time, integrator, steps, rhs evaluations, impacts, max ε per joint, max constraint
violation, energy balance. ``summary.md``: both as markdown tables, with the figures.
``fig_*.png``: per comparison, errors (3 stacked panels) and journal orbits inside their
clearance circles. ``series/<case>.csv.gz``: the analysed time series (errors and orbits).
"""

from __future__ import annotations

import argparse
import csv
import gzip
import math
import re
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mechrel.scene import load_scene
from mechrel.simulation import simulate

PI = math.pi
QTY = ("displacement", "velocity", "acceleration")
UNIT = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s²"}
# display units for figures and the markdown table
SHOW = {"displacement": ("mm", 1e3), "velocity": ("m/s", 1.0), "acceleration": ("m/s²", 1.0)}
# docs/reference.md restates the ranges of PAPER_RANGES (tests/test_clearance_study.py checks it)
REFERENCE_DOC = Path(__file__).resolve().parents[1] / "docs" / "reference.md"


def _speed(w):
    return {"drivers.crank1.speed": -w, "drivers.crank2.speed": w}


def _both(field_, value):
    return {f"joints.C1.{field_}": value, f"joints.C2.{field_}": value}


@dataclass
class Case:
    key: str
    scene: str
    label: str
    overrides: dict = field(default_factory=dict)
    color: str = "C0"
    style: str = "-"
    joints: tuple = ("C1", "C2")


CASES = {c.key: c for c in [
    Case("dry-3pi", "nine-bar-dry", "dry", _speed(3 * PI), "tab:red", "-"),
    Case("lub-3pi", "nine-bar-lubricated", "lubricated, 100 cP, 0.5 mm", _speed(3 * PI),
         "tab:blue", "-"),
    Case("dry-5pi", "nine-bar-dry", "dry", _speed(5 * PI), "tab:red", "-"),
    Case("lub-5pi", "nine-bar-lubricated", "lubricated, 100 cP", _speed(5 * PI), "tab:blue",
         "-"),
    Case("lub-200cP", "nine-bar-lubricated", "lubricated, 200 cP",
         {**_speed(3 * PI), **_both("lubricant.viscosity", 0.2)}, "tab:green", "--"),
    Case("lub-400cP", "nine-bar-lubricated", "lubricated, 400 cP",
         {**_speed(3 * PI), **_both("lubricant.viscosity", 0.4)}, "tab:purple", "-."),
    Case("lub-0.3mm", "nine-bar-lubricated", "lubricated, c = 0.3 mm",
         {**_speed(3 * PI), **_both("clearance", 0.3e-3)}, "tab:green", "--"),
    Case("lub-0.7mm", "nine-bar-lubricated", "lubricated, c = 0.7 mm",
         {**_speed(3 * PI), **_both("clearance", 0.7e-3)}, "tab:orange", "-."),
    Case("sc-dry", "slider-crank-dry", "dry", {}, "tab:red", "-", ("C",)),
    Case("sc-lub", "slider-crank-lubricated", "lubricated, 400 cP", {}, "tab:blue", "-",
         ("C",)),
]}


@dataclass
class Comparison:
    key: str
    title: str
    cases: tuple
    section: str | None = None  # paper section whose ranges apply
    figures: str | None = None  # the paper's figure numbers
    labels: dict = field(default_factory=dict)  # case label overrides for this comparison


COMPARISONS = [
    Comparison("dry_vs_lubricated_3pi",
               "Nine-bar, dry vs lubricated (100 cP), c = 0.5 mm, ω1 = −3π, ω2 = +3π rad/s",
               ("dry-3pi", "lub-3pi"), "4.1 (3π)", "6–8", {"lub-3pi": "lubricated, 100 cP"}),
    Comparison("dry_vs_lubricated_5pi",
               "Nine-bar, dry vs lubricated (100 cP), c = 0.5 mm, ω1 = −5π, ω2 = +5π rad/s",
               ("dry-5pi", "lub-5pi"), "4.1 (5π)", "9–11"),
    Comparison("viscosity",
               "Nine-bar, lubricated, viscosity 100 / 200 / 400 cP, c = 0.5 mm, ∓3π rad/s",
               ("lub-3pi", "lub-200cP", "lub-400cP"), "4.2", "12–14",
               {"lub-3pi": "lubricated, 100 cP"}),
    Comparison("clearance",
               "Nine-bar, lubricated (100 cP), clearance 0.3 / 0.5 / 0.7 mm, ∓3π rad/s",
               ("lub-0.3mm", "lub-3pi", "lub-0.7mm"), "4.3", "15–17",
               {"lub-3pi": "lubricated, c = 0.5 mm"}),
    Comparison("slider_crank",
               "Slider-crank, 5000 rpm, clearance 0.5 mm at the rod–slider joint: dry vs "
               "lubricated (400 cP)", ("sc-dry", "sc-lub")),
]
QUICK = ("dry_vs_lubricated_3pi", "slider_crank")

# The paper's published ranges [min, max] of the slider's errors (SI: m, m/s, m/s²), in the
# order they appear in the text of §4.1–4.3 (check_paper_ranges re-extracts them).
PAPER_RANGES = [
    ("4.1 (3π)", "dry-3pi", "displacement", -4.047e-3, 7.72e-4),
    ("4.1 (3π)", "lub-3pi", "displacement", -4.097e-3, 6.802e-4),
    ("4.1 (3π)", "dry-3pi", "velocity", -0.2039, 0.2427),
    ("4.1 (3π)", "lub-3pi", "velocity", -0.1229, 0.1385),
    ("4.1 (3π)", "dry-3pi", "acceleration", -365.0, 576.0),
    ("4.1 (3π)", "lub-3pi", "acceleration", -14.01, 24.01),
    ("4.1 (5π)", "dry-5pi", "displacement", -3.444e-3, 7.966e-4),
    ("4.1 (5π)", "lub-5pi", "displacement", -3.449e-3, 7.691e-4),
    ("4.1 (5π)", "dry-5pi", "velocity", -0.3324, 0.3054),
    ("4.1 (5π)", "lub-5pi", "velocity", -0.2114, 0.1911),
    ("4.1 (5π)", "dry-5pi", "acceleration", -581.8, 1386.0),
    ("4.1 (5π)", "lub-5pi", "acceleration", -42.8, 107.6),
    ("4.2", "lub-3pi", "displacement", -4.097e-3, 6.802e-4),
    ("4.2", "lub-200cP", "displacement", -4.018e-3, 6.222e-4),
    ("4.2", "lub-400cP", "displacement", -3.892e-3, 5.274e-4),
    ("4.2", "lub-3pi", "velocity", -0.1229, 0.1386),
    ("4.2", "lub-200cP", "velocity", -0.09714, 0.1037),
    ("4.2", "lub-400cP", "velocity", -0.06477, 0.06576),
    ("4.2", "lub-3pi", "acceleration", -14.01, 24.01),
    ("4.2", "lub-200cP", "acceleration", -4.82, 11.25),
    ("4.2", "lub-400cP", "acceleration", -1.504, 6.338),
    ("4.3", "lub-0.3mm", "displacement", -3.496e-3, -1.617e-4),
    ("4.3", "lub-3pi", "displacement", -4.097e-3, 6.802e-4),
    ("4.3", "lub-0.7mm", "displacement", -4.832e-3, 1.58e-3),
    ("4.3", "lub-0.3mm", "velocity", -0.04091, 0.04001),
    ("4.3", "lub-3pi", "velocity", -0.1229, 0.1385),
    ("4.3", "lub-0.7mm", "velocity", -0.1834, 0.2430),
    ("4.3", "lub-0.3mm", "acceleration", -1.532, 5.624),
    ("4.3", "lub-3pi", "acceleration", -14.01, 24.01),
    ("4.3", "lub-0.7mm", "acceleration", -64.92, 100.5),
]


def paper_range(section, case, qty):
    for s, c, q, lo, hi in PAPER_RANGES:
        if (s, c, q) == (section, case, qty):
            return lo, hi
    return None


def extract_paper_ranges(text: str) -> list[tuple[float, float, str]]:
    """All ``[a unit, b unit]`` ranges of §4.1–4.3 of the paper's text, in order."""
    start = text.index("4.1 Impacts of dry contact")
    end = text.index("Fig. 17 Acceleration error of slider")
    num = r"(-?\d+(?:\.\d+)?)(?:\s*\\times\s*10\s*\^\{\s*(-?\d+)\s*\})?"
    unit = r"\s*\\text\{\s*([^}]*?)\s*\}(\^2)?\s*"
    pattern = re.compile(r"\[\s*" + num + unit + r",\s*" + num + unit + r"\]")
    out = []
    for m in pattern.finditer(text[start:end]):
        lo = float(m.group(1)) * 10.0 ** int(m.group(2) or 0)
        hi = float(m.group(5)) * 10.0 ** int(m.group(6) or 0)
        out.append((lo, hi, m.group(3) + (m.group(4) or "")))
    return out


def documented_ranges(text: str) -> list[tuple[str, str, str, float, float, str]]:
    """The rows (section, case, quantity, min, max, unit) of docs/reference.md's range table."""
    start = text.index("<!-- paper-ranges: begin")
    end = text.index("<!-- paper-ranges: end", start)
    rows = []
    for line in text[start:end].splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 6 and cells[0][:1].isdigit():
            rows.append((cells[0], cells[1], cells[2], float(cells[3]), float(cells[4]),
                         cells[5]))
    return rows


def check_paper_ranges(path: Path) -> None:
    """Raise if :data:`PAPER_RANGES` differs from the ranges in the paper's text."""
    found = extract_paper_ranges(path.read_text(encoding="utf-8"))
    if len(found) != len(PAPER_RANGES):
        raise SystemExit(f"{path}: found {len(found)} ranges in §4.1–4.3, transcribed "
                         f"{len(PAPER_RANGES)}")
    units = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2"}
    for (s, c, q, lo, hi), (flo, fhi, u) in zip(PAPER_RANGES, found):
        if not (math.isclose(lo, flo, rel_tol=1e-12) and math.isclose(hi, fhi, rel_tol=1e-12)
                and u == units[q]):
            raise SystemExit(f"{path}: transcription differs for §{s} {c} {q}: "
                             f"[{lo}, {hi}] vs [{flo}, {fhi}] {u}")
    print(f"paper ranges: {len(found)} ranges of §4.1–4.3 match {path}")


# ------------------------------------------------------------------------------ simulation ---

@dataclass
class Run:
    case: Case
    t: np.ndarray  # time since the start of the analysed revolution (s)
    angle: np.ndarray  # crank angle since that start (deg)
    errors: dict  # quantity -> error (SI)
    orbits: dict  # joint -> (ex, ey) (m)
    clearance: dict  # joint -> c (m)
    stats: dict


def run_case(case: Case, sample_deg: float) -> Run:
    scene = load_scene(case.scene, overrides={**case.overrides, "analysis.cycles": 2,
                                              "analysis.sample_step_angle":
                                                  math.radians(sample_deg)})
    t0 = time.perf_counter()
    res = simulate(scene)
    wall = time.perf_counter() - t0
    period = 2 * PI / abs(scene.drivers[scene.analysis.cycle_driver].speed)
    keep = res.crank_angle >= 360.0 - 1e-9
    E = res.energy
    scale = max(E["kinetic"].max(), np.abs(E["input_work"]).max(),
                np.abs(E["dissipated"]).max())
    st = res.stats
    stats = {"case": case.key, "scene": case.scene,
             "overrides": " ".join(f"{k}={v:g}" for k, v in case.overrides.items()),
             "integrator": st["integrator"], "rtol": st["settings"].get("rtol"),
             "wall_time_s": wall, "n_steps": st["n_steps"], "n_rhs": st["n_rhs"],
             "n_rejected": st["n_rejected"], "n_impacts": st["n_impacts"],
             "max_position_violation_m": st["max_position_violation"],
             "energy_balance_rel": float(np.max(np.abs(E["balance"])) / scale),
             "dissipated_J": float(E["dissipated"][-1] - E["dissipated"][np.argmax(keep)]),
             "input_work_J": float(E["input_work"][-1] - E["input_work"][np.argmax(keep)])}
    for j in case.joints:
        stats[f"max_eps_{j}"] = float(res.orbits[j]["eps"][keep].max())
    return Run(case=case, t=res.time[keep] - period, angle=res.crank_angle[keep] - 360.0,
               errors={q: res.error("slider", q)[keep] for q in QTY},
               orbits={j: (res.orbits[j]["ex"][keep], res.orbits[j]["ey"][keep])
                       for j in case.joints},
               clearance={j: scene.joints[j].clearance for j in case.joints}, stats=stats)


# ---------------------------------------------------------------------------------- tables ---

def error_rows(comparisons, runs):
    rows = []
    for comp in comparisons:
        for key in comp.cases:
            r = runs[key]
            for q in QTY:
                e = r.errors[q]
                k = int(np.argmax(np.abs(e)))
                pr = paper_range(comp.section, key, q) if comp.section else None
                rows.append({
                    "comparison": comp.key, "paper_figures": comp.figures or "",
                    "case": key, "label": comp.labels.get(key, r.case.label), "quantity": q,
                    "unit": UNIT[q], "min": float(e.min()), "max": float(e.max()),
                    "t_peak_s": float(r.t[k]),
                    "paper_min": pr[0] if pr else None, "paper_max": pr[1] if pr else None,
                    "wall_time_s": r.stats["wall_time_s"], "integrator": r.stats["integrator"],
                    "n_steps": r.stats["n_steps"], "n_rhs": r.stats["n_rhs"]})
    return rows


def write_csv(path, rows):
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        for row in rows:
            w.writerow({k: ("" if v is None else v) for k, v in row.items()})


def _rng(lo, hi, q):
    unit, f = SHOW[q]
    if lo is None:
        return "–"
    digits = 3 if q != "acceleration" else 3
    return f"[{lo * f:.{digits}g}, {hi * f:.{digits}g}]"


def markdown(comparisons, rows, run_rows, figures, settings):
    out = ["# Slider response errors: Chen, Wang & Gao (2022) §4 on mechrel's nine-bar", "",
           "The nine-bar's geometry is a RECONSTRUCTION (the paper does not publish the ground "
           "pivot of rod 5 or the plate layout): compare trends, not absolute values "
           "(docs/validation.md).", "", settings, "",
           "## Error ranges [min, max] over the analysed revolution", "",
           "Displacement in mm, velocity in m/s, acceleration in m/s². *t_peak*: time of the "
           "largest |error| from the start of the analysed revolution.", ""]
    for comp in comparisons:
        out += [f"### {comp.title}", ""]
        if comp.figures:
            out += [f"Paper: §{comp.section}, Figs. {comp.figures}.", ""]
        out += ["| case | quantity | mechrel [min, max] | t_peak (s) | paper [min, max] |",
                "|---|---|---|---|---|"]
        for row in rows:
            if row["comparison"] != comp.key:
                continue
            q = row["quantity"]
            out.append(f"| {row['label']} | {q} ({SHOW[q][0]}) | "
                       f"{_rng(row['min'], row['max'], q)} | {row['t_peak_s']:.4f} | "
                       f"{_rng(row['paper_min'], row['paper_max'], q)} |")
        out += ["", *[f"![{comp.key} {kind}]({figures[comp.key][kind]})"
                      for kind in ("errors", "orbits")], ""]
    out += ["## Runs (two revolutions each; wall time of `simulate`, warm cache)", "",
            "| case | scene | overrides | integrator | wall (s) | steps | rhs | impacts | "
            "max ε | max \\|Φ\\| (m) | energy balance / scale |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in run_rows:
        eps = ", ".join(f"{k[8:]} {v:.4f}" for k, v in r.items() if k.startswith("max_eps_"))
        out.append(f"| {r['case']} | {r['scene']} | {r['overrides'] or '–'} | "
                   f"{r['integrator']} | {r['wall_time_s']:.2f} | {r['n_steps']} | "
                   f"{r['n_rhs']} | {r['n_impacts']} | {eps} | "
                   f"{r['max_position_violation_m']:.1e} | {r['energy_balance_rel']:.1e} |")
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------------- figures ---

def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": 10, "axes.titlesize": 10, "legend.fontsize": 9,
                         "axes.grid": True, "grid.alpha": 0.3})
    return plt


def plot_errors(comp: Comparison, runs, path):
    plt = _plt()
    fig, axes = plt.subplots(3, 1, figsize=(8.0, 8.6), sharex=True, constrained_layout=True)
    has_dry = any(runs[k].case.scene.endswith("-dry") for k in comp.cases)
    for ax, q in zip(axes, QTY):
        unit, f = SHOW[q]
        for key in comp.cases:
            r = runs[key]
            dry = r.case.scene.endswith("-dry")
            ax.plot(r.t, r.errors[q] * f, color=r.case.color, ls=r.case.style,
                    lw=0.8 if dry else 1.4, alpha=0.85 if dry else 1.0,
                    label=comp.labels.get(key, r.case.label), zorder=1 if dry else 2)
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_ylabel(f"{q} error ({unit})")
        if q == "acceleration" and has_dry:
            # dry spikes are 10–100× the lubricated errors: symmetric log scale, linear up to
            # about half the smallest case's peak (1 significant digit)
            low = 0.5 * min(np.abs(runs[k].errors[q]).max() for k in comp.cases) * f
            lin = float(f"{low:.0e}")
            ax.set_yscale("symlog", linthresh=lin, linscale=1.0)
            ax.set_ylabel(f"{q} error ({unit})\nsymmetric log, linear within ±{lin:g}")
    axes[0].legend(loc="best", ncol=len(comp.cases), frameon=True)
    period = runs[comp.cases[0]].t[-1]
    axes[-1].set_xlim(0.0, period)
    axes[-1].set_xlabel("time from the start of the analysed (second) revolution of the "
                        "crank, t − T (s)")
    fig.suptitle(comp.title + "\nslider response error = with clearance − ideal", fontsize=10.5)
    fig.savefig(path, dpi=130)
    plt.close(fig)


def plot_orbits(comp: Comparison, runs, path):
    import textwrap

    plt = _plt()
    joints = runs[comp.cases[0]].case.joints
    fig, axes = plt.subplots(1, len(joints), figsize=(max(7.0, 4.6 * len(joints) + 0.6), 6.2),
                             layout="constrained", squeeze=False)
    th = np.linspace(0, 2 * PI, 400)
    for ax, j in zip(axes[0], joints):
        drawn = set()
        for key in comp.cases:
            r = runs[key]
            c = r.clearance[j]
            if c not in drawn:
                ax.plot(c * 1e3 * np.cos(th), c * 1e3 * np.sin(th), color="0.35", lw=1.0,
                        ls=":", zorder=0)
                drawn.add(c)
            ex, ey = r.orbits[j]
            eps = r.stats[f"max_eps_{j}"]
            dry = r.case.scene.endswith("-dry")
            ax.plot(ex * 1e3, ey * 1e3, color=r.case.color, ls=r.case.style,
                    lw=0.7 if dry else 1.4, alpha=0.8 if dry else 1.0,
                    label=f"{comp.labels.get(key, r.case.label)}: max ε = {eps:.3f}")
            ax.plot(ex[0] * 1e3, ey[0] * 1e3, "o", ms=4, color=r.case.color)
        ax.plot(0, 0, "+", color="k", ms=8)
        ax.set_aspect("equal")
        lim = max(drawn) * 1e3 * 1.12
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_xlabel("e_x (mm)")
        ax.set_ylabel("e_y (mm)")
        ax.set_title(f"joint {j}")
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), fontsize=8.5, frameon=False)
    title = textwrap.fill(comp.title, 70 if len(joints) == 1 else 120)
    fig.suptitle(title + "\njournal centre relative to the bearing centre over the analysed "
                 "revolution\n(dots: its start; dotted circles: the clearance c)", fontsize=10)
    fig.savefig(path, dpi=130, bbox_inches="tight")  # the legends below the axes included
    plt.close(fig)


def write_series(run: Run, path: Path):
    cols = {"t_minus_T_s": run.t, "crank_angle_deg": run.angle}
    for q in QTY:
        cols[f"{q}_error"] = run.errors[q]
    for j, (ex, ey) in run.orbits.items():
        cols[f"{j}_ex_m"] = ex
        cols[f"{j}_ey_m"] = ey
    with gzip.open(path, "wt", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(list(cols))
        for row in zip(*cols.values()):
            w.writerow([f"{x:.9g}" for x in row])


# ------------------------------------------------------------------------------------ main ---

def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="results/response_errors", help="output directory")
    ap.add_argument("--quick", action="store_true",
                    help="smoke test: the 3π dry/lubricated comparison and the slider-crank "
                         "only, sampled every 0.25°")
    ap.add_argument("--sample-deg", type=float, default=None,
                    help="output sampling in degrees of crank rotation (default 0.05, "
                         "--quick 0.25)")
    ap.add_argument("--paper", type=Path, default=None,
                    help="a text copy of the paper (not in the repository), to check the "
                         "transcribed ranges against it before running")
    args = ap.parse_args(argv)
    sample = args.sample_deg or (0.25 if args.quick else 0.05)
    out = Path(args.out)
    (out / "series").mkdir(parents=True, exist_ok=True)
    if args.paper is not None:
        if not args.paper.is_file():
            ap.error(f"--paper = {args.paper}: no such file; allowed: a text copy of the paper")
        check_paper_ranges(args.paper)

    comparisons = [c for c in COMPARISONS if not args.quick or c.key in QUICK]
    needed = list(dict.fromkeys(k for c in comparisons for k in c.cases))
    # warm the compiled kernels once per scene type so that wall times are warm
    for scene in dict.fromkeys(CASES[k].scene for k in needed):
        simulate(load_scene(scene, overrides={"analysis.cycles": 0.01}))

    runs = {}
    for key in needed:
        runs[key] = run_case(CASES[key], sample)
        s = runs[key].stats
        print(f"{key:10s} {s['integrator']:7s} {s['wall_time_s']:6.2f} s  steps {s['n_steps']:6d}"
              f"  rhs {s['n_rhs']:7d}  impacts {s['n_impacts']:4d}  "
              + "  ".join(f"{k}={v:.4f}" for k, v in s.items() if k.startswith("max_eps")),
              flush=True)
        write_series(runs[key], out / "series" / f"{key}.csv.gz")

    figures = {}
    for comp in comparisons:
        figures[comp.key] = {"errors": f"fig_{comp.key}_errors.png",
                             "orbits": f"fig_{comp.key}_orbits.png"}
        plot_errors(comp, runs, out / figures[comp.key]["errors"])
        plot_orbits(comp, runs, out / figures[comp.key]["orbits"])

    rows = error_rows(comparisons, runs)
    run_rows = [runs[k].stats for k in needed]
    write_csv(out / "errors.csv", rows)
    write_csv(out / "runs.csv", [{k: r.get(k) for k in _run_fields(run_rows)} for r in run_rows])
    used = ", ".join(sorted({f"{r['integrator']} rtol = {r['rtol']:g}" for r in run_rows}))
    settings = (f"Settings: two revolutions of the driving crank, the second analysed; outputs "
                f"every {sample:g}° of crank rotation; each scene type's default integrator "
                f"({used}). Command: `python studies/response_errors.py --out {out}"
                f"{' --quick' if args.quick else ''}"
                f"{'' if args.sample_deg is None else f' --sample-deg {args.sample_deg:g}'}`.")
    (out / "summary.md").write_text(markdown(comparisons, rows, run_rows, figures, settings),
                                    encoding="utf-8")
    print(f"wrote {out}/summary.md, errors.csv, runs.csv and "
          f"{2 * len(comparisons)} figures", file=sys.stderr)


def _run_fields(run_rows):
    keys = []
    for r in run_rows:
        for k in r:
            if k not in keys:
                keys.append(k)
    return keys


if __name__ == "__main__":
    main()
