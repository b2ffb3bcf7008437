"""The dataset format: round trip, detection over a dataset, and every bad input."""

import json
import math
import shutil

import cv2
import numpy as np
import pytest
from test_camera import BOARD, K_TRUE, board_pose, render_board

from rasc.errors import InputError
from rasc.vision.dataset import FORMAT, load_dataset, write_manifest

POSES_DEG = [(0.0, 0.0), (8.0, 0.0), (0.0, 8.0), (-8.0, -8.0)]
INTR_POSES = [(30, [1, 0, 0]), (30, [0, 1, 0]), (35, [1, 1, 0]), (25, [1, -1, 0.2])]


@pytest.fixture(scope="module")
def template(tmp_path_factory):
    """A small valid dataset: 4 intrinsics + 4 pose images per eye, written with numpy
    renders; the manifest is written by write_manifest."""
    tmp_path = tmp_path_factory.mktemp("dataset")
    (tmp_path / "intrinsics").mkdir()
    (tmp_path / "poses").mkdir()
    images = []
    for eye in ("left", "right"):
        for k, (tilt, axis) in enumerate(INTR_POSES):
            img, _ = render_board(BOARD, K_TRUE, board_pose(tilt, axis, 0.5))
            name = f"intrinsics/{eye}_{k:03d}.png"
            cv2.imwrite(str(tmp_path / name), img)
            images.append({"file": name, "eye": eye, "role": "intrinsics"})
        for k, (pan, tilt) in enumerate(POSES_DEG):
            img, _ = render_board(BOARD, K_TRUE, board_pose(10 + k, [1, 0.5 * k, 0], 0.5))
            name = f"poses/{eye}_{k:02d}.png"
            cv2.imwrite(str(tmp_path / name), img)
            images.append({"file": name, "eye": eye, "role": "pose", "pan": pan,
                           "tilt": tilt, "view": f"{k:02d}"})
    (tmp_path / "ground_truth.json").write_text(json.dumps({"K_left": K_TRUE.tolist()}))
    write_manifest(tmp_path, BOARD, images, angle_unit="deg", ground_truth="ground_truth.json")
    return tmp_path


@pytest.fixture
def folder(template, tmp_path):
    """A fresh copy of the template dataset for each test to change."""
    shutil.copytree(template, tmp_path / "ds")
    return tmp_path / "ds"


def manifest(folder):
    return json.loads((folder / "manifest.json").read_text())


def rewrite(folder, obj):
    (folder / "manifest.json").write_text(json.dumps(obj))


# ----------------------------------------------------------------------- happy path

def test_round_trip_and_detection(folder):
    ds = load_dataset(folder)
    assert ds.board == BOARD and len(ds.images) == 16
    poses = ds.select("left", "pose")
    assert [e.view for e in poses] == ["00", "01", "02", "03"]
    # degrees in the file, radians inside: 8° = 0.13962634 rad
    assert poses[1].pan == pytest.approx(math.radians(8.0), abs=1e-15)
    assert poses[3].tilt == pytest.approx(math.radians(-8.0), abs=1e-15)
    assert ds.select("right", "intrinsics")[0].pan is None
    assert ds.validate() == {"left": (640, 480), "right": (640, 480)}
    assert ds.validate(decode=True) == ds.validate()
    assert ds.image_size("right") == (640, 480)
    det = ds.detect("left", "intrinsics")
    assert det.not_found == [] and len(det.corners) == 4
    c = det.corners["intrinsics/left_001.png"]
    _, truth = render_board(BOARD, K_TRUE, board_pose(*INTR_POSES[1], 0.5))
    assert np.abs(c - truth).max() < 0.1  # same bound as the detection tests
    assert ds.load_ground_truth() == {"K_left": K_TRUE.tolist()}
    # what load_dataset read is what write_manifest wrote (angles back in degrees)
    again = ds.to_manifest()
    written = manifest(folder)
    for a, b in zip(again["images"], written["images"], strict=True):
        for key in ("pan", "tilt"):
            if key in b:
                assert a[key] == pytest.approx(b[key], abs=1e-12)
                a[key] = b[key]
    assert again == written
    # the manifest path may be given instead of the folder
    assert load_dataset(folder / "manifest.json").images == ds.images


def test_radians_and_numpy_values(folder):
    obj = manifest(folder)
    imgs = [dict(im, pan=np.float64(math.radians(im["pan"])),
                 tilt=np.float32(math.radians(im["tilt"])))
            if im["role"] == "pose" else im for im in obj["images"]]
    write_manifest(folder / "manifest.json", obj["board"], imgs, angle_unit="rad")
    ds = load_dataset(folder)
    assert ds.angle_unit == "rad"
    assert ds.select("left", "pose")[1].pan == pytest.approx(math.radians(8.0), abs=1e-15)
    # float32 keeps 7 digits
    assert ds.select("left", "pose")[3].tilt == pytest.approx(math.radians(-8.0), abs=1e-7)


# ---------------------------------------------------------------------- bad inputs

def _mutations():
    """(description, change to the manifest dict, message fragment)."""
    def drop(key):
        return lambda m: m.pop(key)

    def image(k, **kw):
        def f(m):
            for key, v in kw.items():
                if v is None:
                    m["images"][k].pop(key)
                else:
                    m["images"][k][key] = v
        return f

    def setitem(key, value):
        return lambda m: m.__setitem__(key, value)

    return [
        ("no format", drop("format"), "missing field 'format'"),
        ("wrong format", setitem("format", "rasc-dataset/9"), "'rasc-dataset/9'"),
        ("no board", drop("board"), "missing field 'board'"),
        ("board not object", setitem("board", [9, 6]), "'board' must be an object"),
        ("length_unit not text", setitem("length_unit", 1000),
         "field 'length_unit' must be a non-empty string"),
        ("board no corners", setitem("board", {"square_size": 1}), "'inner_corners'"),
        ("board even", setitem("board", {"inner_corners": [8, 6], "square_size": 0.03}),
         "nx \\+ ny even"),
        ("board floats", setitem("board", {"inner_corners": [9.0, 6], "square_size": 0.03}),
         "two integers"),
        ("board size", setitem("board", {"inner_corners": [9, 6], "square_size": -1}),
         "square_size must be a positive"),
        ("no images", drop("images"), "missing field 'images'"),
        ("empty images", setitem("images", []), "non-empty list"),
        ("image not object", lambda m: m["images"].__setitem__(2, "x.png"),
         r"images\[2\]: must be an object"),
        ("no file", image(3, file=None), r"images\[3\]: missing field 'file'"),
        ("no eye", image(5, eye=None), r"images\[5\] \(poses/left_01.png\): missing field 'eye'"),
        ("no role", image(0, role=None), r"images\[0\].*missing field 'role'"),
        ("bad eye", image(1, eye="centre"), r"images\[1\].*'eye'.*'centre'"),
        ("bad role", image(1, role="extra"), r"images\[1\].*'role'.*'extra'"),
        ("no pan", image(4, pan=None), r"images\[4\] \(poses/left_00.png\): missing field 'pan'"),
        ("no tilt", image(4, tilt=None), r"images\[4\].*missing field 'tilt'"),
        ("no view", image(4, view=None), r"images\[4\].*missing field 'view'"),
        ("pan text", image(6, pan="8"), r"images\[6\].*'pan': expected a number"),
        ("pan bool", image(6, pan=True), r"images\[6\].*'pan': expected a number"),
        ("pan huge", lambda m: (m.__setitem__("angle_unit", "rad"),
                                m["images"][5].__setitem__("pan", 8.0)),
         r"images\[5\].*more than a full turn: is angle_unit right"),
        ("no unit", drop("angle_unit"), "missing field 'angle_unit'"),
        ("bad unit", setitem("angle_unit", "grad"), "'angle_unit' must be 'deg' or 'rad'"),
        ("duplicate file", image(1, file="intrinsics/left_000.png"),
         r"images\[1\].*same file as images\[0\]"),
        ("duplicate view", image(5, view="00"),
         r"images\[5\].*second left pose image for view '00'"),
        ("absolute", image(1, file="/etc/passwd"), "inside the dataset folder"),
        ("escape", image(1, file="../x.png"), "inside the dataset folder"),
        ("missing file", image(1, file="intrinsics/nope.png"),
         r"images\[1\] \(intrinsics/nope.png\): file does not exist"),
        ("missing gt", setitem("ground_truth", "gt.json"), "'ground_truth'.*does not exist"),
    ]


#: mutations write_manifest cannot express (it always writes these fields itself)
NOT_WRITABLE = {"no format", "wrong format", "no board", "no images", "no unit"}


@pytest.mark.parametrize("name, change, fragment", _mutations(), ids=[m[0] for m in _mutations()])
def test_bad_manifest_fields(folder, name, change, fragment):
    obj = manifest(folder)
    change(obj)
    rewrite(folder, obj)
    with pytest.raises(InputError, match=fragment) as info:
        load_dataset(folder)
    msg = str(info.value)
    assert msg.startswith(str(folder / "manifest.json")) and "\n" not in msg
    if name in NOT_WRITABLE:
        return
    # write_manifest validates the same way before writing, and writes nothing
    (folder / "manifest.json").unlink()
    with pytest.raises(InputError, match=fragment):
        write_manifest(folder, obj["board"], obj["images"], angle_unit=obj["angle_unit"],
                       ground_truth=obj.get("ground_truth"), length_unit=obj.get("length_unit"))
    assert not (folder / "manifest.json").exists()
    assert not list(folder.glob(".manifest.json.*"))  # no temporary file left either


def test_missing_folder_and_manifest(tmp_path):
    with pytest.raises(InputError, match="no such dataset folder"):
        load_dataset(tmp_path / "nowhere")
    with pytest.raises(InputError, match="manifest.json: no manifest"):
        load_dataset(tmp_path)


def test_malformed_json(folder):
    (folder / "manifest.json").write_text('{"format": "rasc-dataset/1",\n "board": }')
    with pytest.raises(InputError, match="manifest.json: malformed JSON.*line 2, column 11"):
        load_dataset(folder)
    (folder / "manifest.json").write_text("[1, 2]")
    with pytest.raises(InputError, match="top level, got an array"):
        load_dataset(folder)
    (folder / "manifest.json").write_bytes(b"\xff\xfe{")
    with pytest.raises(InputError, match="manifest.json: not UTF-8 text"):
        load_dataset(folder)


def test_unreadable_image(folder):
    (folder / "poses" / "right_02.png").write_text("this is not a PNG")
    ds = load_dataset(folder)  # lazy: loading does not read images
    with pytest.raises(InputError, match=r"images\[14\] \(poses/right_02.png\): cannot read"):
        ds.validate()
    with pytest.raises(InputError, match=r"poses/right_02.png.*cannot read image"):
        ds.detect("right", "pose")


def test_truncated_image_found_by_decoding(folder):
    p = folder / "poses" / "left_01.png"
    p.write_bytes(p.read_bytes()[:200])  # header intact, pixels cut off
    ds = load_dataset(folder)
    assert ds.validate() == {"left": (640, 480), "right": (640, 480)}  # headers only
    with pytest.raises(InputError, match=r"images\[5\] \(poses/left_01.png\): cannot read"):
        ds.validate(decode=True)


def test_mixed_sizes_within_one_eye(folder):
    img = cv2.imread(str(folder / "poses" / "left_03.png"), cv2.IMREAD_GRAYSCALE)
    cv2.imwrite(str(folder / "poses" / "left_03.png"), cv2.resize(img, (320, 240)))
    ds = load_dataset(folder)
    with pytest.raises(InputError, match=r"images\[7\] \(poses/left_03.png\) is 320x240 but "
                                         r"intrinsics/left_000.png is 640x480"):
        ds.validate()
    # a different size for the other eye is fine
    for f in (folder / "intrinsics").glob("right_*.png"):
        cv2.imwrite(str(f), cv2.resize(cv2.imread(str(f)), (320, 240)))
    cv2.imwrite(str(folder / "poses" / "left_03.png"), img)
    for f in (folder / "poses").glob("right_*.png"):
        cv2.imwrite(str(f), cv2.resize(cv2.imread(str(f)), (320, 240)))
    assert load_dataset(folder).validate() == {"left": (640, 480), "right": (320, 240)}


def test_wrong_board_size_says_check_inner_corners(folder):
    obj = manifest(folder)
    obj["board"]["inner_corners"] = [10, 7]  # squares detections_counted instead of inner corners
    rewrite(folder, obj)
    ds = load_dataset(folder)
    with pytest.raises(InputError, match=r"board 10x7 not found in 4 of 4 \(first: "
                                         r"intrinsics/left_000.png\): check board.inner_corners"):
        ds.detect("left", "intrinsics")


def test_too_few_views_found(folder):
    blank = np.full((480, 640), 235, np.uint8)
    for k in (1, 2):  # 2 of 4 left pose images lose the board: half found, fewer than 3
        cv2.imwrite(str(folder / "poses" / f"left_{k:02d}.png"), blank)
    ds = load_dataset(folder)
    with pytest.raises(InputError, match=r"left pose images: board found in 2 of 4 images; "
                                         r"need at least 3 pan-tilt positions"):
        ds.detect("left", "pose")
    cv2.imwrite(str(folder / "intrinsics" / "right_003.png"), blank)
    cv2.imwrite(str(folder / "intrinsics" / "right_002.png"), blank)
    with pytest.raises(InputError, match=r"right intrinsics images: board found in 2 of 4 "
                                         r"images; need at least 3 views with the board tilted"):
        load_dataset(folder).detect("right", "intrinsics")
    # one missing view is reported, not fatal
    cv2.imwrite(str(folder / "poses" / "left_01.png"),
                render_board(BOARD, K_TRUE, board_pose(11, [1, 0.5, 0], 0.5))[0])
    det = load_dataset(folder).detect("left", "pose")
    assert det.not_found == ["poses/left_02.png"] and len(det.corners) == 3


def test_select_and_ground_truth_errors(folder):
    ds = load_dataset(folder)
    with pytest.raises(InputError, match="unknown eye 'centre'"):
        ds.select("centre")
    with pytest.raises(InputError, match="unknown role 'calib'"):
        ds.select(role="calib")
    obj = manifest(folder)
    obj.pop("ground_truth")
    rewrite(folder, obj)
    with pytest.raises(InputError, match="no ground_truth file named"):
        load_dataset(folder).load_ground_truth()


def test_write_manifest_rejects_non_json_values(folder):
    obj = manifest(folder)
    obj["images"][0]["view"] = object()
    with pytest.raises(InputError, match="not JSON data"):
        write_manifest(folder, obj["board"], obj["images"])
    assert manifest(folder)["format"] == FORMAT  # the old manifest is untouched


# ------------------------------------------------------------------ detections kept

def test_the_same_bytes_are_detected_once(folder, tmp_path, detections_counted):
    first = load_dataset(folder).detect("left", "pose")
    assert len(detections_counted) == 4
    # a copy of the dataset elsewhere: nothing detected again, the same corners
    shutil.copytree(folder, tmp_path / "copy")
    again = load_dataset(tmp_path / "copy").detect("left", "pose")
    assert len(detections_counted) == 4 and again.corners.keys() == first.corners.keys()
    for name, c in first.corners.items():
        assert c.tobytes() == again.corners[name].tobytes() and c is not again.corners[name]
    # what the caller does to the corners it got changes nothing kept
    for c in again.corners.values():
        c += 100.0
    third = load_dataset(folder).detect("left", "pose")
    for name, c in first.corners.items():
        assert c.tobytes() == third.corners[name].tobytes()
    # the right eye's images hold the left's bytes (the template renders both alike)
    load_dataset(folder).detect("right", "pose")
    assert len(detections_counted) == 4


def test_other_bytes_detector_or_order_are_detected_afresh(folder, detections_counted):
    ds = load_dataset(folder)
    before = ds.detect("left", "pose").corners["poses/left_02.png"]
    # one image rewritten with other content (the board shifted 3 px): only it is detected
    img = cv2.imread(str(folder / "poses" / "left_02.png"), cv2.IMREAD_GRAYSCALE)
    cv2.imwrite(str(folder / "poses" / "left_02.png"), np.roll(img, 3, axis=1))
    after = load_dataset(folder).detect("left", "pose").corners["poses/left_02.png"]
    assert len(detections_counted) == 5
    np.testing.assert_allclose(after - before, [[3.0, 0.0]] * len(before), atol=0.05)
    # another detector or order rule is another question
    ds.detect("left", "pose", method="saddle")
    assert len(detections_counted) == 9
    ds.detect("left", "pose", order_by="image")
    assert len(detections_counted) == 13
    ds.detect("left", "pose", order_by="image")
    assert len(detections_counted) == 13


def test_not_found_is_kept_too_and_errors_are_not(folder, detections_counted):
    blank = np.full((480, 640), 235, np.uint8)
    cv2.imwrite(str(folder / "poses" / "left_01.png"), blank)
    assert load_dataset(folder).detect("left", "pose").not_found == ["poses/left_01.png"]
    assert load_dataset(folder).detect("left", "pose").not_found == ["poses/left_01.png"]
    assert len(detections_counted) == 4
    # an unreadable image raises each time, naming it (a failure is never kept)
    (folder / "poses" / "left_03.png").write_bytes(b"not an image")
    for _ in range(2):
        with pytest.raises(InputError,
                           match=r"images\[7\] \(poses/left_03.png\): cannot read image"):
            load_dataset(folder).detect("left", "pose")


def test_a_file_changed_while_it_is_read_is_not_kept(folder, detections_counted, monkeypatch):
    import rasc.vision.camera as camera

    spy = camera.detect_corners
    target = folder / "poses" / "left_00.png"
    original = target.read_bytes()

    def changing(image, *args, **kwargs):
        target.write_bytes(original + b"\0")      # another content after it was read
        return spy(image, *args, **kwargs)

    monkeypatch.setattr(camera, "detect_corners", changing)
    load_dataset(folder).detect("left", "pose")
    monkeypatch.setattr(camera, "detect_corners", spy)
    target.write_bytes(original)
    load_dataset(folder).detect("left", "pose")
    # left_00 changed while it was detected, so it was not kept and is detected again;
    # the other three were kept
    assert len(detections_counted) == 5 and detections_counted[4] == detections_counted[0]


def test_detections_kept_are_bounded_and_can_be_forgotten(folder, detections_counted, monkeypatch):
    import rasc.vision.dataset as dataset

    ds = load_dataset(folder)
    monkeypatch.setattr(dataset, "DETECTIONS_KEPT", 2)
    ds.detect("left", "intrinsics")                 # 4 images, the last two kept
    assert len(detections_counted) == 4 and len(dataset._kept) == 2
    ds.detect("left", "intrinsics", min_found=1)
    assert len(detections_counted) == 8                      # each image pushed the next one out
    monkeypatch.setattr(dataset, "DETECTIONS_KEPT", 4096)
    ds.detect("left", "intrinsics")
    ds.detect("left", "intrinsics")
    assert len(detections_counted) == 8 + 2                  # the two missing detected, then kept
    dataset.forget_detections()
    ds.detect("left", "intrinsics")
    assert len(detections_counted) == 14
    # files larger than DETECTIONS_KEPT_MAX_BYTES are detected every time
    monkeypatch.setattr(dataset, "DETECTIONS_KEPT_MAX_BYTES", 1000)
    dataset.forget_detections()
    ds.detect("left", "intrinsics")
    ds.detect("left", "intrinsics")
    assert len(detections_counted) == 22 and len(dataset._kept) == 0
