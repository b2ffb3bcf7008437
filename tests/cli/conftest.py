"""The command line's rig: ``rasc_cli`` (rasc in this process), the rendered default
dataset and its calibration by ``rasc calibrate`` (``default_cli_run``): fixtures of
:mod:`shared_fixtures` (see there).
"""

import shared_fixtures as shared

# this room's fixtures of shared_fixtures
default_cli_run = shared.default_cli_run
default_dataset = shared.default_dataset
rasc_cli = shared.rasc_cli
