"""Per-joint parameter vector of a clearance joint.

A clearance joint's parameters travel into the compiled force law as one ``float64`` vector
``p`` of length :data:`N_PARAMS`, indexed by the integer constants below. Build it with
:func:`pack_params` (pure Python, validates every field and raises
:class:`mechrel.errors.SceneError` naming the field and its allowed range).

All values are SI: m, m/s, Pa s, N/m^n.

Defaults where the paper (Chen, Wang & Gao 2022) is silent are collected in :data:`DEFAULTS`;
``docs/forces.md`` justifies each one.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from mechrel.errors import SceneError

__all__ = [
    "MODEL_DRY", "MODEL_LUBRICATED", "MODEL_TRANSITION", "MODEL_NAMES",
    "P_MODEL", "P_C", "P_RB", "P_RS", "P_L", "P_K", "P_N", "P_CE", "P_FLOOR", "P_CF",
    "P_V0", "P_V1", "P_MU", "P_LAMBDA", "P_EPS0", "P_E1", "P_EPSMAX", "N_PARAMS",
    "PARAM_NAMES", "DEFAULTS", "pack_params", "unpack_params",
]

# --- clearance models -------------------------------------------------------------------------
MODEL_DRY = 0
"""Dry contact: Lankarani–Nikravesh normal force + modified Coulomb friction (eqs. 4–9)."""
MODEL_LUBRICATED = 1
"""Pinkus–Sternlicht long-bearing film only (eqs. 10–18), film evaluated at min(ε, ε_max)."""
MODEL_TRANSITION = 2
"""Blend of dry and lubricated over c ≤ |e| ≤ c + e1 (eq. 19, Flores et al. 2009)."""

MODEL_NAMES = {"dry": MODEL_DRY, "lubricated": MODEL_LUBRICATED, "transition": MODEL_TRANSITION}

# --- indices into the parameter vector ---------------------------------------------------------
P_MODEL = 0     # model code (MODEL_DRY / MODEL_LUBRICATED / MODEL_TRANSITION), stored as float
P_C = 1         # radial clearance c = R_B - R_S (m)
P_RB = 2        # bearing (hole) radius R_B (m)
P_RS = 3        # journal (pin) radius R_S = R_B - c (m)
P_L = 4         # bearing length L (m)
P_K = 5         # contact stiffness K (N/m^n)
P_N = 6         # contact force exponent n (-), 1.5 for Hertz line/point contact as in the paper
P_CE = 7        # coefficient of restitution c_e (-), in (0, 1]
P_FLOOR = 8     # floor of the impact speed δ̇⁻ used in the LN damping term (m/s), > 0
P_CF = 9        # friction coefficient c_f (-); 0 means friction is not evaluated at all
P_V0 = 10       # c_d dead-band speed v0 (m/s)
P_V1 = 11       # c_d full-friction speed v1 (m/s), > v0
P_MU = 12       # dynamic viscosity μ (Pa s)
P_LAMBDA = 13   # small-eccentricity correction exponent λ (-)
P_EPS0 = 14     # small-eccentricity correction threshold ε0 (-), in (0, 1]
P_E1 = 15       # transition band width e1 (m)
P_EPSMAX = 16   # transition model: ε at which the film is clamped, ε_max (-), in (0, 1)
N_PARAMS = 17

PARAM_NAMES = (
    "model", "clearance", "bearing_radius", "journal_radius", "length", "stiffness",
    "exponent", "restitution", "impact_speed_floor", "friction_coefficient", "v0", "v1",
    "viscosity", "lam", "eps0", "e1", "eps_max",
)
"""Field name of each index, in index order (``PARAM_NAMES[P_K] == "stiffness"``)."""

DEFAULTS: dict[str, float] = {
    "exponent": 1.5,
    "impact_speed_floor": 1e-3,
    "friction_coefficient": 0.0,
    "v0": 1e-4,
    "v1": 1e-2,
    "viscosity": 0.0,
    "lam": 1.0,
    "eps0": 0.1,
    "e1": 1e-5,
    "eps_max": 0.99,
}
"""Defaults of :func:`pack_params` where the paper gives no value (justified in docs/forces.md)."""


def _check(field: str, value: Any, ok: bool, allowed: str) -> None:
    if not ok:
        raise SceneError(f"{field} = {value!r} is invalid: allowed {allowed}", path=field)


def _real(field: str, value: Any) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise SceneError(f"{field} = {value!r} is not a number", path=field) from None
    if not math.isfinite(x):
        raise SceneError(f"{field} = {value!r} is invalid: allowed a finite number", path=field)
    return x


def pack_params(
    *,
    model: str,
    clearance: float,
    bearing_radius: float,
    length: float,
    stiffness: float,
    exponent: float = DEFAULTS["exponent"],
    restitution: float,
    impact_speed_floor: float = DEFAULTS["impact_speed_floor"],
    friction_coefficient: float = DEFAULTS["friction_coefficient"],
    v0: float = DEFAULTS["v0"],
    v1: float = DEFAULTS["v1"],
    viscosity: float = DEFAULTS["viscosity"],
    lam: float = DEFAULTS["lam"],
    eps0: float = DEFAULTS["eps0"],
    e1: float = DEFAULTS["e1"],
    eps_max: float = DEFAULTS["eps_max"],
) -> np.ndarray:
    """Validate a clearance joint's parameters and pack them into the vector the force law reads.

    Parameters
    ----------
    model : {"dry", "lubricated", "transition"}
        Clearance model (see :data:`MODEL_DRY`, :data:`MODEL_LUBRICATED`,
        :data:`MODEL_TRANSITION`).
    clearance : float
        Radial clearance c = R_B − R_S (m), > 0.
    bearing_radius : float
        Bearing (hole) radius R_B (m); the journal radius R_S = R_B − c must be > 0.
    length : float
        Bearing length L (m), > 0 (used by the film only).
    stiffness : float
        Contact stiffness K (N/m^n), > 0; see :func:`mechrel.forces.contact.contact_stiffness`.
    exponent : float, default 1.5
        Contact force exponent n (-), in [1, 3].
    restitution : float
        Coefficient of restitution c_e (-), in (0, 1].
    impact_speed_floor : float, default 1e-3
        Floor of the impact speed δ̇⁻ (m/s) in the Lankarani–Nikravesh damping term, > 0.
    friction_coefficient : float, default 0
        Coulomb friction coefficient c_f (-), ≥ 0; 0 switches friction off entirely.
    v0, v1 : float, default 1e-4, 1e-2
        Speeds of Ambrósio's dynamic correction c_d (m/s), 0 ≤ v0 < v1.
    viscosity : float, default 0
        Dynamic viscosity μ (Pa s); > 0 for the lubricated and transition models.
    lam : float, default 1
        Exponent λ (-) of the small-eccentricity film correction (ε/ε0)^λ, ≥ 0.
    eps0 : float, default 0.1
        Threshold ε0 (-) of that correction, in (0, 1].
    e1 : float, default 1e-5
        Width of the transition band c ≤ |e| ≤ c + e1 (m), > 0.
    eps_max : float, default 0.99
        Eccentricity ratio at which the film force is clamped in the transition model (-),
        in (0, 1). The lubricated model does not clamp (its film keeps ε < 1; see
        :func:`mechrel.forces.joint.clearance_force`).

    Returns
    -------
    numpy.ndarray
        ``float64`` vector of length :data:`N_PARAMS`, indexed by the ``P_*`` constants.

    Raises
    ------
    mechrel.errors.SceneError
        A value is not a finite number or is outside its allowed range; the message names the
        field, the value and the allowed range, and ``err.path`` is the field name.
    """
    if not isinstance(model, str) or model.lower() not in MODEL_NAMES:
        raise SceneError(
            f"model = {model!r} is invalid: allowed one of {sorted(MODEL_NAMES)}", path="model"
        )
    code = MODEL_NAMES[model.lower()]

    c = _real("clearance", clearance)
    _check("clearance", clearance, c > 0.0, "> 0 (radial clearance R_B - R_S, m)")
    RB = _real("bearing_radius", bearing_radius)
    _check("bearing_radius", bearing_radius, RB > c,
           f"> clearance = {c!r} (the journal radius R_S = bearing_radius - clearance "
           "must be > 0, m)")
    RS = RB - c
    L = _real("length", length)
    _check("length", length, L > 0.0, "> 0 (bearing length, m)")
    K = _real("stiffness", stiffness)
    _check("stiffness", stiffness, K > 0.0, "> 0 (N/m^n)")
    n = _real("exponent", exponent)
    _check("exponent", exponent, 1.0 <= n <= 3.0, "in [1, 3] (1.5 for Hertzian contact)")
    ce = _real("restitution", restitution)
    _check("restitution", restitution, 0.0 < ce <= 1.0, "in (0, 1]")
    floor = _real("impact_speed_floor", impact_speed_floor)
    _check("impact_speed_floor", impact_speed_floor, floor > 0.0, "> 0 (m/s)")
    cf = _real("friction_coefficient", friction_coefficient)
    _check("friction_coefficient", friction_coefficient, cf >= 0.0, ">= 0")
    a0 = _real("v0", v0)
    _check("v0", v0, a0 >= 0.0, ">= 0 (m/s)")
    a1 = _real("v1", v1)
    _check("v1", v1, a1 > a0, f"> v0 = {a0!r} (m/s)")
    mu = _real("viscosity", viscosity)
    if code == MODEL_DRY:
        _check("viscosity", viscosity, mu >= 0.0, ">= 0 (Pa s)")
    else:
        _check("viscosity", viscosity, mu > 0.0, f"> 0 (Pa s) for model {model!r}")
    lm = _real("lam", lam)
    _check("lam", lam, lm >= 0.0, ">= 0")
    e0 = _real("eps0", eps0)
    _check("eps0", eps0, 0.0 < e0 <= 1.0, "in (0, 1]")
    w1 = _real("e1", e1)
    _check("e1", e1, w1 > 0.0, "> 0 (m)")
    em = _real("eps_max", eps_max)
    _check("eps_max", eps_max, 0.0 < em < 1.0, "in (0, 1)")

    p = np.empty(N_PARAMS, dtype=np.float64)
    p[P_MODEL] = code
    p[P_C] = c
    p[P_RB] = RB
    p[P_RS] = RS
    p[P_L] = L
    p[P_K] = K
    p[P_N] = n
    p[P_CE] = ce
    p[P_FLOOR] = floor
    p[P_CF] = cf
    p[P_V0] = a0
    p[P_V1] = a1
    p[P_MU] = mu
    p[P_LAMBDA] = lm
    p[P_EPS0] = e0
    p[P_E1] = w1
    p[P_EPSMAX] = em
    return p


def unpack_params(p: np.ndarray) -> dict[str, Any]:
    """Inverse of :func:`pack_params` for reports and debugging: ``{field name: value}``.

    The model is returned by name (``"dry"``, ``"lubricated"``, ``"transition"``).
    """
    arr = np.asarray(p, dtype=np.float64)
    if arr.shape != (N_PARAMS,):
        raise ValueError(f"parameter vector must have shape ({N_PARAMS},), got {arr.shape}")
    out: dict[str, Any] = {name: float(arr[i]) for i, name in enumerate(PARAM_NAMES)}
    names = {v: k for k, v in MODEL_NAMES.items()}
    out["model"] = names[int(arr[P_MODEL])]
    return out
