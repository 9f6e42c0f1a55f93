"""A scene clearance joint's force-law parameters packed by its model's row (:func:`pack_joint`).

Its own module because it reads the clearance-model table (:mod:`mechrel.forces.models`), the
parameter vector (:mod:`mechrel.forces.params`, which reads the table) and the contact
stiffness (:mod:`mechrel.forces.contact`): inside ``models.py`` it made a circle of modules.
"""

from __future__ import annotations

from typing import Any

from ..errors import SceneError
from .contact import contact_stiffness
from .models import MODELS, PARAMS
from .params import pack_params

__all__ = ["pack_joint"]


def pack_joint(joint: Any) -> Any:
    """Pack a scene clearance joint's force-law parameters by its model's row.

    Every force-law value goes through :func:`mechrel.forces.params.pack_params`, the one
    validator of force-law ranges. The contact stiffness is computed from the contact
    sub-table (defaults when absent: a film-only joint never reads it, but its slot is filled
    so that every parameter vector is complete).

    Parameters
    ----------
    joint : mechrel.scene.model.Joint
        A revolute joint whose ``model`` is a key of :data:`MODELS`.

    Returns
    -------
    numpy.ndarray
        The parameter vector (:data:`mechrel.forces.params.N_PARAMS` floats).

    Raises
    ------
    mechrel.errors.SceneError
        The joint has no bearing radius or length, or a force-law value is out of range.

    Examples
    --------
    The first clearance joint of the embedded dry slider-crank:

    >>> from mechrel.forces.models import model_by_code
    >>> from mechrel.forces.params import P_C, P_K, P_MODEL
    >>> from mechrel.scene import load_scene
    >>> joint = load_scene("slider-crank-dry").clearance_joints[0]
    >>> p = pack_joint(joint)
    >>> model_by_code(p[P_MODEL]).name, bool(p[P_C] == joint.clearance), bool(p[P_K] > 0)
    ('dry', True, True)
    """
    model = MODELS[joint.model]
    path = f"joints.{joint.name}"
    if joint.bearing_radius is None or joint.length is None:
        raise SceneError(f"{path}: a '{joint.model}' clearance joint needs bearing_radius and "
                         f"length (m); got bearing_radius={joint.bearing_radius!r}, "
                         f"length={joint.length!r}", path=path)
    R_B = joint.bearing_radius
    R_S = R_B - joint.clearance
    kw: dict[str, Any] = dict(model=model.name, clearance=joint.clearance, bearing_radius=R_B,
                              length=joint.length)
    # the contact sub-table's values, its defaults when absent (a film-only joint never
    # reads the stiffness, but its slot is filled so that every parameter vector is complete)
    c = {prm.key: prm.default for prm in PARAMS.values() if prm.sub == "contact"}
    if joint.contact is not None:
        c.update({k: getattr(joint.contact, k) for k in c})
    kw["stiffness"] = contact_stiffness(R_B, R_S, c["youngs_modulus_bearing"],
                                        c["poisson_bearing"], c["youngs_modulus_journal"],
                                        c["poisson_journal"], c["stiffness"] == "conformal")
    for prm in model.params:
        if prm.slot is None:
            continue
        table = getattr(joint, prm.sub, None)
        if prm.sub == "contact":
            kw[prm.slot] = c[prm.key]
        elif table is not None:
            kw[prm.slot] = getattr(table, prm.key)
    return pack_params(**kw)
