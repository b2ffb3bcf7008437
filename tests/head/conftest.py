"""The head room's rig: ``rasc_cli``, ``detections_counted`` (the images detection
really looks at), the rendered default dataset and its in-process calibration: fixtures of
:mod:`shared_fixtures` (see there).
"""

import shared_fixtures as shared

# this room's fixtures of shared_fixtures
default_calibration = shared.default_calibration
default_dataset = shared.default_dataset
detections_counted = shared.detections_counted
rasc_cli = shared.rasc_cli
