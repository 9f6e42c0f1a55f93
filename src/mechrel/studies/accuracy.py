"""What accuracy costs in time, measured on the user's own scene: ``mechrel accuracy SCENE``.

Each integrator setting (RK4 step sizes, DOPRI5 tolerances, stiff tolerances) runs the scene;
its error is measured against a tight-tolerance reference and plotted against wall time.

Error measures
--------------
* **pointwise** (ideal and lubricated scenes, whose trajectories converge): the maximum over
  the output instants of |x − x_ref| for the displacement, velocity and acceleration of the
  first output, each divided by that quantity's range over the reference;
* **statistical** (dry and transition scenes: dry contact at speed is chaotic, a 1 nm change
  of the initial state moves the slider by micrometres within a revolution, so pointwise
  errors do not converge with the step; see equations.md): the relative difference of the
  peak |error|, the RMS error and the 95th percentile of |error| over the cycle, for each
  quantity; the measure is the largest of them.

The recommendation is the fastest setting whose measure is below ``target`` (default 1 %).
Wall times are the minimum of ``repeats`` warm runs (the compiled kernels are loaded first).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import MechrelError
from ..scene.model import QUANTITIES


def _stat_measures(err: np.ndarray) -> np.ndarray:
    a = np.abs(err)
    return np.array([a.max(), math.sqrt(np.mean(err ** 2)), np.percentile(a, 95)])


def default_candidates(scene, kind: str, quick: bool = False) -> list[tuple[str, dict]]:
    """Integrator settings to try for a scene type."""
    from ..integrate import INTEGRATORS
    from ..simulation import compile_scene

    period = compile_scene(scene).period or scene.analysis_duration
    cands: list[tuple[str, dict]] = []
    tols = [1e-4, 1e-6, 1e-8] if quick else [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9]
    divisions = [2e3, 8e3] if quick else [1e3, 2e3, 4e3, 8e3, 16e3, 32e3]
    if kind in ("ideal", "dry", "transition"):
        cands += [("rk4", {"step": period / d}) for d in divisions]
        cands += [("dopri5", {"rtol": t, "atol": t * 1e-3}) for t in tols]
    stiff = [name for name in ("radau", "lsoda") if name in INTEGRATORS]
    if kind in ("lubricated", "transition", "ideal"):
        for name in stiff:
            cands += [(name, {"rtol": t, "atol": t * 1e-3}) for t in tols]
        if kind == "lubricated":
            cands += [("dopri5", {"rtol": t, "atol": t * 1e-3}) for t in tols[:2]]
    return cands


@dataclass(frozen=True)
class AccuracyReport:
    """Error against wall time for each integrator setting (frozen).

    ``table`` has one row per setting: ``integrator``, ``setting``, ``wall_time`` (s),
    ``n_steps``, ``n_rhs``, ``error_<quantity>`` and ``measure`` (the largest), or ``failed``
    with the reason."""

    scene: str
    kind: str
    measure: str
    target: float
    reference: dict
    table: pd.DataFrame
    recommended: dict | None
    provenance: dict = field(repr=False, default_factory=dict)

    def to_frame(self) -> pd.DataFrame:
        return self.table.copy()

    def plot(self, path=None):
        import matplotlib
        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7.5, 5), constrained_layout=True)
        ok = self.table[self.table["failed"] == ""]
        for k, (name, grp) in enumerate(ok.groupby("integrator", sort=False)):
            ax.loglog(grp["wall_time"], grp["measure"], "o-", color=f"C{k}", label=name)
            for _, r in grp.iterrows():
                ax.annotate(r["setting"], (r["wall_time"], r["measure"]), fontsize=6,
                            xytext=(3, 3), textcoords="offset points")
        ax.axhline(self.target, color="k", ls=":", lw=1, label=f"target {self.target:g}")
        if self.recommended:
            ax.plot([self.recommended["wall_time"]], [self.recommended["measure"]], "*",
                    ms=16, color="gold", mec="k", label="recommended")
        from matplotlib.ticker import NullFormatter
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("wall time per run (s)")
        ax.set_ylabel(f"error ({self.measure}, relative)")
        ax.set_title(f"{self.scene}: what accuracy costs in time")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
        if path is not None:
            fig.savefig(path, dpi=130)
            plt.close(fig)
        return fig


def accuracy_report(scene, *, candidates=None, reference=None, target: float = 0.01,
                    repeats: int = 2, quick: bool = False, progress: bool = False
                    ) -> AccuracyReport:
    """Measure error against wall time of integrator settings on ``scene``.

    Parameters
    ----------
    scene : Scene
    candidates : list of (integrator, settings), optional
        Default: :func:`default_candidates` for the scene type.
    reference : (integrator, settings), optional
        Default: the scene type's stiff or adaptive method at rtol 1e-11.
    target : float
        Relative error the recommendation must meet.
    repeats : int
        Warm runs per setting; the minimum wall time is reported.
    """
    from ..integrate import INTEGRATORS
    from ..simulation import scene_kind, simulate

    kind = scene_kind(scene)
    statistical = kind in ("dry", "transition")
    if reference is None:
        stiff = "radau" if "radau" in INTEGRATORS else "lsoda"
        reference = ((stiff, {"rtol": 1e-11, "atol": 1e-14}) if kind == "lubricated"
                     else ("dopri5", {"rtol": 1e-11, "atol": 1e-14}))
    t0 = time.perf_counter()
    ref = simulate(scene, method="dynamics", integrator=reference[0], **reference[1])
    output = next(iter(ref.outputs))

    def curves(res):
        if res.ideal is not None:
            return {q: res.error(output, q) for q in QUANTITIES}
        return {q: res.outputs[output][q] for q in QUANTITIES}

    ref_c = curves(ref)
    scale = {q: max(np.ptp(ref_c[q]), 1e-300) for q in QUANTITIES}
    ref_stats = {q: _stat_measures(ref_c[q]) for q in QUANTITIES}
    rows = []
    cands = candidates if candidates is not None else default_candidates(scene, kind, quick)
    iterator = cands
    if progress:
        from tqdm.auto import tqdm
        iterator = tqdm(cands, desc=f"accuracy {scene.name}", unit="setting")
    for name, settings in iterator:
        label = ", ".join(f"{k}={v:.3g}" for k, v in settings.items())
        row = {"integrator": name, "setting": label, "failed": ""}
        try:
            best = math.inf
            for _ in range(max(1, repeats)):
                start = time.perf_counter()
                res = simulate(scene, method="dynamics", integrator=name, **settings)
                best = min(best, time.perf_counter() - start)
        except MechrelError as exc:
            row.update(failed=str(exc)[:200], wall_time=np.nan, measure=np.nan)
            rows.append(row)
            continue
        c = curves(res)
        errs = {}
        for q in QUANTITIES:
            if statistical:
                s = _stat_measures(c[q])
                errs[q] = float(np.max(np.abs(s - ref_stats[q]) / np.maximum(ref_stats[q],
                                                                               1e-300)))
            else:
                errs[q] = float(np.max(np.abs(c[q] - ref_c[q])) / scale[q])
        row.update(wall_time=best, n_steps=res.stats["n_steps"], n_rhs=res.stats["n_rhs"],
                   max_violation=res.stats["max_position_violation"],
                   **{f"error_{q}": v for q, v in errs.items()}, measure=max(errs.values()))
        rows.append(row)
    table = pd.DataFrame(rows)
    ok = table[(table["failed"] == "") & (table["measure"] <= target)]
    recommended = None
    if len(ok):
        r = ok.loc[ok["wall_time"].idxmin()]
        recommended = {"integrator": r["integrator"], "setting": r["setting"],
                       "wall_time": float(r["wall_time"]), "measure": float(r["measure"])}
    from ..simulation import _provenance
    return AccuracyReport(scene=scene.name, kind=kind,
                          measure="statistics of the error curves" if statistical
                          else "max pointwise error / range",
                          target=target, reference={"integrator": reference[0],
                                                    **reference[1]},
                          table=table, recommended=recommended,
                          provenance=_provenance(scene, time.perf_counter() - t0))


def run_accuracy(scene, *, target=0.01, quick=False, out=None, progress=True):
    """CLI runner: table printed, ``accuracy.csv`` and ``accuracy.png`` in ``out``."""
    rep = accuracy_report(scene, target=target, quick=quick, progress=progress)
    cols = ["integrator", "setting", "wall_time", "n_steps", "n_rhs", "measure", "failed"]
    t = rep.table[[c for c in cols if c in rep.table]]
    lines = [f"scene {rep.scene} ({rep.kind}); error measure: {rep.measure}; reference "
             f"{rep.reference}",
             t.to_string(index=False, float_format=lambda v: f"{v:.3g}")]
    if rep.recommended:
        r = rep.recommended
        lines.append(f"recommended: solver.integrator = {r['integrator']!r} with {r['setting']} "
                     f"(error {r['measure']:.2g} ≤ {target:g}, {r['wall_time']:.3g} s per run)")
    else:
        lines.append(f"no setting met the target {target:g}; tighten the candidates")
    if out:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        from ..io import write_table
        write_table(rep.table, out / "accuracy.csv")
        rep.plot(out / "accuracy.png")
        lines.append(f"wrote {out}/accuracy.csv, accuracy.png")
    return lines, rep
