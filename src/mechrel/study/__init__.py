"""A study: its file, its run and its report.

A study file (TOML, :mod:`~mechrel.study.study`) names a scene, the uncertain inputs, the
allowables and the methods; the runner (:mod:`~mechrel.study.runner`) behind ``mechrel
reliability`` and ``mechrel sensitivity`` runs the methods of the registry, each shown by its
presenter (:mod:`~mechrel.study.presenters`, sharing the run's
:class:`~mechrel.study.context.Context`), with the whole-cycle and inverse reports
(:mod:`~mechrel.study.rare`, :mod:`~mechrel.study.inverse`); :mod:`~mechrel.study.accuracy`
is the study behind ``mechrel accuracy``. (Named ``study``, not ``studies``: the top-level
``studies/`` folder holds the scripts that reproduce the paper.)
"""
