"""The export room's rig: ``rasc_cli`` (rasc in this process, :mod:`shared_fixtures`)."""

import shared_fixtures as shared

# this room's fixtures of shared_fixtures
rasc_cli = shared.rasc_cli
