"""The calibrated head: the head model (:mod:`~rasc.head.model`), base-to-ptu loop
closure and the cyclopean base (:mod:`~rasc.head.base_to_ptu`), and the whole-head
pipeline from a dataset to a calibration (:mod:`~rasc.head.pipeline`)."""
