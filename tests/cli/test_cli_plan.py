"""``rasc plan``'s doors for a head's units and encoder scales (issue 30): ``--unit`` and
rasc render's options for both units, ``--scales`` as rasc calibrate takes it, the
assumptions printed; and its refusals of hostile values (one line naming the option,
exit status 2, nothing written), each before any large allocation."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

import signal
from pathlib import Path

import pytest

from rasc.cli import main

#: a refusal must come at once: the hostile ranges used to allocate 70.8 GiB over 85 s
ALARM_S = 20


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _run(argv, capsys) -> tuple[int, str, str]:
    def on_alarm(signum, frame):
        raise TimeoutError(f"no answer within {ALARM_S} s")

    capsys.readouterr()
    previous = signal.signal(signal.SIGALRM, on_alarm)
    signal.alarm(ALARM_S)
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:
        code = exc.code
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    cap = capsys.readouterr()
    return code, cap.out, cap.err


UNIT_TOML = "[both]\ntilt_axis_offset_mm = [0, 25, 0]\naxis_skew_deg = 0.5\n" \
            "[left]\npan_scale = 1.006\n"

HOSTILE = [
    # (name, extra argv (ws substituted), fragment of the one line)
    ("depth-behind", ["--workspace-depth", "-1"],
     "--workspace-depth: expected a positive number of metres"),
    ("depth-nan", ["--workspace-depth", "nan"],
     "--workspace-depth: expected a positive number of metres"),
    ("depth-too-near", ["--workspace-depth", "0.2"],
     "--workspace-depth 0.2: both eyes must see the whole 0.6 m plane"),
    ("depth-parallel-rays", ["--workspace-depth", "1e9"],
     "--workspace-depth 1e+09: both eyes must see"),
    ("distance-far", ["--distance", "1e9"], "--distance: expected more than 0 and at most 4.4"),
    ("distance-negative", ["--distance", "-1"], "--distance: expected more than 0"),
    ("pan-range-huge", ["--pan-range=-1e9,1e9"],
     "--pan-range: expected angles from -180 to 180 degrees"),
    ("tilt-range-huge", ["--tilt-range=-1e9,1e9"],
     "--tilt-range: expected angles from -180 to 180 degrees"),
    # 3601 x 1801 positions
    ("grid-too-fine", ["--step", "0.1", "--pan-range=-180,180", "--tilt-range=-90,90"],
     "--step 0.1: the grid over pan -180..180 and tilt -90..90 deg has 6485401 positions"),
    ("unit-device", ["--unit", "/dev/zero"],
     "/dev/zero: not a regular file (a device, pipe or socket); the unit parameter file"),
    ("unit-missing", ["--unit", "{ws}/missing.toml"],
     "missing.toml: unit parameter file not found"),
    ("unit-and-calibration", ["--unit", "{ws}/u.toml", "--calibration", "{ws}/u.toml"],
     "--unit: the head of --calibration"),
    ("axis-skew-beyond", ["--axis-skew", "60"], "--axis-skew: expected a finite angle within"),
]


@pytest.mark.parametrize("name, extra, fragment", HOSTILE, ids=[h[0] for h in HOSTILE])
def test_a_hostile_value_is_one_line_naming_it_and_nothing_is_written(tmp_path, capsys, name,
                                                                      extra, fragment):
    (tmp_path / "u.toml").write_text(UNIT_TOML)
    before = _files(tmp_path)
    argv = ["plan", "-k", "3", "--step", "6", "--out", tmp_path / "p.csv"] \
        + [a.replace("{ws}", str(tmp_path)) for a in extra]
    code, out, err = _run(argv, capsys)
    lines = err.splitlines()
    assert code == 2 and out == "", (code, err[-2000:])
    assert len(lines) == 1 and lines[0].startswith("rasc plan: error: "), err[-2000:]
    assert fragment in lines[0], lines[0]
    assert _files(tmp_path) == before


def test_a_unit_file_and_the_scales_choice_are_planned_for_and_said(tmp_path, capsys):
    """``--unit FILE`` plans for the head rasc render renders with it (the unit's axis
    distance and scales printed as planned under); ``--scales auto`` (the default) plans
    as estimated, ``hold`` predicts the axis distance many times more precise and warns
    that this head's scales are not 1."""
    (tmp_path / "u.toml").write_text(UNIT_TOML)
    common = ["plan", "-k", "4", "--step", "6", "--unit", tmp_path / "u.toml",
              "--workspace-depth", "1.5"]
    code, out_auto, err = _run(common + ["--out", tmp_path / "a.csv"], capsys)
    assert code == 0, err
    assert "planned under:" in out_auto
    assert "left: axis distance 25 mm, axis angle 89.5 deg, encoder scales 1.006 (pan)" \
        in out_auto
    assert "right: axis distance 25 mm, axis angle 89.5 deg, encoder scales 1 (pan)" \
        in out_auto
    assert "scales  estimated (scales auto" in out_auto
    assert "left.pan_scale" in out_auto
    code, out_hold, err = _run(common + ["--scales", "hold", "--out", tmp_path / "h.csv"],
                               capsys)
    assert code == 0, err
    assert "held at 1 (scales hold)" in out_hold and "left pan 1.006" in out_hold
    assert "left.pan_scale" not in out_hold

    def sigma(text, key):
        return float(next(line.split()[-1] for line in text.splitlines()
                          if line.strip().startswith(key + " ")))

    assert sigma(out_auto, "left.axis_distance_mm") > 5 * sigma(out_hold,
                                                               "left.axis_distance_mm")
    assert (tmp_path / "a.csv").is_file() and (tmp_path / "h.csv").is_file()


@pytest.mark.slow
def test_a_calibrations_image_size_is_planned_for(tmp_path, capsys):
    """``--calibration``: the plan uses the calibration's image size (it planned at
    1280x960 whatever the cameras): the same cameras with images cropped to half the
    width and height see a ChArUco target (counted when seen in part) at fewer positions;
    eyes of different sizes are
    refused in one line."""
    import json

    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
    from rasc.sim.synthetic import corner_dataset, default_head

    cal = calibrate_dataset(corner_dataset(default_head(), seed=0, noise_px=0.05),
                            CalibrationOptions(scales="hold"))
    doc = cal.to_dict()
    full = tmp_path / "full.json"
    full.write_text(json.dumps(doc))
    for eye in ("left", "right"):          # the central half of each image, K's centre moved
        doc["head"][eye]["image_size"] = [640, 480]
        doc["head"][eye]["K"][0][2] -= 320
        doc["head"][eye]["K"][1][2] -= 240
    half = tmp_path / "half.json"
    half.write_text(json.dumps(doc))
    usable = {}
    for name, path in (("full", full), ("half", half)):
        code, out, err = _run(["plan", "--calibration", path, "--target",
                               "charuco:8x6,0.04,0.03", "-k", "4", "--step", "4",
                               "--workspace-depth", "3", "--out", tmp_path / f"{name}.csv"],
                              capsys)
        assert code == 0, err
        usable[name] = int(out.split(" of ")[1].split()[0])
        size = "640x480" if name == "half" else "1280x960"
        assert f"{size} pixels (from {path})" in out, out
    assert 0 < usable["half"] < usable["full"], usable
    doc["head"]["right"]["image_size"] = [1280, 960]
    odd = tmp_path / "odd.json"
    odd.write_text(json.dumps(doc))
    code, out, err = _run(["plan", "--calibration", odd, "--out", tmp_path / "o.csv"], capsys)
    assert code == 2 and out == "" and not (tmp_path / "o.csv").exists()
    assert err.strip() == (f"rasc plan: error: {odd}: the eyes' images differ in size (left "
                           "640x480, right 1280x960); the planner models one image size"), err
