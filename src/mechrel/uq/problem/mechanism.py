"""The mechanism as a black-box model for the estimators: parameters → error curves.

:class:`MechanismModel` implements the :class:`mechrel.uq.Model` protocol. Its inputs
are dotted scene paths (``joints.C1.clearance``, ``joints.C1.lubricant.viscosity``,
``drivers.crank1.speed``, ``bodies.rod3.points.P``… any numeric scene value); its outputs are
the signed errors (with clearance − ideal) of one output point's displacement (m), velocity
(m/s) and acceleration (m/s²) at the analysis crank angles (every 18° by default, as in the
paper's §5), labelled by a ``(quantity, crank_angle)`` MultiIndex, followed by each quantity's
cycle extremes over the analysed cycle, labelled ``(quantity, "max")``, ``(quantity, "min")``
and ``(quantity, "max_abs")`` (:data:`~mechrel.uq.problem.allowables.EXTREME_STATS`): the largest and
smallest signed error and the largest |error|, found on the integrator's solution (every step
and points inside it), not on the analysis angles (docs/uq.md, "Outputs of the mechanism
model"). :meth:`MechanismModel.extremes` says where in the cycle they occur.

It is deterministic (no randomness: the simulation is deterministic and its settings are part
of :meth:`cache_key`) and picklable (it carries the scene's raw mapping, not the compiled
objects; each worker process rebuilds the scene once and numba loads the compiled kernels from
its on-disk cache once per process).

Geometric tolerances
--------------------
A point's coordinate is an input by its component path, ``bodies.rod.points.B[0]`` or
``ground.points.O4[1]`` (m), and a link's length by the distance between two of its points,
``bodies.crank.length(O,A)`` (m): setting it moves A along the line from O through A so that
the distance ``|A − O|`` equals the value exactly (the other points, the body's mass, inertia and frame stay).
Under such inputs the error is measured against the ideal motion of the *nominal* design
(``reference="nominal"``, the default): the ideal mechanism with the scene's own point
coordinates and every other input at the sample's value (a speed tolerance still moves the
reference, as before); ``reference="same-geometry"`` measures it against the ideal mechanism of
the sample's own geometry, where a geometric tolerance alone causes no error. Without geometric
inputs the two are the same.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from ..._checks import ARGS
from ...errors import MechrelError, SceneError, StudyError, interrupt_of
from ...forces.models import MODELS
from ...outputs import quantities_of
from .model import ModelFailure, RowFailures, evaluate_rows
from .allowables import EXTREME_STATS, sector_label

SECTOR_STATS = ("max", "min")

REFERENCES = ("nominal", "same-geometry")
"""What the error is measured against: the ideal motion of the nominal geometry, or of the
sample's own geometry (see the module docstring)."""

_GEOMETRY = re.compile(r"-?(ground\.points\.|bodies\.[A-Za-z_]\w*\.(global_)?points\.|"
                       r"(ground|bodies\.[A-Za-z_]\w*)\.length\()")


def is_geometric(path: str) -> bool:
    """Whether a scene path sets the mechanism's geometry.

    Geometric paths are a point's coordinates (whole or one component; a body's ``points`` or,
    for a body written from joint positions, its ``global_points``) and a length between two
    points of a body or of the ground.

    Parameters
    ----------
    path : str
        A dotted scene path, optionally prefixed with ``-``.

    Returns
    -------
    bool
        True for a geometric path.

    Examples
    --------
    >>> is_geometric("bodies.crank.points.B"), is_geometric("joints.C.clearance")
    (True, False)
    >>> is_geometric("bodies.lever.global_points.B[0]")
    True
    """
    return bool(_GEOMETRY.match(path))


def _one_of_models() -> str:
    """``'dry', 'lubricated' or 'transition'``: the clearance models of the table."""
    names = [repr(m) for m in MODELS]
    return " or ".join([", ".join(names[:-1]), names[-1]] if len(names) > 1 else names)


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
    reference : {"nominal", "same-geometry"}
        The ideal motion the error is measured against when inputs set the geometry (point
        coordinates, lengths): that of the nominal geometry (default) or of the sample's own.
        Without geometric inputs both are the ideal counterpart of the sample. With
        ``"nominal"`` and geometric inputs, a scene without clearance joints is a valid model
        (its error is the tolerances' kinematic error).
    extremes : bool
        Append the cycle extremes of each quantity to the outputs (default). Without them
        the outputs are the analysis angles only and whole-cycle estimates fall back on them.
    sectors : bool
        With ``extremes``, also append each quantity's largest and smallest error over every
        sector between consecutive analysis angles (``(quantity, "max[lo,hi]")``,
        :func:`~mechrel.uq.problem.allowables.sector_label`): the members of the whole cycle's
        series system, whose design points FORM searches one by one (docs/uq.md, "The whole
        cycle as a series system"). Default False (the outputs of earlier versions).

    Examples
    --------
    Building the model loads the scene; nothing is simulated until it is evaluated:

    >>> from mechrel.uq import MechanismModel
    >>> m = MechanismModel("slider-crank-lubricated", {"clearance": ["joints.C.clearance"]},
    ...                    quantities=["velocity"], angle_step=90.0)
    >>> m.input_names, list(m.output_index)[:3]
    (('clearance',), [('velocity', 0.0), ('velocity', 90.0), ('velocity', 180.0)])
    """

    def __init__(self, scene, inputs: Sequence[str] | Mapping[str, str | Sequence[str]], *,
                 output: str | None = None,
                 quantities: Sequence[str] | None = None, angle_step: float = 18.0,
                 cycles: float | None = None, overrides=None, reference: str = "nominal",
                 extremes: bool = True, sectors: bool = False):
        from ...scene import load_scene, scene_hash
        from ...scene.loader import thaw

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
        if reference not in REFERENCES:
            raise StudyError(f"reference: {reference!r} is not a reference; allowed: "
                             f"{', '.join(map(repr, REFERENCES))}")
        self.reference = reference
        geometric = [p for paths in targets.values() for p in paths if is_geometric(p)]
        self.nominal_reference = reference == "nominal" and bool(geometric)
        if not base.clearance_joints and not self.nominal_reference:
            raise StudyError(
                f"scene {base.name!r}: has no clearance joints, so its response error is zero; "
                f"allowed: a joint with model = {_one_of_models()}, or "
                "geometric inputs (point coordinates, lengths) measured against the nominal "
                "design" + (" (reference = 'nominal')" if geometric else ""))
        if base.analysis.cycle_driver is None:
            raise StudyError(f"scene {base.name!r}: analysis.cycle_driver is needed to define "
                             "the crank angles of the analysis")
        ARGS.angle_step("angle_step", angle_step)
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
                if path.lstrip("-").split(".")[0] == "analysis":
                    # the model sets the analysis itself (whole cycles, its angle step); a
                    # sampled one would move the analysed cycle under the output's angles
                    raise StudyError(
                        f"inputs.{name}: {path!r}: the analysis (its cycles, duration and "
                        "sample step) is the model's own, not an uncertain input; allowed: a "
                        "value of the mechanism, e.g. 'joints.C1.clearance', "
                        "'drivers.crank1.speed' or 'bodies.crank.length(O,A)' (the model's "
                        "cycles and angle_step set the analysis)")
                value = _lookup(base.raw, path.lstrip("-"))
                if is_geometric(path) and path.startswith("-"):
                    raise StudyError(f"inputs.{name}: {path!r}: a geometric path cannot be "
                                     "negated; allowed: the path without '-'")
                if isinstance(value, bool) or not isinstance(value, (int, float)):
                    raise StudyError(f"inputs: scene path {path!r} holds {value!r}; an "
                                     "uncertain input must be a number")
            first = paths[0]
            sign = -1.0 if first.startswith("-") else 1.0
            nominal.append(sign * float(_lookup(base.raw, first.lstrip("-"))))
        self.nominal = np.asarray(nominal)
        self._raw = thaw(base.raw)
        self._scene = base
        self._samples: _Samples | None = None  # what the samples share, made on first use
        angles = np.arange(0.0, 360.0 + 0.5 * self.angle_step, self.angle_step)
        self.crank_angles = angles
        if not isinstance(extremes, bool):
            raise StudyError(f"extremes: {extremes!r} is not a boolean; allowed: True, False")
        self.with_extremes = extremes
        if not isinstance(sectors, bool) or (sectors and not extremes):
            raise StudyError(f"sectors: {sectors!r}; allowed: True (with extremes=True) or False")
        self.with_sectors = sectors
        labels = [(q, float(a)) for q in self.quantities for a in angles]
        if extremes:
            labels += [(q, stat) for q in self.quantities for stat in EXTREME_STATS]
        if sectors:
            for q in self.quantities:
                for stat in SECTOR_STATS:
                    labels += [(q, sector_label(stat, lo, hi)) for lo, hi in zip(angles[:-1], angles[1:])]
        self.output_index = pd.MultiIndex.from_tuples(labels, names=["quantity", "crank_angle"])

    # pickling: ship the raw mapping, rebuild the scene (and what the samples share) in the
    # worker
    def __getstate__(self):
        state = dict(self.__dict__)
        state["_scene"] = None
        state["_samples"] = None
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)

    @property
    def scene(self):
        """The scene the model simulates (rebuilt from its raw mapping after unpickling).

        Returns
        -------
        mechrel.scene.Scene
            The scene with the model's analysis grid.

        Examples
        --------
        >>> m = MechanismModel("slider-crank-lubricated", ["joints.C.clearance"], angle_step=90.0)
        >>> m.scene.name
        'slider-crank-lubricated'
        """
        if self._scene is None:
            from ...scene import load_scene
            self._scene = load_scene(self._raw)
        return self._scene

    @property
    def output_noise(self) -> float:
        """Relative noise of the outputs (used by FOSM's automatic finite-difference step).

        A mechanism with clearance joints is integrated: the solver's rtol, or 1e-6 for a
        fixed-step method, whose error is not controlled. One without (geometric tolerances
        against the nominal design) is solved by kinematic analysis: Newton–Raphson to
        ``|Φ| ≤ solver.assembly_tolerance`` (m), relative to the mechanism's size (its largest
        point distance from a body's frame or the ground's origin), and no less than machine
        epsilon. The error's reference (the nominal design) is the same in every sample, so its
        own noise cancels in the differences.

        Returns
        -------
        float
            The relative noise (dimensionless).

        Examples
        --------
        >>> m = MechanismModel("slider-crank-lubricated", ["joints.C.clearance"], angle_step=90.0)
        >>> m.output_noise   # the rtol the automatic integrator uses
        1e-07
        """
        from ...simulation import make_integrator
        scene = self.scene
        if not scene.clearance_joints:
            pts = [abs(c) for b in scene.bodies.values() for p in b.points.values() for c in p]
            pts += [abs(c) for p in scene.ground.values() for c in p]
            size = max(pts) if pts else 1.0
            return max(scene.solver.assembly_tolerance / size, float(np.finfo(float).eps))
        integ = make_integrator(scene)
        return float(integ.rtol) if integ.adaptive and integ.rtol else 1e-6

    @property
    def nonsmooth(self) -> str | None:
        """Why the response is not a smooth function of the inputs, or None.

        A clearance model whose row is not ``smooth`` (:data:`mechrel.forces.models.MODELS`:
        dry contact) makes it piecewise smooth at best, chaotic at worst. FOSM warns on such a
        model.

        Returns
        -------
        str or None
            The reason, None for a smooth model (e.g. a lubricant film only).

        Examples
        --------
        >>> MechanismModel("slider-crank-lubricated", ["joints.C.clearance"],
        ...                angle_step=90.0).nonsmooth is None
        True
        """
        rough = [j for j in self.scene.clearance_joints if not j.clearance_model.smooth]
        if not rough:
            return None
        what = ("dry contact" if all(j.clearance_model.has_contact for j in rough)
                else "a non-smooth force law")
        return (f"{what} in joint{'s' if len(rough) > 1 else ''} "
                f"{', '.join(j.name for j in rough)}: impacts make the response non-smooth, "
                "often chaotic")

    def describe(self) -> dict:
        """Describe the model for provenance.

        The scene as given (name, :func:`~mechrel.scene.scene_hash` with ``overrides`` applied,
        source), its solver settings and the analysed outputs.

        Returns
        -------
        dict
            JSON-friendly: ``kind``, ``scene``, ``scene_hash``, ``scene_source``, ``solver``,
            ``output``, ``quantities``, ``angle_step`` (degrees), ``cycles``, ``reference``,
            ``extremes``.

        Examples
        --------
        >>> d = MechanismModel("slider-crank-lubricated", ["joints.C.clearance"],
        ...                    angle_step=90.0).describe()
        >>> d["scene"], d["angle_step"]
        ('slider-crank-lubricated', 90.0)
        """
        return {"kind": "MechanismModel", "scene": self._raw["name"], "scene_hash": self.scene_hash,
                "scene_source": self.scene_source, "solver": dict(self._raw.get("solver", {})),
                "output": self.output, "quantities": list(self.quantities),
                "angle_step": self.angle_step, "cycles": self.cycles,
                "reference": self.reference, "extremes": self.with_extremes,
                "sectors": getattr(self, "with_sectors", False)}

    def cache_key(self) -> str:
        """A SHA-256 hash of what determines the outputs besides ``x``.

        The scene's hash, the inputs' paths, the output, quantities, angle step, cycles, reference,
        extremes, the dense-output resolution, mechrel's version and the simulator code's digest.

        Returns
        -------
        str
            A hex digest.

        Examples
        --------
        >>> a = MechanismModel("slider-crank-lubricated", ["joints.C.clearance"], angle_step=90.0)
        >>> b = MechanismModel("slider-crank-lubricated", ["joints.C.clearance"], angle_step=45.0)
        >>> a.cache_key() != b.cache_key()
        True
        """
        from ... import __version__
        from ..._kernel_cache import simulator_digest
        from ...scene import scene_hash
        from ...simulation import DENSE_POINTS

        payload = json.dumps({"kind": "MechanismModel", "scene": scene_hash(self.scene),
                              "inputs": self.targets, "output": self.output,
                              "quantities": list(self.quantities),
                              "angle_step": self.angle_step, "cycles": self.cycles,
                              **({"reference": "nominal"} if self.nominal_reference else {}),
                              "extremes": self.with_extremes, "dense_points": DENSE_POINTS,
                              **({"sectors": True} if getattr(self, "with_sectors", False) else {}),
                              "mechrel": __version__, "code": simulator_digest()},
                             sort_keys=True)
        return hashlib.sha256(payload.encode()).hexdigest()

    def scene_values(self, x) -> dict:
        """The scene overrides that input vector ``x`` stands for.

        A path prefixed with ``-`` receives the negated value. Subclasses with other kinds of inputs
        extend this.

        Parameters
        ----------
        x : array_like, shape (d,)
            The inputs, in the order of ``input_names`` (SI units).

        Returns
        -------
        dict
            ``{dotted scene path: value}``.

        Raises
        ------
        StudyError
            If ``x`` does not hold one value per input.

        Examples
        --------
        >>> m = MechanismModel("slider-crank-lubricated", {"c": ["joints.C.clearance"]},
        ...                    angle_step=90.0)
        >>> m.scene_values([0.4e-3])
        {'joints.C.clearance': 0.0004}
        """
        x = np.asarray(x, dtype=float).reshape(-1)
        if x.size != len(self.input_names):
            raise StudyError(f"x: expected {len(self.input_names)} values "
                             f"({', '.join(self.input_names)}), got {x.size}")
        values = {}
        for (_name, paths), value in zip(self.targets.items(), map(float, x)):
            for path in paths:
                if path.startswith("-"):
                    values[path[1:]] = -value
                else:
                    values[path] = value
        return values

    def simulate(self, x):
        """The full simulation at input vector ``x``, its errors measured against the model's ``reference``.

        Parameters
        ----------
        x : array_like, shape (d,)
            The inputs, in the order of ``input_names`` (SI units).

        Returns
        -------
        mechrel.simulation.SimulationResult
            The simulation of the scene with ``x`` applied.

        Raises
        ------
        StudyError
            If ``x`` does not hold one value per input.
        mechrel.errors.MechrelError
            If the scene is invalid at ``x``, cannot assemble, or the integration fails.

        Examples
        --------
        >>> m = MechanismModel("slider-crank-lubricated", ["joints.C.clearance"],
        ...                    quantities=["velocity"], angle_step=90.0, cycles=1)
        >>> res = m.simulate(m.nominal)
        >>> bool(res.time[-1] > 0)
        True
        """
        return self._simulate(x)

    def _simulate(self, x):
        """:meth:`simulate`: the sample's scene built and validated in full
        (:func:`~mechrel.scene.with_overrides`) and simulated with its provenance; the
        reference :meth:`evaluate` is tested against."""
        from ...scene import with_overrides
        from ...simulation import simulate

        values = self.scene_values(x)
        scene = with_overrides(self.scene, values)
        reference = None
        if self.nominal_reference:
            # the nominal geometry with the sample's other values (a speed, a clearance)
            other = {p: v for p, v in values.items() if not is_geometric(p)}
            reference = with_overrides(self.scene, other) if other else self.scene
        sectors = self.angle_step if getattr(self, "with_sectors", False) else None
        return simulate(scene, reference=reference, extremes=self.with_extremes, sectors=sectors)

    def extremes(self, x) -> pd.DataFrame:
        """Where the cycle extremes occur at input vector ``x``.

        Parameters
        ----------
        x : array_like, shape (d,)
            The inputs, in the order of ``input_names`` (SI units).

        Returns
        -------
        pandas.DataFrame
            One row per quantity and statistic
            (:data:`~mechrel.uq.problem.allowables.EXTREME_STATS`); columns ``value``, ``time``
            (s since the start of the run) and ``crank_angle`` (degrees, from the start of the
            analysed cycle, as the analysis angles).

        Raises
        ------
        StudyError
            If the model was made with ``extremes=False``.

        Examples
        --------
        >>> m = MechanismModel("slider-crank-lubricated", ["joints.C.clearance"],
        ...                    quantities=["velocity"], angle_step=90.0, cycles=1)
        >>> m.extremes(m.nominal).columns.tolist()
        ['value', 'time', 'crank_angle']
        """
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

    def cycle_closure(self, Y) -> pd.DataFrame:
        """How far the analysed cycle is from closing on itself, per sample and quantity.

        In a periodic response the error at the cycle's end (360°) is the error at its start
        (0°). They differ when the response has not settled (the start transient, with one
        cycle analysed or too short a warm-up) or is not periodic (a dry joint's impacts): the
        estimates then describe this one cycle, not the mechanism's periodic response.

        Parameters
        ----------
        Y : array_like, shape (n, len(output_index))
            Outputs of this model (rows of :meth:`evaluate_batch`; NaN rows for failed
            samples).

        Returns
        -------
        pandas.DataFrame
            One row per row of ``Y``, one column per quantity: ``|e(360°) − e(0°)| / span``,
            where the span is the largest range over the cycle (max − min over the analysis
            angles) of that quantity's error among the rows (a span, not each row's own range,
            so that a row of zero error, the nominal design under geometric tolerances alone,
            is not a ratio of round-off); NaN for failed rows. Above
            :data:`~mechrel.simulation.extremes.CLOSURE_LIMIT` a study warns.

        Raises
        ------
        StudyError
            ``Y`` does not have one column per output.

        Examples
        --------
        The lubricated slider-crank starts with its journal centred and at rest: analysed from
        the start, its acceleration error at 0° is the start transient's; the second cycle
        closes:

        >>> first = MechanismModel("slider-crank-lubricated", ["joints.C.clearance"],
        ...                        quantities=["acceleration"], angle_step=90.0, cycles=1)
        >>> second = MechanismModel("slider-crank-lubricated", ["joints.C.clearance"],
        ...                         quantities=["acceleration"], angle_step=90.0, cycles=2)
        >>> c1 = first.cycle_closure([first.evaluate(first.nominal)])
        >>> c2 = second.cycle_closure([second.evaluate(second.nominal)])
        >>> bool(c1.loc[0, "acceleration"] > 0.5 and c2.loc[0, "acceleration"] < 1e-4)
        True
        """
        Y = np.asarray(Y, dtype=float)
        if Y.ndim != 2 or Y.shape[1] != len(self.output_index):
            raise StudyError(f"Y: expected shape (n, {len(self.output_index)}) for this model's "
                             f"outputs, got {Y.shape}")
        out = {}
        for q in self.quantities:
            cols = [self.output_index.get_loc((q, float(a))) for a in self.crank_angles]
            E = Y[:, cols]
            with np.errstate(invalid="ignore"):
                span = np.nanmax(np.ptp(E, axis=1)) if np.isfinite(E).any() else np.nan
                out[q] = np.abs(E[:, -1] - E[:, 0]) / span if span > 0 else 0.0 * E[:, 0]
        return pd.DataFrame(out)

    def closure_warnings(self, Y) -> list[str]:
        """The warning of each quantity whose analysed cycle does not close.

        Parameters
        ----------
        Y : array_like, shape (n, len(output_index))
            Outputs of this model (:meth:`cycle_closure`).

        Returns
        -------
        list of str
            One line per quantity above
            :data:`~mechrel.simulation.extremes.CLOSURE_LIMIT` at some row: how far, at how
            many rows, why, and what to change; empty when every cycle closes.

        Examples
        --------
        >>> m = MechanismModel("slider-crank-lubricated", ["joints.C.clearance"],
        ...                    quantities=["acceleration"], angle_step=90.0, cycles=1)
        >>> print(m.closure_warnings([m.evaluate(m.nominal)])[0])  # doctest: +ELLIPSIS
        acceleration: the analysed cycle does not close: the error at 360° differs from that at 0° by up to 94 % of its span over the cycle (at 1 of 1 samples above 5 %): ...
        """
        from ...simulation.extremes import CLOSURE_LIMIT

        closure = self.cycle_closure(Y)
        cycles = int(self.cycles)
        if cycles == 1:
            why = ("with cycles = 1 the analysed cycle is the start, whose transient is in "
                   "these numbers; allowed: cycles = 2 or more")
        else:
            rough = self.nonsmooth
            why = (f"the response has not settled after {cycles - 1} warm-up "
                   f"cycle{'s' if cycles > 2 else ''}"
                   + (", or is not periodic (" + rough.split(":")[0] + ")" if rough else "")
                   + f": the estimates are those of this one cycle; more cycles than {cycles} "
                   "show whether it settles")
        lines = []
        for q in closure.columns:
            c = closure[q].to_numpy()
            ok = np.isfinite(c)
            above = int(np.count_nonzero(c[ok] > CLOSURE_LIMIT))
            if above:
                lines.append(f"{q}: the analysed cycle does not close: the error at 360° "
                             f"differs from that at 0° by up to {100 * np.max(c[ok]):.2g} % of "
                             f"its span over the cycle (at {above} of {int(ok.sum())} samples "
                             f"above {100 * CLOSURE_LIMIT:g} %): {why} (docs/studies.md, "
                             "\"Which cycle is analysed\")")
        return lines

    vectorized = True
    """The executor hands a chunk of samples to one :meth:`evaluate_batch` call."""

    max_chunk_rows = 1000
    """The most samples of the executor's default chunk: each row is a simulation
    (milliseconds), so larger chunks would save nothing and coarsen the progress and what an
    interrupted run loses."""

    def evaluate(self, x) -> np.ndarray:
        """The errors at the analysis crank angles of the last cycle, then the cycle extremes.

        Quantity-major (m, m/s, m/s²), then (with ``extremes``) each quantity's cycle extremes (see
        the module docstring), in the order of ``output_index``.

        Parameters
        ----------
        x : array_like, shape (d,)
            The inputs, in the order of ``input_names`` (SI units).

        Returns
        -------
        ndarray, shape (n_out,)
            The response errors.

        Raises
        ------
        ModelFailure
            With the reason, when the scene is invalid at ``x`` (e.g. a clearance <= 0), cannot
            assemble, the integrator fails or the response is not finite.
        StudyError
            If ``x`` does not hold one value per input.

        Examples
        --------
        >>> m = MechanismModel("slider-crank-lubricated", ["joints.C.clearance"],
        ...                    quantities=["velocity"], angle_step=90.0, cycles=1)
        >>> y = m.evaluate(m.nominal)
        >>> y.shape == (len(m.output_index),), bool(np.isfinite(y).all())
        (True, True)
        """
        return self._evaluate(x)

    def evaluate_batch(self, X) -> np.ndarray:
        """:meth:`evaluate` at each row of ``X`` in one call.

        What does not depend on the sample (the integrator) is made once for the batch, and no
        provenance is recorded per sample; the rows' scenes are set and validated first, then
        the rows are run. The rows' numbers, and the reasons of failed rows, are those of
        :meth:`evaluate`, bitwise, for any batch.

        Parameters
        ----------
        X : array_like, shape (m, d)
            One sample per row, in the order of ``input_names`` (SI units).

        Returns
        -------
        ndarray, shape (m, n_out)
            The response errors of each row, as :meth:`evaluate` returns them.

        Raises
        ------
        mechrel.uq.RowFailures
            When rows failed: every row's outputs and, per failed row, the reason
            :meth:`evaluate` raises with (the executor records them as they are;
            :func:`mechrel.uq.problem.model.evaluate_rows`).
        StudyError
            If ``X`` is not of shape (m, d).

        Examples
        --------
        >>> m = MechanismModel("slider-crank-lubricated", ["joints.C.clearance"],
        ...                    quantities=["velocity"], angle_step=90.0, cycles=1)
        >>> Y = m.evaluate_batch([m.nominal, m.nominal])
        >>> Y.shape == (2, len(m.output_index)), bool((Y[0] == m.evaluate(m.nominal)).all())
        (True, True)
        """
        X = np.asarray(X, dtype=float)
        if X.ndim != 2 or X.shape[1] != len(self.input_names):
            raise StudyError(f"X: expected shape (m, {len(self.input_names)}) for inputs "
                             f"{list(self.input_names)}, got {X.shape}")
        from ...simulation import signal_session

        if self._samples is None:
            self._samples = _Samples(self)
        # every row's scene first, then the runs: the same calls as row by row, but the
        # validation's Python runs back to back rather than once between two kernels, whose
        # runs evict it from the processor's caches (docs/dev/performance-log.md, 2026-11-29)
        ready = [self._samples.prepare(self.scene_values(x)) for x in X]
        outcomes: dict[int, object] = {}
        rows = iter(range(X.shape[0]))

        def row(_x):
            i = next(rows)  # evaluate_rows calls once per row, in order
            if i not in outcomes:  # the steps of this row and the next few, each in turn
                outcomes.update(self._in_steps(range(i, min(i + self.STEP_ROWS, len(ready))),
                                               ready))
            out = outcomes.pop(i)
            if isinstance(out, Exception):
                raise out
            return out

        with signal_session():  # the signal watcher installed once for the batch's runs
            Y, ok, reasons = evaluate_rows(row, X, len(self.output_index))
        if not ok.all():
            raise RowFailures(Y, reasons)
        return Y

    #: Rows of a batch whose runs go step by step together (:meth:`_in_steps`). The first row
    #: of a group runs each step with cold caches: 16 rows gave 0.79 ms of Python a sample,
    #: 8 rows 0.85 ms, 4 rows 0.92 ms (docs/dev/performance-log.md, 2026-11-29 evening).
    STEP_ROWS = 16
    #: Bytes of the kernels' outputs a group holds at most (plus one row's) before the rows
    #: whose kernels have run take their last steps: a row holds its run's outputs and
    #: solution log until then, 0.75 MB for the main study (16 rows: 12 MB) but 60 MB for the
    #: dry nine-bar's two cycles, whose rows then run one by one.
    STEP_BYTES = 32 * 2**20

    def _in_steps(self, rows, ready) -> dict:
        """The outputs of ``rows`` (or what each raised), their runs' steps
        (:func:`~mechrel.simulation.sample_steps`) taken for all of them in turn: every
        row's steps up to its kernel, the kernels back to back, then every row's last steps
        (the kernels in turns of at most :attr:`STEP_BYTES` of outputs, each turn's rows
        finished before the next). What a row's step raises is that row's (an
        ``Exception``, raised when the row's turn comes; an interrupt, also one inside a
        compiled callback, ends the group at once)."""
        done: dict[int, object] = {}
        paused = []  # (row, its steps, its kernel)
        for i in rows:
            steps = self._steps(ready[i])
            try:
                paused.append((i, steps, steps.send(None)))
            except StopIteration as stop:
                done[i] = stop.value
            except Exception as exc:  # noqa: BLE001 - the row's failure (evaluate_rows sorts)
                done[i] = _unless_interrupt(exc)
        while paused:
            ran, held = [], 0
            while paused and held <= self.STEP_BYTES:  # kernels back to back
                i, steps, work = paused.pop(0)
                try:
                    value = work()
                except Exception as exc:  # noqa: BLE001 - thrown into the row's steps
                    ran.append((i, steps, steps.throw, _unless_interrupt(exc)))
                else:
                    ran.append((i, steps, steps.send, value))
                    held += _nbytes(value)
            for i, steps, resume, value in ran:  # then their rows' next steps
                try:
                    paused.append((i, steps, resume(value)))
                except StopIteration as stop:
                    done[i] = stop.value
                except Exception as exc:  # noqa: BLE001
                    done[i] = _unless_interrupt(exc)
        return done

    def _evaluate(self, x, ready=None) -> np.ndarray:
        """The outputs at ``x``; ``ready``: what :meth:`_Samples.prepare` gave for it."""
        from ...simulation import run_steps

        if self._samples is None:
            self._samples = _Samples(self)
        return run_steps(self._steps(ready or self._samples.prepare(self.scene_values(x))))

    def _steps(self, ready):
        """The steps of a sample's evaluation from what :meth:`_Samples.prepare` gave for it
        (:func:`~mechrel.simulation.sample_steps`; returns the outputs)."""
        try:
            res = yield from self._samples.steps(ready)
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
        if getattr(self, "with_sectors", False):
            parts += [v for q in self.quantities for v in res.sector_extremes[self.output][q]]
        out = np.concatenate(parts)
        if not np.isfinite(out).all():
            raise ModelFailure("non-finite response error")
        return out

    def __repr__(self) -> str:
        return (f"MechanismModel({self.scene.name!r}, inputs={list(self.input_names)}, "
                f"output={self.output!r}, angle_step={self.angle_step:g})")


class _Samples:
    """What the samples of one :class:`MechanismModel` share, in one process (not pickled):
    the scene prepared for the inputs' paths (:class:`~mechrel.simulation.PreparedScene`: a
    sample's values are set in the compiled scene, validated by the scene's own rules on the
    tables they sit in), the integrators by solver table and scene kind, and the nominal
    reference design by the sample's non-geometric values (with geometric inputs only: one,
    its ideal mechanism analysed once per set of output instants); the ideal mechanism's
    positions at t = 0 are the scene's own when the values leave them (a speed, a clearance:
    :meth:`~mechrel.simulation.PreparedScene.ideal_start`). A sample's numbers are
    those of :meth:`MechanismModel.simulate`, bitwise."""

    KEEP = 8  # reference designs kept (one per set of non-geometric values)

    def __init__(self, model: MechanismModel):
        from ...scene._values import SceneValues
        from ...simulation import (PreparedScene, ReferenceDesign, make_integrator, sample_steps,
                                   scene_kind)

        self.model = model
        paths = list(model.scene_values(model.nominal))
        self.prepared = PreparedScene(model.scene, paths)
        self.solvers: dict = {}
        self.other = SceneValues(model.scene, [p for p in paths if not is_geometric(p)])
        self.references: dict = {}
        # what a sample calls, looked up once (the simulation layer is imported lazily here)
        self._simulation = (ReferenceDesign, make_integrator, scene_kind, sample_steps)

    def prepare(self, values: dict):
        """``(values, scene, compiled, q0)`` of a sample (:meth:`PreparedScene.at
        <mechrel.simulation.PreparedScene.at>` and
        :meth:`~mechrel.simulation.PreparedScene.ideal_start`), or the
        :class:`~mechrel.errors.MechrelError` with which the scene refuses the values (raised
        by :meth:`simulate`)."""
        try:
            scene, compiled = self.prepared.at(values)
        except MechrelError as exc:
            return exc
        return values, scene, compiled, self.prepared.ideal_start(scene, compiled)

    def steps(self, ready):
        """The steps of the sample's run (:func:`~mechrel.simulation.sample_steps`) from what
        :meth:`prepare` gave for it."""
        if isinstance(ready, MechrelError):
            raise ready
        ReferenceDesign, make_integrator, scene_kind, sample_steps = self._simulation
        model = self.model
        values, scene, compiled, q0 = ready
        reference = None
        if model.nominal_reference:
            # the nominal geometry with the sample's other values (a speed, a clearance)
            other = {p: v for p, v in values.items() if not is_geometric(p)}
            key = tuple(other.items())
            reference = self.references.get(key)
            if reference is None:
                if len(self.references) >= self.KEEP:
                    self.references.pop(next(iter(self.references)))
                reference = self.references[key] = ReferenceDesign(
                    self.other(other) if other else model.scene)
        key = (scene.solver, scene_kind(scene))
        solver = self.solvers.get(key)
        if solver is None:
            solver = self.solvers[key] = make_integrator(scene)
        sectors = model.angle_step if getattr(model, "with_sectors", False) else None
        return (yield from sample_steps(scene, solver, reference=reference,
                                        extremes=model.with_extremes, sectors=sectors,
                                        compiled=compiled, q0=q0))


def _nbytes(value) -> int:
    """Bytes of the arrays in ``value`` (nested tuples and lists of them)."""
    if isinstance(value, np.ndarray):
        return value.nbytes
    if isinstance(value, (tuple, list)):
        return sum(_nbytes(v) for v in value)
    return 0


def _unless_interrupt(exc: Exception) -> Exception:
    """``exc``, raised again when it is an interrupt inside a compiled callback
    (:func:`~mechrel.errors.interrupt_of`): the batch stops there, as row by row."""
    if isinstance(exc, SystemError) and interrupt_of(exc) is not None:
        raise exc
    return exc


_NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def _stable_reason(exc: Exception) -> str:
    """The failure reason without the sample's numbers (replaced by ``#``): the executor counts
    failures by their reason string, and the values are in the failed rows' inputs anyway."""
    return f"{type(exc).__name__}: " + _NUMBER.sub("#", str(exc))


def _lookup(raw, path: str):
    from ...scene.loader import get_value

    try:
        return get_value(raw, path)
    except SceneError:
        raise StudyError(f"inputs: {path!r} is not a value of the scene; allowed: dotted scene "
                         "paths like 'joints.C1.clearance', a component of a point "
                         "'bodies.rod.points.B[0]' or a length 'bodies.crank.length(O,A)' "
                         "(docs/uq.md)") from None
