"""The documentation room's rig: the run's rasc.testing dataset cache, which the
pages' examples share with tests/handeye: fixtures of
:mod:`shared_fixtures` (see there).
"""

import shared_fixtures as shared

# this room's fixtures of shared_fixtures
rasc_testing_cache = shared.rasc_testing_cache
