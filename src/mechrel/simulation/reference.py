"""The ideal counterpart a simulation's errors are measured against: the scene's own ideal
mechanism or a reference design's (:class:`ReferenceDesign`, prepared once for the samples
that share it), by kinematic analysis when it is fully driven, by forward dynamics otherwise.
"""

from __future__ import annotations


import numpy as np

from ..errors import SimulationError
from ..mechanics.kinematics import assemble, assemble_positions, kinematic_analysis
from ..mechanics.system import CompiledScene, compile_scene
from ..scene.model import Scene

from .evaluators import values

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
    >>> from mechrel.simulation import make_integrator, simulate, simulate_sample
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
                self._q0 = assemble_positions(compiled.ideal, compiled.q_guess, 0.0, tol=tol,
                                              labels=compiled.labels["ideal"])
            Q, V, A, _ = kinematic_analysis(compiled.ideal, self._q0, times, tol=tol,
                                            labels=compiled.labels["ideal"])
            for a in (Q, V, A):
                a.setflags(write=False)  # shared by the samples
            if len(self._kinematics) >= self.KEEP:
                self._kinematics.pop(next(iter(self._kinematics)))
            got = self._kinematics[key] = (Q, V, A)
        return values(scene, compiled, times, *got, ideal=True, actual=actual)


def _reference_outputs(reference: ReferenceDesign, times: np.ndarray, actual: Scene):
    """The outputs of ``reference``'s ideal mechanism at ``times`` (kinematic analysis when it
    is fully driven; None otherwise: forward dynamics then)."""
    return reference.outputs(times, actual)


def _ideal_by_dynamics(source: Scene, solver, times: np.ndarray, actual: Scene):
    """The outputs of ``source``'s ideal mechanism by forward dynamics (undriven scenes), and
    the run's max |Φ| (m or rad: its joints' drift)."""
    compiled = compile_scene(source)
    n = compiled.q_guess.size
    tol = source.solver.assembly_tolerance
    qi, vi = assemble(compiled.ideal, compiled.q_guess, 0.0, tol=tol,
                      labels=compiled.labels["ideal"])
    resi = solver.integrate(compiled.ideal, np.concatenate([qi, vi, np.zeros(2)]),
                            np.zeros(0), times, t0=0.0)
    return values(source, compiled, times, resi.y[:, :n], resi.y[:, n:2 * n],
                  resi.ydot[:, n:2 * n], ideal=True,
                  actual=actual), resi.stats.max_position_violation


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
            return _ideal_by_dynamics(reference.scene, solver, T, scene)[0]
    elif compiled.ideal.n_constraints == compiled.q_guess.size:
        Qi, Vi, Ai, _ = kinematic_analysis(compiled.ideal, q0, TT,
                                           tol=scene.solver.assembly_tolerance,
                                           labels=compiled.labels["ideal"])
        got = values(scene, compiled, TT, Qi, Vi, Ai, ideal=True)
    else:
        return _ideal_by_dynamics(scene, solver, T, scene)[0]
    return {name: {qty: v[m:] for qty, v in d.items()} for name, d in got.items()}
