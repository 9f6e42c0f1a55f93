"""Integrators behind one interface (:class:`Integrator`; subclass contract in
:mod:`mechrel.integrate.base`)."""

from .base import DOPRI5, RK4, IntegrationResult, Integrator, SolverStats
from .radau import Radau
from .scipy_ivp import ScipyBDF, ScipyLSODA, ScipyRadau

INTEGRATORS: dict[str, type[Integrator]] = {
    cls.name: cls for cls in (RK4, DOPRI5, Radau, ScipyRadau, ScipyBDF, ScipyLSODA)
}


def get_integrator(name: str, **settings) -> Integrator:
    """Instantiate the integrator registered under ``name``.

    Parameters
    ----------
    name : str
        A key of :data:`INTEGRATORS`.
    **settings
        Keyword arguments of its constructor (``step``, ``rtol``, ``atol``, ``max_steps``,
        ``onset_tolerance``; see :class:`Integrator`).

    Returns
    -------
    Integrator
        The integrator.

    Raises
    ------
    mechrel.errors.SimulationError
        Unknown name, or a setting out of range.

    Examples
    --------
    >>> get_integrator("radau", rtol=1e-7).settings
    {'rtol': 1e-07, 'atol': 1e-09}
    >>> get_integrator("euler")
    Traceback (most recent call last):
    ...
    mechrel.errors.SimulationError: solver.integrator: unknown integrator 'euler'; allowed: bdf, ...
    """
    from ..errors import SimulationError
    try:
        cls = INTEGRATORS[name]
    except KeyError:
        raise SimulationError(f"solver.integrator: unknown integrator {name!r}; allowed: "
                              f"{', '.join(sorted(INTEGRATORS))}") from None
    return cls(**settings)


__all__ = ["INTEGRATORS", "Integrator", "IntegrationResult", "SolverStats", "RK4", "DOPRI5",
           "Radau", "ScipyRadau", "ScipyBDF", "ScipyLSODA", "get_integrator"]
