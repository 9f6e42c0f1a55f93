"""Run a scene: ``simulate(scene) -> SimulationResult``.

What runs depends only on what the scene declares:

* no clearance joints and fully driven → kinematic analysis only (no dynamics);
* clearance joints → forward dynamics of the mechanism with the clearance joints as force
  elements, plus the ideal counterpart (the same scene with those joints ideal) by kinematic
  analysis when it is fully driven (by forward dynamics otherwise), and the errors;
* undriven (free) mechanisms → forward dynamics.
"""

from __future__ import annotations

import inspect
import math
import os
import platform
import time
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from .errors import AssemblyError, SimulationError
from .integrate import INTEGRATORS, IntegrationResult, get_integrator
from .mechanics import problem
from .mechanics.kinematics import assemble, kinematic_analysis
from .mechanics.system import CompiledScene, compile_scene
from .scene.model import QUANTITIES, Scene

# Default integrator per scene type, chosen from measurements (docs/performance.md).
DEFAULT_SOLVERS: dict[str, tuple[str, dict]] = {
    "ideal": ("dopri5", {"rtol": 1e-9, "atol": 1e-12}),
    # dry: 1e-7 was shown biased by the ensemble measure (nine-bar-dry, R = 32, two seeds:
    # velocity statistics 5 % and acceleration statistics 13-21 % off the DOPRI5 1e-11
    # reference; slider-crank-dry velocity statistics 4 %); from 1e-8 on no setting is shown
    # to exceed 1 %, for 1.4x the evaluations (docs/performance.md, "What accuracy costs")
    "dry": ("dopri5", {"rtol": 1e-8, "atol": 1e-11}),
    # the film of a transition joint makes it stiff like a lubricated one: on the nine-bar
    # radau needs 15x (100 cP, no impact), 4x (10 cP, 5 impacts) and 1.2x (1 cP, 16 impacts)
    # fewer rhs evaluations than DOPRI5 (docs/performance.md)
    "transition": ("radau", {"rtol": 1e-7, "atol": 1e-10}),
    # compiled Radau IIA: 8x faster than LSODA at the same tolerances on the lubricated
    # nine-bar (0.023 vs 0.18 s, 6.5k vs 13.6k rhs evaluations per cycle, no Python per
    # step), peak slider acceleration within 2e-4 m/s² of a tight reference (docs/performance.md)
    "lubricated": ("radau", {"rtol": 1e-7, "atol": 1e-10}),
}


def scene_kind(scene: Scene) -> str:
    """``ideal``, ``dry``, ``transition`` or ``lubricated``: the most demanding effect declared.

    A lubricated joint makes the problem stiff; a dry or transition joint makes it
    non-smooth; the stiff default wins when both are present."""
    models = {j.model for j in scene.clearance_joints}
    for kind in ("lubricated", "transition", "dry"):
        if kind in models:
            return kind
    return "ideal"


def make_integrator(scene: Scene, integrator: str | None = None, **settings):
    """The integrator a scene asks for (``solver.integrator``; ``"auto"`` → per scene type)."""
    s = scene.solver
    name = s.integrator if integrator is None else integrator
    if name != "auto" and name not in INTEGRATORS:
        raise SimulationError(f"solver.integrator: unknown integrator {name!r}; allowed: auto, "
                              f"{', '.join(sorted(INTEGRATORS))}")
    chosen: dict = {}
    if name == "auto":
        name, chosen = DEFAULT_SOLVERS[scene_kind(scene)]
        chosen = dict(chosen)
        if name not in INTEGRATORS:  # compiled stiff method not available: SciPy's
            name = "lsoda"
    # step, rtol, atol and the integrator's own keywords (Radau's fixed_step); the step
    # budget and the onset tolerance come from the scene
    own = set(inspect.signature(INTEGRATORS[name]).parameters) - {"kwargs"}
    allowed = sorted(({"step", "rtol", "atol"} | own) - {"max_steps", "onset_tolerance"})
    unknown = sorted(set(settings) - set(allowed))
    if unknown:
        raise SimulationError(f"solver settings of {name!r}: unknown "
                              f"{', '.join(map(repr, unknown))}; allowed: {', '.join(allowed)}")
    for key in ("step", "rtol", "atol"):
        value = getattr(s, key)
        if value is not None:
            chosen[key] = value
    chosen.update({k: v for k, v in settings.items() if v is not None})
    if name == "rk4" and chosen.get("step") is None:
        raise SimulationError("solver.step: the fixed-step integrator 'rk4' needs a step (s)")
    if INTEGRATORS.get(name) is not None and not INTEGRATORS[name].adaptive:
        chosen.pop("rtol", None)
        chosen.pop("atol", None)
    return get_integrator(name, max_steps=s.max_steps, onset_tolerance=s.onset_tolerance,
                          **chosen)


def _physical_memory() -> int | None:
    """The machine's physical memory (bytes), or None where the OS does not say (Windows)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return None


def output_times(scene: Scene, compiled: CompiledScene | None = None) -> np.ndarray:
    """Output instants (s) from the scene's analysis settings."""
    compiled = compiled or compile_scene(scene)
    a = scene.analysis
    duration = a.duration if a.duration is not None else a.cycles * compiled.period
    if a.sample_step is not None:
        step = a.sample_step
    else:
        speed = abs(scene.drivers[a.cycle_driver].speed)
        step = a.sample_step_angle / speed
    n = math.floor(duration / step * (1 + 1e-12)) + 1
    # the state and its derivative, positions, velocities, accelerations and point outputs
    # at every instant: about 8 arrays of the state's size, 8 bytes per value
    need = 8 * 8 * n * (2 * compiled.q_guess.size + 2)
    have = _physical_memory()
    if have is not None and need > have:
        field = "analysis.sample_step" if a.sample_step is not None else \
            "analysis.sample_step_angle"
        raise SimulationError(
            f"{scene.source or scene.name}: {field}: {n:.3g} output instants over {duration:.6g} s need about "
            f"{need / 2**30:.3g} GiB, more than this machine's {have / 2**30:.3g} GiB; allowed: "
            "a sample step that keeps the output within memory")
    return np.arange(n) * step


def _crank_angle(scene: Scene, compiled: CompiledScene, times: np.ndarray):
    if compiled.cycle_driver < 0:
        return None
    sys = compiled.ideal
    k = compiled.cycle_driver
    theta = problem.driver_angles(sys.dr_law[k], sys.dr_par[k], times)
    th0 = problem.driver_law(sys.dr_law[k], sys.dr_par[k], 0.0)[0]
    sign = math.copysign(1.0, scene.drivers[compiled.driver_names[k]].speed)
    return (theta - th0) * sign * (180.0 / math.pi)


def _point_outputs(compiled: CompiledScene, Q, V, A):
    """Displacement, velocity, acceleration of every output point along its axis."""
    out = {}
    for k, name in enumerate(compiled.output_names):
        b = compiled.out_body[k]
        sx, sy = compiled.out_s[k]
        ux, uy = compiled.out_axis[k]
        th = Q[:, 3 * b + 2]
        w = V[:, 3 * b + 2]
        al = A[:, 3 * b + 2]
        c, s = np.cos(th), np.sin(th)
        ax, ay = c * sx - s * sy, s * sx + c * sy  # A s
        px, py = Q[:, 3 * b] + ax, Q[:, 3 * b + 1] + ay
        vx, vy = V[:, 3 * b] - ay * w, V[:, 3 * b + 1] + ax * w
        accx = A[:, 3 * b] - ay * al - ax * w * w
        accy = A[:, 3 * b + 1] + ax * al - ay * w * w
        out[name] = {"displacement": px * ux + py * uy, "velocity": vx * ux + vy * uy,
                     "acceleration": accx * ux + accy * uy}
    return out


@dataclass(frozen=True)
class SimulationResult:
    """The outcome of :func:`simulate`.

    Attributes
    ----------
    scene : Scene
    time : ndarray
        Output instants (s).
    crank_angle : ndarray or None
        Rotation of the cycle driver since t = 0 (degrees), when the analysis has one.
    outputs : dict
        ``outputs[name][quantity]`` (m, m/s, m/s²) of the simulated mechanism.
    ideal : dict or None
        The same for the ideal counterpart (scenes with clearance joints).
    q, v, a : ndarray, shape (n_times, n)
        Coordinates (m, rad) and their first and second derivatives.
    orbits : dict
        Per clearance joint: eccentricity components ``ex``, ``ey`` (m) and ratio ``eps``.
    energy : dict
        ``kinetic``, ``potential``, ``elastic``, ``input_work``, ``clearance_work`` (J) and
        ``balance`` = ΔT + ΔV − W_in − W_cl (J), which integration and Baumgarte errors alone
        make non-zero.
    method : str
        ``"kinematics"`` or ``"dynamics"``.
    stats : dict
        Solver statistics (:class:`~mechrel.integrate.SolverStats` as a dict) or those of the
        kinematic analysis; always includes ``max_position_violation`` and ``wall_time``.
    provenance : dict
    """

    scene: Scene
    time: np.ndarray
    crank_angle: np.ndarray | None
    outputs: Mapping[str, Mapping[str, np.ndarray]]
    ideal: Mapping[str, Mapping[str, np.ndarray]] | None
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    method: str
    stats: Mapping
    provenance: Mapping
    orbits: Mapping[str, Mapping[str, np.ndarray]] = field(default_factory=dict)
    energy: Mapping[str, np.ndarray] = field(default_factory=dict)

    def error(self, output: str, quantity: str) -> np.ndarray:
        """Simulated minus ideal ``quantity`` of ``output``."""
        if self.ideal is None:
            raise SimulationError("this scene has no clearance joints: there is no response "
                                  "error (the mechanism is its own ideal counterpart)")
        return self.outputs[output][quantity] - self.ideal[output][quantity]

    def to_frame(self):
        """A :class:`pandas.DataFrame` with columns ``time``, ``crank_angle`` (when defined),
        ``<output>.<quantity>`` and, for scenes with clearance joints,
        ``<output>.<quantity>.ideal`` and ``<output>.<quantity>.error``."""
        import pandas as pd

        cols: dict[str, np.ndarray] = {"time": self.time}
        if self.crank_angle is not None:
            cols["crank_angle"] = self.crank_angle
        for name, quantities in self.outputs.items():
            for qty in QUANTITIES:
                cols[f"{name}.{qty}"] = quantities[qty]
                if self.ideal is not None:
                    cols[f"{name}.{qty}.ideal"] = self.ideal[name][qty]
                    cols[f"{name}.{qty}.error"] = quantities[qty] - self.ideal[name][qty]
        frame = pd.DataFrame(cols)
        frame.attrs["provenance"] = dict(self.provenance)
        return frame

    def orbits_frame(self):
        """Journal orbits: ``time``, ``<joint>.ex``, ``<joint>.ey`` (m), ``<joint>.eps``."""
        import pandas as pd

        cols = {"time": self.time}
        for joint, d in self.orbits.items():
            for key, values in d.items():
                cols[f"{joint}.{key}"] = values
        return pd.DataFrame(cols)


def _orbits_and_energy(compiled: CompiledScene, res: IntegrationResult):
    """Journal orbits and the energy bookkeeping at the output instants (one compiled call)."""
    from .forces.params import P_C

    sys = compiled.dynamic
    n = sys.mass.shape[0]
    Y = np.ascontiguousarray(res.y)
    EX, EY, T, V, E = problem.post_process(np.ascontiguousarray(res.t), Y, sys)
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
        eps = d["eps"]
        i = int(np.argmax(eps))
        if joint.model == "lubricated" and eps[i] >= 1.0:
            raise SimulationError(
                f"joint {name}: the journal left the bearing (eccentricity ratio ε = "
                f"{eps[i]:.4g} >= 1 at t = {times[i]:.6g} s): the film (viscosity "
                f"{joint.lubricant.viscosity:g} Pa s) cannot carry the load there; use model = "
                "'transition' (adds metal contact) or check the load and viscosity")
        if joint.model != "lubricated" and eps[i] >= 2.0:
            raise SimulationError(
                f"joint {name}: penetration {(eps[i] - 1.0) * joint.clearance:.4g} m at t = "
                f"{times[i]:.6g} s exceeds the clearance ({joint.clearance:g} m): the contact "
                "law (small deformations) does not apply; check the contact's Young's moduli "
                "and the load")


def _provenance(scene: Scene, wall: float) -> dict:
    from . import __version__
    from .scene import scene_hash

    import numba
    import scipy

    return {"scene": scene.name, "scene_hash": scene_hash(scene), "mechrel": __version__,
            "numpy": np.__version__, "scipy": scipy.__version__, "numba": numba.__version__,
            "python": platform.python_version(), "wall_time": wall}


def _check_step_budget(solver, times) -> None:
    """Refuse up front a fixed-step run whose steps over the span exceed ``solver.max_steps``
    (it would stop at the budget, after running it all, with "maximum number of steps")."""
    if solver.adaptive or times.size < 2:
        return
    span = float(times[-1] - times[0])
    needed = span / solver.step
    if needed > solver.max_steps:
        raise SimulationError(
            f"solver.step = {solver.step:g} s: the analysis span of {span:g} s needs "
            f"{needed:.3g} steps of {solver.name}, more than solver.max_steps = "
            f"{solver.max_steps}; allowed: solver.step >= {span / solver.max_steps:.3g} s, or "
            "a larger solver.max_steps (each step costs about a microsecond or more)")


# Magnitudes (SI) beyond which a scene value is named when a run fails: no quantity of a
# planar mechanism comes near it (Young's moduli are ~1e11 Pa), and products and squares of
# such values overflow float64 in the force laws and the kinematics.
EXTREME_MAGNITUDE = 1e15


def extreme_values(scene: Scene) -> list[str]:
    """``PATH = VALUE`` of the scene's numbers of magnitude >= :data:`EXTREME_MAGNITUDE`."""
    from collections.abc import Mapping
    found, stack = [], [(scene.raw or {}, "")]
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


def simulate(scene: Scene, *, method: str = "auto", integrator: str | None = None,
             progress: bool = False, **solver_settings) -> SimulationResult:
    """Simulate a scene over its analysis span.

    Parameters
    ----------
    scene : Scene
        From :func:`mechrel.scene.load_scene`.
    method : {"auto", "kinematics", "dynamics"}
        ``auto`` uses kinematic analysis for a fully driven scene without clearance joints and
        forward dynamics otherwise; ``dynamics`` forces forward dynamics (e.g. to check an
        integrator against the kinematic analysis).
    integrator : str, optional
        Overrides ``scene.solver.integrator``.
    progress : bool
        Show a progress bar over the output instants.
    **solver_settings
        ``step``, ``rtol``, ``atol`` overrides.

    Returns
    -------
    SimulationResult

    Raises
    ------
    AssemblyError, SimulationError
        A failed run; when the scene holds values of magnitude >= ``EXTREME_MAGNITUDE``
        the message names them first (their overflow is the likely cause).
    """
    try:
        return _simulate(scene, method=method, integrator=integrator, progress=progress,
                         **solver_settings)
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


def _simulate(scene: Scene, *, method: str = "auto", integrator: str | None = None,
              progress: bool = False, **solver_settings) -> SimulationResult:
    start = time.perf_counter()
    if not isinstance(scene, Scene):
        raise TypeError(f"simulate: scene must be a Scene, got {type(scene).__name__} "
                        f"{scene!r:.60}; load it first: simulate(load_scene(...))")
    # made (and so checked) even when kinematic analysis needs no integrator
    solver = make_integrator(scene, integrator, **solver_settings)
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
    q0, _ = assemble(compiled.ideal, compiled.q_guess, 0.0, tol=tol,
                     labels=compiled.labels["ideal"])

    ideal = None
    if driven and (has_clearance or method in ("auto", "kinematics")):
        Qi, Vi, Ai, viol_i = kinematic_analysis(compiled.ideal, q0, times, tol=tol,
                                                labels=compiled.labels["ideal"])
        ideal = _point_outputs(compiled, Qi, Vi, Ai)

    if not has_clearance and driven and method != "dynamics":
        wall = time.perf_counter() - start
        stats = {"integrator": "kinematic-analysis", "n_steps": times.size,
                 "max_position_violation": float(viol_i), "wall_time": wall, "status": "ok"}
        return SimulationResult(scene=scene, time=times,
                                crank_angle=_crank_angle(scene, compiled, times),
                                outputs=ideal, ideal=None, q=Qi, v=Vi, a=Ai,
                                method="kinematics", stats=stats,
                                provenance=_provenance(scene, wall))

    sys = compiled.dynamic
    qa, va = assemble(compiled.assembly, q0, 0.0, tol=tol,
                      labels=compiled.labels["assembly"])
    y0 = np.concatenate([qa, va, np.zeros(problem.N_WORK)])
    hist0 = np.zeros(sys.n_contacts)
    bar = None
    if progress:
        from tqdm.auto import tqdm
        bar = tqdm(total=times.size, desc=f"simulate {scene.name}", unit="sample", leave=False)
    try:
        res = solver.integrate(sys, y0, hist0, times, progress=bar)
    finally:
        if bar is not None:
            bar.close()
    Y, YD = res.y, res.ydot
    Q, V, A = Y[:, :n], Y[:, n:2 * n], YD[:, n:2 * n]
    outputs = _point_outputs(compiled, Q, V, A)
    if has_clearance and ideal is None:  # undriven mechanism: ideal counterpart by dynamics
        qi, vi = assemble(compiled.ideal, q0, 0.0, tol=tol)
        resi = solver.integrate(compiled.ideal, np.concatenate([qi, vi, np.zeros(2)]),
                                np.zeros(0), times)
        ideal = _point_outputs(compiled, resi.y[:, :n], resi.y[:, n:2 * n],
                               resi.ydot[:, n:2 * n])
    orbits, energy = _orbits_and_energy(compiled, res)
    _check_orbits(scene, times, orbits)
    wall = time.perf_counter() - start
    stats = res.stats.as_dict()
    stats["total_wall_time"] = wall
    return SimulationResult(scene=scene, time=times,
                            crank_angle=_crank_angle(scene, compiled, times),
                            outputs=outputs, ideal=ideal if has_clearance else None,
                            q=Q, v=V, a=A, method="dynamics", stats=stats,
                            provenance=_provenance(scene, wall),
                            orbits=orbits, energy=energy)
