"""rasc: Robust Active Stereo Calibration (Neubert & Ferrier, ICRA 2002).

Frames and notation: see :mod:`rasc.geometry.frames` and the README's frame table.
The mathematics (``transforms``, ``kinematics``, ``handeye``, ``li``, ``base_to_ptu``,
``triangulation``, ``noise``) needs only numpy and scipy; ``camera`` imports cv2 and
``sim`` imports mujoco, lazily.

``rasc.load_calibration(path)`` reads the file ``rasc calibrate`` writes and returns the
:class:`rasc.head.model.HeadCalibration` (:func:`rasc.head.use.load_calibration`); it is
imported on first use, so ``import rasc`` stays cheap.
"""

__version__ = "0.2.0"

__all__ = ["__version__", "load_calibration"]


def __getattr__(name: str):
    if name == "load_calibration":
        from rasc.head.use import load_calibration

        return load_calibration
    raise AttributeError(f"module 'rasc' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | {"load_calibration"})
