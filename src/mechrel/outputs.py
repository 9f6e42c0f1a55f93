"""What a scene can report: the output kinds, in one table.

An ``[outputs.NAME]`` table of a scene picks a ``kind`` (default ``"point"``); each kind has
its scene fields, its quantities (with SI and display units and a default allowable error, if
any), how they are computed from the mechanism's state, and what the ideal mechanism's value
is. :data:`OUTPUT_KINDS` is that table; :data:`QUANTITY_INFO` indexes its quantities by name.
The scene validation, the simulation, the command line's summary and figures, the uncertainty
model (:class:`~mechrel.uq.MechanismModel`) and the default allowables
(:data:`mechrel.uq.problem.allowables.DEFAULT_ALLOWABLES`) all read it.

This module is the catalogue only, on the ground floor: it imports nothing of mechrel, so the
scene can read it. The function that computes a kind's values from the mechanism's states is
the kind's evaluator, in :mod:`mechrel.simulation.evaluators`; a new kind is one row here and
one function there (docs/scenes.md, "How to add an output kind").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType
from collections.abc import Mapping


@dataclass(frozen=True)
class Quantity:
    """One quantity of an output kind.

    Parameters
    ----------
    name : str
        The quantity's name (e.g. ``"displacement"``).
    unit : str
        SI unit of the values (and of the errors).
    display_unit : str
        Unit of the command line's summary and figures.
    display_scale : float
        Display value = SI value × ``display_scale``.
    allowable : tuple of float or None
        Default allowable error (mean, standard deviation) in SI units, or None (a study must
        give one).

    Examples
    --------
    >>> q = QUANTITY_INFO["min_film_thickness"]
    >>> q.unit, q.display_unit, q.display_scale
    ('m', 'µm', 1000000.0)
    """

    name: str
    unit: str
    display_unit: str
    display_scale: float
    allowable: tuple[float, float] | None = None


@dataclass(frozen=True)
class OutputKind:
    """One row of :data:`OUTPUT_KINDS` (module docstring).

    Parameters
    ----------
    name : str
        The ``kind`` of a scene output.
    fields : tuple of str
        The fields of the output's table besides ``kind`` (e.g. ``point``, ``axis``).
    quantities : tuple of Quantity
        What it measures, with units.
    computed, ideal : str
        How the value and its ideal counterpart are computed (for the docs); the function
        that computes them is the kind's evaluator
        (:data:`mechrel.simulation.evaluators.EVALUATORS`).

    Examples
    --------
    >>> kind = OUTPUT_KINDS["point"]
    >>> kind.fields, [q.name for q in kind.quantities]
    (('point', 'axis'), ['displacement', 'velocity', 'acceleration'])
    """

    name: str
    fields: tuple[str, ...]
    quantities: tuple[Quantity, ...]
    computed: str
    ideal: str


# Instants per cycle of the ideal path (a closed polyline) that path deviations are measured
# against: chord sag ds² / (8 R) ≤ 1e-8 m for paths ≤ 1 m long with curvature radius ≥ 1 mm.
PATH_POINTS = 7200


OUTPUT_KINDS: Mapping[str, OutputKind] = MappingProxyType({
    "point": OutputKind(
        name="point", fields=("point", "axis"),
        quantities=(Quantity("displacement", "m", "mm", 1e3, (0.012, 0.004)),
                    Quantity("velocity", "m/s", "m/s", 1.0, (0.3, 0.1)),
                    Quantity("acceleration", "m/s²", "m/s²", 1.0, (18.0, 6.0))),
        computed="the point's position, velocity and acceleration projected on the unit axis "
                 "(any direction)",
        ideal="the same point of the ideal mechanism at the same instant"),
    "body": OutputKind(
        name="body", fields=("body",),
        quantities=(Quantity("angle", "rad", "deg", 180.0 / math.pi),
                    Quantity("angular_velocity", "rad/s", "rad/s", 1.0),
                    Quantity("angular_acceleration", "rad/s²", "rad/s²", 1.0)),
        computed="the body's absolute angle θ and its first and second time derivatives",
        ideal="the same body of the ideal mechanism at the same instant"),
    "joint": OutputKind(
        name="joint", fields=("joint",),
        quantities=(Quantity("eccentricity_ratio", "1", "", 1.0),
                    Quantity("min_film_thickness", "m", "µm", 1e6),
                    Quantity("penetration", "m", "µm", 1e6),
                    Quantity("reaction_force", "N", "N", 1.0)),
        computed="ε = |e|/c, h_min = c (1 − ε) and max(|e| − c, 0) of a revolute joint with "
                 "a clearance c, e = journal point − bearing point (0 while the joint is "
                 "ideal); the magnitude of the force it transmits: its force law's (contact "
                 "and friction, film) for a clearance joint, the constraint force |λ| for an "
                 "ideal one",
        ideal="the ideal joint is concentric: ε = 0, h_min = c, no penetration; its force is "
              "the ideal mechanism's constraint force |λ| (inverse dynamics)"),
    "path": OutputKind(
        name="path", fields=("point",),
        quantities=(Quantity("path_deviation", "m", "µm", 1e6),),
        computed="the distance from the point's position to the ideal mechanism's path of the "
                 "same point over one cycle (a polyline of PATH_POINTS instants)",
        ideal="0: the ideal point lies on its own path"),
})

#: Every quantity of every kind by name (names are unique across kinds).
QUANTITY_INFO: Mapping[str, Quantity] = MappingProxyType(
    {q.name: q for kind in OUTPUT_KINDS.values() for q in kind.quantities})


def quantities_of(output) -> tuple[str, ...]:
    """The quantity names of a scene output (an :class:`~mechrel.scene.model.Output`).

    Parameters
    ----------
    output : Output
        A scene output.

    Returns
    -------
    tuple of str

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> quantities_of(load_scene("slider-crank").outputs["slider"])
    ('displacement', 'velocity', 'acceleration')
    """
    return tuple(q.name for q in OUTPUT_KINDS[output.kind].quantities)


def display(quantity: str) -> tuple[str, float]:
    """(display unit, scale) of a quantity name; ("", 1.0) for an unknown one.

    Parameters
    ----------
    quantity : str
        A name of :data:`QUANTITY_INFO`.

    Returns
    -------
    tuple of (str, float)
        The display unit and the factor from SI to it.

    Examples
    --------
    >>> display("min_film_thickness"), display("unknown")
    (('µm', 1000000.0), ('', 1.0))
    """
    q = QUANTITY_INFO.get(quantity)
    return (q.display_unit, q.display_scale) if q is not None else ("", 1.0)
