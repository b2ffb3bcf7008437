"""The vision room's rig: ``rasc_cli``, ``detections_counted`` (the images detection
really looks at), the rendered default dataset and its calibration by ``rasc calibrate``
(``default_cli_run``): fixtures of
:mod:`shared_fixtures` (see there).
"""

import shared_fixtures as shared

# this room's fixtures of shared_fixtures
default_cli_run = shared.default_cli_run
default_dataset = shared.default_dataset
detections_counted = shared.detections_counted
rasc_cli = shared.rasc_cli
