"""Run a scene: ``simulate(scene) -> SimulationResult``.

What runs depends only on what the scene declares:

* no clearance joints and fully driven → kinematic analysis only (no dynamics);
* clearance joints → forward dynamics of the mechanism with the clearance joints as force
  elements, plus the ideal counterpart (the same scene with those joints ideal) by kinematic
  analysis when it is fully driven (by forward dynamics otherwise), and the errors;
* undriven (free) mechanisms → forward dynamics.

The package's modules, one job each: :mod:`~mechrel.simulation.run` (:func:`simulate`,
:func:`simulate_sample`: the run and its checks; :func:`sample_steps`: a sample's run as
steps, for a batch that runs each step for several samples in turn),
:mod:`~mechrel.simulation.solver` (the solver choice: :func:`make_integrator`,
:data:`DEFAULT_SOLVERS`),
:mod:`~mechrel.simulation.times` (the output instants), :mod:`~mechrel.simulation.result`
(:class:`SimulationResult`), :mod:`~mechrel.simulation.extremes` (the cycle extremes),
:mod:`~mechrel.simulation.evaluators` (the output kinds' values),
:mod:`~mechrel.simulation.reference` (the ideal counterpart, :class:`ReferenceDesign`) and
:mod:`~mechrel.simulation.prepared` (a scene compiled once for many samples,
:class:`PreparedScene`). Import the public names from here; :func:`signal_session` (a batch
of runs sharing one installation of the integrators' signal watcher) and :func:`run_steps`
(the steps of one run, in order) are :mod:`mechrel.integrate`'s, named here for the batches of
samples that run through this package.
"""

from __future__ import annotations

from ..integrate.base import run_steps, signal_session
from .extremes import DENSE_POINTS, EXTREME_FIELDS, KINEMATIC_POINTS, analysis_window
from .prepared import PreparedScene, locate_point
from .reference import ReferenceDesign
from .result import SimulationResult
from .run import EXTREME_MAGNITUDE, extreme_values, sample_steps, simulate, simulate_sample
from .solver import DEFAULT_SOLVERS, make_integrator, scene_kind
from .times import output_times

__all__ = ["simulate", "simulate_sample", "sample_steps", "run_steps", "SimulationResult",
           "make_integrator", "scene_kind", "DEFAULT_SOLVERS", "output_times",
           "analysis_window", "DENSE_POINTS", "EXTREME_FIELDS", "KINEMATIC_POINTS",
           "extreme_values", "EXTREME_MAGNITUDE", "ReferenceDesign", "PreparedScene",
           "locate_point", "signal_session"]
