"""The mechanism as a black-box model for the estimators: parameters → error curves.

:class:`MechanismModel` implements the :class:`mechrel.uq.model.Model` protocol. Its inputs
are dotted scene paths (``joints.C1.clearance``, ``joints.C1.lubricant.viscosity``,
``drivers.crank1.speed``, ``bodies.rod3.points.P``… any numeric scene value); its outputs are
the signed errors (with clearance − ideal) of one output point's displacement (m), velocity
(m/s) and acceleration (m/s²) at the analysis crank angles (every 18° by default, as in the
paper's §5), labelled by a ``(quantity, crank_angle)`` MultiIndex, followed by each quantity's
cycle extremes over the analysed cycle, labelled ``(quantity, "max")``, ``(quantity, "min")``
and ``(quantity, "max_abs")`` (:data:`~mechrel.uq.reliability.EXTREME_STATS`): the largest and
smallest signed error and the largest |error|, found on the integrator's solution (every step
and points inside it), not on the analysis angles (docs/uq.md, "Outputs of the mechanism
model"). :meth:`MechanismModel.extremes` says where in the cycle they occur.

It is deterministic (no randomness: the simulation is deterministic and its settings are part
of :meth:`cache_key`) and picklable (it carries the scene's raw mapping, not the compiled
objects; each worker process rebuilds the scene once and numba loads the compiled kernels from
its on-disk cache once per process).
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from typing import Sequence

import numpy as np
import pandas as pd

from ..errors import MechrelError, StudyError
from ..outputs import quantities_of
from .model import ModelFailure
from .reliability import EXTREME_STATS


class MechanismModel:
    """Errors of a scene's output at fixed crank angles as a function of scene parameters.

    Parameters
    ----------
    scene : str, path, mapping or Scene
        Anything :func:`mechrel.scene.load_scene` accepts; must have clearance joints and a
        cycle driver (the crank angle is the cycle driver's rotation).
    inputs : sequence of str, or mapping of name to paths
        The uncertain parameters, in the order of ``x``: dotted scene paths, or a mapping
        ``{name: [path, ...]}`` when one parameter sets several scene values (the same oil's
        viscosity in two joints). A path prefixed with ``-`` receives the negated value (two
        cranks turning in opposite senses at one uncertain speed).
    output : str, optional
        Output name (default: the scene's first output).
    quantities : sequence of str, optional
        Subset of the output's quantities (by its kind, :data:`mechrel.outputs.OUTPUT_KINDS`;
        a point: ``("displacement", "velocity", "acceleration")``); default: all of them.
    angle_step : float
        Crank-angle step of the analysis points (degrees); the scene is sampled at this step.
    cycles : float, optional
        Overrides the scene's number of cycles; the last cycle is analysed (default: the
        scene's own; with more than one, the last whole cycle is used to skip transients).
    overrides : mapping, optional
        Fixed scene overrides applied before the inputs (e.g. the solver).
    extremes : bool
        Append the cycle extremes of each quantity to the outputs (default). Without them
        the outputs are the analysis angles only and whole-cycle estimates fall back on them.
    """

    def __init__(self, scene, inputs: Sequence[str], *, output: str | None = None,
                 quantities: Sequence[str] | None = None, angle_step: float = 18.0,
                 cycles: float | None = None, overrides=None, extremes: bool = True):
        from ..scene import load_scene, scene_hash
        from ..scene.loader import thaw

        base = load_scene(scene, overrides=overrides or {})
        # provenance of the scene as given (the one rebuilt below has another analysis grid
        # and no source): scene_hash(load_scene(scene, overrides=overrides)) reproduces it
        self.scene_source = base.source
        self.scene_hash = scene_hash(base)
        if isinstance(inputs, str):
            raise StudyError(f"inputs: expected a sequence of dotted scene paths, got the "
                             f"string {inputs!r}")
        if hasattr(inputs, "items"):
            targets = {str(k): ([v] if isinstance(v, str) else list(v)) for k, v in inputs.items()}
        else:
            targets = {str(k): [str(k)] for k in inputs}
        self.input_names = tuple(targets)
        self.targets = targets
        if not self.input_names or len(set(self.input_names)) != len(self.input_names):
            raise StudyError(f"inputs: must be non-empty and unique, got {self.input_names!r}")
        if not base.clearance_joints:
            raise StudyError(f"scene {base.name!r}: has no clearance joints, so its response "
                             "error is zero; declare a joint with model = 'dry', 'lubricated' "
                             "or 'transition'")
        if base.analysis.cycle_driver is None:
            raise StudyError(f"scene {base.name!r}: analysis.cycle_driver is needed to define "
                             "the crank angles of the analysis")
        if not (angle_step > 0 and 360.0 / angle_step == round(360.0 / angle_step)):
            raise StudyError(f"angle_step: {angle_step!r} must be > 0 and divide 360 degrees")
        self.output = output or next(iter(base.outputs))
        if self.output not in base.outputs:
            raise StudyError(f"output: {self.output!r} is not an output of scene "
                             f"{base.name!r}; allowed: {', '.join(base.outputs)}")
        own = quantities_of(base.outputs[self.output])
        quantities = own if quantities is None else tuple(quantities)
        bad = [q for q in quantities if q not in own]
        if bad or not quantities:
            raise StudyError(f"quantities: {list(quantities)!r} must be a non-empty subset of "
                             f"{list(own)} (the quantities of output {self.output!r}, kind "
                             f"{base.outputs[self.output].kind!r})")
        self.quantities = tuple(quantities)
        self.angle_step = float(angle_step)
        if base.analysis.cycles is None:
            raise StudyError(f"scene {base.name!r}: the analysis must be given in cycles "
                             "(analysis.cycles), not as a duration")
        self.cycles = float(cycles if cycles is not None else base.analysis.cycles)
        if not (self.cycles >= 1 and self.cycles.is_integer()):
            # the analysed window is the last whole cycle, labelled 0..360 from its start: a
            # fractional or sub-cycle duration would shift or wrap it silently
            raise StudyError(f"cycles: {self.cycles!r} must be a whole number of cycles >= 1 "
                             "(the last whole cycle is analysed)")
        raw = thaw(base.raw)
        analysis = raw.setdefault("analysis", {})
        analysis.pop("sample_step", None)
        analysis["sample_step_angle"] = math.radians(self.angle_step)
        analysis["cycles"] = self.cycles
        base = load_scene(raw)
        # Every input path must exist and be numeric: try it at its current value.
        nominal = []
        for name, paths in targets.items():
            if not paths:
                raise StudyError(f"inputs.{name}: names no scene path")
            for path in paths:
                value = _lookup(base.raw, path.lstrip("-"))
                if isinstance(value, bool) or not isinstance(value, (int, float)):
                    raise StudyError(f"inputs: scene path {path!r} holds {value!r}; an "
                                     "uncertain input must be a number")
            first = paths[0]
            sign = -1.0 if first.startswith("-") else 1.0
            nominal.append(sign * float(_lookup(base.raw, first.lstrip("-"))))
        self.nominal = np.asarray(nominal)
        self._raw = thaw(base.raw)
        self._scene = base
        angles = np.arange(0.0, 360.0 + 0.5 * self.angle_step, self.angle_step)
        self.crank_angles = angles
        if not isinstance(extremes, bool):
            raise StudyError(f"extremes: {extremes!r} is not a boolean; allowed: True, False")
        self.with_extremes = extremes
        labels = [(q, float(a)) for q in self.quantities for a in angles]
        if extremes:
            labels += [(q, stat) for q in self.quantities for stat in EXTREME_STATS]
        self.output_index = pd.MultiIndex.from_tuples(labels, names=["quantity", "crank_angle"])

    # pickling: ship the raw mapping, rebuild the scene in the worker
    def __getstate__(self):
        state = dict(self.__dict__)
        state["_scene"] = None
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)

    @property
    def scene(self):
        if self._scene is None:
            from ..scene import load_scene
            self._scene = load_scene(self._raw)
        return self._scene

    @property
    def output_noise(self) -> float:
        """Relative noise of the outputs from the integrator's tolerance (used by FOSM's
        automatic finite-difference step): the solver's rtol, or 1e-6 for a fixed-step
        method, whose error is not controlled."""
        from ..simulation import make_integrator
        integ = make_integrator(self.scene)
        return float(integ.rtol) if integ.adaptive and integ.rtol else 1e-6

    def describe(self) -> dict:
        """The scene as given (name, :func:`~mechrel.scene.scene_hash` with ``overrides``
        applied, source), its solver settings and the analysed outputs."""
        return {"kind": "MechanismModel", "scene": self._raw["name"], "scene_hash": self.scene_hash,
                "scene_source": self.scene_source, "solver": dict(self._raw.get("solver", {})),
                "output": self.output, "quantities": list(self.quantities),
                "angle_step": self.angle_step, "cycles": self.cycles,
                "extremes": self.with_extremes}

    def cache_key(self) -> str:
        from .. import __version__
        from .._kernel_cache import simulator_digest
        from ..scene import scene_hash
        from ..simulation import DENSE_POINTS

        payload = json.dumps({"kind": "MechanismModel", "scene": scene_hash(self.scene),
                              "inputs": self.targets, "output": self.output,
                              "quantities": list(self.quantities),
                              "angle_step": self.angle_step, "cycles": self.cycles,
                              "extremes": self.with_extremes, "dense_points": DENSE_POINTS,
                              "mechrel": __version__, "code": simulator_digest()},
                             sort_keys=True)
        return hashlib.sha256(payload.encode()).hexdigest()

    def scene_values(self, x) -> dict:
        """The scene overrides ``{path: value}`` that input vector ``x`` stands for (a ``-``
        path receives the negated value). Subclasses with other kinds of inputs extend this."""
        x = np.asarray(x, dtype=float).reshape(-1)
        if x.size != len(self.input_names):
            raise StudyError(f"x: expected {len(self.input_names)} values "
                             f"({', '.join(self.input_names)}), got {x.size}")
        values = {}
        for (name, paths), value in zip(self.targets.items(), map(float, x)):
            for path in paths:
                if path.startswith("-"):
                    values[path[1:]] = -value
                else:
                    values[path] = value
        return values

    def simulate(self, x):
        """The full :class:`~mechrel.simulation.SimulationResult` at input vector ``x``."""
        from ..scene import with_overrides
        from ..simulation import simulate

        scene = with_overrides(self.scene, self.scene_values(x))
        return simulate(scene, extremes=self.with_extremes)

    def extremes(self, x) -> pd.DataFrame:
        """Where the cycle extremes occur at input vector ``x``: one row per quantity and
        statistic (:data:`~mechrel.uq.reliability.EXTREME_STATS`), columns ``value``,
        ``time`` (s since the start of the run) and ``crank_angle`` (degrees, from the start
        of the analysed cycle, as the analysis angles)."""
        res = self.simulate(x)
        if res.extremes is None:
            raise StudyError("extremes: this model was made with extremes=False")
        n_per_cycle = self.crank_angles.size - 1
        start = res.crank_angle[res.time.size - 1 - n_per_cycle]
        rows = []
        for q in self.quantities:
            d = res.extremes[self.output][q]
            for stat in EXTREME_STATS:
                rows.append((q, stat, d[stat], d[f"{stat}_time"], d[f"{stat}_angle"] - start))
        frame = pd.DataFrame(rows, columns=["quantity", "statistic", "value", "time",
                                            "crank_angle"])
        return frame.set_index(["quantity", "statistic"])

    def evaluate(self, x) -> np.ndarray:
        """Errors at the analysis crank angles of the last cycle, quantity-major (m, m/s, m/s²),
        then (with ``extremes``) each quantity's cycle extremes (module docstring).

        Raises :class:`~mechrel.uq.ModelFailure` with the reason when the scene is invalid at
        ``x`` (e.g. a clearance ≤ 0), cannot assemble, or the integrator fails."""
        try:
            res = self.simulate(x)
        except StudyError:
            raise
        except MechrelError as exc:
            raise ModelFailure(_stable_reason(exc)) from None
        n_per_cycle = self.crank_angles.size - 1
        last = res.time.size - 1
        rows = np.arange(last - n_per_cycle, last + 1)
        parts = [res.error(self.output, q)[rows] for q in self.quantities]
        if self.with_extremes:
            parts.append(np.array([res.extremes[self.output][q][stat]
                                   for q in self.quantities for stat in EXTREME_STATS]))
        out = np.concatenate(parts)
        if not np.all(np.isfinite(out)):
            raise ModelFailure("non-finite response error")
        return out

    def __repr__(self) -> str:
        return (f"MechanismModel({self.scene.name!r}, inputs={list(self.input_names)}, "
                f"output={self.output!r}, angle_step={self.angle_step:g})")


_NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def _stable_reason(exc: Exception) -> str:
    """The failure reason without the sample's numbers (replaced by ``#``): the executor counts
    failures by their reason string, and the values are in the failed rows' inputs anyway."""
    return f"{type(exc).__name__}: " + _NUMBER.sub("#", str(exc))


def _lookup(raw, path: str):
    node = raw
    for part in path.split("."):
        if not hasattr(node, "get") or part not in node:
            raise StudyError(f"inputs: {path!r} is not a value of the scene (no {part!r} "
                             "there); inputs are dotted scene paths like "
                             "'joints.C1.clearance'")
        node = node[part]
    return node
