"""Evaluating a design: :func:`~mechrel.uq.evaluate` (``executor``: joblib/Dask workers, failure
capture, per-row caching), the SQLite :class:`~mechrel.uq.EvaluationCache` (``cache``) and the
worker-process plumbing (``_workers``). The public names are imported from :mod:`mechrel.uq`.
"""
