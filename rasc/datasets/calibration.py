"""The dataset service's calibration of a dataset: what the study's cells (and the
reproduction's experiments) need of a calibrated dataset, as one JSON document
(:data:`rasc.formats.DATASET_CALIBRATION`; its tag keeps the name it was first written
under, ``rasc-study-dataset/1``, so a study's ``datasets/<key>.json`` keep their bytes).

:func:`calibrate` runs the real pipeline (:func:`rasc.head.pipeline.calibrate_dataset`,
the paper's model) on a :class:`rasc.vision.dataset.Dataset` — a folder, or one held in
memory (rendered by :func:`rasc.sim.render.render_in_memory`) — and returns the document
(:func:`calibration_document`); :func:`check_calibration_document` is its reader's check
(a cache entry or a study's file is used only when whole).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rasc import formats
from rasc.geometry.frames import EYES

#: the format of a dataset's calibration document
FORMAT = formats.DATASET_CALIBRATION


def calibrate(dataset, *, dist_model: str | None = None, **extra: Any) -> dict:
    """Calibrate ``dataset`` (a :class:`rasc.vision.dataset.Dataset`: files or images in
    memory) with the real pipeline, the paper's model, and return its calibration
    document (:func:`calibration_document`; its truth, when it has one, is the
    reference; ``extra`` fields are added). ``dist_model``: the lens model
    (``CalibrationOptions.dist_model``; None: its default)."""
    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset

    options = CalibrationOptions(model="paper", **({"dist_model": dist_model}
                                                   if dist_model is not None else {}))
    cal = calibrate_dataset(dataset, options)
    truth = None if dataset.ground_truth is None else dataset.load_ground_truth()
    return calibration_document(cal, dataset.board, truth, **extra)


def calibration_document(cal, board, truth: dict | None, **extra: Any) -> dict:
    """What the cells need from a calibrated dataset (JSON-ready): per eye the pipeline's
    poses, angles, kept pose corners (``EyeResult.corners``), intrinsics, and the
    reference ``T_cam_from_gaze``.

    Parameters
    ----------
    cal : rasc.head.pipeline.Calibration
    board : rasc.vision.board.Board
    truth : dict or None
        The renderer's ``ground_truth.json``; its ``T_cam_from_gaze`` per eye is the
        reference. None (a real head's dataset): the reference is the pipeline's own RASC
        solution on the measured poses (``"reference": "measured"``), so errors are
        deviations from what the data give without added noise.
    """
    eyes = {}
    views = (truth or {}).get("views", {})
    for eye, res in cal.eyes.items():
        ref = (truth[eye]["T_cam_from_gaze"] if truth is not None
               else np.asarray(res.handeye.T_cam_from_gaze, float).tolist())
        if all(f in views for f in res.pose_files):
            extra_eye = {"T_cam_from_world_true": [views[f]["T_cam_from_world"]
                                                   for f in res.pose_files]}
        else:
            extra_eye = {}
        eyes[eye] = {
            "files": list(res.pose_files),
            "pan_tilt_rad": np.asarray(res.pan_tilt, float).tolist(),
            "T_cam_from_world": np.asarray(res.T_cam_from_world, float).tolist(),
            "corners": [_nulls(res.corners["pose"][f]) for f in res.pose_files],
            "K": np.asarray(res.intrinsics.K, float).tolist(),
            "dist": np.asarray(res.intrinsics.dist, float).ravel().tolist(),
            # the lens model of K and dist, when not the pinhole (absent: pinhole)
            **({"lens": res.intrinsics.lens} if res.intrinsics.lens != "pinhole" else {}),
            "T_cam_from_gaze_true": ref, **extra_eye}
    scene = _scene_record(truth, cal.eyes[next(iter(cal.eyes))].pose_files) \
        if truth is not None else None
    return {"format": FORMAT.tag, **extra,
            **({} if truth is not None else {"reference": "measured"}),
            **({"scene": scene} if scene is not None else {}),
            "board": {"inner_corners": list(board.inner_corners),
                      "square_size": board.square_size},
            "eyes": eyes}


def _scene_record(truth: dict, pose_files) -> dict | None:
    """What re-rendering a dataset's scene needs and checks, from its ground truth: the
    render options, the board's pose (at the first pose view) and each head as built;
    None for a dataset whose ground truth does not record them (not rendered by rasc)."""
    from rasc.sim.render import DEGRADATIONS, LENS_FIELDS

    opts = truth.get("render_options")
    views = truth.get("views", {})
    first = views.get(pose_files[0]) if pose_files else None
    if opts is None or first is None or "T_base_from_world" not in first or not all(
            "unit_as_built" in truth.get(eye, {}) for eye in EYES):
        return None
    return {"render_options": {k: opts.get(k) for k in (
                "seed", "target_distance", "noise_sigma", "blur_sigma", "dist",
                "supersample", *DEGRADATIONS, *LENS_FIELDS) if k in opts or k not in (
                    "supersample", *DEGRADATIONS, *LENS_FIELDS)},
            "model_file": truth.get("model_file"),
            "generated_scene": truth.get("generated_scene", False),
            "T_base_from_world": first["T_base_from_world"],
            "heads": {eye: truth[eye]["unit_as_built"] for eye in EYES}}


def check_calibration_document(doc: dict) -> None:
    """ValueError unless ``doc`` looks like a whole calibration document (the reader's
    check of a cache entry or a study's ``datasets/<key>.json``)."""
    if doc.get("format") != FORMAT.tag:
        raise ValueError(f"format {doc.get('format')!r}, not {FORMAT.tag}")
    eyes, board = doc.get("eyes"), doc.get("board")
    if not isinstance(board, dict) or not isinstance(eyes, dict) or not eyes:
        raise ValueError("no board or no eyes")
    for name, eye in eyes.items():
        if not isinstance(eye, dict):
            raise ValueError(f"eyes.{name} is not an object")
        n = None
        for k in ("files", "pan_tilt_rad", "T_cam_from_world", "corners"):
            v = eye.get(k)
            if not isinstance(v, list) or n is not None and len(v) != n:
                raise ValueError(f"eyes.{name}.{k} is missing or of another length")
            n = len(v)
        T = np.asarray(eye["T_cam_from_world"], float)
        if T.shape != (n, 4, 4) or not np.all(np.isfinite(T)):
            raise ValueError(f"eyes.{name}.T_cam_from_world is not {n} finite 4x4 matrices")
        for k in ("K", "T_cam_from_gaze_true"):
            if not isinstance(eye.get(k), list):
                raise ValueError(f"eyes.{name}.{k} is missing")


def in_metres(doc: dict, metres: float) -> dict:
    """A dataset document's lengths (the board's square size, every translation) scaled
    by ``metres`` per unit: the cells measure errors and eq. 14 noise in metres."""
    if metres == 1.0:
        return doc
    doc["board"]["square_size"] *= metres
    if "scene" in doc:
        T = np.asarray(doc["scene"]["T_base_from_world"], float)
        T[:3, 3] *= metres
        doc["scene"]["T_base_from_world"] = T.tolist()
    for eye in doc["eyes"].values():
        for key in ("T_cam_from_world", "T_cam_from_gaze_true", "T_cam_from_world_true"):
            if key not in eye:
                continue
            T = np.asarray(eye[key], float)
            T[..., :3, 3] *= metres
            eye[key] = T.tolist()
    return doc


def _nulls(corners) -> list:
    """Corners as JSON lists, a corner not seen (a NaN row of a target seen in part) as
    ``null``s, which ``np.asarray(..., float)`` reads back as NaN (a chessboard's rows
    are all finite: the same lists as before)."""
    a = np.asarray(corners, float)
    return [[float(v) if np.isfinite(v) else None for v in row] for row in a]
