"""
What a tilt axis off the pan axis does to the camera
====================================================

The paper's pan-tilt model (eq. 3) turns the gaze about two axes through one point. A
real unit's tilt axis misses the pan axis by some distance ``d``
(:class:`rasc.geometry.kinematics.PanTiltUnit`, ``tilt_point``). This example moves a
camera with a unit whose tilt axis is 20 mm in front of the pan axis and with the ideal
unit, both with the same hand-eye transform, and plots where the camera centre goes
over the paper's ±8° range: the difference is what a calibration under the paper's
model must absorb elsewhere.
"""

import matplotlib.pyplot as plt
import numpy as np

from rasc.geometry.kinematics import PanTiltUnit
from rasc.geometry.transforms import invert_transform
from rasc.testing import default_T_cam_from_gaze

ideal = PanTiltUnit()
offset = PanTiltUnit.canonical(axis_offset=0.020)          # d = 20 mm, axes orthogonal
print(f"axis distance d: ideal {ideal.axis_distance * 1000:.1f} mm, "
      f"offset unit {offset.axis_distance * 1000:.1f} mm; "
      f"axis angle {offset.axis_angle_deg:.1f} deg")

T_cam_from_gaze = default_T_cam_from_gaze()
tilts = np.radians(np.linspace(-8, 8, 17))


def camera_centres(unit: PanTiltUnit, pan_deg: float) -> np.ndarray:
    """The camera centre in ptu coordinates (metres) along a tilt sweep at one pan."""
    pan = np.full_like(tilts, np.radians(pan_deg))
    T_cam_from_ptu = T_cam_from_gaze @ unit.T_gaze_from_ptu(pan, tilts)
    return invert_transform(T_cam_from_ptu)[:, :3, 3]


# %%
# Camera centre positions in the ptu frame (x up along the pan axis, y forward, z left),
# seen from the side (y–x plane) for three pan readings.

fig, ax = plt.subplots(figsize=(7.5, 4.2), layout="constrained")
for pan_deg, colour in zip((-8, 0, 8), ("C0", "C1", "C2"), strict=True):
    for unit, style, name in ((ideal, "-", "ideal"), (offset, "--", "d = 20 mm")):
        c = camera_centres(unit, pan_deg) * 1000
        ax.plot(c[:, 1], c[:, 0], style, color=colour, marker=".",
                label=f"pan {pan_deg:+d}°, {name}")
ax.set(xlabel="forward y (mm)", ylabel="up x (mm)",
       title="camera centre over tilt −8° … +8°")
ax.grid(alpha=0.3)
_ = fig.legend(loc="outside right upper", fontsize="small")

# %%
# The largest displacement between the two units over the sweep:

worst = max(np.linalg.norm(camera_centres(offset, p) - camera_centres(ideal, p), axis=1).max()
            for p in (-8, 0, 8))
print(f"largest camera-centre difference: {worst * 1000:.2f} mm")
plt.show()
