"""Surrogate models of a model's outputs: :func:`~mechrel.uq.polynomial_chaos` (``pce``). The
public names are imported from :mod:`mechrel.uq`.
"""
