"""mechrel.mechanics: the scene compiled to arrays, constraints, assembly, kinematics and the
forward-dynamics right-hand side (compiled)."""

from .._kernel_cache import ensure_fresh_kernel_cache

ensure_fresh_kernel_cache()
