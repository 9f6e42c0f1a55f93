"""mechrel.forces: clearance-joint force laws as pure compiled functions.

Everything here is a pure function of scalars and a per-joint parameter vector (SI units);
the ``@numba.njit(cache=True)`` ones are called from the compiled right-hand side in
:mod:`mechrel.mechanics`. See docs/forces.md for equations, sources, corrections and defaults.
"""

from mechrel.forces.contact import contact_energy, contact_stiffness, ln_normal_force
from mechrel.forces.film import (
    film_forces, film_forces_eps_w, full_film_squeeze, half_sommerfeld_steady,
    small_eccentricity_factor,
)
from mechrel.forces.friction import dynamic_correction, friction_force
from mechrel.forces.joint import (
    clearance_force, film_shear_torques, transition_energy, transition_weight,
)
from mechrel.forces.models import BEARINGS, MODELS, BearingModel, ClearanceModel, model_by_code
from mechrel.forces.packing import pack_joint
from mechrel.forces.params import (
    BEARING_LONG, BEARING_NAMES, BEARING_SHORT, DEFAULTS, LIMITS, MODEL_DRY, MODEL_LUBRICATED,
    MODEL_NAMES, MODEL_TRANSITION, N_PARAMS,
    P_C, P_CE, P_CF, P_E1, P_EPS0, P_EPSMAX, P_FLOOR, P_K, P_L, P_LAMBDA, P_MODEL, P_MU, P_N,
    P_BEARING, P_CAVITATION, P_RB, P_SHEAR, P_RS, P_V0, P_V1, PARAM_NAMES, pack_params,
    unpack_params,
)
from mechrel.forces.finite_film import finite_film_forces
from mechrel.forces.short_film import ocvirk_steady, short_film_forces

__all__ = [
    "contact_stiffness", "ln_normal_force", "contact_energy",
    "dynamic_correction", "friction_force",
    "film_forces", "film_forces_eps_w", "half_sommerfeld_steady", "full_film_squeeze",
    "small_eccentricity_factor", "short_film_forces", "ocvirk_steady",
    "finite_film_forces",
    "MODELS", "BEARINGS", "ClearanceModel", "BearingModel", "model_by_code", "pack_joint",
    "BEARING_LONG", "BEARING_SHORT", "BEARING_NAMES", "LIMITS", "P_BEARING", "P_CAVITATION",
    "P_SHEAR",
    "clearance_force", "transition_weight", "transition_energy", "film_shear_torques",
    "pack_params", "unpack_params", "DEFAULTS", "PARAM_NAMES", "MODEL_NAMES",
    "MODEL_DRY", "MODEL_LUBRICATED", "MODEL_TRANSITION", "N_PARAMS",
    "P_MODEL", "P_C", "P_RB", "P_RS", "P_L", "P_K", "P_N", "P_CE", "P_FLOOR", "P_CF",
    "P_V0", "P_V1", "P_MU", "P_LAMBDA", "P_EPS0", "P_E1", "P_EPSMAX",
]
