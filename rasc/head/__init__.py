"""The calibrated head: the head model (:mod:`~rasc.head.model`), base-to-ptu loop
closure and the cyclopean base (:mod:`~rasc.head.base_to_ptu`), and the whole-head
pipeline from a dataset to a calibration (:mod:`~rasc.head.pipeline`)."""


def __getattr__(name: str):
    """Names the old module ``rasc.head`` had: forwarded with a DeprecationWarning."""
    from rasc import moved_attribute

    return moved_attribute(__name__, name)
