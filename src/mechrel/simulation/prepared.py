"""A scene prepared once for many runs that differ only in values at fixed scene paths:
:class:`PreparedScene` (the section comment below says how), :func:`locate_point`."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import Any

import numpy as np

from ..errors import AssemblyError
from ..forces.models import SUBTABLES
from ..mechanics.drivers import driver_law
from ..mechanics.kinematics import assemble_positions
from ..mechanics.system import CompiledScene, System, _driver_row, compile_scene
from ..scene._values import SceneValues, table_of, value_path
from ..scene.model import GROUND, Scene


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
                if (patchable and joint is not None and joint.is_clearance
                        and joint.name not in dict(joints)):
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
        self._start: tuple | None = None  # (the drivers' angles at t = 0, positions) or ()

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
        systems: dict[str, Any] = {name: getattr(c, name) for name in _SYSTEMS}
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
        top: dict[str, Any] = {f: a for (s, f), a in own.items() if s == ""}
        return scene, c._replace(**systems, **top, period=period)

    def ideal_start(self, scene: Scene, compiled: CompiledScene) -> np.ndarray | None:
        """The positions at t = 0 of the ideal mechanism of ``(scene, compiled)`` (a result
        of :meth:`at`) when they are the prepared scene's own, else None.

        The assembly at t = 0 (:func:`~mechrel.mechanics.kinematics.assemble_positions` from
        ``q_guess``, the first step of a run) reads the ideal mechanism's arrays and, of a
        driver, only its angle at t = 0 (the constraints' driver rows, ``driver_law``; their
        rates do not enter the positions). When :meth:`at` replaced none of those arrays but
        the drivers' parameters, every driver's angle at t = 0 is bitwise the scene's (a
        changed speed leaves it) and the assembly tolerance is the scene's, the scene's
        positions are the sample's, bitwise: they are assembled once, at the first call.

        Parameters
        ----------
        scene, compiled
            What :meth:`at` returned.

        Returns
        -------
        numpy.ndarray or None
            The positions (m, rad), a copy, or None: the run assembles its own (also when the
            scene's own assembly fails, so that the run reports it).

        Examples
        --------
        A crank speed changes the run, not where the crank starts:

        >>> from mechrel.mechanics.kinematics import assemble_positions
        >>> from mechrel.scene import load_scene
        >>> prepared = PreparedScene(load_scene("nine-bar-lubricated"),
        ...                          ["drivers.crank1.speed", "drivers.crank1.angle0"])
        >>> scene, c = prepared.at({"drivers.crank1.speed": -9.0})
        >>> q0 = prepared.ideal_start(scene, c)
        >>> bool((q0 == assemble_positions(c.ideal, c.q_guess, 0.0)).all())
        True
        >>> prepared.ideal_start(*prepared.at({"drivers.crank1.angle0": 0.1})) is None
        True
        """
        base = self.compiled
        tol = self.scene.solver.assembly_tolerance
        if (compiled.q_guess is not base.q_guess or compiled.labels is not base.labels
                or scene.solver.assembly_tolerance != tol):
            return None
        mine, theirs = compiled.ideal, base.ideal
        if any(getattr(mine, f) is not getattr(theirs, f) for f in System._fields
               if f != "dr_par"):
            return None
        if self._start is None:
            try:
                q0 = assemble_positions(theirs, base.q_guess, 0.0, tol=tol,
                                        labels=base.labels["ideal"])
            except AssemblyError:
                self._start = ()
            else:
                self._start = (_angles_at_start(theirs), q0)
        if not self._start:
            return None
        angles, q0 = self._start
        if mine.dr_par is not theirs.dr_par and _angles_at_start(mine) != angles:
            return None
        return q0.copy()  # a run's own (the compiled code takes writable arrays)


def _angles_at_start(system: System) -> bytes:
    """The drivers' angles at t = 0 (the bytes of their float64 values: ±0.0 told apart)."""
    return np.array([driver_law(system.dr_law[k], system.dr_par[k], 0.0)[0]
                     for k in range(system.dr_i.shape[0])], dtype=float).tobytes()
