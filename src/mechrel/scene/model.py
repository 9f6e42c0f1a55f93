"""The scene: frozen, validated plain data describing a planar mechanism and its analysis.

All values are SI (m, kg, s, rad, N, Pa, Pa s). A scene is built by
:func:`mechrel.scene.load_scene` (TOML file, embedded name or mapping), which validates every
field; constructing these dataclasses directly skips that validation, so prefer the loader.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, make_dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Literal

from ..forces.models import MODELS as _MODELS
from ..forces.models import PARAMS as _PARAMS
from ..forces.models import SUBTABLES as _SUBTABLES

Vec2 = tuple[float, float]

GROUND = "ground"
"""Reserved body name for the frame; its points are the scene's ``ground`` points."""

CLEARANCE_MODELS = ("ideal", *_MODELS)
"""Allowed values of ``joints.NAME.model``: ``"ideal"`` and the clearance models of
:data:`mechrel.forces.models.MODELS` (those of the package; the validation reads the table
itself, so a model added by :func:`~mechrel.forces.models.register_model` is allowed too)."""
DRIVER_LAWS = ("constant-speed", "constant-acceleration", "harmonic", "smooth-start")
QUANTITIES = ("displacement", "velocity", "acceleration")
INTEGRATOR_NAMES = ("auto", "rk4", "dopri5", "radau", "scipy-radau", "bdf", "lsoda")
"""Allowed values of ``[solver] integrator`` (checked by the scene loader)."""
FORMULATIONS = ("auto", "absolute", "reduced")
"""Allowed values of ``[solver] formulation``, the equations ``radau`` integrates
(:class:`mechrel.integrate.radau.Radau`): ``"reduced"`` the clearance joints' eccentricities
and the undriven freedoms, ``"absolute"`` all bodies' coordinates with Lagrange multipliers,
``"auto"`` the reduced ones where they apply."""


@dataclass(frozen=True)
class Body:
    """A rigid body. ``position``/``angle`` are the initial guess for assembly (m, rad);
    ``points`` are named points in the body frame, whose origin is the centre of mass (m).

    A body written from joint positions (``global_points`` in the scene file) has its points
    given in ground coordinates at the initial configuration; the loader derives ``points``
    from them, ``position`` (the centre of mass) and ``angle`` (its frame's angle there,
    default 0), and keeps what was written in ``global_points``.

    Parameters
    ----------
    name : str
        The body's name (``bodies.NAME``).
    mass : float
        Mass (kg), > 0.
    inertia : float
        Moment of inertia about the centre of mass (kg m²), > 0.
    position : (float, float)
        Initial guess of the centre of mass (m, global frame).
    angle : float
        Initial guess of the body angle (rad).
    points : mapping of str to (float, float)
        Named points in the body frame (m).
    global_points : mapping of str to (float, float), optional
        The same points in ground coordinates at the initial configuration (m), when the
        body was written that way; None otherwise.

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank")
    >>> crank = scene.bodies["crank"]
    >>> crank.mass, crank.points["A"]  # kg; m in the body frame
    (0.3, (0.025, 0.0))
    """

    name: str
    mass: float
    inertia: float
    position: Vec2
    angle: float
    points: Mapping[str, Vec2]
    global_points: Mapping[str, Vec2] | None = None  # unset: not in the canonical raw


@dataclass(frozen=True)
class PointRef:
    """A named point on a body (``body == "ground"`` for a ground point).

    Parameters
    ----------
    body : str
        A body name, or ``"ground"``.
    point : str
        A point of that body (or of the scene's ``ground`` table).

    Examples
    --------
    >>> PointRef("slider", "B")
    PointRef(body='slider', point='B')
    """

    body: str
    point: str

    def __str__(self) -> str:
        return f"{self.body}.{self.point}"


class SubTable:
    """A clearance joint's sub-table (``joints.NAME.SUB``): frozen values of declared parameters.

    One class per sub-table of the table of clearance models
    (:data:`mechrel.forces.models.SUBTABLES`: :class:`Contact`, :class:`Friction`,
    :class:`Lubricant`, :class:`Transition`), made from the models' parameter declarations
    (:class:`mechrel.forces.models.Param`): its fields, in order, are the declared keys with
    their defaults. A model's new parameter is a new field with its default.

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> friction = load_scene("slider-crank-dry").joints["C"].friction
    >>> isinstance(friction, SubTable), SUBTABLE_CLASSES["friction"] is Friction
    (True, True)
    """

    __slots__ = ()

    if TYPE_CHECKING:  # the fields are made from the declarations at import
        def __init__(self, **values: Any) -> None: ...

        def __getattr__(self, name: str) -> Any: ...


_TYPES = {bool: "bool", str: "str"}


def _param_line(prm) -> str:
    kind = ("{" + ", ".join(f'"{c}"' for c in prm.choices) + "}" if prm.choices
            else _TYPES.get(type(prm.default), "float"))
    rng = ""
    if prm.limit:
        from .._checks import describe_number
        rng = "; " + describe_number(**prm.limit).replace("a finite number ", "")
    unit = f" ({prm.unit})" if prm.unit != "-" else ""
    return (f"    {prm.key} : {kind}, default {prm.default!r}\n"
            f"        {prm.summary[:1].upper()}{prm.summary[1:]}{unit}{rng}.")


def _subtable_class(name: str, intro: str, examples: str) -> type:
    sub = name.lower()  # the class of sub-table "contact" is Contact
    params = [prm for prm in _PARAMS.values() if prm.sub == sub]
    cls = make_dataclass(
        name, [(prm.key, type(prm.default), field(default=prm.default)) for prm in params],
        bases=(SubTable,), frozen=True)
    cls.__module__ = __name__
    cls.__doc__ = (f"{intro}\n\n    Made from the parameters the clearance models declare in "
                   f"``{sub}`` (:data:`mechrel.forces.models.PARAMS`).\n\n"
                   "    Parameters\n    ----------\n"
                   + "\n".join(_param_line(prm) for prm in params)
                   + f"\n\n    Examples\n    --------\n{examples}")
    return cls


Contact = _subtable_class("Contact", """\
Dry-contact parameters (Lankarani–Nikravesh). Moduli in Pa, speeds in m/s.

    The equations are those of :mod:`mechrel.forces.contact` (sources there).""", """\
    >>> from mechrel.scene import load_scene
    >>> contact = load_scene("slider-crank-dry").joints["C"].contact
    >>> contact.restitution, contact.youngs_modulus_bearing, contact.stiffness
    (0.9, 206000000000.0, 'conformal')
""")
Friction = _subtable_class("Friction", """\
Modified Coulomb friction with the dynamic correction c_d (v0 < v1, m/s).

    The law is :func:`mechrel.forces.friction.friction_force` (source there).""", """\
    >>> from mechrel.scene import load_scene
    >>> load_scene("slider-crank-dry").joints["C"].friction
    Friction(coefficient=0.01, v0=0.0001, v1=0.01)
""")
Lubricant = _subtable_class("Lubricant", """\
The lubricant film. ``viscosity`` in Pa s (100 cP = 0.1 Pa s); ``bearing`` the film
    model, a key of :data:`mechrel.forces.models.BEARINGS`.

    The film laws and their sources are in :mod:`mechrel.forces.film`,
    :mod:`mechrel.forces.short_film` and :mod:`mechrel.forces.finite_film`.""", """\
    >>> from mechrel.scene import load_scene
    >>> film = load_scene("slider-crank-lubricated").joints["C"].lubricant
    >>> film.viscosity, film.bearing   # 400 cP
    (0.4, 'long')
""")
Transition = _subtable_class("Transition", """\
Dry/lubricated blend over c <= |e| <= c + e1 (m); film evaluated at eps <= eps_max.

    The blend is :func:`mechrel.forces.joint.transition_weight` (paper eq. 19, source there).""",
                             """\
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank", overrides=["joints.C.model=transition"])
    >>> scene.joints["C"].transition
    Transition(e1=1e-05, eps_max=0.99)
""")
SUBTABLE_CLASSES: Mapping[str, type] = MappingProxyType({
    cls.__name__.lower(): cls for cls in (Contact, Friction, Lubricant, Transition)})
"""The class of each sub-table of a clearance joint, by its scene key."""
assert tuple(SUBTABLE_CLASSES) == _SUBTABLES, "a class per declared sub-table"


@dataclass(frozen=True)
class Joint:
    """A kinematic joint.

    ``type``: ``"revolute"`` (connects two points, 2 equations, or a clearance joint when
    ``model != "ideal"``), ``"translational"`` (``points[0]`` slides on the line through
    ``points[1]`` with unit ``direction``, written in the frame of ``points[1]``'s body (the
    ground's: global axes); the angle of ``points[0]``'s body relative to ``points[1]``'s stays
    ``angle``; 2 equations), ``"pin-in-slot"`` (``points[0]`` on that line, rotation free;
    1 equation) or ``"fixed-angle"`` (body of ``points[0]`` keeps ``angle``; 1 equation).
    The line may be on the ground or on a moving body, the point on any other body.

    For a revolute clearance joint, ``points[0]`` is on the bearing (hole) body and
    ``points[1]`` on the journal (pin) body; ``clearance`` is the radial clearance c = R_B − R_S,
    ``bearing_radius`` is R_B and ``length`` the bearing length (m). ``initial_eccentricity``
    (m, global frame) and ``initial_eccentricity_rate`` (m/s) set the journal's initial offset.

    Parameters
    ----------
    name : str
        The joint's name (``joints.NAME``).
    type : {"revolute", "translational", "pin-in-slot", "fixed-angle"}
        The joint type (above).
    points : tuple of PointRef
        Two points (revolute, translational, pin-in-slot) or one (fixed-angle).
    direction : (float, float), optional
        Unit direction of a translational or pin-in-slot joint's line, in the frame of the
        body of ``points[1]`` (global axes for the ground).
    angle : float, optional
        Angle held by a translational joint (of ``points[0]``'s body relative to
        ``points[1]``'s; with the ground, the body's angle) or a fixed-angle joint (rad).
    model : str
        ``"ideal"`` or a clearance model (:data:`CLEARANCE_MODELS`).
    clearance : float
        Radial clearance c (m), > 0 for a clearance joint.
    bearing_radius : float, optional
        Bearing radius R_B (m).
    length : float, optional
        Bearing length L (m).
    contact, friction, lubricant, transition : optional
        The clearance model's sub-tables (:class:`Contact`, :class:`Friction`,
        :class:`Lubricant`, :class:`Transition`).
    initial_eccentricity : (float, float)
        Initial journal offset e (m, global frame).
    initial_eccentricity_rate : (float, float)
        Its rate (m/s).

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> joint = load_scene("slider-crank-dry").joints["C"]
    >>> joint.type, joint.model, joint.clearance, joint.bearing_radius   # m
    ('revolute', 'dry', 0.0005, 0.01)
    """

    name: str
    type: Literal["revolute", "translational", "pin-in-slot", "fixed-angle"]
    points: tuple[PointRef, ...]
    direction: Vec2 | None = None
    angle: float | None = None
    model: str = "ideal"  # one of CLEARANCE_MODELS
    clearance: float = 0.0
    bearing_radius: float | None = None
    length: float | None = None
    contact: SubTable | None = None
    friction: SubTable | None = None
    lubricant: SubTable | None = None
    transition: SubTable | None = None
    initial_eccentricity: Vec2 = (0.0, 0.0)
    initial_eccentricity_rate: Vec2 = (0.0, 0.0)

    @property
    def is_clearance(self) -> bool:
        """Whether this is a revolute joint with clearance (a model other than ``"ideal"``).

        Returns
        -------
        bool
            True for a clearance joint.

        Examples
        --------
        >>> from mechrel.scene import load_scene
        >>> joints = load_scene("slider-crank-dry").joints
        >>> joints["C"].is_clearance, joints["A"].is_clearance
        (True, False)
        """
        return self.type == "revolute" and self.model != "ideal"

    @property
    def clearance_model(self):
        """The row of :data:`mechrel.forces.models.MODELS` of a clearance joint (else None).

        Returns
        -------
        mechrel.forces.models.ClearanceModel or None
            The model's row.

        Examples
        --------
        >>> from mechrel.scene import load_scene
        >>> joints = load_scene("slider-crank-dry").joints
        >>> joints["C"].clearance_model.has_contact, joints["A"].clearance_model
        (True, None)
        """
        return _MODELS.get(self.model) if self.is_clearance else None


@dataclass(frozen=True)
class Driver:
    """A rheonomic constraint on a body's absolute angle, θ(t) = law(t) (rad).

    Laws: ``constant-speed`` θ0 + ω t; ``constant-acceleration`` θ0 + ω t + α t²/2;
    ``harmonic`` θ0 + A sin(Ω t + φ); ``smooth-start`` reaches ω after ``ramp_time`` with a
    quintic blend of the speed (zero acceleration at both ends).

    Parameters
    ----------
    name : str
        The driver's name (``drivers.NAME``).
    body : str
        The driven body.
    law : {"constant-speed", "constant-acceleration", "harmonic", "smooth-start"}
        The law (above).
    angle0 : float
        θ0 (rad).
    speed : float
        ω (rad/s).
    acceleration : float
        α (rad/s²).
    amplitude : float
        A (rad).
    frequency : float
        Ω (rad/s).
    phase : float
        φ (rad).
    ramp_time : float
        Ramp of the smooth start (s).

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank")
    >>> d = scene.drivers["crank"]
    >>> d.law, round(d.speed * 60 / (2 * math.pi), 6)  # rad/s as rpm
    ('constant-speed', 5000.0)
    """

    name: str
    body: str
    law: Literal["constant-speed", "constant-acceleration", "harmonic", "smooth-start"]
    angle0: float
    speed: float = 0.0
    acceleration: float = 0.0
    amplitude: float = 0.0
    frequency: float = 0.0
    phase: float = 0.0
    ramp_time: float = 0.0


@dataclass(frozen=True)
class Output:
    """What the scene reports, by ``kind`` (:data:`mechrel.outputs.OUTPUT_KINDS`): ``point``
    (a body point's displacement, velocity and acceleration along the unit ``axis``),
    ``body`` (a body's angle and its rates), ``joint`` (a clearance joint's eccentricity
    ratio, minimum film thickness and penetration) or ``path`` (a point's distance from its
    ideal path). Fields another kind uses are None.

    Parameters
    ----------
    name : str
        The output's name (``outputs.NAME``).
    point : PointRef, optional
        The point (kinds ``point`` and ``path``).
    axis : (float, float), optional
        The direction measured (kind ``point``; unit vector).
    kind : str
        A key of :data:`mechrel.outputs.OUTPUT_KINDS`; default ``"point"``.
    body : str, optional
        The body (kind ``body``).
    joint : str, optional
        The clearance joint (kind ``joint``).

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank")
    >>> o = scene.outputs["slider"]
    >>> o.kind, o.point, o.axis
    ('point', PointRef(body='slider', point='B'), (1.0, 0.0))
    """

    name: str
    point: PointRef | None = None
    axis: Vec2 | None = None
    kind: str = "point"
    body: str | None = None
    joint: str | None = None


@dataclass(frozen=True)
class Analysis:
    """What to simulate and where to sample.

    Exactly one of ``duration`` (s) or ``cycles`` (periods of ``cycle_driver``, a
    constant-speed driver). Exactly one of ``sample_step`` (s) or ``sample_step_angle``
    (rad of the cycle driver's rotation).

    Parameters
    ----------
    duration : float, optional
        Simulated time (s).
    cycles : float, optional
        Simulated periods of the cycle driver.
    cycle_driver : str, optional
        A constant-speed driver whose period sets the cycle.
    sample_step : float, optional
        Output interval (s).
    sample_step_angle : float, optional
        Output interval as the cycle driver's rotation (rad).

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank")
    >>> a = scene.analysis
    >>> a.cycles, a.cycle_driver, round(math.degrees(a.sample_step_angle), 9)
    (1.0, 'crank', 1.0)
    """

    duration: float | None = None
    cycles: float | None = None
    cycle_driver: str | None = None
    sample_step: float | None = None
    sample_step_angle: float | None = None


MAX_STEPS_LIMIT = 2**53  # the integrators count steps in float64, exact up to 2**53


@dataclass(frozen=True)
class Solver:
    """Integrator settings. ``integrator`` names an entry of
    :data:`mechrel.integrate.INTEGRATORS`; ``"auto"`` picks the scene type's default
    (see docs/performance.md). ``step`` is the fixed step of RK4 (s).

    Parameters
    ----------
    integrator : str
        One of :data:`INTEGRATOR_NAMES`; default ``"auto"``.
    step : float, optional
        Fixed step of RK4, or the first step of an adaptive method (s).
    rtol, atol : float, optional
        Tolerances of an adaptive method (default: the integrator's or the model's).
    max_steps : int
        Attempted steps allowed, in [1, 2**53].
    baumgarte_alpha, baumgarte_beta : float
        Baumgarte stabilisation of the constraints (1/s); default 5.
    assembly_tolerance : float
        Largest constraint violation accepted at assembly (m, rad); default 1e-12.
    onset_tolerance : float
        Largest penetration at which a contact onset counts as located (m); default 1e-9.
    formulation : str, optional
        One of :data:`FORMULATIONS`: the equations ``radau`` integrates (only with the
        integrator ``radau``); unset: radau's default, ``"auto"``.

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank")
    >>> scene.solver.integrator, scene.solver.assembly_tolerance
    ('auto', 1e-12)
    """

    integrator: str = "auto"
    step: float | None = None
    rtol: float | None = None
    atol: float | None = None
    max_steps: int = 10_000_000
    baumgarte_alpha: float = 5.0
    baumgarte_beta: float = 5.0
    assembly_tolerance: float = 1e-12
    onset_tolerance: float = 1e-9
    formulation: str | None = None  # unset: not in the canonical raw, so no scene hash moves


@dataclass(frozen=True)
class Scene:
    """A complete, validated scene (frozen; from :func:`mechrel.scene.load_scene`).

    Parameters
    ----------
    name : str
        The scene's name.
    description : str
        One paragraph about it.
    bodies : mapping of str to Body
        The moving bodies.
    ground : mapping of str to (float, float)
        Named ground points (m, global frame).
    joints : mapping of str to Joint
        The joints.
    drivers : mapping of str to Driver
        The drivers.
    outputs : mapping of str to Output
        The outputs.
    analysis : Analysis
        What to simulate and where to sample.
    solver : Solver
        Integrator settings.
    gravity : (float, float)
        Gravitational acceleration (m/s²); default (0, −9.81).
    source : str, optional
        The file or embedded name it was loaded from.
    raw : mapping
        The validated TOML data, with defaults (for the scene hash and overrides).

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank")
    >>> sorted(scene.bodies), sorted(scene.outputs)
    (['crank', 'rod', 'slider'], ['slider'])
    >>> round(scene.analysis_duration, 9)  # one revolution at 5000 rpm (s)
    0.012
    """

    name: str
    description: str
    bodies: Mapping[str, Body]
    ground: Mapping[str, Vec2]
    joints: Mapping[str, Joint]
    drivers: Mapping[str, Driver]
    outputs: Mapping[str, Output]
    analysis: Analysis
    solver: Solver = field(default_factory=Solver)
    gravity: Vec2 = (0.0, -9.81)
    source: str | None = None
    raw: Mapping = field(default_factory=lambda: MappingProxyType({}), repr=False, compare=False)

    @property
    def clearance_joints(self) -> tuple[Joint, ...]:
        """The joints with clearance, in scene order.

        Returns
        -------
        tuple of Joint
            The joints whose :attr:`Joint.is_clearance` is true.

        Examples
        --------
        >>> from mechrel.scene import load_scene
        >>> [j.name for j in load_scene("nine-bar-dry").clearance_joints]
        ['C1', 'C2']
        """
        return tuple(j for j in self.joints.values() if j.is_clearance)

    @property
    def analysis_duration(self) -> float:
        """The simulated time span (s): ``analysis.duration``, or ``analysis.cycles`` periods
        2π/|ω| of the cycle driver.

        Returns
        -------
        float
            Duration (s).

        Examples
        --------
        >>> from mechrel.scene import load_scene
        >>> round(load_scene("slider-crank-dry").analysis_duration, 9)   # two turns at 5000 rpm
        0.024
        """
        a = self.analysis
        if a.duration is not None:
            return a.duration
        assert a.cycles is not None and a.cycle_driver is not None  # validated: one is given
        return a.cycles * 2.0 * math.pi / abs(self.drivers[a.cycle_driver].speed)

    @property
    def analysis_sample_step(self) -> float:
        """The output sampling interval (s): ``analysis.sample_step``, or
        ``analysis.sample_step_angle`` (rad) divided by the cycle driver's |ω|.

        Returns
        -------
        float
            Interval (s).

        Examples
        --------
        One degree of the crank at 5000 rpm:

        >>> from mechrel.scene import load_scene
        >>> f"{load_scene('slider-crank').analysis_sample_step:.6e}"
        '3.333333e-05'
        """
        a = self.analysis
        if a.sample_step is not None:
            return a.sample_step
        assert a.sample_step_angle is not None and a.cycle_driver is not None  # validated
        return a.sample_step_angle / abs(self.drivers[a.cycle_driver].speed)
