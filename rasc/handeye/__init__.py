"""Gaze-to-camera ("hand-eye") calibration: RASC's closed form (eq. 6–10) written plainly
in :mod:`~rasc.handeye.paper` and computed fast in :mod:`~rasc.handeye.solver` (its
private kernels in ``_kernels``, ``_checks``, ``_linalg``), Li's baseline in
:mod:`~rasc.handeye.li`, OpenCV's five solvers in :mod:`~rasc.handeye.opencv` (cv2 imported
when called), every method by name and the jackknife in :mod:`~rasc.handeye.methods`, the
paper's noise model (eq. 13–14) in :mod:`~rasc.handeye.noise`, user advice in
:mod:`~rasc.handeye.advice`, and the ``rasc-handeye/1`` reader in
:mod:`~rasc.handeye.document`.

Importing the package imports nothing: the modules are imported by name.
"""


def __getattr__(name: str):
    """Names the old module ``rasc.handeye`` had: forwarded with a DeprecationWarning."""
    from rasc import moved_attribute

    return moved_attribute(__name__, name)
