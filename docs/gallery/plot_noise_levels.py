"""
Hand-eye error against the paper's noise levels
===============================================

The paper's experiment 1 in miniature: for each of its eight noise levels
(eq. 13–14: σ_r = 0.005·k rad, σ_t = k mm on every target pose) draw seeded pose
sets at the paper's nine pan-tilt positions, solve ``A X = X B`` with RASC's closed
form and with Li's baseline, and compare each solution with the true
``T_cam_from_gaze`` the poses were generated from. No image is rendered:
:func:`rasc.testing.make_pose_set` builds the poses from a known truth.
"""

import matplotlib.pyplot as plt
import numpy as np

from rasc.handeye.methods import solve
from rasc.testing import handeye_errors, make_pose_set

LEVELS = range(1, 9)
SAMPLES = 20          # the paper used 30; 20 keeps this example under a few seconds
METHODS = ("rasc", "li")

errors = {m: np.zeros((len(LEVELS), SAMPLES, 2)) for m in METHODS}
for i, level in enumerate(LEVELS):
    for s in range(SAMPLES):
        poses = make_pose_set(level, seed=1000 * level + s)
        for m in METHODS:
            result = solve(m, poses.T_cam_from_world, poses.T_gaze_from_ptu)
            errors[m][i, s] = handeye_errors(result, poses)

# %%
# The median error of each method per level: rotation in degrees, translation in
# millimetres (the poses are in metres).

print("level  method  rotation (deg)  translation (mm)")
for i, level in enumerate(LEVELS):
    for m in METHODS:
        rot, trans = np.median(errors[m][i], axis=0)
        print(f"{level:5d}  {m:6s}  {rot:14.3f}  {trans * 1000:16.2f}")

# %%
# Both errors grow with the noise level, and RASC's translation error stays below
# Li's, as in the paper's figures 3 and 4.

fig, (ax_t, ax_r) = plt.subplots(1, 2, figsize=(9, 3.6), layout="constrained")
for m, marker in zip(METHODS, "os", strict=True):
    med = np.median(errors[m], axis=1)
    ax_t.plot(list(LEVELS), med[:, 1] * 1000, marker=marker, label=m)
    ax_r.plot(list(LEVELS), med[:, 0], marker=marker, label=m)
ax_t.set(xlabel="noise level k", ylabel="median translation error (mm)",
         title="translation")
ax_r.set(xlabel="noise level k", ylabel="median rotation error (deg)", title="rotation")
for ax in (ax_t, ax_r):
    ax.grid(alpha=0.3)
    _ = ax.legend(title="method")
plt.show()
