"""rasc: Robust Active Stereo Calibration (Neubert & Ferrier, ICRA 2002).

Frames and notation: see :mod:`rasc.geometry.frames` and the README's frame table.
The mathematics (``transforms``, ``kinematics``, ``handeye``, ``li``, ``base_to_ptu``,
``triangulation``, ``noise``) needs only numpy and scipy; ``camera`` imports cv2 and
``sim`` imports mujoco, lazily.
"""

__version__ = "0.1.0"
