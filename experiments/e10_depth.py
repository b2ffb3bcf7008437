"""E10 (beyond the paper) — depth at any gaze, measured against MuJoCo's depth buffer
(issue 31, item 2).

Protocol:

* **Scene**: the stock head before a textured scene: a wall 3 m ahead and a floor, two
  boxes and a ball 0.9–2.2 m away, all covered with a seeded random texture (blurred
  Gaussian noise at three scales, drawn from ``--seed``); the chessboard target is moved
  behind the wall.
  Written to ``scene/scene.xml`` and ``scene/texture.png``.
* **Gazes** (:data:`GAZES`): both eyes fixate a point (``rasc.head.use.look_at`` on the
  true head), then each eye's pan and tilt are offset: converging at 0.9 m and 1.5 m,
  diverging, asymmetric, up-left and down-right, every reading within ±30°. Vergence is
  reported as ``pan_right − pan_left`` (degrees; positive: converging).
* **Calibrations**: (a) the true head (the renderer's ground truth, no distortion);
  (b) the general model and (c) the paper's model, both ``calibrate_dataset`` on the
  reproduction's default dataset (c is ``ctx.calibration()``, shared with E1–E9);
  (d) the true head with the left hand-eye ``T_cam_from_gaze`` turned by
  :data:`PERTURB_DEG` about the camera's y axis (a vergence error: it shifts every
  disparity by about f·0.1° ≈ 2 px).
* **Depth**: each pair rectified with ``rasc.stereo.rectify.rectify_head`` for each
  calibration (``rectify_images``), disparity by OpenCV's StereoSGBM (block 5, the
  search range from the scene's depth bounds 0.7–8 m), every valid disparity through
  ``Q`` into the rectified left frame, back to the calibrated left camera (``R1ᵀ``),
  projected with its K and distortion to the nearest pixel of the unrectified image, and
  its depth (along the optical axis) compared with MuJoCo's depth buffer there
  (``StereoHeadSim.render_depth``, metres along the optical axis). Reported per gaze and
  calibration: the valid pixels, the median absolute depth error (mm and % of depth) and
  the fraction within 1 %.

``--quick`` (for tests): two gazes (converging 0.9 m, asymmetric) instead of six.

Run::

    python -m experiments.e10_depth [--seed S] [--quick] [--out DIR]

Writes ``<out>/e10/``: ``depth.csv`` (one row per gaze and calibration),
``summary.json``, ``scene/scene.xml`` + ``scene/texture.png`` (the scene),
``e10_depth.png`` (+ .svg).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from experiments._common import (
    Context,
    Section,
    md_table,
    script_main,
    stage,
    write_csv,
    write_json,
)

NAME = "e10"
TITLE = "E10 — beyond the paper: depth at any gaze against the depth buffer"

#: (name, the base point both eyes fixate (x up, y ahead, z left; metres), then (pan,
#: tilt) offsets added to the left and the right eye's fixation, degrees)
GAZES = (
    ("converging 0.9 m", (0.0, 0.9, 0.0), (0.0, 0.0), (0.0, 0.0)),
    ("converging 1.5 m", (0.0, 1.5, 0.0), (0.0, 0.0), (0.0, 0.0)),
    ("diverging", (0.0, 2.5, 0.0), (4.0, 0.0), (-4.0, 0.0)),
    ("asymmetric", (0.35, 1.0, 0.3), (-2.0, 1.5), (1.0, -1.0)),
    ("up-left", (0.55, 1.2, 0.55), (0.0, 0.0), (0.0, 0.0)),
    ("down-right", (-0.45, 1.0, -0.5), (1.5, -1.0), (-1.0, 2.0)),
)
QUICK_GAZES = ("converging 0.9 m", "asymmetric")
CALIBRATIONS = ("true head", "general model", "paper model", "perturbed (0.1°)")
#: the deliberate hand-eye error of calibration (d), degrees about the left camera's y
PERTURB_DEG = 0.1
#: the scene's depth bounds (metres): StereoSGBM's disparity search covers them
Z_NEAR, Z_FAR = 0.7, 8.0
#: StereoSGBM's block size (OpenCV's stereo_match sample's P1, P2 for it)
BLOCK = 5
#: the depth error counted as good (relative)
GOOD = 0.01
HEADER = ("gaze", "calibration", "left_pan_deg", "left_tilt_deg", "right_pan_deg",
          "right_tilt_deg", "vergence_deg", "valid_pixels", "valid_fraction",
          "median_abs_error_mm", "median_rel_error_pct", "within_1pct")


# ------------------------------------------------------------------ the scene

def texture(seed: int, n: int = 1024) -> np.ndarray:
    """A seeded random grey texture (n×n, uint8): Gaussian noise blurred at three scales."""
    import cv2

    rng = np.random.default_rng((seed, 10))
    tex = np.zeros((n, n))
    for sigma, weight in ((2.0, 1.0), (6.0, 0.7), (20.0, 0.5)):
        a = cv2.GaussianBlur(rng.standard_normal((n, n)), (0, 0), sigma)
        tex += weight * a / a.std()
    return np.clip(128 + 40 * tex, 0, 255).astype(np.uint8)


TEXTURE_FILE = "texture.png"
_ASSETS = f"""
    <texture name="e10_plane" type="2d" file="{TEXTURE_FILE}"/>
    <texture name="e10_cube" type="cube" file="{TEXTURE_FILE}"/>
    <material name="e10_wall" texture="e10_plane" texrepeat="1 1" texuniform="true" specular="0"/>
    <material name="e10_object" texture="e10_cube" specular="0"/>
"""
# scene frame: x ahead, y left, z up; the head's base 1.2 m above the floor
_GEOMS = """
    <geom name="e10_wall" type="plane" pos="3.0 0 2.5" size="3 6 0.1" euler="0 -90 0"
      material="e10_wall" contype="0" conaffinity="0"/>
    <geom name="e10_box1" type="box" pos="1.2 0.35 1.35" size="0.15 0.2 0.2" euler="0 0 25"
      material="e10_object" contype="0" conaffinity="0"/>
    <geom name="e10_box2" type="box" pos="1.6 -0.5 0.9" size="0.2 0.2 0.25" euler="0 0 -20"
      material="e10_object" contype="0" conaffinity="0"/>
    <geom name="e10_ball" type="sphere" pos="2.0 0.1 1.0" size="0.25" material="e10_object"
      contype="0" conaffinity="0"/>
  </worldbody>"""


def write_scene(folder: Path, seed: int) -> Path:
    """``folder/scene/scene.xml`` (the stock head and chessboard scene, ``rasc.sim.mjcf.scene_xml``,
    with the textured wall, floor and objects) and its ``texture.png``; the scene's path."""
    from rasc.io import write_bytes_atomic, write_text_atomic
    from rasc.sim.mjcf import DEFAULT_BOARD, scene_xml
    from rasc.vision.camera import encode_png

    xml = scene_xml(DEFAULT_BOARD)
    floor = '<material name="floor" rgba="0.42 0.42 0.44 1" specular="0"/>'
    assert floor in xml and xml.count("</worldbody>") == 1
    xml = xml.replace(floor, _ASSETS.strip() + "\n    <material name=\"floor\" "
                      'texture="e10_plane" texrepeat="4 4" texuniform="true" specular="0"/>')
    xml = xml.replace("  </worldbody>", _GEOMS.strip("\n"))
    folder = folder / "scene"     # apart from the report's figures (the folder's *.png)
    folder.mkdir(exist_ok=True)
    write_bytes_atomic(folder / TEXTURE_FILE, encode_png(texture(seed)))
    write_text_atomic(folder / "scene.xml", xml)
    return folder / "scene.xml"


# ------------------------------------------------------------------ calibrations

def true_head(sim):
    """The simulated head's ground truth as a HeadCalibration (no lens distortion)."""
    from rasc.head.model import HeadCalibration

    return HeadCalibration.from_truth(sim.ground_truth())


def perturbed(head, degrees: float = PERTURB_DEG):
    """``head`` with the left camera turned by ``degrees`` about its own y axis (its
    hand-eye ``T_cam_from_gaze`` premultiplied by the rotation)."""
    import dataclasses

    from scipy.spatial.transform import Rotation

    R = np.eye(4)
    R[:3, :3] = Rotation.from_rotvec([0.0, math.radians(degrees), 0.0]).as_matrix()
    left = dataclasses.replace(head.left, T_cam_from_gaze=R @ head.left.T_cam_from_gaze)
    return dataclasses.replace(head, left=left)


def calibrations(ctx: Context, truth, names) -> dict:
    heads = {}
    for name in names:
        if name == "true head":
            heads[name] = truth
        elif name == "perturbed (0.1°)":
            heads[name] = perturbed(truth)
        elif name == "paper model":
            heads[name] = ctx.calibration().head
        elif name == "general model":
            from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
            from rasc.vision.dataset import load_dataset

            with stage("E10: calibrate the default dataset with the general model"):
                heads[name] = calibrate_dataset(load_dataset(ctx.dataset_dir()),
                                                CalibrationOptions(model="general")).head
    return heads


# ------------------------------------------------------------------ depth

def sgbm_disparity(rect, left, right) -> tuple[np.ndarray, np.ndarray]:
    """StereoSGBM on a rectified pair: (disparity (H, W) in pixels, valid mask); the search
    range covers depths :data:`Z_NEAR`–:data:`Z_FAR` for this rectification's f and
    baseline."""
    import cv2

    fb = float(rect.P1[0, 0]) * rect.baseline
    d_min = int(math.floor(fb / Z_FAR))
    n = int(math.ceil((fb / Z_NEAR - d_min) / 16.0)) * 16
    sgbm = cv2.StereoSGBM_create(minDisparity=d_min, numDisparities=n, blockSize=BLOCK,
                                 P1=8 * BLOCK ** 2, P2=32 * BLOCK ** 2, disp12MaxDiff=1,
                                 uniquenessRatio=10, speckleWindowSize=100, speckleRange=2,
                                 mode=cv2.STEREO_SGBM_MODE_SGBM)
    raw = sgbm.compute(left, right)
    return raw.astype(float) / 16.0, raw >= 16 * d_min


def depth_errors(rect, disparity, valid, depth_true) -> np.ndarray:
    """Relative and absolute depth errors (2, N) of the valid disparities against the
    depth buffer of the (unrectified) left image: each pixel through ``Q`` into the
    rectified left frame, ``R1ᵀ`` into the calibrated left camera, projected with its K and
    distortion to the nearest pixel, its z against the buffer's there."""
    import cv2

    v, u = np.nonzero(valid)
    X = np.c_[u, v, disparity[valid], np.ones(len(u))] @ rect.Q.T
    p_cam = (X[:, :3] / X[:, 3:]) @ rect.R1          # R1ᵀ p, row by row
    front = p_cam[:, 2] > 0
    p_cam = p_cam[front]
    uv, _ = cv2.projectPoints(p_cam.reshape(-1, 1, 3), np.zeros(3), np.zeros(3),
                              rect.K["left"], rect.dist["left"])
    px = np.rint(uv.reshape(-1, 2)).astype(int)
    h, w = depth_true.shape
    inside = (px[:, 0] >= 0) & (px[:, 0] < w) & (px[:, 1] >= 0) & (px[:, 1] < h)
    z_true = depth_true[px[inside, 1], px[inside, 0]]
    err = np.abs(p_cam[inside, 2] - z_true)
    return np.vstack([err / z_true, err])


def gaze_rows(scene: Path, heads: dict, gazes) -> list[tuple]:
    """Render each gaze, rectify it with each calibration, compare: rows of :data:`HEADER`."""
    from rasc.head.use import look_at
    from rasc.sim.mjcf import T_base_from_world_facing
    from rasc.sim.scene import StereoHeadSim
    from rasc.stereo.rectify import rectify_head, rectify_images

    rows = []
    with StereoHeadSim(scene) as sim:
        truth = heads.get("true head") or true_head(sim)
        sim.set_target(T_base_from_world_facing(sim.board, distance=6.0))  # behind the wall
        for name, point, d_left, d_right in gazes:
            readings = {}
            for eye, d in (("left", d_left), ("right", d_right)):
                fix = look_at(getattr(truth, eye), np.asarray(point, dtype=float))
                readings[eye] = (fix.pan + math.radians(d[0]), fix.tilt + math.radians(d[1]))
                sim.set_angles(eye, *readings[eye])
            images = {eye: sim.render_grey(eye) for eye in ("left", "right")}
            depth = sim.render_depth("left")
            deg = {eye: tuple(math.degrees(a) for a in readings[eye]) for eye in readings}
            vergence = deg["right"][0] - deg["left"][0]
            for cal, head in heads.items():
                rect = rectify_head(head, readings["left"], readings["right"])
                left, right = rectify_images(rect, images["left"], images["right"])
                disparity, valid = sgbm_disparity(rect, left, right)
                rel, err = depth_errors(rect, disparity, valid, depth)
                rows.append((name, cal, *deg["left"], *deg["right"], vergence,
                             int(rel.size), rel.size / valid.size,
                             1000 * float(np.median(err)), 100 * float(np.median(rel)),
                             float(np.mean(rel < GOOD))))
    return rows


# ------------------------------------------------------------------ report

def figure(rows: list[tuple], folder: Path, quick: bool) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from experiments._figures import save_experiment_figure

    gazes = sorted(dict.fromkeys(r[0] for r in rows),
                   key=lambda g: next(r[6] for r in rows if r[0] == g))
    verg = {g: next(r[6] for r in rows if r[0] == g) for g in gazes}
    x = np.arange(len(gazes))
    fig, axes = plt.subplots(1, 2, figsize=(12.0, 4.6))
    styles = {"true head": ("C0", "o"), "general model": ("C2", "s"),
              "paper model": ("C1", "^"), "perturbed (0.1°)": ("C3", "x")}
    for cal in dict.fromkeys(r[1] for r in rows):
        by = {r[0]: r for r in rows if r[1] == cal}
        c, m = styles.get(cal, ("k", "."))
        axes[0].plot(x, [by[g][10] for g in gazes], marker=m, color=c, label=cal)
        axes[1].plot(x, [100 * by[g][11] for g in gazes], marker=m, color=c, label=cal)
    labels = [f"{g}\n{verg[g]:+.1f}°" for g in gazes]
    for ax, ylabel in ((axes[0], "median |depth error| (% of depth)"),
                       (axes[1], "pixels within 1 % of the true depth (%)")):
        ax.set_xticks(x, labels, fontsize=8)
        ax.set_xlabel("gaze, with vergence (pan right − pan left), sorted by vergence")
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_yscale("log")
    axes[1].set_ylim(0, 102)
    axes[0].legend(fontsize=9, title="calibration")
    fig.suptitle("Depth from StereoSGBM on rectified pairs against MuJoCo's depth buffer "
                 "(valid disparities)", fontsize=11)
    fig.tight_layout()
    try:
        return save_experiment_figure(fig, folder / "e10_depth", quick)
    finally:
        plt.close(fig)


def markdown(rows: list[tuple], files, quick: bool) -> str:
    table = [(r[0], r[1], f"{r[2]:+.1f}, {r[3]:+.1f}", f"{r[4]:+.1f}, {r[5]:+.1f}",
              f"{r[6]:+.1f}", f"{100 * r[8]:.0f}", f"{r[9]:.2f}", f"{r[10]:.3f}",
              f"{100 * r[11]:.1f}") for r in rows]
    lines = [f"![E10]({NAME}/{files[0].name})", "",
             "The stock head before a textured scene (wall 3 m ahead, floor, two boxes and a "
             "ball 0.9–2.2 m away, a seeded random texture), rendered by both eyes at each "
             "gaze; each pair rectified with `rasc.stereo.rectify.rectify_head` for each "
             "calibration, disparity by OpenCV's StereoSGBM (block 5), depth through Q back "
             "in the calibrated left camera, against MuJoCo's depth buffer at the same pixel "
             "(valid disparities only). \"perturbed\": the true head with the left hand-eye "
             f"turned {PERTURB_DEG}° about the camera's y axis."
             + (" Quick protocol: two of the six gazes." if quick else ""),
             "",
             md_table(("gaze", "calibration", "left pan, tilt (°)", "right pan, tilt (°)",
                       "vergence (°)", "valid pixels (%)", "median depth error (mm)",
                       "median depth error (% of depth)", "within 1 % (%)"), table), "",
             "SGBM's disparity is quantised to 1/16 px and its subpixel fit is biased; a "
             "disparity error δ moves the depth by Z²δ/(f·B) (f ≈ 1150 px, B ≈ 0.33 m: "
             "0.1 px is 0.1 % at 1.3 m). A 0.1° vergence error is f·0.0017 ≈ 2 px of "
             "disparity, a depth error of 2 px / d (about 1 % at 1.5 m)."]
    return "\n".join(lines) + "\n"


def run(ctx: Context) -> Section:
    folder = ctx.dir(NAME)
    gazes = [g for g in GAZES if not ctx.quick or g[0] in QUICK_GAZES]
    names = CALIBRATIONS
    scene = write_scene(folder, ctx.seed)
    from rasc.sim.scene import StereoHeadSim
    with StereoHeadSim(scene) as sim:
        truth = true_head(sim)
    heads = calibrations(ctx, truth, names)
    with stage("E10 render, rectify, SGBM"):
        rows = gaze_rows(scene, heads, gazes)
    write_csv(folder / "depth.csv", HEADER, rows)
    summary = {"seed": ctx.seed, "quick": ctx.quick, "perturb_deg": PERTURB_DEG,
               "rows": [dict(zip(HEADER, r, strict=True)) for r in rows]}
    write_json(folder / "summary.json", summary)
    files = figure(rows, folder, ctx.quick)
    return Section(NAME, TITLE, markdown(rows, files, ctx.quick),
                   files=[folder / "depth.csv", folder / "summary.json", *files],
                   summary={f"{r[0]}|{r[1]}": r[10] for r in rows})


def main(argv=None) -> int:
    return script_main(run, __doc__, argv)


if __name__ == "__main__":
    raise SystemExit(main())
