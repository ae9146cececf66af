"""Settings for every test under the repository root.

Hypothesis' per-example deadline is a wall-clock timing assertion: on the 2-core machine a test beside a
Monte Carlo campaign or the node-graph tests takes several times its usual time and fails for no reason
of its own. Timings are measured by the benchmark scripts, not asserted in tests (README), so it is off.
"""

from hypothesis import settings

settings.register_profile('flyby', deadline=None)
settings.load_profile('flyby')
