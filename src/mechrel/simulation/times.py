"""The output instants of a scene's analysis (:func:`output_times`) and the cycle driver's
rotation at them (degrees)."""

from __future__ import annotations

import math

import numpy as np

from .._machine import physical_memory
from ..errors import SimulationError
from ..mechanics.drivers import driver_angles, driver_law
from ..mechanics.system import CompiledScene, compile_scene
from ..scene.model import Scene


def output_times(scene: Scene, compiled: CompiledScene | None = None) -> np.ndarray:
    """Output instants (s) from the scene's analysis settings.

    Parameters
    ----------
    scene : Scene
        ``analysis.duration`` (s) or ``analysis.cycles`` of the cycle driver, and
        ``analysis.sample_step`` (s) or ``analysis.sample_step_angle`` (rad).
    compiled : CompiledScene, optional
        The scene compiled (:func:`mechrel.mechanics.system.compile_scene`), if at hand.

    Returns
    -------
    ndarray
        ``0, h, 2h, ...`` up to the duration (s), both ends included.

    Raises
    ------
    SimulationError
        When the instants would not fit in this machine's memory.

    Examples
    --------
    One crank revolution at 5000 rpm (12 ms) sampled every degree:

    >>> from mechrel.scene import load_scene
    >>> t = output_times(load_scene("slider-crank"))
    >>> t.size, round(float(t[-1]), 9)
    (361, 0.012)
    """
    compiled = compiled or compile_scene(scene)
    a = scene.analysis
    if a.duration is not None:
        duration = a.duration
    else:
        # validated: cycles come with a cycle driver, which gives the period
        assert a.cycles is not None and compiled.period is not None
        duration = a.cycles * compiled.period
    if a.sample_step is not None:
        step = a.sample_step
    else:
        assert a.sample_step_angle is not None and a.cycle_driver is not None  # validated
        speed = abs(scene.drivers[a.cycle_driver].speed)
        step = a.sample_step_angle / speed
    # a subnormal step (5e-324 rad) makes the ratio overflow, or the step itself underflow
    # to 0 once divided by the speed: as many instants as no memory holds
    ratio = duration / step if step > 0.0 else math.inf
    n = math.floor(ratio * (1 + 1e-12)) + 1 if ratio < math.inf else math.inf
    # the state and its derivative, positions, velocities, accelerations and point outputs
    # at every instant: about 8 arrays of the state's size, 8 bytes per value
    need = 8 * 8 * n * (2 * compiled.q_guess.size + 2)
    have = physical_memory()
    if n == math.inf or (have is not None and need > have):
        field = "analysis.sample_step" if a.sample_step is not None else \
            "analysis.sample_step_angle"
        memory = ("any machine's memory" if have is None else
                  f"this machine's {have / 2**30:.3g} GiB")
        raise SimulationError(
            f"{scene.source or scene.name}: {field}: {n:.3g} output instants over "
            f"{duration:.6g} s need about {need / 2**30:.3g} GiB, more than {memory}; "
            "allowed: a sample step that keeps the output within memory")
    return np.arange(n) * step


def _crank_angle(scene: Scene, compiled: CompiledScene, times: np.ndarray):
    if compiled.cycle_driver < 0:
        return None
    sys = compiled.ideal
    k = compiled.cycle_driver
    theta = driver_angles(sys.dr_law[k], sys.dr_par[k], times)
    th0 = driver_law(sys.dr_law[k], sys.dr_par[k], 0.0)[0]
    sign = math.copysign(1.0, scene.drivers[compiled.driver_names[k]].speed)
    return (theta - th0) * sign * (180.0 / math.pi)
