"""Settings for the whole test session.

Hypothesis draws its examples from a seed derived from each test (``derandomize=True``), so
that the default run, the CI's included, checks the same examples every time: a property
test passes or fails for the code, not for the day's draw. Random exploration, with the
example database, is the ``explore`` profile: ``HYPOTHESIS_PROFILE=explore python -m pytest``
(an example it finds that fails goes into a test as an explicit ``@example``).
"""

from __future__ import annotations

import os

from hypothesis import settings

settings.register_profile("default", derandomize=True, database=None)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))
