"""Run a scene: ``simulate(scene) -> SimulationResult``.

What runs depends only on what the scene declares:

* no clearance joints and fully driven → kinematic analysis only (no dynamics);
* clearance joints → forward dynamics of the mechanism with the clearance joints as force
  elements, plus the ideal counterpart (the same scene with those joints ideal) by kinematic
  analysis when it is fully driven (by forward dynamics otherwise), and the errors;
* undriven (free) mechanisms → forward dynamics.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
import os
import platform
import time
from dataclasses import dataclass, field
from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import Any

import numpy as np

from .errors import AssemblyError, SimulationError
from .forces.models import MODELS, SUBTABLES
from .integrate import INTEGRATORS, IntegrationResult, get_integrator
from .mechanics.drivers import driver_angles, driver_law
from .mechanics.dynamics import N_WORK
from .mechanics.kinematics import assemble, kinematic_analysis
from .mechanics.post import post_process
from .mechanics.system import CompiledScene, System, _driver_row, compile_scene
from .scene._values import SceneValues, table_of, value_path
from .scene.model import GROUND, Scene

# Default integrator per scene kind: "ideal" here, each clearance model's from its row of the
# table of models (mechrel.forces.models.MODELS, where the measurements behind each are cited).
DEFAULT_SOLVERS: dict[str, tuple[str, dict]] = {
    "ideal": ("dopri5", {"rtol": 1e-9, "atol": 1e-12}),
    **{m.name: (m.solver[0], dict(m.solver[1])) for m in MODELS.values()},
}


# Points of the integrator's continuous extension logged inside each step for the cycle
# extremes, beside the step's end (docs/mechanics.md, "Cycle extremes"): the four-bar's peak
# acceleration errors change by < 1e-3 (relative) from 3 to 15 points (tests/test_extremes.py).
DENSE_POINTS = 3
# Kinematic-only runs (an ideal scene against a reference design) have no steps: their extremes
# come from this many equal intervals of the window (smooth errors, error of the peak
# ~ (window / KINEMATIC_POINTS)^2 / 8 of its curvature).
KINEMATIC_POINTS = 3600
# The statistics of every output's error over the window, in SimulationResult.extremes.
EXTREME_FIELDS = ("max", "max_time", "max_angle", "min", "min_time", "min_angle",
                  "max_abs", "max_abs_time", "max_abs_angle")


def scene_kind(scene: Scene) -> str:
    """``ideal`` or the name of a clearance model: the most demanding effect declared.

    A film makes the problem stiff; contact makes it non-smooth; when a scene mixes models the
    one of highest ``precedence`` in the table of models wins (lubricated, then transition,
    then dry: the stiff default wins).

    Parameters
    ----------
    scene : mechrel.scene.model.Scene
        The scene.

    Returns
    -------
    str
        ``"ideal"``, ``"dry"``, ``"lubricated"`` or ``"transition"``.

    Examples
    --------
    The four-bar has a lubricated and a dry joint: the stiff film sets its kind:

    >>> from mechrel.scene import load_scene
    >>> scene_kind(load_scene("slider-crank")), scene_kind(load_scene("four-bar"))
    ('ideal', 'lubricated')
    """
    rows = [j.clearance_model for j in scene.clearance_joints]
    return max(rows, key=lambda m: m.precedence).name if rows else "ideal"


def make_integrator(scene: Scene, integrator: str | None = None, **settings):
    """The integrator a scene asks for (``solver.integrator``; ``"auto"`` → per scene type).

    Parameters
    ----------
    scene : Scene
        Its ``solver`` table gives the integrator, step (s), tolerances, step budget,
        contact-onset tolerance (m) and radau's formulation.
    integrator : str, optional
        Overrides ``scene.solver.integrator``: ``"auto"`` (:data:`DEFAULT_SOLVERS` of the
        scene's kind, :func:`scene_kind`) or a name of :data:`mechrel.integrate.INTEGRATORS`.
    **settings
        ``step`` (s), ``rtol``, ``atol`` and the integrator's own keywords, overriding the
        scene's (None leaves a value as it is).

    Returns
    -------
    Integrator
        Configured, ready for :meth:`~mechrel.integrate.base.Integrator.integrate`.

    Raises
    ------
    SimulationError
        An unknown integrator or setting, a fixed-step method without a step, or a
        ``solver.formulation`` for an integrator other than radau.

    Examples
    --------
    A dry clearance joint makes the problem non-smooth: the default is DOPRI5 at tight
    tolerances.

    >>> from mechrel.scene import load_scene
    >>> solver = make_integrator(load_scene("slider-crank-dry"))
    >>> solver.name, solver.rtol, solver.atol
    ('dopri5', 1e-08, 1e-11)

    A scene may choose the equations radau integrates:

    >>> scene = load_scene("nine-bar-lubricated", overrides={"solver.formulation": "absolute"})
    >>> make_integrator(scene).formulation
    'absolute'
    """
    s = scene.solver
    name = s.integrator if integrator is None else integrator
    if name != "auto" and name not in INTEGRATORS:
        raise SimulationError(f"solver.integrator: unknown integrator {name!r}; allowed: auto, "
                              f"{', '.join(sorted(INTEGRATORS))}")
    chosen: dict = {}
    if name == "auto":
        kind = scene_kind(scene)  # a model registered since import: its row's solver
        name, table = DEFAULT_SOLVERS.get(kind) or MODELS[kind].solver
        chosen = dict(table)
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
    if s.formulation is not None:  # radau's equations (a setting of radau alone)
        if "formulation" not in own:
            raise SimulationError(
                f"solver.formulation = {s.formulation!r}: the equations that 'radau' "
                f"integrates, but this scene runs {name!r} (set solver.integrator = 'radau', "
                "or leave solver.formulation unset)")
        chosen["formulation"] = s.formulation
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
    """Output instants (s) from the scene's analysis settings.

    Parameters
    ----------
    scene : Scene
        ``analysis.duration`` (s) or ``analysis.cycles`` of the cycle driver, and
        ``analysis.sample_step`` (s) or ``analysis.sample_step_angle`` (rad).
    compiled : CompiledScene, optional
        The scene compiled (:func:`mechrel.mechanics.system.compile_scene`), if at hand.

    Returns
    -------
    ndarray
        ``0, h, 2h, ...`` up to the duration (s), both ends included.

    Raises
    ------
    SimulationError
        When the instants would not fit in this machine's memory.

    Examples
    --------
    One crank revolution at 5000 rpm (12 ms) sampled every degree:

    >>> from mechrel.scene import load_scene
    >>> t = output_times(load_scene("slider-crank"))
    >>> t.size, round(float(t[-1]), 9)
    (361, 0.012)
    """
    compiled = compiled or compile_scene(scene)
    a = scene.analysis
    if a.duration is not None:
        duration = a.duration
    else:
        # validated: cycles come with a cycle driver, which gives the period
        assert a.cycles is not None and compiled.period is not None
        duration = a.cycles * compiled.period
    if a.sample_step is not None:
        step = a.sample_step
    else:
        assert a.sample_step_angle is not None and a.cycle_driver is not None  # validated
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
            f"{scene.source or scene.name}: {field}: {n:.3g} output instants over "
            f"{duration:.6g} s need about "
            f"{need / 2**30:.3g} GiB, more than this machine's {have / 2**30:.3g} GiB; allowed: "
            "a sample step that keeps the output within memory")
    return np.arange(n) * step


def _crank_angle(scene: Scene, compiled: CompiledScene, times: np.ndarray):
    if compiled.cycle_driver < 0:
        return None
    sys = compiled.ideal
    k = compiled.cycle_driver
    theta = driver_angles(sys.dr_law[k], sys.dr_par[k], times)
    th0 = driver_law(sys.dr_law[k], sys.dr_par[k], 0.0)[0]
    sign = math.copysign(1.0, scene.drivers[compiled.driver_names[k]].speed)
    return (theta - th0) * sign * (180.0 / math.pi)


def _outputs(scene: Scene, compiled: CompiledScene, T, Q, V, A, *, H=None, ideal=False,
             actual=None, counterpart=None):
    """Every output of ``scene`` at the instants ``T`` and states ``Q``, ``V``, ``A`` (rows),
    ``H`` the contact history there, by its kind (:data:`mechrel.outputs.OUTPUT_KINDS`)."""
    from .outputs import values
    return values(scene, compiled, T, Q, V, A, H=H, ideal=ideal, actual=actual,
                  counterpart=counterpart)


@dataclass(frozen=True)
class SimulationResult:
    """The outcome of :func:`simulate`.

    Parameters
    ----------
    scene : Scene
        The scene simulated.
    time : ndarray
        Output instants (s).
    crank_angle : ndarray or None
        Rotation of the cycle driver since t = 0 (degrees), when the analysis has one.
    outputs : dict
        ``outputs[name][quantity]`` of the simulated mechanism, in SI units; the quantities
        of each output are those of its kind (:data:`mechrel.outputs.OUTPUT_KINDS`).
    ideal : dict or None
        The same for the ideal counterpart: the scene's own mechanism with all joints ideal
        (scenes with clearance joints), or the ideal mechanism of the ``reference`` design
        given to :func:`simulate`.
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
        Scene name and hash, reference name and hash (if any), versions of mechrel, NumPy,
        SciPy, Numba and Python, and the wall time (s).
    extremes : dict or None
        With ``simulate(..., extremes=True)``: ``extremes[output][quantity][field]`` for the
        fields of :data:`EXTREME_FIELDS`: the largest (``max``) and smallest (``min``) signed
        error and the largest magnitude (``max_abs``) over the analysis window (the last cycle
        of the cycle driver, or the whole span), each with the instant (``*_time``, s) and
        the cycle driver's rotation since t = 0 (``*_angle``, degrees; NaN without a cycle
        driver) where it occurs. Found on the integrator's solution (every accepted step's end
        and ``dense_points`` points of its continuous extension inside it, plus the output
        instants), not on the output grid (docs/mechanics.md, "Cycle extremes").
    sector_extremes : dict or None
        With ``simulate(..., extremes=True, sectors=step)``: ``sector_extremes[output][quantity]``
        = ``(max, min)``, arrays of the largest and smallest signed error over each closed
        sector [k·step, (k + 1)·step] of the analysed cycle's crank angle (degrees from its
        start), found on the same points as the cycle extremes: the members of the whole cycle's
        series system (docs/uq.md, "The whole cycle as a series system").

    See Also
    --------
    simulate : Makes it.

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> r = simulate(load_scene("slider-crank"))
    >>> sorted(r.outputs["slider"])
    ['acceleration', 'displacement', 'velocity']
    >>> r.q.shape == (r.time.size, 9)
    True
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
    extremes: Mapping[str, Mapping[str, Mapping[str, float]]] | None = None
    sector_extremes: Mapping[str, Mapping[str, tuple]] | None = None

    def extremes_frame(self):
        """The cycle extremes as a :class:`pandas.DataFrame`: one row per ``(output,
        quantity)``, the columns of :data:`EXTREME_FIELDS` (values in SI units, times in s,
        angles in degrees of the cycle driver's rotation since t = 0).

        Returns
        -------
        pandas.DataFrame
            The extremes, with the provenance in ``frame.attrs["provenance"]``.

        Raises
        ------
        mechrel.errors.SimulationError
            The result was simulated without ``extremes=True``.

        Examples
        --------
        A crank 0.1 mm longer than the nominal one moves the slider by 0.1 mm at its dead
        centres:

        >>> from mechrel.scene import load_scene
        >>> nominal = load_scene("slider-crank")
        >>> longer = load_scene("slider-crank", overrides=["bodies.crank.length(O,A)=0.0501"])
        >>> r = simulate(longer, reference=nominal, extremes=True)
        >>> round(float(r.extremes_frame().loc[("slider", "displacement"), "max_abs"]), 9)
        0.0001
        """
        import pandas as pd

        if self.extremes is None:
            raise SimulationError("this result has no cycle extremes; simulate(scene, "
                                  "extremes=True) computes them")
        rows = {(name, qty): d for name, qs in self.extremes.items() for qty, d in qs.items()}
        frame = pd.DataFrame.from_dict(rows, orient="index", columns=list(EXTREME_FIELDS))
        frame.index = pd.MultiIndex.from_tuples(frame.index, names=["output", "quantity"])
        frame.attrs["provenance"] = dict(self.provenance)
        return frame

    def error(self, output: str, quantity: str) -> np.ndarray:
        """Simulated minus ideal ``quantity`` of ``output``.

        Parameters
        ----------
        output : str
            An output name of the scene.
        quantity : str
            One of the output's quantities (e.g. ``"displacement"``).

        Returns
        -------
        numpy.ndarray
            The error at each output instant (SI units).

        Raises
        ------
        mechrel.errors.SimulationError
            The result has no ideal counterpart (no clearance joint and no reference).

        Examples
        --------
        A crank 0.1 mm longer than the nominal one: at t = 0 (crank along the slider's line)
        the slider is 0.1 mm further out:

        >>> from mechrel.scene import load_scene
        >>> nominal = load_scene("slider-crank")
        >>> longer = load_scene("slider-crank", overrides=["bodies.crank.length(O,A)=0.0501"])
        >>> e = simulate(longer, reference=nominal).error("slider", "displacement")
        >>> round(float(e[0]), 9)   # m
        0.0001
        """
        if self.ideal is None:
            raise SimulationError("this scene has no clearance joints: there is no response "
                                  "error (the mechanism is its own ideal counterpart)")
        return self.outputs[output][quantity] - self.ideal[output][quantity]

    def to_frame(self):
        """A :class:`pandas.DataFrame` with columns ``time``, ``crank_angle`` (when defined),
        ``<output>.<quantity>`` and, for scenes with clearance joints,
        ``<output>.<quantity>.ideal`` and ``<output>.<quantity>.error``.

        Returns
        -------
        pandas.DataFrame
            One row per output instant (SI units; ``crank_angle`` in degrees), with the
            provenance in ``frame.attrs["provenance"]``.

        Examples
        --------
        >>> from mechrel.scene import load_scene
        >>> frame = simulate(load_scene("slider-crank")).to_frame()
        >>> frame.columns.tolist()
        ['time', 'crank_angle', 'slider.displacement', 'slider.velocity', 'slider.acceleration']
        >>> len(frame)   # one cycle sampled every degree
        361
        """
        import pandas as pd

        cols: dict[str, np.ndarray] = {"time": self.time}
        if self.crank_angle is not None:
            cols["crank_angle"] = self.crank_angle
        for name, quantities in self.outputs.items():
            for qty in quantities:
                cols[f"{name}.{qty}"] = quantities[qty]
                if self.ideal is not None:
                    cols[f"{name}.{qty}.ideal"] = self.ideal[name][qty]
                    cols[f"{name}.{qty}.error"] = quantities[qty] - self.ideal[name][qty]
        frame = pd.DataFrame(cols)
        frame.attrs["provenance"] = dict(self.provenance)
        return frame

    def orbits_frame(self):
        """Journal orbits: ``time``, ``<joint>.ex``, ``<joint>.ey`` (m), ``<joint>.eps``.

        Returns
        -------
        pandas.DataFrame
            One row per output instant; only ``time`` for a scene without clearance joints.

        Examples
        --------
        >>> from mechrel.scene import load_scene
        >>> simulate(load_scene("slider-crank")).orbits_frame().columns.tolist()
        ['time']
        """
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


def _provenance(scene: Scene, wall: float, reference: Scene | None = None) -> dict:
    from . import __version__
    from .scene import scene_hash

    import numba
    import scipy

    out = {"scene": scene.name, "scene_hash": scene_hash(scene), "mechrel": __version__,
           "numpy": np.__version__, "scipy": scipy.__version__, "numba": numba.__version__,
           "python": platform.python_version(), "wall_time": wall}
    if reference is not None:
        out["reference"] = reference.name
        out["reference_hash"] = scene_hash(reference)
    return out


class ReferenceDesign:
    """The ideal mechanism of a reference design (:func:`simulate`'s ``reference``), compiled
    and assembled once, its kinematic analysis kept for the last few sets of instants: the
    samples of a study measured against one nominal design share it
    (:meth:`mechrel.uq.problem.mechanism.MechanismModel.evaluate_batch`), and each sample's
    outputs are still computed from it (they may read the simulated scene, e.g. a joint's
    clearance). The numbers are those of a reference made anew, bitwise.

    Parameters
    ----------
    scene : Scene
        The reference design.

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> nominal = load_scene("slider-crank")
    >>> longer = load_scene("slider-crank", overrides=["bodies.crank.length(O,A)=0.0501"])
    >>> ref = ReferenceDesign(nominal)
    >>> a = simulate_sample(longer, make_integrator(longer), reference=ref)
    >>> b = simulate(longer, reference=nominal)
    >>> bool((a.error("slider", "displacement") == b.error("slider", "displacement")).all())
    True
    """

    KEEP = 4  # sets of instants kept (a sample's output grid and its extremes' window points)

    def __init__(self, scene: Scene):
        self.scene = scene
        self._compiled: CompiledScene | None = None
        self._q0: np.ndarray | None = None
        self._kinematics: dict[bytes, tuple] = {}

    def outputs(self, times: np.ndarray, actual: Scene):
        """The outputs of the ideal mechanism at some instants, by kinematic analysis.

        Parameters
        ----------
        times : ndarray
            Instants (s), increasing.
        actual : Scene
            The simulated scene (an output may read it, e.g. a joint's clearance).

        Returns
        -------
        dict or None
            ``{output: {quantity: array}}``; None when the reference is not fully driven
            (its ideal mechanism is then simulated by forward dynamics).

        Raises
        ------
        AssemblyError
            The reference cannot be assembled, or its kinematic analysis fails.

        Examples
        --------
        >>> from mechrel.scene import load_scene
        >>> ref = ReferenceDesign(load_scene("slider-crank"))
        >>> x = ref.outputs(np.array([0.0, 0.006]), ref.scene)["slider"]["displacement"]
        >>> x.round(6).tolist()   # the crank along the slider's line, then opposite
        [0.17, 0.07]
        """
        scene = self.scene
        if self._compiled is None:
            self._compiled = compile_scene(scene)
        compiled = self._compiled
        if compiled.ideal.n_constraints != compiled.q_guess.size:
            return None
        tol = scene.solver.assembly_tolerance
        key = np.ascontiguousarray(times, dtype=float).tobytes()
        got = self._kinematics.get(key)
        if got is None:
            if self._q0 is None:
                self._q0, _ = assemble(compiled.ideal, compiled.q_guess, 0.0, tol=tol,
                                       labels=compiled.labels["ideal"])
            Q, V, A, _ = kinematic_analysis(compiled.ideal, self._q0, times, tol=tol,
                                            labels=compiled.labels["ideal"])
            for a in (Q, V, A):
                a.setflags(write=False)  # shared by the samples
            if len(self._kinematics) >= self.KEEP:
                self._kinematics.pop(next(iter(self._kinematics)))
            got = self._kinematics[key] = (Q, V, A)
        return _outputs(scene, compiled, times, *got, ideal=True, actual=actual)


def _reference_outputs(reference: ReferenceDesign, times: np.ndarray, actual: Scene):
    """The outputs of ``reference``'s ideal mechanism at ``times`` (kinematic analysis when it
    is fully driven; None otherwise: forward dynamics then)."""
    return reference.outputs(times, actual)


def _ideal_by_dynamics(source: Scene, solver, times: np.ndarray, actual: Scene):
    """The outputs of ``source``'s ideal mechanism by forward dynamics (undriven scenes)."""
    compiled = compile_scene(source)
    n = compiled.q_guess.size
    tol = source.solver.assembly_tolerance
    q0, _ = assemble(compiled.ideal, compiled.q_guess, 0.0, tol=tol,
                     labels=compiled.labels["ideal"])
    qi, vi = assemble(compiled.ideal, q0, 0.0, tol=tol)
    resi = solver.integrate(compiled.ideal, np.concatenate([qi, vi, np.zeros(2)]),
                            np.zeros(0), times, t0=0.0)
    return _outputs(source, compiled, times, resi.y[:, :n], resi.y[:, n:2 * n],
                    resi.ydot[:, n:2 * n],
                    ideal=True, actual=actual)


def _check_reference(scene: Scene, reference: Scene) -> None:
    """Raise :class:`SimulationError` unless ``reference`` can serve as the ideal counterpart
    of ``scene``: the same output names, the same bodies and the same drivers (the output
    instants come from ``scene``, so the reference must be driven the same way at them)."""
    if not isinstance(reference, Scene):
        raise SimulationError(f"simulate: reference = {reference!r:.60}: not a Scene; allowed: "
                              "None or a Scene from load_scene(...)")
    name = reference.source or reference.name

    def refuse(what, mine, theirs):
        raise SimulationError(
            f"simulate: reference = {name}: {what} {theirs!r} differ from the scene's "
            f"{mine!r}; allowed: a reference with the scene's {what} (the same mechanism with "
            "other dimensions or joint models)")

    if tuple(scene.bodies) != tuple(reference.bodies):
        refuse("bodies", tuple(scene.bodies), tuple(reference.bodies))
    if tuple(scene.outputs) != tuple(reference.outputs):
        refuse("output names", tuple(scene.outputs), tuple(reference.outputs))
    kinds = {n: (o.kind, o.body, o.joint) for n, o in scene.outputs.items()}
    theirs = {n: (o.kind, o.body, o.joint) for n, o in reference.outputs.items()}
    if kinds != theirs:
        refuse("output kinds (kind, body, joint)", kinds, theirs)
    if scene.analysis.cycle_driver != reference.analysis.cycle_driver:
        refuse("cycle driver", scene.analysis.cycle_driver, reference.analysis.cycle_driver)
    if dict(scene.drivers) != dict(reference.drivers):
        refuse("drivers", dict(scene.drivers), dict(reference.drivers))


def analysis_window(compiled: CompiledScene, times: np.ndarray) -> float:
    """Start (s) of the window the cycle extremes cover: the last cycle of the cycle driver
    (one period before the last output instant), or the whole span without a cycle driver.

    Parameters
    ----------
    compiled : CompiledScene
        The compiled scene (its cycle driver and period, s).
    times : ndarray
        The output instants (s).

    Returns
    -------
    float
        The window's start (s).

    Examples
    --------
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank-dry")  # two revolutions of 12 ms
    >>> compiled = compile_scene(scene)
    >>> round(analysis_window(compiled, output_times(scene, compiled)), 9)
    0.012
    """
    if compiled.cycle_driver < 0 or compiled.period is None:
        return float(times[0])
    return max(float(times[0]), float(times[-1]) - compiled.period)


def _window_points(times: np.ndarray, t_lo: float, extra_t: np.ndarray):
    """The output instants at or after ``t_lo`` merged with the instants ``extra_t``, sorted,
    duplicates dropped: ``(T, sel, first)`` with ``sel`` the mask of the output instants kept
    and ``first`` the positions in ``concatenate([times[sel], extra_t])`` that make ``T``."""
    span = max(float(times[-1]) - t_lo, 1.0)
    sel = times >= t_lo - 1e-12 * span
    T = np.concatenate([times[sel], extra_t])
    T, first = np.unique(T, return_index=True)
    return T, sel, first


def _extremes_of(scene, compiled, T, outputs, ideal, sectors=None):
    """``({output: {quantity: {field: value}}}, sector extremes or None)`` of the error
    ``outputs − ideal`` at ``T``; with ``sectors`` (degrees), per output and quantity the
    largest and smallest error over each closed sector [k·sectors, (k + 1)·sectors] of the
    window's crank angle (:func:`_sector_extremes`)."""
    angles = _crank_angle(scene, compiled, T)
    out = {}
    by_sector = {} if sectors else None
    for name, quantities in outputs.items():
        out[name] = {}
        for qty, values in quantities.items():
            err = values - ideal[name][qty]
            if not np.all(np.isfinite(err)):
                raise SimulationError(f"output {name}.{qty}: a non-finite error on the "
                                      "solution log (cycle extremes)")
            d = {}
            for key, i in (("max", int(np.argmax(err))), ("min", int(np.argmin(err))),
                           ("max_abs", int(np.argmax(np.abs(err))))):
                d[key] = float(abs(err[i]) if key == "max_abs" else err[i])
                d[f"{key}_time"] = float(T[i])
                d[f"{key}_angle"] = float(angles[i]) if angles is not None else math.nan
            out[name][qty] = {k: d[k] for k in EXTREME_FIELDS}
            if sectors:
                by_sector.setdefault(name, {})[qty] = _sector_extremes(err, angles, sectors)
    return out, by_sector


def _sector_extremes(err: np.ndarray, angles: np.ndarray, step: float):
    """``(max, min)`` of ``err`` over the closed sectors [k·step, (k + 1)·step] of the crank
    angle since the window's start (degrees), k = 0 … 360/step − 1: the whole cycle is their
    union, so the cycle's extremes are the sectors' extremes (a point on a boundary counts in
    both sectors)."""
    n = int(round(360.0 / step))
    rel = (angles - angles[0]) / step
    k = np.clip(np.floor(rel + 1e-9).astype(int), 0, n - 1)
    smax = np.full(n, -np.inf)
    smin = np.full(n, np.inf)
    np.maximum.at(smax, k, err)
    np.minimum.at(smin, k, err)
    edge = np.abs(rel - np.round(rel)) <= 1e-9
    prev = np.round(rel).astype(int) - 1
    on = edge & (prev >= 0) & (prev < n)
    np.maximum.at(smax, prev[on], err[on])
    np.minimum.at(smin, prev[on], err[on])
    if not (np.all(np.isfinite(smax)) and np.all(np.isfinite(smin))):
        raise SimulationError(f"sector extremes: a sector of {step:g}° holds no point of the "
                              "solution "
                              "log; allowed: sectors no finer than the output grid")
    return smax, smin


def _ideal_at(scene, compiled, reference, q0, solver, T, lead):
    """The counterpart's outputs at the instants ``T``: the reference design's ideal mechanism
    or the scene's own, by kinematic analysis (driven) or forward dynamics. ``lead``: the
    output instants before ``T[0]``, through which the kinematic analysis follows the
    mechanism from its assembly at t = 0 (Newton from the t = 0 state a whole cycle later
    would have to turn the crank by 2π in one linearised step)."""
    m = lead.size
    TT = np.concatenate([lead, T])
    if reference is not None:
        got = _reference_outputs(reference, TT, scene)
        if got is None:
            return _ideal_by_dynamics(reference.scene, solver, T, scene)
    elif compiled.ideal.n_constraints == compiled.q_guess.size:
        Qi, Vi, Ai, _ = kinematic_analysis(compiled.ideal, q0, TT,
                                           tol=scene.solver.assembly_tolerance,
                                           labels=compiled.labels["ideal"])
        got = _outputs(scene, compiled, TT, Qi, Vi, Ai, ideal=True)
    else:
        return _ideal_by_dynamics(scene, solver, T, scene)
    return {name: {qty: values[m:] for qty, values in d.items()} for name, d in got.items()}


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
    from collections.abc import Mapping
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
    return _explained(scene, reference=reference, method=method, integrator=integrator,
                      progress=progress, extremes=extremes, dense_points=dense_points,
                      sectors=sectors, solver_settings=solver_settings)


def simulate_sample(scene: Scene, solver, *, reference: Scene | ReferenceDesign | None = None,
                    extremes: bool = False, sectors: float | None = None,
                    compiled: CompiledScene | None = None) -> SimulationResult:
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

    Returns
    -------
    SimulationResult
        As :func:`simulate`'s, with an empty ``provenance``.

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
    return _explained(scene, reference=reference, method="auto", integrator=None,
                      progress=False, extremes=extremes, dense_points=DENSE_POINTS,
                      sectors=sectors, solver=solver, provenance=False, compiled=compiled)


def _explained(scene, **kwargs) -> SimulationResult:
    """``_simulate(scene, **kwargs)``, a failure of a scene with values of extreme magnitude
    explained by them."""
    try:
        return _simulate(scene, **kwargs)
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
              solver_settings=None, compiled: CompiledScene | None = None) -> SimulationResult:
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
    q0, _ = assemble(compiled.ideal, compiled.q_guess, 0.0, tol=tol,
                     labels=compiled.labels["ideal"])

    ideal = None
    if driven and (has_clearance or method in ("auto", "kinematics")):
        Qi, Vi, Ai, viol_i = kinematic_analysis(compiled.ideal, q0, times, tol=tol,
                                                labels=compiled.labels["ideal"])
        # against a reference design, the scene's ideal mechanism is not the one the errors
        # are measured against: its outputs by their formulas (a path output's distance from
        # the reference's path, not the 0 of a point on its own path)
        ideal = _outputs(scene, compiled, times, Qi, Vi, Ai, ideal=reference is None,
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
                                    _outputs(scene, compiled, T, Qf[m:], Vf[m:], Af[m:],
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
        res = solver.integrate(sys, y0, hist0, times, progress=bar, log_from=t_lo,
                               dense_points=dense_points)
    finally:
        if bar is not None:
            bar.close()
    Y, YD = res.y, res.ydot
    Q, V, A = Y[:, :n], Y[:, n:2 * n], YD[:, n:2 * n]
    outputs = _outputs(scene, compiled, times, Q, V, A, H=res.hist_out, counterpart=reference)
    if counterpart is None and (has_clearance or reference is not None):
        # undriven mechanism: ideal counterpart by dynamics
        counterpart = _ideal_by_dynamics(reference or scene, solver, times, scene)
    orbits, energy = _orbits_and_energy(compiled, res)
    _check_orbits(scene, times, orbits)
    ext = sec = None
    if extremes:
        assert t_lo is not None  # set above when extremes
        ny = Y.shape[1]
        log = res.log
        T, sel, first = _window_points(times, t_lo, log[:, 0])
        Ql = np.concatenate([Y[sel, :n], log[:, 1:1 + n]])[first]
        Vl = np.concatenate([Y[sel, n:2 * n], log[:, 1 + n:1 + 2 * n]])[first]
        Al = np.concatenate([YD[sel, n:2 * n], log[:, 1 + ny + n:1 + ny + 2 * n]])[first]
        Hl = np.concatenate([res.hist_out[sel], log[:, 1 + 2 * ny:]])[first]
        ext, sec = _extremes_of(scene, compiled, T,
                                _outputs(scene, compiled, T, Ql, Vl, Al, H=Hl,
                                         counterpart=reference),
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
                            orbits=orbits, energy=energy, extremes=ext, sector_extremes=sec)


# ----------------------------------------------------------------------------- prepared scenes
# A scene prepared once for many runs that differ only in values at fixed scene paths.
#
# The samples of a study change a few numbers of one scene (a clearance, a viscosity, a crank
# speed, a point's coordinates); everything else is the same in every run. As a PyBaMM model
# takes its sampled parameters as inputs at solve time instead of being rebuilt, a
# PreparedScene compiles the scene once and, per run, sets the values where they act:
#
# * the scene: SceneValues (mechrel.scene._values) validates only the tables the values
#   sit in, with the scene loader's own rules (a bad value fails with the message a full
#   validation gives);
# * the compiled arrays (compile_scene): a clearance joint's
#   force-law values give its row of packed parameters (the vector the joint's validation
#   packed, pack_joint, which checks them: packed once), a
#   driver's values its row of driver parameters (and the cycle period), a point's
#   coordinates are written where the compiled scene holds that point; the rest of the arrays
#   are shared with the scene's own compilation.
#
# Where a point sits in the arrays is not restated here: it is found by compiling the scene
# once with the point at NaN (every entry that reads it turns NaN) and once at a probe value
# (those entries must then hold exactly the probe value, everything else unchanged). A point
# that enters the arrays other than as a copy of its coordinates, and a value at any other path
# (a mass, the solver, a joint's model or its initial eccentricity), makes the run compile its
# scene in full, as before. ``tests/test_scene_values.py`` checks, for each kind of value, that
# the arrays are bitwise those of compiling the scene.

# Fields of a joint that enter the compiled scene only through the packed force-law
# parameters of a clearance joint (pack_joint).
_FORCE_LAW_FIELDS = ("clearance", "bearing_radius", "length", *SUBTABLES)
# Numeric fields of a driver: its row of driver parameters.
_DRIVER_FIELDS = ("angle0", "speed", "acceleration", "amplitude", "frequency", "phase",
                 "ramp_time")
_SYSTEMS = ("dynamic", "assembly", "ideal")
_PROBE = (12345.678901234567, -8765.4321098765)  # no coordinate of a mechanism: a probe value


def _point_path(path: str) -> tuple[str, str] | None:
    """``(owner, point)`` of the point a geometric path sets (owner: a body or ``ground``)."""
    parts = value_path(path).split(".")
    if len(parts) == 3 and parts[:2] == ["ground", "points"]:
        return GROUND, parts[2]
    if len(parts) == 4 and parts[0] == "bodies" and parts[2] == "points":
        return parts[1], parts[3]
    return None


def _with_point(scene: Scene, owner: str, point: str, xy) -> Scene:
    """``scene`` with one point moved, not validated (for the probes)."""
    if owner == GROUND:
        return dataclasses.replace(scene, ground=MappingProxyType({**scene.ground, point: xy}))
    body = scene.bodies[owner]
    body = dataclasses.replace(body, points=MappingProxyType({**body.points, point: xy}))
    return dataclasses.replace(scene, bodies=MappingProxyType({**scene.bodies, owner: body}))


def _arrays(c: CompiledScene) -> dict[tuple[str, str], Any]:
    """Every field of a compiled scene, the systems' fields by ``(system, field)``."""
    out: dict[tuple[str, str], Any] = {}
    for name in _SYSTEMS:
        system = getattr(c, name)
        out.update({(name, f): getattr(system, f) for f in System._fields})
    out.update({("", f): getattr(c, f) for f in CompiledScene._fields if f not in _SYSTEMS})
    return out


def _same(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return (isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.shape == b.shape
                and a.dtype == b.dtype and np.array_equal(a, b, equal_nan=a.dtype.kind == "f"))
    return a == b


def locate_point(scene: Scene, compiled: CompiledScene, owner: str, point: str):
    """Where a compiled scene holds the coordinates of one point (found by probing, see the
    section comment above :class:`PreparedScene`).

    Parameters
    ----------
    scene : Scene
        The scene.
    compiled : CompiledScene
        ``compile_scene(scene)``.
    owner : str
        The body holding the point, or ``"ground"``.
    point : str
        The point's name.

    Returns
    -------
    list of (str, str, ndarray) or None
        ``(system, field, rows)`` of every array row that is a copy of the point's
        coordinates (system ``""``: a field of the compiled scene itself, e.g. ``out_s``), or
        None when the point enters the arrays other than as such a copy.

    Examples
    --------
    The slider-crank's crank pin A, where the crank–rod joint A and its ideal counterpart
    hold it:

    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank")
    >>> where = locate_point(scene, compile_scene(scene), "crank", "A")
    >>> sorted({(system, field) for system, field, _ in where})[:2]
    [('assembly', 'rev_sj'), ('dynamic', 'rev_sj')]
    """
    try:
        at_nan = _arrays(compile_scene(_with_point(scene, owner, point, (math.nan, math.nan))))
        at_probe = _arrays(compile_scene(_with_point(scene, owner, point, _PROBE)))
    except Exception:  # noqa: BLE001 - a probe the compilation refuses: compile per run
        return None
    where = []
    for key, a in _arrays(compiled).items():
        n, p = at_nan[key], at_probe[key]
        if not (isinstance(a, np.ndarray) and a.dtype.kind == "f" and a.ndim == 2
                and a.shape[1] == 2):
            if not (_same(a, n) and _same(a, p)):
                return None
            continue
        if not (isinstance(n, np.ndarray) and n.shape == a.shape
                and isinstance(p, np.ndarray) and p.shape == a.shape):
            return None
        hit = np.isnan(n) & ~np.isnan(a)
        rows = np.flatnonzero(hit.all(axis=1))
        if not np.array_equal(np.flatnonzero(hit.any(axis=1)), rows):
            return None  # one coordinate of a row, not the point
        expected = a.copy()
        expected[rows] = _PROBE
        if not np.array_equal(p, expected, equal_nan=True):
            return None  # derived from the point, not a copy of it
        if rows.size:
            where.append((key[0], key[1], rows))
    return where


class PreparedScene:
    """``scene`` compiled once, for runs with other values at ``paths`` (module docstring).

    Parameters
    ----------
    scene : Scene
        The validated scene.
    paths : sequence of str
        The dotted scene paths whose values change between runs.

    Examples
    --------
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene, with_overrides
    >>> base = load_scene("nine-bar-lubricated")
    >>> prepared = PreparedScene(base, ["joints.C1.clearance", "drivers.crank1.speed"])
    >>> values = {"joints.C1.clearance": 4e-4, "drivers.crank1.speed": -9.0}
    >>> scene, compiled = prepared.at(values)
    >>> full = compile_scene(with_overrides(base, values))
    >>> bool((compiled.dynamic.cl_p == full.dynamic.cl_p).all())
    True
    """

    def __init__(self, scene: Scene, paths: Sequence[str]):
        self.scene = scene
        self.values = SceneValues(scene, paths)
        self.compiled = compile_scene(scene)
        c = self.compiled
        joints: list[tuple[str, int]] = []
        drivers: list[tuple[str, int]] = []
        points: dict[tuple[str, str], list] = {}
        patchable = self.values.incremental
        for path in paths:
            table = table_of(path)
            point = _point_path(path)
            if point is not None:
                if point not in points:
                    where = locate_point(scene, c, *point)
                    patchable &= where is not None
                    points[point] = where or []
            elif table is not None and table[0] == "joint":
                field = path.split(".")[2].split("[")[0]
                joint = scene.joints.get(table[1])
                patchable &= (joint is not None and joint.type == "revolute"
                              and field in _FORCE_LAW_FIELDS)
                if patchable and joint.is_clearance and joint.name not in dict(joints):
                    joints.append((joint.name, c.clearance_names.index(joint.name)))
            elif table == ("drivers",):
                name, field = path.split(".")[1:3]
                patchable &= name in scene.drivers and field in _DRIVER_FIELDS
                if patchable and name not in dict(drivers):
                    drivers.append((name, c.driver_names.index(name)))
            else:
                patchable = False
        self.patchable = patchable
        self._joints, self._drivers, self._points = joints, drivers, points

    def at(self, values: Mapping[str, Any]) -> tuple[Scene, CompiledScene]:
        """The scene with ``values`` set, and its compilation.

        Parameters
        ----------
        values : mapping
            ``{dotted path: value}`` at (some of) the prepared paths (SI units).

        Returns
        -------
        (Scene, CompiledScene)
            What ``with_overrides(scene, values)`` and its ``compile_scene`` give (equal,
            bitwise).

        Raises
        ------
        mechrel.errors.SceneError
            As ``with_overrides`` raises it for these values.

        Examples
        --------
        A longer crank moves the crank pin A where the compiled scene holds it:

        >>> from mechrel.scene import load_scene
        >>> prepared = PreparedScene(load_scene("slider-crank"), ["bodies.crank.length(O,A)"])
        >>> scene, compiled = prepared.at({"bodies.crank.length(O,A)": 0.06})
        >>> (ax, _), (ox, _) = (scene.bodies["crank"].points[p] for p in "AO")
        >>> round(ax - ox, 12), prepared.patchable
        (0.06, True)
        """
        scene, packed = self.values.validate(values)
        if not self.patchable:
            return scene, compile_scene(scene)
        c = self.compiled
        systems = {name: getattr(c, name) for name in _SYSTEMS}
        own: dict[tuple[str, str], np.ndarray] = {}

        def writable(system: str, field: str) -> np.ndarray:
            key = (system, field)
            if key not in own:
                own[key] = np.array(getattr(systems[system], field) if system else
                                    getattr(c, field))
            return own[key]

        for name, k in self._joints:  # the vector the validation packed
            writable("dynamic", "cl_p")[k] = packed[name]
        period = c.period
        for name, k in self._drivers:
            row = _driver_row(scene.drivers[name])
            for system in _SYSTEMS:
                writable(system, "dr_par")[k] = row
            if k == c.cycle_driver:
                period = 2.0 * math.pi / abs(scene.drivers[name].speed)
        for (owner, point), where in self._points.items():
            xy = scene.ground[point] if owner == GROUND else scene.bodies[owner].points[point]
            for system, name, rows in where:
                writable(system, name)[rows] = xy
        for system in _SYSTEMS:
            fields = {f: a for (s, f), a in own.items() if s == system}
            if fields:
                systems[system] = systems[system]._replace(**fields)
        top = {f: a for (s, f), a in own.items() if s == ""}
        return scene, c._replace(**systems, **top, period=period)
