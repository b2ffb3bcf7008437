"""``rasc rectify`` with fisheye eyes: ``--balance`` and ``--fov-scale`` (cv2.fisheye's)
reach the library and the file; the options a lens model has none of, and a pair of two
models, are refused in one line, exit status 2, nothing written."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from lens_rig import lens_head

READINGS = ("--left-readings=-9,-3", "--right-readings=9.5,-2", "--angle-unit", "deg")


def _write(root, kind):
    head = lens_head(kind) if kind != "mixed" else replace(
        lens_head("fisheye"), right=lens_head("pinhole").right)
    path = root / f"{kind}.json"
    path.write_text(json.dumps(head.to_dict()))
    return path, head


def test_balance_and_fov_scale_reach_the_rectification(rasc_cli, tmp_path):
    from rasc.stereo.rectify import RectifyOptions, rectify_head

    path, head = _write(tmp_path, "fisheye")
    out = tmp_path / "rect"
    status, stdout, stderr = rasc_cli("rectify", str(path), *READINGS, "--balance", "1",
                                      "--fov-scale", "1.5", "--out", str(out))
    assert (status, stdout, stderr) == (0, "", "")
    doc = json.loads((out / "rectification.json").read_text())
    assert doc["lens"] == "fisheye"
    assert doc["options"]["balance"] == 1.0 and doc["options"]["fov_scale"] == 1.5
    rect = rectify_head(head, np.radians([-9.0, -3.0]), np.radians([9.5, -2.0]),
                        RectifyOptions(balance=1.0, fov_scale=1.5), maps=False)
    for key in ("R1", "R2", "P1", "P2", "Q"):
        assert np.allclose(doc[key], getattr(rect, key), rtol=1e-12, atol=1e-12), key
    assert doc["roi1"] == list(rect.roi1)


@pytest.mark.parametrize("kind, more, message", [
    ("fisheye", ("--alpha", "0"), "{cal}: --alpha 0: the eyes are fisheye, whose "
     "rectification (cv2.fisheye.stereoRectify) has no alpha; use balance (0 only valid "
     "pixels, 1 the whole image) and fov_scale"),
    ("pinhole", ("--balance", "0.5"), "{cal}: --balance: only for fisheye eyes "
     "(cv2.fisheye.stereoRectify); these eyes are pinhole: use alpha"),
    ("rational", ("--fov-scale", "2"), "{cal}: --fov-scale: only for fisheye eyes "
     "(cv2.fisheye.stereoRectify); these eyes are pinhole: use alpha"),
    ("fisheye", ("--balance", "2"), "--balance: expected a number from 0 (only valid "
     "pixels) to 1 (the whole fisheye image), got 2.0"),
    ("fisheye", ("--fov-scale", "0"), "--fov-scale: expected a number above 0 and at most "
     "10 (the rectified focal length divided by it), got 0.0"),
    ("mixed", (), "{cal}: lens: the eyes' lens models differ (left fisheye, right "
     "pinhole); rectification takes a pair of one model (cv2.stereoRectify or "
     "cv2.fisheye.stereoRectify)"),
])
def test_refusals_write_nothing(rasc_cli, tmp_path, kind, more, message):
    path, _ = _write(tmp_path, kind)
    out = tmp_path / "rect"
    status, stdout, stderr = rasc_cli("rectify", str(path), *READINGS, *more, "--out",
                                      str(out))
    assert status == 2 and stdout == ""
    assert stderr.splitlines() == [f"rasc rectify: error: {message.format(cal=path)}"]
    assert not out.exists()
