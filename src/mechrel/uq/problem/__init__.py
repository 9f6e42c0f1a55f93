"""The problem: uncertain inputs, models, and the failure event.

``inputs`` (marginals, :class:`~mechrel.uq.UncertainInputs`, seeds), ``model`` (the
:class:`~mechrel.uq.Model` protocol, :class:`~mechrel.uq.FunctionModel`), ``mechanism``
(:class:`~mechrel.uq.MechanismModel`), ``analytic`` (closed-form test models), ``allowables``
(:class:`~mechrel.uq.Allowable`, the events and their reliability formulas) and ``limit_state``
(:class:`~mechrel.uq.LimitState`). The public names are imported from :mod:`mechrel.uq`; this
package imports nothing itself, so a worker unpickling a model loads only the modules it needs.
"""
