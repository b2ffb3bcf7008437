"""A head file whose eyes carry ``"lens": "fisheye"`` through every door that uses a
calibration (rasc project, triangulate, look-at, rectify, export, plan): each answers
through the lens model (checked against the truth the file was written from), or, for
rasc plan, which cannot model it, refuses in one line; a wrong file (a fisheye with 5
coefficients, an unknown lens model) is refused by every door in one line naming the file
and the field, exit status 2, nothing written.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from lens_rig import EYES, gaze_readings, lens_head, points_seen

from rasc.geometry import lens


@pytest.fixture
def fisheye_files(tmp_path):
    """The fisheye head as rasc-head/1, a points file and a pixels file at one gaze (the
    true distorted pixels of seeded points), and the truth."""
    head = lens_head("fisheye")
    (tmp_path / "head.json").write_text(json.dumps(head.to_dict()))
    point = (0.1, 1.2, 0.05)
    r = gaze_readings(head, point)
    p, uv = points_seen(head, r, np.random.default_rng(2), 6, centre=point, spread=0.5)
    deg = [float(np.degrees(a)) for eye in EYES for a in r[eye]]
    angles = ",".join(f"{a:.17g}" for a in deg)
    with open(tmp_path / "points.csv", "w") as f:
        f.write("x,y,z,pan_left,tilt_left,pan_right,tilt_right\n")
        f.writelines(",".join(f"{v:.17g}" for v in q) + f",{angles}\n" for q in p)
    with open(tmp_path / "pixels.csv", "w") as f:
        f.write("u_left,v_left,u_right,v_right,pan_left,tilt_left,pan_right,tilt_right\n")
        f.writelines(",".join(f"{v:.17g}" for v in (*a, *b)) + f",{angles}\n"
                     for a, b in zip(uv["left"], uv["right"], strict=True))
    # the readings as written to the file (degrees to 17 digits, back to radians)
    r = {eye: tuple(np.radians(deg[2 * k:2 * k + 2])) for k, eye in enumerate(EYES)}
    return tmp_path, head, r, p, uv


def test_every_use_door_answers_through_the_fisheye(rasc_cli, fisheye_files):
    root, head, r, p, uv = fisheye_files
    cal = str(root / "head.json")
    # project: the lens model's pixels
    status, out, err = rasc_cli("project", cal, str(root / "points.csv"), "--angle-unit",
                                "deg")
    assert status == 0, err
    for i, point in enumerate(json.loads(out)["points"]):
        for eye in EYES:
            e = getattr(head, eye)
            want = lens.project_points(
                (e.T_cam_from_base(*r[eye])[:3] @ np.r_[p[i], 1.0])[None], e.K, e.dist,
                model="fisheye")[0]
            assert point[eye]["in_image"] and np.abs(np.subtract(point[eye]["uv"],
                                                                 want)).max() < 1e-9
    # triangulate: the points back, with sigmas from --pixel-sigma
    status, out, err = rasc_cli("triangulate", cal, str(root / "pixels.csv"), "--angle-unit",
                                "deg", "--pixel-sigma", "0.1")
    assert status == 0, err
    got = np.array([q["p_base"] for q in json.loads(out)["points"]])
    assert np.abs(got - p).max() < 1e-9
    assert all(np.all(np.array(q["sigma_base"]) > 0) for q in json.loads(out)["points"])
    # look-at: the angles that put the point on the principal point through the lens
    status, out, err = rasc_cli("look-at", cal, "--point", "0.1,1.2,0.05", "--angle-unit",
                                "rad")
    assert status == 0, err
    for eye in EYES:
        fix = json.loads(out)["points"][0][eye]
        e = getattr(head, eye)
        uv0 = e.project(np.array([[0.1, 1.2, 0.05]]), fix["pan"], fix["tilt"])[0]
        assert np.abs(uv0 - e.K[:2, 2]).max() < 1e-9
    # rectify: rows shared through cv2.fisheye's rectification
    readings = {eye: ",".join(f"{np.degrees(a):.17g}" for a in r[eye]) for eye in EYES}
    status, _, err = rasc_cli("rectify", cal, f"--left-readings={readings['left']}",
                              f"--right-readings={readings['right']}", "--angle-unit", "deg",
                              "--balance", "0.5", "--out", str(root / "rect"))
    assert status == 0, err
    doc = json.loads((root / "rect" / "rectification.json").read_text())
    assert doc["lens"] == "fisheye" and doc["options"]["balance"] == 0.5
    # export: camera_info's equidistant model
    status, _, err = rasc_cli("export", cal, "--format", "camera-info", "--out",
                              str(root / "info"))
    assert status == 0, err
    import yaml

    info = yaml.safe_load((root / "info" / "left.yaml").read_text())
    assert info["distortion_model"] == "equidistant"
    assert info["distortion_coefficients"]["data"] == head.left.dist.tolist()


def test_rasc_plan_refuses_a_fisheye_head_in_one_line(rasc_cli, fisheye_files):
    root = fisheye_files[0]
    out = root / "positions.csv"
    status, stdout, stderr = rasc_cli("plan", "--calibration", str(root / "head.json"),
                                      "-k", "3", "--out", str(out))
    assert status == 2 and stdout == "" and stderr.splitlines() == [
        f"rasc plan: error: {root / 'head.json'}: the left eye's lens is fisheye: the "
        "planner predicts with the whole-head refinement's pinhole model and cannot plan "
        "for it"]
    assert not out.exists()


#: every door that reads a calibration, its arguments after the file ({root}: the
#: folder) and the output it would write
DOORS = {
    "project": (["{root}/points.csv", "--angle-unit", "deg", "--out", "{root}/o.json"],
                "o.json"),
    "triangulate": (["{root}/pixels.csv", "--angle-unit", "deg", "--out", "{root}/o.json"],
                    "o.json"),
    "look-at": (["--point", "0,1,0", "--angle-unit", "deg", "--out", "{root}/o.json"],
                "o.json"),
    "rectify": (["--left-readings=0,0", "--right-readings=0,0", "--angle-unit", "deg",
                 "--out", "{root}/rect"], "rect"),
    "export": (["--format", "camera-info", "--out", "{root}/info"], "info"),
    "plan": (["-k", "3", "--out", "{root}/positions.csv"], "positions.csv"),
}


@pytest.mark.parametrize("door", sorted(DOORS))
@pytest.mark.parametrize("change, message", [
    ({"dist": [0.04, -0.012, 0.004, -0.0006, 0.0]},
     "left.dist: expected 0 or 4 coefficients for a fisheye lens (k1 k2 k3 k4), got 5"),
    ({"lens": "fish-eye"},
     "left.lens: unknown lens model 'fish-eye' (use one of pinhole, fisheye)"),
])
def test_a_wrong_lens_is_refused_by_every_door(rasc_cli, fisheye_files, door, change,
                                               message):
    root = fisheye_files[0]
    doc = json.loads((root / "head.json").read_text())
    doc["left"].update(change)
    bad = root / "bad.json"
    bad.write_text(json.dumps(doc))
    args, output = DOORS[door]
    args = [a.format(root=root) for a in args]
    argv = ["plan", "--calibration", str(bad), *args] if door == "plan" else \
        [door, str(bad), *args]
    status, stdout, stderr = rasc_cli(*argv)
    assert status == 2 and stdout == "", (door, stderr)
    assert stderr.splitlines() == [f"rasc {door}: error: {bad}: {message}"], stderr
    assert not (root / output).exists()
