"""The report room's rig: ``rasc_cli`` (rasc in this process): fixtures of
:mod:`shared_fixtures` (see there).
"""

import shared_fixtures as shared

# this room's fixtures of shared_fixtures
rasc_cli = shared.rasc_cli
