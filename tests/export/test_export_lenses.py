"""rasc export of heads with fisheye and rational lenses (tests/lens_rig.py), each file read
back by a reader rasc did not write (PyYAML, cv2.FileStorage) and its camera projected by
OpenCV (``cv2.fisheye.projectPoints`` for the equidistant model, ``cv2.projectPoints`` for
the rational one) with the exported K and D: the pixels agree with rasc's lens model
(:func:`rasc.geometry.lens.project_points`) over the whole image.

Measured (2026-11-28): camera_info, OpenCV and Kalibr files of the fisheye head agree
with the lens core to ≤ 4.5e-13 px at rays up to 78° off the axis (the image's corners);
the rational head's camera_info and OpenCV files to ≤ 4.5e-13 px (bound 1e-9 px).
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import yaml
from lens_rig import EYES, lens_head

from rasc.errors import InputError
from rasc.export import ExportOptions, export_calibration
from rasc.geometry import lens


def _rays(eye) -> np.ndarray:
    """Camera-frame rays (N, 3) through a 17×13 grid of pixels over the whole image,
    corners included (the lens model inverted: rays up to 78° off the fisheye's axis)."""
    w, h = eye.image_size
    gx, gy = np.meshgrid(np.linspace(-0.5, w - 0.5, 17), np.linspace(-0.5, h - 0.5, 13))
    ideal = eye.undistort(np.c_[gx.ravel(), gy.ravel()])
    xy = (ideal - eye.K[:2, 2]) / np.diag(eye.K)[:2]
    return np.c_[xy, np.ones(len(xy))]


def _opencv_pixels(model: str, K, D, rays) -> np.ndarray:
    """OpenCV's projection of camera-frame rays with an exported K and D."""
    zero = np.zeros(3)
    if model == "fisheye":
        uv, _ = cv2.fisheye.projectPoints(rays[None], zero, zero, K, np.asarray(D, float))
    else:
        uv, _ = cv2.projectPoints(rays, zero, zero, K, np.asarray(D, float))
    return uv.reshape(-1, 2)


def _agreement(eye, model: str, K, D) -> float:
    rays = _rays(eye)
    want = lens.project_points(rays, eye.K, eye.dist, model=eye.lens)
    return float(np.abs(_opencv_pixels(model, K, D, rays) - want).max())


@pytest.mark.parametrize("kind, ros_model, n", [("fisheye", "equidistant", 4),
                                                ("rational", "rational_polynomial", 8)])
def test_camera_info_names_the_model_and_projects_as_rasc(kind, ros_model, n):
    head = lens_head(kind)
    files = export_calibration(head, ExportOptions("camera-info")).files
    worst = 0.0
    for eye in EYES:
        doc = yaml.safe_load(files[f"{eye}.yaml"])
        e = getattr(head, eye)
        assert doc["distortion_model"] == ros_model
        m = doc["distortion_coefficients"]
        assert (m["rows"], m["cols"]) == (1, n) and np.array_equal(m["data"], e.dist)
        K = np.reshape(doc["camera_matrix"]["data"], (3, 3))
        worst = max(worst, _agreement(e, "fisheye" if kind == "fisheye" else "pinhole", K,
                                      m["data"]))
    print(f"{kind} camera_info: OpenCV's projection within {worst:.2g} px of the lens core")
    assert worst < 1e-9


@pytest.mark.parametrize("kind", ["fisheye", "rational"])
def test_opencv_filestorage_says_the_lens_model(kind, tmp_path):
    head = lens_head(kind)
    path = tmp_path / "stereo.yaml"
    path.write_text(export_calibration(head, ExportOptions("opencv")).files["stereo.yaml"])
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    worst = 0.0
    for k, eye in enumerate(EYES, start=1):
        e = getattr(head, eye)
        model = fs.getNode(f"lens_model{k}").string()
        assert model == e.lens
        K, D = fs.getNode(f"K{k}").mat(), fs.getNode(f"D{k}").mat()
        assert D.shape == (1, e.dist.size) and np.array_equal(D.ravel(), e.dist)
        worst = max(worst, _agreement(e, model, K, D))
    fs.release()
    print(f"{kind} OpenCV FileStorage: within {worst:.2g} px of the lens core")
    assert worst < 1e-9


def test_a_pinhole_heads_opencv_file_says_pinhole(tmp_path):
    path = tmp_path / "stereo.yaml"
    path.write_text(export_calibration(lens_head("pinhole"), ExportOptions("opencv"))
                    .files["stereo.yaml"])
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    assert [fs.getNode(f"lens_model{k}").string() for k in (1, 2)] == ["pinhole"] * 2


def test_kalibr_writes_pinhole_equidistant_and_projects_as_rasc():
    head = lens_head("fisheye")
    doc = yaml.safe_load(export_calibration(head, ExportOptions("kalibr"))
                         .files["camchain.yaml"])
    worst = 0.0
    for cam, eye in (("cam0", "left"), ("cam1", "right")):
        c, e = doc[cam], getattr(head, eye)
        assert c["camera_model"] == "pinhole" and c["distortion_model"] == "equidistant"
        assert c["distortion_coeffs"] == list(e.dist)
        fu, fv, pu, pv = c["intrinsics"]
        K = np.array([[fu, 0.0, pu], [0.0, fv, pv], [0.0, 0.0, 1.0]])
        worst = max(worst, _agreement(e, "fisheye", K, c["distortion_coeffs"]))
    print(f"fisheye Kalibr camchain: within {worst:.2g} px of the lens core")
    assert worst < 1e-9


def test_kalibr_refuses_the_rational_model():
    with pytest.raises(InputError, match=r"left.dist: k3..k6 = .* radtan model has four"):
        export_calibration(lens_head("rational"), ExportOptions("kalibr"))


def test_a_fisheye_without_coefficients_exports_four_zeros(tmp_path):
    from dataclasses import replace

    head = lens_head("fisheye")
    head = replace(head, left=replace(head.left, dist=np.zeros(0)))
    assert head.left.lens == "fisheye" and head.left.dist.size == 0
    info = yaml.safe_load(export_calibration(head, ExportOptions("camera-info"))
                          .files["left.yaml"])
    assert info["distortion_model"] == "equidistant"
    assert info["distortion_coefficients"]["data"] == [0.0] * 4
    kalibr = yaml.safe_load(export_calibration(head, ExportOptions("kalibr"))
                            .files["camchain.yaml"])
    assert kalibr["cam0"]["distortion_coeffs"] == [0.0] * 4
