"""What accuracy costs in time, measured on the user's own scene: ``mechrel accuracy SCENE``.

Each integrator setting (RK4 step sizes, DOPRI5 tolerances, stiff tolerances) runs the scene;
its error is measured against a tight-tolerance reference and plotted against wall time.

Error measures
--------------
* **pointwise** (ideal and lubricated scenes, whose trajectories converge): the maximum over
  the output instants of |x − x_ref| for each quantity of the first output (a point's
  displacement, velocity and acceleration; a body's angle and its rates; ...), each divided
  by that quantity's range over the reference;
* **ensemble statistics** (dry and transition scenes). Dry contact at speed is chaotic: a 1 nm
  change of the initial state moves the slider by micrometres within a revolution, so
  pointwise errors do not converge with the step, and even the statistics of the error curve
  of *one* trajectory (peak |error|, RMS error, 95th percentile of |error|) differ by 1–75 %
  between two equally converged runs (docs/performance.md). Those statistics are therefore
  treated as random variables: the setting and the reference each run the same ensemble of
  ``R`` initial states, the journal's initial eccentricity moved by ``perturbation`` × the
  clearance (default 1e-6: 0.5 nm at 0.5 mm) in a seeded random direction
  (:func:`perturbed_scenes`). Per statistic, the error is the difference of the ensemble
  means relative to the reference's mean, and its *floor* is the standard error of that
  difference (:func:`compare_ensembles`); the measure is the largest error, the floor the
  largest standard error, over the three statistics of the three quantities.

Verdicts
--------
With ``t`` the one-sided ``confidence`` (95 %) Student-t quantile for ``R − 1`` degrees of
freedom (the member statistics are taken as roughly normal), a setting

* **meets** the target when ``|error| + t · floor <= target`` for every statistic (the upper
  confidence bound is below the target: it has been *shown* accurate enough; requiring all
  nine bounds needs no multiple-comparison correction);
* **exceeds** it when ``|error| − t' · floor > target`` for some statistic, where ``t'`` is
  the two-sided quantile Bonferroni-corrected over the nine statistics (three of each of a
  point's three quantities; 1 − 0.05/18 at 95 %: 3.9 for R = 8, 7.2 for R = 4; twelve for a
  joint output's four). Without the correction, an accurate setting of a chaotic
  scene would be declared inaccurate by chance in about half the reports, since *some* of
  nine noise-dominated differences usually exceeds one t;
* is **unresolved** otherwise: the ensemble is too small to tell. When no setting meets the
  target and some are unresolved, no recommendation can be made at this ``R``; the floor falls
  as 1/√R, so the report states the ``R`` at which a setting with the unresolved settings'
  median floor and no error would meet the target (:attr:`AccuracyReport.ensemble_needed`,
  ≈ R (t · floor / target)²; the median, because the smallest of several floors estimated
  from R members each is biased low).

Pointwise settings meet the target when the measure is below it and exceed it otherwise.
The recommendation is the fastest setting that meets the target (default 1 %).

Wall time per run: pointwise, the minimum of ``repeats`` warm runs; ensembles, the median of
the ``R`` member runs (each run once, after one untimed run per integrator that loads its
compiled kernels), and ``wall_total`` is the whole ensemble's time.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field
from numbers import Integral

import numpy as np
import pandas as pd

from ..errors import MechrelError, SimulationWarning, StudyError
from ..forces.models import MODELS

STATISTICS = ("peak", "rms", "p95")
"""The statistics of an error curve compared in ensemble mode: peak |error|, RMS error and
the 95th percentile of |error| (the order of :func:`_stat_measures`)."""

DEFAULT_ENSEMBLE = 8
"""Members per ensemble for chaotic scenes: the floor (∝ 1/√R) against the R-fold cost."""

DEFAULT_PERTURBATION = 1e-6
"""Size of the initial-eccentricity perturbation, relative to the clearance: nanometres,
far below any manufacturing tolerance, yet well above the assembly tolerance (1e-12 m by
default; a smaller offset would not survive assembly, which stops when |Φ| <= tolerance)."""

FILES = ("accuracy.csv", "accuracy.png")
"""What ``mechrel accuracy`` writes into its output folder (one set, :mod:`mechrel.io.results`)."""
CHAOTIC_KINDS = tuple(m.name for m in MODELS.values() if m.chaotic)
"""Scene kinds measured by ensemble statistics (impacts make their trajectories chaotic):
the clearance models marked ``chaotic`` in the table of models."""


def _stat_measures(err: np.ndarray) -> np.ndarray:
    a = np.abs(err)
    return np.array([a.max(), math.sqrt(np.mean(err ** 2)), np.percentile(a, 95)])


def _check_ensemble(ensemble) -> int:
    if isinstance(ensemble, bool) or not isinstance(ensemble, Integral):
        raise StudyError(f"ensemble: {ensemble!r} is not an integer; it is the number of "
                         "perturbed initial states per setting (at least 2)")
    if ensemble < 2:
        raise StudyError(f"ensemble: {ensemble} members cannot give a spread; use at least 2 "
                         f"(default {DEFAULT_ENSEMBLE}; the floor falls as 1/sqrt(R))")
    return int(ensemble)


def student_t(confidence: float, ensemble: int) -> float:
    """One-sided Student-t quantile for ``ensemble − 1`` degrees of freedom.

    Parameters
    ----------
    confidence : float
        One-sided confidence level, in (0, 1).
    ensemble : int
        Members R (>= 2).

    Returns
    -------
    float
        t such that P(T_{R−1} <= t) = ``confidence``.

    Examples
    --------
    >>> round(student_t(0.95, 8), 4)   # 7 degrees of freedom
    1.8946
    """
    from scipy.stats import t

    return float(t.ppf(confidence, ensemble - 1))


def perturbed_scenes(scene, ensemble: int, seed: int = 0,
                     perturbation: float = DEFAULT_PERTURBATION) -> list:
    """The ensemble: ``scene`` with each clearance joint's initial eccentricity perturbed.

    Member ``i`` moves every clearance joint's ``initial_eccentricity`` by
    ``perturbation × clearance`` (at least 10 × ``solver.assembly_tolerance``, so that the
    offset survives assembly) in a direction drawn from the ``i``-th child of
    ``numpy.random.SeedSequence(seed)``. Member ``i`` therefore depends only on ``seed`` and
    ``i``: enlarging the ensemble keeps the existing members, and the same members are used
    for every setting and the reference (common random numbers, see
    :func:`compare_ensembles`).

    Parameters
    ----------
    scene : Scene
        A scene with at least one clearance joint.
    ensemble : int
        Number of members R (>= 2).
    seed : int
        Root seed (>= 0).
    perturbation : float
        Offset size relative to the clearance (0 < perturbation <= 1e-3).

    Returns
    -------
    list of Scene
        Validated scenes (through :func:`mechrel.scene.load_scene` overrides).

    Raises
    ------
    mechrel.errors.StudyError
        A bad ``ensemble``, ``seed`` or ``perturbation``, or a scene without clearance joints
        (or with one too small to perturb).

    Examples
    --------
    Offsets of 1e-6 × 0.5 mm = 0.5 nm, in random directions:

    >>> from mechrel.scene import load_scene
    >>> members = perturbed_scenes(load_scene("slider-crank-dry"), 2, seed=1)
    >>> [round(math.hypot(*m.joints["C"].initial_eccentricity), 15) for m in members]
    [5e-10, 5e-10]
    """
    from ..scene import load_scene

    ensemble = _check_ensemble(ensemble)
    if not isinstance(seed, Integral) or isinstance(seed, bool) or seed < 0:
        raise StudyError(f"seed: {seed!r} is not a non-negative integer")
    if not (isinstance(perturbation, (int, float)) and 0.0 < perturbation <= 1e-3):
        raise StudyError(f"perturbation: {perturbation!r} is not in (0, 1e-3]; it is the "
                         "initial-eccentricity offset relative to the clearance, meant to be "
                         "far below any physical tolerance (default "
                         f"{DEFAULT_PERTURBATION:g})")
    joints = scene.clearance_joints
    if not joints:
        raise StudyError(f"scene {scene.name!r} has no clearance joint whose initial "
                         "eccentricity could be perturbed")
    floor_offset = 10.0 * scene.solver.assembly_tolerance
    members = []
    for child in np.random.SeedSequence(seed).spawn(ensemble):
        rng = np.random.default_rng(child)
        overrides = {}
        for j in joints:
            size = max(perturbation * j.clearance, floor_offset)
            if size > 1e-3 * j.clearance:
                raise StudyError(f"joints.{j.name}: clearance {j.clearance:g} m is too small "
                                 "for a perturbation above 10 x the assembly tolerance "
                                 f"({scene.solver.assembly_tolerance:g} m) and below 1e-3 of "
                                 "the clearance")
            phi = rng.uniform(0.0, 2.0 * math.pi)
            e0 = j.initial_eccentricity
            overrides[f"joints.{j.name}.initial_eccentricity"] = [
                e0[0] + size * math.cos(phi), e0[1] + size * math.sin(phi)]
        members.append(load_scene(scene, overrides=overrides))
    return members


@dataclass(frozen=True)
class EnsembleRun:
    """One integrator setting run on every member of an ensemble.

    Parameters
    ----------
    integrator : str
        The integrator's name.
    settings : dict
        Its settings (``step``, ``rtol``, ``atol``).
    statistics : ndarray, shape (R, n_quantities, 3)
        Per member, per quantity of the output's kind (:data:`mechrel.outputs.OUTPUT_KINDS`;
        a point's displacement, velocity, acceleration), the statistics :data:`STATISTICS`
        of the error curve (SI units of the quantity).
    wall_times : ndarray, shape (R,)
        Wall time of each member run (s).
    n_steps, n_rhs : ndarray, shape (R,)
        Accepted steps and right-hand-side evaluations per member.
    max_violation : float
        Largest position-constraint violation over the members (m or rad).

    Examples
    --------
    :func:`run_ensemble` makes one (a short run of the dry slider-crank, two members):

    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-dry", overrides=["analysis.cycles=0.05"])
    >>> run = run_ensemble(perturbed_scenes(scene, 2), "dopri5", {"rtol": 1e-6, "atol": 1e-9})
    >>> run.statistics.shape, run.wall_times.shape   # (R, quantities, statistics)
    ((2, 3, 3), (2,))
    """

    integrator: str
    settings: dict
    statistics: np.ndarray
    wall_times: np.ndarray
    n_steps: np.ndarray
    n_rhs: np.ndarray
    max_violation: float


def _quantities(scene, output):
    """The quantities measured: those of the scene output's kind (the first output's by
    default; :data:`mechrel.outputs.OUTPUT_KINDS`)."""
    from ..outputs import quantities_of

    return quantities_of(scene.outputs[output or next(iter(scene.outputs))])


def _curves(res, output):
    quantities = _quantities(res.scene, output)
    if res.ideal is not None:
        return {q: res.error(output, q) for q in quantities}
    return {q: res.outputs[output][q] for q in quantities}


def run_ensemble(members, integrator: str, settings: dict | None = None,
                 output: str | None = None) -> EnsembleRun:
    """Run one integrator setting on each member of an ensemble (see :func:`perturbed_scenes`).

    Parameters
    ----------
    members : list of Scene
        The ensemble.
    integrator : str
        The integrator's name.
    settings : dict, optional
        ``step``, ``rtol``, ``atol``.
    output : str, optional
        The scene output whose error curves are measured (default: the first).

    Returns
    -------
    EnsembleRun
        The members' error statistics and costs.

    Raises
    ------
    SimulationError
        If a member fails; the message names the member.

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-dry", overrides=["analysis.cycles=0.05"])
    >>> run = run_ensemble(perturbed_scenes(scene, 2), "dopri5", {"rtol": 1e-6, "atol": 1e-9})
    >>> run.integrator, run.n_steps.shape, bool(run.max_violation < 1e-6)
    ('dopri5', (2,), True)
    """
    from ..simulation import simulate

    settings = dict(settings or {})
    stats, walls, steps, rhs, viol = [], [], [], [], 0.0
    for i, member in enumerate(members):
        start = time.perf_counter()
        try:
            res = simulate(member, method="dynamics", integrator=integrator, **settings)
        except MechrelError as exc:
            raise type(exc)(f"ensemble member {i}: {exc}") from exc
        walls.append(time.perf_counter() - start)
        name = output or next(iter(res.outputs))
        c = _curves(res, name)
        stats.append([_stat_measures(c[q]) for q in _quantities(res.scene, name)])
        steps.append(res.stats["n_steps"])
        rhs.append(res.stats.get("n_rhs", 0))
        viol = max(viol, float(res.stats["max_position_violation"]))
    return EnsembleRun(integrator=integrator, settings=settings,
                       statistics=np.asarray(stats, dtype=float),
                       wall_times=np.asarray(walls), n_steps=np.asarray(steps, dtype=float),
                       n_rhs=np.asarray(rhs, dtype=float), max_violation=viol)


def ensemble_statistics(scene, integrator: str, settings: dict | None = None, *,
                        ensemble: int = DEFAULT_ENSEMBLE, seed: int = 0,
                        perturbation: float = DEFAULT_PERTURBATION) -> EnsembleRun:
    """:func:`run_ensemble` on :func:`perturbed_scenes` ``(scene, ensemble, seed,
    perturbation)``.

    Parameters
    ----------
    scene : Scene
        A scene with clearance joints.
    integrator : str
        The integrator's name.
    settings : dict, optional
        ``step``, ``rtol``, ``atol``.
    ensemble : int
        Members R (>= 2).
    seed : int
        Root seed of the perturbations.
    perturbation : float
        Initial-eccentricity offset relative to the clearance.

    Returns
    -------
    EnsembleRun
        The members' error statistics and costs.

    Examples
    --------
    Same seed, same members, same result:

    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-dry", overrides=["analysis.cycles=0.05"])
    >>> a = ensemble_statistics(scene, "dopri5", {"rtol": 1e-6, "atol": 1e-9}, ensemble=2)
    >>> b = run_ensemble(perturbed_scenes(scene, 2), "dopri5", {"rtol": 1e-6, "atol": 1e-9})
    >>> bool((a.statistics == b.statistics).all())
    True
    """
    return run_ensemble(perturbed_scenes(scene, ensemble, seed, perturbation), integrator,
                        settings)


def compare_ensembles(run: EnsembleRun, reference: EnsembleRun) -> tuple[np.ndarray, np.ndarray]:
    """Relative difference of the ensemble means and its standard error, per statistic.

    Members are paired by index: member ``i`` of ``run`` and of ``reference`` start from the
    same perturbed state when both come from the same seed (common random numbers). The
    standard error is that of the mean paired difference, s_d / √R, which is valid whether
    or not the pairs are correlated (the members are independent of each other): over spans
    short enough that neighbouring trajectories have not separated, pairing cancels their
    common part and resolves smaller errors; once they have separated (the chaotic regime),
    it equals the unpaired √(s_a²/R + s_b²/R). Both are divided by |reference mean|.

    Parameters
    ----------
    run, reference : EnsembleRun
        Two runs of the same members.

    Returns
    -------
    difference, standard_error : ndarray, shape (n_quantities, 3)
        Signed (run − reference) / |reference| and its standard error.

    Raises
    ------
    mechrel.errors.StudyError
        The ensembles have different shapes, or fewer than 2 members.

    Examples
    --------
    A run compared with itself differs by nothing:

    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-dry", overrides=["analysis.cycles=0.05"])
    >>> run = run_ensemble(perturbed_scenes(scene, 2), "dopri5", {"rtol": 1e-6, "atol": 1e-9})
    >>> d, se = compare_ensembles(run, run)
    >>> d.shape, float(abs(d).max()), float(se.max())
    ((3, 3), 0.0, 0.0)
    """
    a, b = run.statistics, reference.statistics
    if a.shape != b.shape:
        raise StudyError(f"ensembles of different shapes {a.shape} and {b.shape} cannot be "
                         "compared member by member")
    R = a.shape[0]
    _check_ensemble(R)
    scale = np.maximum(np.abs(b.mean(axis=0)), 1e-300)
    d = a - b
    return d.mean(axis=0) / scale, d.std(axis=0, ddof=1) / math.sqrt(R) / scale


def ensemble_needed(floor: float, target: float, ensemble: int,
                    confidence: float = 0.95) -> int:
    """Smallest R' >= ``ensemble`` at which a setting with this ``floor`` at R = ``ensemble``
    and no error could meet ``target``: t(R'−1) · floor · √(R/R') <= target.

    The floor is a standard error, so it falls as 1/√R; R' ≈ R (t · floor / target)², with
    t tending to the normal quantile (1.645 at 95 %) as R' grows.

    Parameters
    ----------
    floor : float
        Relative standard error at R = ``ensemble``.
    target : float
        Relative error to be resolved.
    ensemble : int
        Members R the floor was measured with.
    confidence : float
        One-sided confidence, in (0.5, 1).

    Returns
    -------
    int
        R' (``ensemble`` itself when the floor already resolves the target).

    Examples
    --------
    A floor as large as the target at R = 8 needs R' ≈ 8 · 1.7² ≈ 24 members:

    >>> ensemble_needed(0.01, 0.01, 8), ensemble_needed(0.001, 0.01, 8)
    (24, 8)
    """
    def ok(r):
        return student_t(confidence, r) * floor * math.sqrt(ensemble / r) <= target

    if not np.isfinite(floor) or floor <= 0 or ok(ensemble):
        return ensemble
    hi = ensemble
    while not ok(hi):  # terminates: the left side falls as 1/sqrt(hi) once t is ~constant
        hi *= 2
    lo = hi // 2  # ok(lo) is False
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if ok(mid) else (mid, hi)
    return hi


def default_candidates(scene, kind: str, quick: bool = False) -> list[tuple[str, dict]]:
    """Integrator settings to try for a scene type.

    Chaotic (dry, transition) scenes run every setting on an ensemble of R members, so their
    lists are shorter: 8 settings (dry) and 10 (transition), 4 and 6 with ``quick``.

    Parameters
    ----------
    scene : Scene
        The scene (its cycle period scales the RK4 steps).
    kind : str
        The scene's kind (:func:`mechrel.simulation.scene_kind`).
    quick : bool
        A shorter list.

    Returns
    -------
    list of (str, dict)
        ``(integrator, settings)`` pairs.

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> cands = default_candidates(load_scene("slider-crank-dry"), "dry", quick=True)
    >>> len(cands), cands[0][0], cands[0][1]["rtol"], cands[-1][0]
    (4, 'dopri5', 0.0001, 'rk4')
    """
    from ..integrate import INTEGRATORS
    from ..mechanics.system import compile_scene

    period = compile_scene(scene).period or scene.analysis_duration
    cands: list[tuple[str, dict]] = []
    stiff = [name for name in ("radau", "lsoda") if name in INTEGRATORS]
    if kind in CHAOTIC_KINDS:
        tols = [1e-4, 1e-6, 1e-8] if quick else [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9]
        divisions = [8e3] if quick else [4e3, 16e3]
        cands += [("dopri5", {"rtol": t, "atol": t * 1e-3}) for t in tols]
        cands += [("rk4", {"step": period / d}) for d in divisions]
        if MODELS[kind].stiff:  # e.g. transition: its film makes it stiff
            cands += [(stiff[0], {"rtol": t, "atol": t * 1e-3}) for t in (1e-5, 1e-7)]
        return cands
    tols = [1e-4, 1e-6, 1e-8] if quick else [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9]
    divisions = [2e3, 8e3] if quick else [1e3, 2e3, 4e3, 8e3, 16e3, 32e3]
    if kind == "ideal":
        cands += [("rk4", {"step": period / d}) for d in divisions]
        cands += [("dopri5", {"rtol": t, "atol": t * 1e-3}) for t in tols]
    for name in stiff:
        cands += [(name, {"rtol": t, "atol": t * 1e-3}) for t in tols]
    if kind in MODELS and MODELS[kind].stiff:  # an explicit method, for comparison
        cands += [("dopri5", {"rtol": t, "atol": t * 1e-3}) for t in tols[:2]]
    return cands


@dataclass(frozen=True)
class AccuracyReport:
    """Error against wall time for each integrator setting (frozen).

    ``table`` has one row per setting: ``integrator``, ``setting``, ``ensemble`` (members R,
    1 for pointwise), ``wall_time`` (s per run), ``wall_total`` (s, all members),
    ``n_steps`` and ``n_rhs`` (per run; ensemble mean), ``error_<quantity>`` and ``measure``
    (the largest), ``floor_<quantity>`` and ``floor`` (ensemble mode: the standard errors,
    relative; NaN for pointwise), ``bound`` (measure's upper confidence bound,
    max |error| + t · floor), ``verdict`` (``meets``, ``exceeds``, ``unresolved`` or
    ``failed``) and ``failed`` (the reason, or "").

    ``floor`` (the report's) is the standard error of the difference between two independent
    R-member ensembles of the reference, relative: what the measure resolves for an accurate
    setting whose trajectories have separated from the reference's. ``ensemble_needed`` is
    set when no setting met the target and some were unresolved (the R at which their median
    floor would resolve it); ``conclusion`` says in words
    what can be recommended.

    Parameters
    ----------
    scene : str
        The scene's name.
    kind : str
        Its kind (:func:`mechrel.simulation.scene_kind`).
    measure : str
        What the errors measure, in words.
    target : float
        Relative error the recommendation must meet.
    reference : dict
        The reference run's integrator and settings.
    table : pandas.DataFrame
        One row per setting (above).
    recommended : dict or None
        The table row of the fastest setting that meets the target.
    provenance : dict
        Versions, scene hash, wall time.
    ensemble : int
        Members R (1: pointwise).
    seed : int or None
        Root seed of the ensemble.
    perturbation : float or None
        Initial-eccentricity offset relative to the clearance.
    confidence : float
        One-sided confidence of the verdicts.
    floor : float
        The reference ensemble against itself (relative standard error).
    ensemble_needed : int or None
        R that would resolve the target (above).
    conclusion : str
        The recommendation in words.

    Examples
    --------
    :func:`accuracy_report` makes one; a tenth of a crank turn of the ideal slider-crank:

    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank", overrides=["analysis.cycles=0.1"])
    >>> rep = accuracy_report(scene, candidates=[("rk4", {"step": 1e-5})],
    ...                       reference=("dopri5", {"rtol": 1e-10, "atol": 1e-13}), repeats=1)
    >>> rep.kind, rep.recommended["integrator"], rep.table["verdict"].tolist()
    ('ideal', 'rk4', ['meets'])
    """

    scene: str
    kind: str
    measure: str
    target: float
    reference: dict
    table: pd.DataFrame
    recommended: dict | None
    provenance: dict = field(repr=False, default_factory=dict)
    ensemble: int = 1
    seed: int | None = None
    perturbation: float | None = None
    confidence: float = 0.95
    floor: float = float("nan")
    ensemble_needed: int | None = None
    conclusion: str = ""

    def to_frame(self) -> pd.DataFrame:
        """The table (a copy), one row per integrator setting.

        Returns
        -------
        pandas.DataFrame
            The columns described in the class docstring.

        Examples
        --------
        >>> from mechrel.scene import load_scene
        >>> scene = load_scene("slider-crank", overrides=["analysis.cycles=0.1"])
        >>> rep = accuracy_report(scene, candidates=[("rk4", {"step": 1e-5})],
        ...                       reference=("dopri5", {"rtol": 1e-10, "atol": 1e-13}), repeats=1)
        >>> rep.to_frame()[["integrator", "setting", "verdict"]].values.tolist()
        [['rk4', 'step=1e-05', 'meets']]
        """
        return self.table.copy()

    def plot(self, path=None):
        """Error against wall time per run; for ensembles, each point's upper confidence
        bound as a bar and the reference-ensemble floor t · floor as a grey band.

        Parameters
        ----------
        path : str or os.PathLike, optional
            Save the figure there (and close it).

        Returns
        -------
        matplotlib.figure.Figure
            The figure.

        Examples
        --------
        >>> from mechrel.scene import load_scene
        >>> scene = load_scene("slider-crank", overrides=["analysis.cycles=0.1"])
        >>> rep = accuracy_report(scene, candidates=[("rk4", {"step": 1e-5})],
        ...                       reference=("dopri5", {"rtol": 1e-10, "atol": 1e-13}), repeats=1)
        >>> rep.plot().axes[0].get_xlabel()
        'wall time per run (s)'
        """
        import matplotlib
        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7.5, 5), constrained_layout=True)
        ok = self.table[self.table["failed"] == ""]
        has_bound = self.ensemble > 1 and "bound" in ok
        for k, (name, grp) in enumerate(ok.groupby("integrator", sort=False)):
            ax.loglog(grp["wall_time"], grp["measure"], "o-", color=f"C{k}", label=name)
            if has_bound:
                ax.vlines(grp["wall_time"], grp["measure"], grp["bound"], color=f"C{k}",
                          lw=1, alpha=0.6)
                ax.plot(grp["wall_time"], grp["bound"], "_", color=f"C{k}", ms=8)
                # the verdict at a glance: hollow = unresolved, cross = shown to exceed
                if "verdict" in grp:
                    u = grp[grp["verdict"] == "unresolved"]
                    ax.plot(u["wall_time"], u["measure"], "o", color=f"C{k}", mfc="white")
                    x = grp[grp["verdict"] == "exceeds"]
                    ax.plot(x["wall_time"], x["measure"], "x", color="k", ms=7, mew=1.5)
            for _, r in grp.iterrows():
                ax.annotate(r["setting"], (r["wall_time"], r["measure"]), fontsize=6,
                            xytext=(3, 3), textcoords="offset points")
        ax.axhline(self.target, color="k", ls=":", lw=1, label=f"target {self.target:g}")
        if has_bound:
            ax.plot([], [], "o", color="grey", mfc="white", label="unresolved")
            ax.plot([], [], "x", color="k", mew=1.5, label="exceeds the target")
        if self.recommended:
            ax.plot([self.recommended["wall_time"]], [self.recommended["measure"]], "*",
                    ms=16, color="gold", mec="k", label="recommended")
        if self.ensemble > 1 and np.isfinite(self.floor):
            level = student_t(self.confidence, self.ensemble) * self.floor
            lo, hi = ax.get_ylim()
            lo = min(lo, level / 10)
            ax.axhspan(lo, level, color="grey", alpha=0.2,
                       label=f"reference against itself, t·floor at R = {self.ensemble}: "
                             f"{level:.2g}")
            ax.set_ylim(lo, max(hi, 2 * level))
        from matplotlib.ticker import NullFormatter
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("wall time per run (s)")
        label = f"error ({self.measure}, relative)"
        if self.ensemble > 1:
            label = (f"|Δ ensemble mean of error statistics| / reference\n"
                     f"(bars: {self.confidence:.0%} upper bound)")
        ax.set_ylabel(label)
        ax.set_title(f"{self.scene}: what accuracy costs in time")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
        if path is not None:
            from ..io import save_figure
            save_figure(fig, path, dpi=130)
            plt.close(fig)
        return fig


def _count(n: float) -> str:
    return f"{n:.0f}" if n < 1e5 else f"{n:.1e}"


def _label(settings: dict) -> str:
    return ", ".join(f"{k}={v:.3g}" for k, v in settings.items())


def accuracy_report(scene, *, candidates=None, reference=None, target: float = 0.01,
                    repeats: int = 2, quick: bool = False, progress: bool = False,
                    ensemble: int | None = None, seed: int = 0,
                    perturbation: float = DEFAULT_PERTURBATION, confidence: float = 0.95
                    ) -> AccuracyReport:
    """Measure error against wall time of integrator settings on ``scene``.

    Parameters
    ----------
    scene : Scene
        The scene.
    candidates : list of (integrator, settings), optional
        Default: :func:`default_candidates` for the scene type.
    reference : (integrator, settings), optional
        Default: the scene type's stiff or adaptive method at rtol 1e-11.
    target : float
        Relative error the recommendation must meet.
    repeats : int
        Warm runs per setting in pointwise mode; the minimum wall time is reported.
        (Ensemble members run once each; their median is reported.)
    quick : bool
        The shorter default candidate list.
    progress : bool
        Print a line per setting.
    ensemble : int, optional
        Members R per setting for chaotic (dry, transition) scenes, >= 2; default
        :data:`DEFAULT_ENSEMBLE`. Not allowed for other scenes, whose errors converge and are
        measured pointwise. The run time grows R-fold.
    seed : int
        Root seed of the ensemble's perturbations (:func:`perturbed_scenes`).
    perturbation : float
        Initial-eccentricity offset relative to the clearance.
    confidence : float
        One-sided confidence of the verdicts (0.5 < confidence < 1).

    Returns
    -------
    AccuracyReport
        The table of settings and the recommendation.

    Raises
    ------
    StudyError
        For invalid arguments (target <= 0, ensemble < 2, ensemble on a non-chaotic scene).

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank", overrides=["analysis.cycles=0.1"])
    >>> rep = accuracy_report(scene, candidates=[("rk4", {"step": 1e-5})],
    ...                       reference=("dopri5", {"rtol": 1e-10, "atol": 1e-13}), repeats=1)
    >>> rep.measure, bool(rep.table["measure"].iloc[0] < 0.01)
    ('max pointwise error / range', True)
    >>> accuracy_report(scene, ensemble=4)
    Traceback (most recent call last):
    ...
    mechrel.errors.StudyError: ...
    """
    from ..integrate import INTEGRATORS
    from ..simulation import scene_kind, simulate

    if not (isinstance(target, (int, float)) and target > 0 and math.isfinite(target)):
        raise StudyError(f"target: {target!r} is not a positive relative error")
    if not (0.5 < confidence < 1.0):
        raise StudyError(f"confidence: {confidence!r} is not in (0.5, 1)")
    kind = scene_kind(scene)
    statistical = kind in CHAOTIC_KINDS
    if ensemble is not None and not statistical:
        raise StudyError(f"ensemble: scene {scene.name!r} is {kind}; its trajectories converge "
                         "and are measured pointwise. Ensembles apply to chaotic (dry, "
                         "transition) scenes")
    R = _check_ensemble(DEFAULT_ENSEMBLE if ensemble is None else ensemble) if statistical \
        else 1
    if reference is None:
        stiff = "radau" if "radau" in INTEGRATORS else "lsoda"
        reference = ((stiff, {"rtol": 1e-11, "atol": 1e-14})
                     if kind in MODELS and MODELS[kind].stiff and not statistical
                     else ("dopri5", {"rtol": 1e-11, "atol": 1e-14}))
    t0 = time.perf_counter()
    cands = candidates if candidates is not None else default_candidates(scene, kind, quick)
    if statistical:
        members = perturbed_scenes(scene, R, seed, perturbation)
        tq = student_t(confidence, R)
        # "exceeds" claims that *some* of the statistics is off in either direction:
        # two-sided and Bonferroni-corrected, so that the claim holds at `confidence` overall
        quantities = _quantities(scene, None)
        n_stats = len(quantities) * len(STATISTICS)
        tq_exceeds = student_t(1.0 - (1.0 - confidence) / (2 * n_stats), R)
        warmed: set[str] = set()

        def warm(name, settings):
            # the first run of an integrator in a process loads its compiled kernels (0.5 s
            # on the nine-bar): keep it out of the timed runs
            if name not in warmed:
                warmed.add(name)
                try:
                    simulate(members[0], method="dynamics", integrator=name, **settings)
                except MechrelError:
                    pass  # the timed run reports it

        warm(*reference)
        ref_run = run_ensemble(members, reference[0], reference[1])
        ref_stats = ref_run.statistics
        ref_floor = float(np.max(math.sqrt(2.0 / R) * ref_stats.std(axis=0, ddof=1)
                                 / np.maximum(np.abs(ref_stats.mean(axis=0)), 1e-300)))
    else:
        ref = simulate(scene, method="dynamics", integrator=reference[0], **reference[1])
        output = next(iter(ref.outputs))
        quantities = _quantities(scene, output)
        ref_c = _curves(ref, output)
        scale = {q: max(np.ptp(ref_c[q]), 1e-300) for q in quantities}
    rows = []
    iterator = cands
    if progress:
        from tqdm.auto import tqdm
        iterator = tqdm(cands, desc=f"accuracy {scene.name}" + (f" (R = {R})" if R > 1 else ""),
                        unit="setting")
    # a candidate's drift of the ideal joints (SimulationWarning) is measured here, in its
    # error against the reference and its max_violation column: not repeated per run
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SimulationWarning)
        for name, settings in iterator:
            row = {"integrator": name, "setting": _label(settings), "failed": "", "ensemble": R}
            if statistical:
                warm(name, settings)
                try:
                    run = run_ensemble(members, name, settings)
                except MechrelError as exc:
                    row.update(failed=str(exc)[:200], verdict="failed", wall_time=np.nan,
                               measure=np.nan)
                    rows.append(row)
                    continue
                diff, se = compare_ensembles(run, ref_run)
                ad = np.abs(diff)
                errs = {q: float(ad[k].max()) for k, q in enumerate(quantities)}
                floors = {q: float(se[k].max()) for k, q in enumerate(quantities)}
                bound = float(np.max(ad + tq * se))
                lower = float(np.max(ad - tq_exceeds * se))
                verdict = ("meets" if bound <= target else "exceeds" if lower > target
                           else "unresolved")
                row.update(wall_time=float(np.median(run.wall_times)),
                           wall_total=float(run.wall_times.sum()),
                           n_steps=float(run.n_steps.mean()), n_rhs=float(run.n_rhs.mean()),
                           max_violation=run.max_violation,
                           **{f"error_{q}": v for q, v in errs.items()},
                           measure=max(errs.values()),
                           **{f"floor_{q}": v for q, v in floors.items()},
                           floor=max(floors.values()), bound=bound, verdict=verdict)
                rows.append(row)
                continue
            try:
                best = math.inf
                total = 0.0
                for _ in range(max(1, repeats)):
                    start = time.perf_counter()
                    res = simulate(scene, method="dynamics", integrator=name, **settings)
                    took = time.perf_counter() - start
                    best, total = min(best, took), total + took
            except MechrelError as exc:
                row.update(failed=str(exc)[:200], verdict="failed", wall_time=np.nan,
                           measure=np.nan)
                rows.append(row)
                continue
            c = _curves(res, output)
            errs = {q: float(np.max(np.abs(c[q] - ref_c[q])) / scale[q]) for q in quantities}
            measure = max(errs.values())
            row.update(wall_time=best, wall_total=total, n_steps=res.stats["n_steps"],
                       n_rhs=res.stats["n_rhs"], max_violation=res.stats["max_position_violation"],
                       **{f"error_{q}": v for q, v in errs.items()}, measure=measure,
                       floor=np.nan, bound=measure,
                       verdict="meets" if measure <= target else "exceeds")
            rows.append(row)
    table = pd.DataFrame(rows)
    ok = table[table["verdict"] == "meets"] if len(table) else table
    recommended = None
    if len(ok):
        r = ok.loc[ok["wall_time"].idxmin()]
        recommended = {"integrator": r["integrator"], "setting": r["setting"],
                       "wall_time": float(r["wall_time"]), "measure": float(r["measure"]),
                       "bound": float(r["bound"])}
    needed = None
    unresolved = table[table["verdict"] == "unresolved"] if len(table) else table
    if recommended:
        r = recommended
        conclusion = (f"recommended: solver.integrator = {r['integrator']!r} with "
                      f"{r['setting']} (error {r['measure']:.2g}"
                      + (f", {confidence:.0%} upper bound {r['bound']:.2g}" if R > 1 else "")
                      + f" <= {target:g}; {r['wall_time']:.3g} s per run)")
    elif len(unresolved):
        typical = float(unresolved["floor"].median())
        needed = ensemble_needed(typical, target, R, confidence)
        conclusion = (f"no recommendation can be made at R = {R}: the target {target:g} is "
                      f"below the resolvable floor — {len(unresolved)} setting(s) may meet it "
                      f"but their errors cannot be told from zero (median floor "
                      f"{typical:.2g}, t·floor {tq * typical:.2g}). The floor falls as "
                      f"1/sqrt(R): R ≈ {_count(needed)} members would be needed "
                      f"({_count(needed / R)} × the run time), or accept a larger target")
    else:
        conclusion = (f"no setting met the target {target:g}"
                      + (" (every error is resolved above it)" if R > 1 else "")
                      + "; tighten the candidates")
    from ..simulation.result import _provenance
    ref_info = {"integrator": reference[0], **reference[1]}
    if statistical:
        ref_info.update(ensemble=R, wall_time=float(np.median(ref_run.wall_times)),
                        n_rhs=float(ref_run.n_rhs.mean()))
    measure = (f"ensemble means of the error statistics (R = {R})" if statistical
               else "max pointwise error / range")
    return AccuracyReport(scene=scene.name, kind=kind, measure=measure, target=target,
                          reference=ref_info, table=table, recommended=recommended,
                          provenance=_provenance(scene, time.perf_counter() - t0),
                          ensemble=R, seed=seed if statistical else None,
                          perturbation=perturbation if statistical else None,
                          confidence=confidence,
                          floor=ref_floor if statistical else float("nan"),
                          ensemble_needed=needed, conclusion=conclusion)


def run_accuracy(scene, *, target=0.01, quick=False, out=None, progress=True, ensemble=None,
                 seed=0):
    """CLI runner: table printed, ``accuracy.csv`` and ``accuracy.png`` in ``out``.

    Parameters
    ----------
    scene : Scene
        The scene.
    target : float
        Relative error the recommendation must meet.
    quick : bool
        The shorter candidate list.
    out : str or os.PathLike, optional
        Folder for ``accuracy.csv`` and ``accuracy.png``.
    progress : bool
        Print a line per setting.
    ensemble : int, optional
        Members R for chaotic scenes.
    seed : int
        Root seed of the ensemble.

    Returns
    -------
    lines : list of str
        The report's text.
    report : AccuracyReport
        The report.

    Raises
    ------
    mechrel.errors.StudyError
        Invalid arguments (before anything runs).

    Examples
    --------
    A full run takes minutes (every candidate setting, against a tight reference); a wrong
    argument fails at once:

    >>> from mechrel.scene import load_scene
    >>> run_accuracy(load_scene("slider-crank"), target=0.0)
    Traceback (most recent call last):
    ...
    mechrel.errors.StudyError: target: 0.0 is not a positive relative error
    """
    from ..io.results import check_folder, removed_if_left_empty, result_set

    with removed_if_left_empty(out):  # refused or interrupted: no empty folder left behind
        folder = check_folder(out, FILES)  # before the run (minutes), not after it
        rep = accuracy_report(scene, target=target, quick=quick, progress=progress,
                              ensemble=ensemble, seed=seed)
    cols = ["integrator", "setting", "wall_time", "n_steps", "n_rhs", "measure"]
    if rep.ensemble > 1:
        cols += ["floor", "bound"]
    cols += ["verdict", "failed"]
    t = rep.table[[c for c in cols if c in rep.table]]
    ref = ", ".join(f"{k}={v:.3g}" if isinstance(v, float) else f"{k}={v}"
                    for k, v in rep.reference.items())
    head = f"scene {rep.scene} ({rep.kind}); error measure: {rep.measure}; reference: {ref}"
    lines = [head]
    if rep.ensemble > 1:
        lines.append(
            f"ensemble: R = {rep.ensemble} initial eccentricities perturbed by "
            f"{rep.perturbation:g} x clearance (seed {rep.seed}); floor = standard error of "
            f"the difference, relative (reference against itself: {rep.floor:.2g}); a setting "
            f"meets the target when error + t·floor <= target (t = "
            f"{student_t(rep.confidence, rep.ensemble):.2f}, {rep.confidence:.0%} one-sided); "
            "wall time = median per run")
    # the table's lines one by one: each element of ``lines`` is one line on the terminal
    lines += t.to_string(index=False, float_format=lambda v: f"{v:.3g}").splitlines()
    lines.append(rep.conclusion)
    total = float(rep.table["wall_total"].sum()) if "wall_total" in rep.table else float("nan")
    lines.append(f"total wall time {rep.provenance.get('wall_time', float('nan')):.3g} s "
                 f"({total:.3g} s in the timed candidate runs)")
    if folder is not None:
        from ..io import write_table

        with result_set(folder, "accuracy", known=FILES) as stage:  # one set
            write_table(rep.table, stage / "accuracy.csv")
            rep.plot(stage / "accuracy.png")
        lines.append(f"wrote {folder}/accuracy.csv, accuracy.png")
    return lines, rep
