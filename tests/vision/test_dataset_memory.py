"""rasc's one dataset class beyond a folder: images held in memory, corners given
instead of detected, the one writer (write_dataset) and the deprecated old names."""

import json
import os

import numpy as np
import pytest
from test_camera import BOARD, K_TRUE, board_pose, render_board

from rasc.errors import InputError
from rasc.vision import Dataset, load_dataset, write_dataset
from rasc.vision.dataset import ImageEntry, forget_detections

POSES_DEG = [(0.0, 0.0), (8.0, 0.0), (0.0, 8.0), (-8.0, -8.0)]
INTR_POSES = [(30, [1, 0, 0]), (30, [0, 1, 0]), (35, [1, 1, 0]), (25, [1, -1, 0.2])]


def _views():
    """A small dataset's manifest entries and images (numpy renders of the board, both
    eyes: 4 intrinsics and 4 pose views each; pan/tilt given in degrees)."""
    images, pixels = [], {}
    for eye in ("left", "right"):
        for k, (tilt, axis) in enumerate(INTR_POSES):
            name = f"intrinsics/{eye}_{k:03d}.png"
            pixels[name], _ = render_board(BOARD, K_TRUE, board_pose(tilt, axis, 0.5))
            images.append({"file": name, "eye": eye, "role": "intrinsics"})
        for k, (pan, tilt) in enumerate(POSES_DEG):
            name = f"poses/{eye}_{k:02d}.png"
            pixels[name], _ = render_board(BOARD, K_TRUE,
                                           board_pose(10 + k, [1, 0.5 * k, 0], 0.5))
            images.append({"file": name, "eye": eye, "role": "pose", "pan": pan,
                           "tilt": tilt, "view": f"{k:02d}"})
    return images, pixels


@pytest.fixture(scope="module")
def memory():
    images, pixels = _views()
    return Dataset.in_memory(BOARD, images, pixels, truth={"note": "a truth document"})


def test_in_memory_detection_is_the_folder_detection(memory, tmp_path):
    """The images written (PNG, lossless) and read back give exactly the corners
    detected from the arrays, image for image; the sizes agree."""
    write_dataset(memory, tmp_path / "ds")
    folder = load_dataset(tmp_path / "ds")
    forget_detections()       # the folder's images detected afresh, not remembered
    assert folder.validate() == memory.validate() == {"left": (640, 480),
                                                      "right": (640, 480)}
    for eye in ("left", "right"):
        for role in ("intrinsics", "pose"):
            a, b = memory.detect(eye, role), folder.detect(eye, role)
            assert list(a.corners) == list(b.corners) and a.not_found == b.not_found
            assert a.corners, "the board is found in the numpy renders"
            for f in a.corners:
                assert np.array_equal(a.corners[f], b.corners[f]), f


def test_write_dataset_round_trip(memory, tmp_path):
    """The folder holds the arrays (decoded bytes equal), the manifest the entries as
    given (angles in degrees exactly), the truth document; writing it again from the
    folder's dataset gives the same files."""
    write_dataset(memory, tmp_path / "a")
    ds = load_dataset(tmp_path / "a")
    for e in ds.images:
        assert np.array_equal(ds.read(e), memory.pixels[e.file])
    manifest = json.loads((tmp_path / "a" / "manifest.json").read_text())
    poses = [im for im in manifest["images"] if im["role"] == "pose"]
    assert [(im["pan"], im["tilt"]) for im in poses] == POSES_DEG * 2
    assert ds.load_ground_truth() == {"note": "a truth document"}
    write_dataset(ds, tmp_path / "b")              # from files, not memory
    for path in sorted((tmp_path / "a").rglob("*")):
        other = tmp_path / "b" / path.relative_to(tmp_path / "a")
        assert path.is_dir() or path.read_bytes() == other.read_bytes(), path


def test_write_dataset_is_atomic(memory, tmp_path):
    """A non-empty destination is refused with one line; nothing of the new dataset is
    left, beside it or in it."""
    out = tmp_path / "taken"
    out.mkdir()
    (out / "mine.txt").write_text("keep me")
    with pytest.raises(InputError, match="taken"):
        write_dataset(memory, out, flag="keep_datasets:")
    assert os.listdir(out) == ["mine.txt"] and sorted(os.listdir(tmp_path)) == ["taken"]


def test_an_image_missing_from_memory_is_named(memory):
    images, pixels = _views()
    del pixels["poses/right_02.png"]
    with pytest.raises(InputError, match=r"no image in memory for poses/right_02\.png"):
        Dataset.in_memory(BOARD, images, pixels)


def test_an_image_in_memory_must_be_grey_8_bit(memory):
    images, pixels = _views()
    pixels["intrinsics/left_001.png"] = np.dstack([pixels["intrinsics/left_001.png"]] * 3)
    with pytest.raises(InputError, match=r"images\[1\] \(intrinsics/left_001\.png\): "
                       r"expected an 8-bit grey image .* shape \(480, 640, 3\)"):
        Dataset.in_memory(BOARD, images, pixels)


def test_given_corners_are_the_detections():
    """Corners given instead of detected come back from detect() as given (a view given
    as None is not found); the sizes are the given ones; there are no images to read
    or write."""
    rng = np.random.default_rng(0)
    entries, corners = [], {}
    for eye in ("left", "right"):
        for k in range(4):
            f = f"intrinsics/{eye}_{k:03d}.png"
            entries.append(ImageEntry(len(entries), f, f, eye, "intrinsics"))
            corners[f] = rng.uniform(0, 400, (BOARD.n_corners, 2))
        for k in range(4):
            f = f"poses/{eye}_{k:02d}.png"
            entries.append(ImageEntry(len(entries), f, f, eye, "pose", pan=0.1 * k,
                                      tilt=0.05 * k, view=f"{k:02d}"))
            corners[f] = None if (eye, k) == ("left", 3) else \
                rng.uniform(0, 400, (BOARD.n_corners, 2))
    ds = Dataset.with_corners(BOARD, entries, corners, {"left": (640, 480),
                                                        "right": (640, 480)})
    assert ds.validate() == {"left": (640, 480), "right": (640, 480)}
    det = ds.detect("left", "pose")
    assert det.not_found == ["poses/left_03.png"] and len(det.corners) == 3
    for f, c in det.corners.items():
        assert np.array_equal(c, corners[f])
    with pytest.raises(InputError, match="no images"):
        ds.read(entries[0])
    with pytest.raises(InputError, match="no images to write"):
        write_dataset(ds, "never-written")
    assert not os.path.exists("never-written")


def test_old_names_warn_and_name_the_new_class():
    with pytest.warns(DeprecationWarning, match=r"rasc\.vision\.Dataset"):
        from rasc.sim.synthetic import CornerDataset
    assert CornerDataset is Dataset
    with pytest.warns(DeprecationWarning, match=r"rasc\.vision\.Dataset"):
        from rasc.testing import RenderedDataset
    assert RenderedDataset is Dataset


def test_corner_dataset_is_a_dataset_with_its_head_as_truth():
    from rasc.sim.synthetic import corner_dataset, default_head

    head = default_head()
    ds = corner_dataset(head, seed=0, noise_px=0.0, n_intrinsics=4)
    assert type(ds) is Dataset and ds.truth is head and ds.pixels is None
    np.testing.assert_array_equal(ds.T_cam_from_gaze("left"), head.T_cam_from_gaze["left"])
    assert len(ds.select(role="pose")) == 2 * 9
