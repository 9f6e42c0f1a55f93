"""Integrators behind one interface (:class:`Integrator`; subclass contract in
:mod:`mechrel.integrate.base`)."""

from .base import DOPRI5, RK4, IntegrationResult, Integrator, SolverStats
from .radau import Radau
from .scipy_ivp import ScipyBDF, ScipyLSODA, ScipyRadau

INTEGRATORS: dict[str, type[Integrator]] = {
    cls.name: cls for cls in (RK4, DOPRI5, Radau, ScipyRadau, ScipyBDF, ScipyLSODA)
}


def get_integrator(name: str, **settings) -> Integrator:
    """Instantiate the integrator registered under ``name``."""
    from ..errors import SimulationError
    try:
        cls = INTEGRATORS[name]
    except KeyError:
        raise SimulationError(f"solver.integrator: unknown integrator {name!r}; allowed: "
                              f"{', '.join(sorted(INTEGRATORS))}") from None
    return cls(**settings)


__all__ = ["INTEGRATORS", "Integrator", "IntegrationResult", "SolverStats", "RK4", "DOPRI5",
           "Radau", "ScipyRadau", "ScipyBDF", "ScipyLSODA", "get_integrator"]
