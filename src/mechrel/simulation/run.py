"""Run a scene: ``simulate(scene) -> SimulationResult``.

What runs depends only on what the scene declares:

* no clearance joints and fully driven → kinematic analysis only (no dynamics);
* clearance joints → forward dynamics of the mechanism with the clearance joints as force
  elements, plus the ideal counterpart (the same scene with those joints ideal) by kinematic
  analysis when it is fully driven (by forward dynamics otherwise), and the errors;
* undriven (free) mechanisms → forward dynamics.

A run that ends where its force laws have no meaning (a journal through its film, a
penetration beyond the clearance) raises :class:`~mechrel.errors.SimulationError`.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable, Generator, Mapping
from typing import Any

import numpy as np

from ..errors import AssemblyError, SimulationError, SimulationWarning
from ..forces.models import MODELS
from ..forces.params import P_C
from ..integrate import IntegrationResult
from ..integrate.base import run_steps
from ..mechanics.dynamics import N_WORK
from ..mechanics.kinematics import assemble, assemble_positions, kinematic_analysis
from ..mechanics.post import post_process
from ..mechanics.system import CompiledScene, compile_scene
from ..scene.model import Scene

from .evaluators import values
from .extremes import (DENSE_POINTS, KINEMATIC_POINTS, _extremes_of, _window_points,
                       analysis_window)
from .reference import (ReferenceDesign, _check_reference, _ideal_at, _ideal_by_dynamics,
                        _reference_outputs)
from .result import SimulationResult, _provenance
from .solver import _check_step_budget, make_integrator
from .times import _crank_angle, output_times

def _window_values(scene, compiled, outputs, sel, first, log, n, reference):
    """The outputs at the extremes' window points (:func:`_window_points`: ``first`` into the
    output instants ``sel`` and the log's rows): those at the output instants already
    computed (``outputs``), those at the log's rows computed on the log's columns where they
    are (views: of each row only the columns the outputs read leave memory), then both put in
    the window's order. An output's value at a state depends on that state alone (every
    evaluator's is row by row), so these are the values of the window's states, bitwise."""
    ny = 2 * n + N_WORK
    at_log = values(scene, compiled, log[:, 0], log[:, 1:1 + n], log[:, 1 + n:1 + 2 * n],
                    log[:, 1 + ny + n:1 + ny + 2 * n], H=log[:, 1 + 2 * ny:],
                    counterpart=reference)
    return {name: {q: np.concatenate([v[sel], at_log[name][q]])[first]
                   for q, v in quantities.items()}
            for name, quantities in outputs.items()}


def _orbits_and_energy(compiled: CompiledScene, res: IntegrationResult):
    """Journal orbits and the energy bookkeeping at the output instants (one compiled call)."""
    sys = compiled.dynamic
    n = sys.mass.shape[0]
    Y = np.ascontiguousarray(res.y)
    EX, EY, T, V, E = post_process(np.ascontiguousarray(res.t), Y, sys)
    orbits = {name: {"ex": EX[:, k], "ey": EY[:, k],
                     "eps": np.hypot(EX[:, k], EY[:, k]) / sys.cl_p[k, P_C]}
              for k, name in enumerate(compiled.clearance_names)}
    win, wcl = Y[:, 2 * n], Y[:, 2 * n + 1]
    energy = {"kinetic": T, "potential": V, "elastic": E, "input_work": win,
              "clearance_work": wcl, "dissipated": -wcl - (E - E[0]),
              "balance": (T - T[0]) + (V - V[0]) - win - wcl}
    return orbits, energy


def _check_orbits(scene: Scene, times: np.ndarray, orbits) -> None:
    """Raise :class:`SimulationError` when a journal is where its force law has no meaning:
    a lubricated journal at or beyond the bearing wall (ε ≥ 1; the film's divergence is what
    keeps it inside, docs/forces.md §5, so reaching the wall means the integrator stepped over
    the film), or a dry/transition penetration δ = (ε − 1) c beyond the clearance itself
    (ε ≥ 2; the Lankarani–Nikravesh law is a small-deformation law, δ ≪ radii, and steel joints
    penetrate micrometres). Such a run is a failed run, not a result."""
    for name, d in orbits.items():
        joint = scene.joints[name]
        model = joint.clearance_model
        eps = d["eps"]
        i = int(np.argmax(eps))
        if model.film_only and eps[i] >= 1.0:
            contact = ", ".join(f"'{m.name}'" for m in MODELS.values()
                                if m.has_film and m.has_contact)
            assert joint.lubricant is not None  # validated: a film model has one
            raise SimulationError(
                f"joint {name}: the journal left the bearing (eccentricity ratio ε = "
                f"{eps[i]:.4g} >= 1 at t = {times[i]:.6g} s): the film (viscosity "
                f"{joint.lubricant.viscosity:g} Pa s) cannot carry the load there; use model = "
                f"{contact} (adds metal contact) or check the load and viscosity")
        if model.has_contact and eps[i] >= 2.0:
            raise SimulationError(
                f"joint {name}: penetration {(eps[i] - 1.0) * joint.clearance:.4g} m at t = "
                f"{times[i]:.6g} s exceeds the clearance ({joint.clearance:g} m): the contact "
                "law (small deformations) does not apply; check the contact's Young's moduli "
                "and the load")


#: The ideal joints' drift (max |Φ| over the run, m or rad), as a fraction of the smallest
#: clearance, from which a run's numbers carry a warning (docs/mechanics.md, "Drift of the
#: ideal joints"): the errors a run reports are of the clearance's size, and a drift of the
#: ideal joints moves the mechanism by its own size, so from a tenth of the clearance on the
#: integrator's drift is a tenth of the answer. Sound runs drift by at most ~1e-3 of it.
DRIFT_LIMIT = 0.1


def _drift_caveats(scene: Scene, compiled: CompiledScene, drift: float,
                   stats: Mapping) -> tuple[str, ...]:
    """The warning of a run whose ideal joints drifted by ``drift`` (max |Φ|, m or rad), when
    that is at least :data:`DRIFT_LIMIT` of the smallest clearance (none without clearance
    joints: there the errors have no clearance to be measured against)."""
    if not compiled.clearance_names:
        return ()
    name = min(compiled.clearance_names, key=lambda n: scene.joints[n].clearance)
    c = scene.joints[name].clearance
    if drift < DRIFT_LIMIT * c:  # (a NaN drift warns)
        return ()
    settings = stats.get("settings", {})
    advice = ("tighten solver.rtol and solver.atol" if "rtol" in settings
              else "use a smaller solver.step")
    if stats.get("integrator") == "radau" and stats.get("formulation") == "absolute":
        advice += (" or, for a driven mechanism, use solver.formulation = 'reduced' (its ideal "
                   "joints held exactly)")
    now = ", ".join(f"{k} {v:g}" for k, v in settings.items() if isinstance(v, float))
    return (f"{scene.source or scene.name}: the ideal joints drifted apart by {drift:.3g} (max "
            f"|Φ|, m or rad), {drift / c:.3g} times the smallest clearance ({c:g} m, joint "
            f"{name}): the run's errors are partly the integrator's (allowed: less than "
            f"{DRIFT_LIMIT:g} of the clearance); {advice}"
            + (f" (now {stats.get('integrator')} with {now})" if now else ""),)


# Magnitudes (SI) beyond which a scene value is named when a run fails: no quantity of a
# planar mechanism comes near it (Young's moduli are ~1e11 Pa), and products and squares of
# such values overflow float64 in the force laws and the kinematics.
EXTREME_MAGNITUDE = 1e15


def extreme_values(scene: Scene) -> list[str]:
    """``PATH = VALUE`` of the scene's numbers of magnitude >= :data:`EXTREME_MAGNITUDE`.

    A failed run names them in its advice: such values overflow the force laws.

    Parameters
    ----------
    scene : mechrel.scene.model.Scene
        The scene.

    Returns
    -------
    list of str
        ``"PATH = VALUE"`` lines, sorted.

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> extreme_values(load_scene("slider-crank-lubricated"))
    []
    >>> extreme_values(load_scene("slider-crank-lubricated",
    ...                           overrides=["joints.C.lubricant.viscosity=1e200"]))
    ['joints.C.lubricant.viscosity = 1e+200']
    """
    found: list[str] = []
    stack: list[tuple[object, str]] = [(scene.raw or {}, "")]
    while stack:
        node, path = stack.pop()
        if isinstance(node, Mapping):
            stack.extend((v, f"{path}.{k}" if path else str(k)) for k, v in node.items())
        elif isinstance(node, (list, tuple)):
            stack.extend((v, f"{path}[{i}]") for i, v in enumerate(node))
        elif (isinstance(node, (int, float)) and not isinstance(node, bool)
              and abs(node) >= EXTREME_MAGNITUDE):
            found.append(f"{path} = {node:g}")
    return sorted(found)


def simulate(scene: Scene, *, reference: Scene | None = None, method: str = "auto",
             integrator: str | None = None, progress: bool = False, extremes: bool = False,
             dense_points: int = DENSE_POINTS, sectors: float | None = None,
             **solver_settings) -> SimulationResult:
    """Simulate a scene over its analysis span.

    Parameters
    ----------
    scene : Scene
        From :func:`mechrel.scene.load_scene`.
    reference : Scene, optional
        The design the errors are measured against: the ideal (all-joints-ideal) mechanism of
        ``reference`` instead of that of ``scene`` (e.g. the nominal design when ``scene``
        carries geometric tolerances). It must have the scene's output names, bodies and
        drivers (:class:`SimulationError` otherwise). With a reference the result always has
        an ideal counterpart and errors, also for a scene without clearance joints.
    method : {"auto", "kinematics", "dynamics"}
        ``auto`` uses kinematic analysis for a fully driven scene without clearance joints and
        forward dynamics otherwise; ``dynamics`` forces forward dynamics (e.g. to check an
        integrator against the kinematic analysis).
    integrator : str, optional
        Overrides ``scene.solver.integrator``.
    progress : bool
        Show a progress bar over the output instants.
    extremes : bool
        Also find the cycle extremes of every output's error on the integrator's solution
        (:attr:`SimulationResult.extremes`); needs an ideal counterpart (clearance joints or a
        ``reference``). Without it the run is bitwise what it was.
    dense_points : int
        Points of the integrator's continuous extension evaluated inside each step for the
        extremes (besides the step's end), ≥ 0.
    sectors : float, optional
        With ``extremes``: also the extremes over each sector of this many degrees of the
        analysed cycle (:attr:`SimulationResult.sector_extremes`); a divisor of 360 and a
        multiple of the output grid's crank-angle step.
    **solver_settings
        ``step``, ``rtol``, ``atol`` overrides.

    Returns
    -------
    SimulationResult

    Raises
    ------
    AssemblyError
        The initial configuration cannot be assembled.
    SimulationError
        An over-constrained scene, an unknown method or setting, a reference that does not
        match, or a failed integration (non-finite state, step-size underflow, too many
        steps, a journal leaving its bearing). When the scene holds values of magnitude
        >= ``EXTREME_MAGNITUDE``, the message of either error names them first (their
        overflow is the likely cause).
    TypeError
        ``scene`` is not a :class:`~mechrel.scene.model.Scene`.

    Warns
    -----
    mechrel.errors.SimulationWarning
        The ideal joints drifted apart by at least :data:`DRIFT_LIMIT` of the smallest
        clearance (loose tolerances on the absolute equations): the same text is in the
        result's ``warnings``.

    Examples
    --------
    The slider-crank with ideal joints is fully driven: kinematic analysis over one crank
    revolution; the slider travels twice the crank radius (0.05 m):

    >>> from mechrel.scene import load_scene
    >>> r = simulate(load_scene("slider-crank"))
    >>> r.method, r.time.size, float(r.crank_angle[-1])
    ('kinematics', 361, 360.0)
    >>> x = r.outputs["slider"]["displacement"]
    >>> round(float(x.max() - x.min()), 9)
    0.1
    """
    # the settings as one mapping: a setting named like a parameter of the private path
    # (solver=, provenance=) is then refused by name with the allowed ones, not taken for it
    result = run_steps(_explained(scene, reference=reference, method=method,
                                  integrator=integrator, progress=progress, extremes=extremes,
                                  dense_points=dense_points, sectors=sectors,
                                  solver_settings=solver_settings))
    for text in result.warnings:
        warnings.warn(text, SimulationWarning, stacklevel=2)
    return result


def simulate_sample(scene: Scene, solver, *, reference: Scene | ReferenceDesign | None = None,
                    extremes: bool = False, sectors: float | None = None,
                    compiled: CompiledScene | None = None,
                    q0: np.ndarray | None = None) -> SimulationResult:
    """:func:`simulate` (``reference``, ``extremes``) with an integrator made beforehand and
    without the provenance record: the inner call of a batch of samples
    (:meth:`mechrel.uq.problem.mechanism.MechanismModel.evaluate_batch`), where the integrator
    is made once per batch and the provenance is the model's.

    Parameters
    ----------
    scene, extremes, sectors
        As for :func:`simulate`.
    reference : Scene or ReferenceDesign, optional
        As for :func:`simulate`; a :class:`ReferenceDesign` is the same design prepared once
        for the samples that share it.
    solver : Integrator
        ``make_integrator(scene)`` or an equal one (made from a scene with the same ``solver``
        table and :func:`scene_kind`): the numbers are then those of ``simulate``, bitwise.
    compiled : CompiledScene, optional
        ``compile_scene(scene)`` or equal arrays (a
        :class:`PreparedScene`'s); compiled here when not given.
    q0 : numpy.ndarray, optional
        The ideal mechanism's positions at t = 0 as ``assemble_positions(compiled.ideal,
        compiled.q_guess, 0.0)`` gives them (:meth:`PreparedScene.ideal_start`); assembled
        here when not given.

    Returns
    -------
    SimulationResult
        As :func:`simulate`'s, with an empty ``provenance``.

    Raises
    ------
    mechrel.errors.SimulationError
        As :func:`simulate`, and where :func:`simulate` warns of the ideal joints' drift
        (the warning's text): a sample's numbers must not carry it.

    Examples
    --------
    Bitwise the numbers of :func:`simulate`, without the provenance record:

    >>> import math
    >>> from mechrel.scene import load_scene, with_overrides
    >>> scene = with_overrides(load_scene("slider-crank-lubricated"),
    ...                        {"analysis.cycles": 1, "analysis.sample_step_angle": math.pi / 2})
    >>> r = simulate_sample(scene, make_integrator(scene))
    >>> e = r.error("slider", "velocity")
    >>> bool((e == simulate(scene).error("slider", "velocity")).all()), r.provenance
    (True, {})
    """
    return run_steps(sample_steps(scene, solver, reference=reference, extremes=extremes,
                                  sectors=sectors, compiled=compiled, q0=q0))


def sample_steps(scene: Scene, solver, *, reference: Scene | ReferenceDesign | None = None,
                 extremes: bool = False, sectors: float | None = None,
                 compiled: CompiledScene | None = None, q0: np.ndarray | None = None
                 ) -> Generator[Callable[[], Any], Any, SimulationResult]:
    """:func:`simulate_sample` as its steps: a generator that pauses where the integrator runs,
    so that a batch of samples can run each step for all its samples in turn.

    The generator yields a callable without arguments, the integrator's compiled kernel
    (:meth:`~mechrel.integrate.Integrator.integrate_steps`): its caller calls it and sends its
    result back (or throws in what it raised), and the generator goes on with the Python
    after the kernel, the run's checks and outputs; it returns the :class:`SimulationResult`.
    A run without integration (kinematic analysis) returns without yielding.
    :func:`~mechrel.integrate.base.run_steps` runs the steps of one sample;
    :meth:`~mechrel.uq.problem.mechanism.MechanismModel.evaluate_batch` runs, for a few
    samples at a time, the steps before every sample's kernel, then the kernels, then the
    steps after them: each step's Python then runs back to back, while its code is in the
    processor's caches, not once after each 20 ms kernel, which evicts it
    (docs/dev/performance-log.md, 2026-11-29). The numbers are those of
    :func:`simulate_sample`, bitwise, whatever the order the steps of several samples run
    in.

    Parameters
    ----------
    scene, solver, reference, extremes, sectors, compiled, q0
        As for :func:`simulate_sample`.

    Returns
    -------
    generator
        Yields the integrator's run (a callable without arguments); returns the
        :class:`SimulationResult`.

    Raises
    ------
    mechrel.errors.SimulationError, mechrel.errors.AssemblyError
        From the step that finds the failure, as :func:`simulate_sample` raises them.

    Examples
    --------
    The two steps of a lubricated slider-crank's run, driven by hand:

    >>> import math
    >>> from mechrel.scene import load_scene, with_overrides
    >>> scene = with_overrides(load_scene("slider-crank-lubricated"),
    ...                        {"analysis.cycles": 1, "analysis.sample_step_angle": math.pi / 2})
    >>> steps = sample_steps(scene, make_integrator(scene))
    >>> kernel = next(steps)  # everything before the integrator's kernel has run
    >>> try:
    ...     steps.send(kernel())
    ... except StopIteration as done:
    ...     r = done.value
    >>> bool((r.time == simulate_sample(scene, make_integrator(scene)).time).all())
    True
    """
    result = yield from _explained(scene, reference=reference, method="auto", integrator=None,
                                   progress=False, extremes=extremes,
                                   dense_points=DENSE_POINTS, sectors=sectors, solver=solver,
                                   provenance=False, compiled=compiled, q0=q0)
    if result.warnings:  # a study's number must not carry the integrator's drift
        raise SimulationError(result.warnings[0])
    return result


def _explained(scene, **kwargs) -> Generator[Callable[[], Any], Any, SimulationResult]:
    """The steps of ``_simulate(scene, **kwargs)``, a failure of a scene with values of
    extreme magnitude explained by them."""
    try:
        return (yield from _simulate(scene, **kwargs))
    except (AssemblyError, SimulationError) as exc:
        extreme = extreme_values(scene) if isinstance(scene, Scene) else []
        if not extreme:
            raise
        # a failure of a scene with values of no physical magnitude is their overflow, not a
        # toggle position or a step size: say so first
        raise type(exc)(f"{scene.source or scene.name}: the run failed with values of extreme "
                        f"magnitude in the scene, which overflow float64 arithmetic: "
                        f"{', '.join(extreme[:4])}; allowed: values of physical magnitude "
                        f"(SI, below {EXTREME_MAGNITUDE:g}) (the failure: {exc})") from None


def _simulate(scene: Scene, *, reference: Scene | ReferenceDesign | None, method: str,
              integrator: str | None, progress: bool, extremes: bool, dense_points: int,
              sectors: float | None = None, solver=None, provenance: bool = True,
              solver_settings=None, compiled: CompiledScene | None = None,
              q0: np.ndarray | None = None
              ) -> Generator[Callable[[], Any], Any, SimulationResult]:
    """The run's steps (:func:`sample_steps`): one pause, where the integrator runs."""
    start = time.perf_counter()
    if not isinstance(scene, Scene):
        raise TypeError(f"simulate: scene must be a Scene, got {type(scene).__name__} "
                        f"{scene!r:.60}; load it first: simulate(load_scene(...))")
    ref = None  # the reference design, prepared (its ideal mechanism compiled once)
    if isinstance(reference, ReferenceDesign):
        ref, reference = reference, reference.scene
    if reference is not None:
        _check_reference(scene, reference)
        ref = ref or ReferenceDesign(reference)
    # made (and so checked) even when kinematic analysis needs no integrator
    if solver is None:
        solver = make_integrator(scene, integrator, **(solver_settings or {}))
    if compiled is None:
        compiled = compile_scene(scene)
    n = compiled.q_guess.size
    if compiled.ideal.n_constraints > n:
        # more equations than coordinates: the constraint Jacobian cannot have full row rank,
        # which the Schur complement of the dynamics (and the kinematic analysis) needs; it
        # used to surface as a step-size or rank failure deep in the integration
        raise SimulationError(
            f"{scene.source or scene.name}: over-constrained: with ideal joints the mechanism "
            f"has {compiled.ideal.n_constraints} constraint equations for {n} coordinates "
            f"({n // 3} bodies): {', '.join(compiled.labels['ideal'])}; allowed: at most one "
            "equation per coordinate (remove a driver or a joint)")
    times = output_times(scene, compiled)
    _check_step_budget(solver, times)
    has_clearance = bool(compiled.clearance_names)
    driven = compiled.ideal.n_constraints == n
    tol = scene.solver.assembly_tolerance
    if method not in ("auto", "kinematics", "dynamics"):
        raise SimulationError(f"method: {method!r} is not one of 'auto', 'kinematics', "
                              "'dynamics'")
    if method == "kinematics" and (has_clearance or not driven):
        raise SimulationError("method='kinematics' needs a fully driven scene without "
                              "clearance joints")
    if extremes and not has_clearance and reference is None:
        raise SimulationError(
            f"simulate: extremes = True: scene {scene.name!r} has no clearance joints and no "
            "reference design, so its outputs have no error whose extremes could be found; "
            "allowed: extremes with a clearance joint or a reference")
    if sectors is not None and not (extremes and isinstance(sectors, (int, float))
                                    and not isinstance(sectors, bool) and sectors > 0
                                    and abs(360.0 / sectors - round(360.0 / sectors)) < 1e-9):
        raise SimulationError(f"simulate: sectors = {sectors!r}: allowed: with extremes=True, a "
                              "divisor of 360 degrees (e.g. 18)")
    if isinstance(dense_points, bool) or not isinstance(dense_points, (int, np.integer)) \
            or dense_points < 0:
        raise SimulationError(f"simulate: dense_points = {dense_points!r}: not an integer >= 0; "
                              "allowed: 0, 1, 2, ... points inside each integrator step")
    if q0 is None:
        q0 = assemble_positions(compiled.ideal, compiled.q_guess, 0.0, tol=tol,
                                labels=compiled.labels["ideal"])

    ideal = None
    if driven and (has_clearance or method in ("auto", "kinematics")):
        Qi, Vi, Ai, viol_i = kinematic_analysis(compiled.ideal, q0, times, tol=tol,
                                                labels=compiled.labels["ideal"])
        # against a reference design, the scene's ideal mechanism is not the one the errors
        # are measured against: its outputs by their formulas (a path output's distance from
        # the reference's path, not the 0 of a point on its own path)
        ideal = values(scene, compiled, times, Qi, Vi, Ai, ideal=reference is None,
                         counterpart=reference)
    # the ideal counterpart the errors are measured against: the reference design's, or the
    # scene's own ideal mechanism
    counterpart = ideal if ref is None else _reference_outputs(ref, times, scene)

    if not has_clearance and driven and method != "dynamics":
        assert ideal is not None  # driven, method "auto" or "kinematics": computed above
        ext = sec = None
        if extremes:  # no integrator steps: a fine uniform sampling of the window
            t_win = analysis_window(compiled, times)
            fine = np.linspace(t_win, float(times[-1]), KINEMATIC_POINTS + 1)
            T, sel, _ = _window_points(times, t_win, fine)
            lead = times[~sel]
            Qf, Vf, Af, _ = kinematic_analysis(compiled.ideal, q0, np.concatenate([lead, T]),
                                               tol=tol, labels=compiled.labels["ideal"])
            m = lead.size
            ext, sec = _extremes_of(scene, compiled, T,
                                    values(scene, compiled, T, Qf[m:], Vf[m:], Af[m:],
                                             ideal=reference is None, counterpart=reference),
                                    _ideal_at(scene, compiled, ref, q0, solver, T, lead),
                                    sectors)
        wall = time.perf_counter() - start
        stats = {"integrator": "kinematic-analysis", "n_steps": times.size,
                 "max_position_violation": float(viol_i), "wall_time": wall, "status": "ok"}
        return SimulationResult(scene=scene, time=times,
                                crank_angle=_crank_angle(scene, compiled, times),
                                outputs=ideal, ideal=None if reference is None else counterpart,
                                q=Qi, v=Vi, a=Ai, method="kinematics", stats=stats,
                                provenance=_provenance(scene, wall, reference)
                                if provenance else {}, extremes=ext, sector_extremes=sec)

    sys = compiled.dynamic
    qa, va = assemble(compiled.assembly, q0, 0.0, tol=tol,
                      labels=compiled.labels["assembly"])
    y0 = np.concatenate([qa, va, np.zeros(N_WORK)])
    hist0 = np.zeros(sys.n_contacts)
    bar = None
    if progress:
        from tqdm.auto import tqdm
        bar = tqdm(total=times.size, desc=f"simulate {scene.name}", unit="sample", leave=False)
    t_lo = analysis_window(compiled, times) if extremes else None
    try:
        paused = time.perf_counter()
        res = yield from solver.integrate_steps(sys, y0, hist0, times, progress=bar,
                                                log_from=t_lo, dense_points=dense_points)
        # not the other samples' steps' time (the integration's own is its wall time)
        start += time.perf_counter() - paused - res.stats.wall_time
    finally:
        if bar is not None:
            bar.close()
    Y, YD = res.y, res.ydot
    Q, V, A = Y[:, :n], Y[:, n:2 * n], YD[:, n:2 * n]
    outputs = values(scene, compiled, times, Q, V, A, H=res.hist_out, counterpart=reference)
    drift = res.stats.max_position_violation
    if counterpart is None and (has_clearance or reference is not None):
        # undriven mechanism: ideal counterpart by dynamics
        counterpart, drift_i = _ideal_by_dynamics(reference or scene, solver, times, scene)
        drift = max(drift, drift_i)
    orbits, energy = _orbits_and_energy(compiled, res)
    _check_orbits(scene, times, orbits)
    ext = sec = None
    if extremes:
        assert t_lo is not None  # set above when extremes
        log = res.log
        T, sel, first = _window_points(times, t_lo, log[:, 0])
        ext, sec = _extremes_of(scene, compiled, T,
                                _window_values(scene, compiled, outputs, sel, first, log, n,
                                               reference),
                                _ideal_at(scene, compiled, ref, q0, solver, T, times[~sel]),
                                sectors)
    wall = time.perf_counter() - start
    stats = res.stats.as_dict()
    stats["total_wall_time"] = wall
    if extremes:
        stats["n_extreme_points"] = int(T.size)
    return SimulationResult(scene=scene, time=times,
                            crank_angle=_crank_angle(scene, compiled, times),
                            outputs=outputs,
                            ideal=counterpart if has_clearance or reference is not None
                            else None,
                            q=Q, v=V, a=A, method="dynamics", stats=stats,
                            provenance=_provenance(scene, wall, reference)
                            if provenance else {},
                            orbits=orbits, energy=energy, extremes=ext, sector_extremes=sec,
                            warnings=_drift_caveats(scene, compiled, drift, stats))
