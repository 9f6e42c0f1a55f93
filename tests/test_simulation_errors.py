"""Simulations that cannot succeed fail with a clear error, never NaN."""

import pytest

from mechrel.scene import load_scene
from mechrel.simulation import simulate


def test_lubricated_film_that_cannot_carry_the_load_is_a_clear_error():
    # A lubricated joint has no contact force: at 5000 rpm with a 1e-6 Pa s "oil" the film
    # cannot carry the slider's inertia load, ε is driven to 1 and the stiff integrator's step
    # collapses. That must be a SimulationError that says so, never NaN or a silent result.
    from mechrel.errors import SimulationError
    scene = load_scene("slider-crank-lubricated",
                       overrides={"joints.C.lubricant.viscosity": 1e-6, "analysis.cycles": 0.25})
    with pytest.raises(SimulationError, match=r"stopped at t = .*model = 'transition'"):
        simulate(scene)
