"""Continuous motion in the bench (issue 33, docs/topics/continuous.md): the trajectory,
the cameras' and encoders' clocks, the joint stream's file, and continuous renders
against the truth."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

import math  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from rasc.errors import InputError  # noqa: E402
from rasc.geometry.frames import EYES  # noqa: E402
from rasc.geometry.kinematics import PAPER_POSES_DEG  # noqa: E402
from rasc.sim.motion import (  # noqa: E402
    MIN_JERK_PEAK,
    Trajectory,
    expose,
    exposure_plan,
    frame_times,
    kept_frames,
    sample_joint_stream,
)
from rasc.vision.joint_stream import (  # noqa: E402
    JointStream,
    format_joint_stream,
    read_joint_stream,
)

PAPER = np.radians(PAPER_POSES_DEG)


# ---------------------------------------------------------------------- the trajectory

@pytest.mark.parametrize("dwell", [0.0, 0.3])
@pytest.mark.parametrize("speed", [10.0, 60.0])
def test_trajectory_passes_the_positions_at_rest_within_its_speed(speed, dwell):
    traj = Trajectory(PAPER, speed, dwell=dwell)
    # at each planned position: there, and at rest
    np.testing.assert_allclose(traj.angles(traj.arrivals),
                               np.repeat(PAPER[:, None, :], 2, axis=1), atol=1e-12)
    assert np.abs(traj.velocity(traj.arrivals)).max() < 1e-12
    t = np.linspace(0.0, traj.duration, 200_001)
    speed_now = np.degrees(np.linalg.norm(traj.velocity(t), axis=-1).max(axis=-1))
    # the peak speed is reached (half-way through each motion) and never exceeded; the
    # sampled grid (30 µs) misses the exact peak by far less than 1e-6 of it
    assert speed_now.max() <= speed * (1 + 1e-9)
    assert speed_now.max() >= speed * (1 - 1e-6)
    # the velocity is the angles' derivative (central differences, step 1 µs)
    tt = np.linspace(0.01, traj.duration - 0.01, 997)
    numeric = (traj.angles(tt + 1e-6) - traj.angles(tt - 1e-6)) / 2e-6
    np.testing.assert_allclose(traj.velocity(tt), numeric, atol=1e-6)
    # the motions take 1.875 · distance / speed, plus the dwells
    steps = np.linalg.norm(np.diff(PAPER, axis=0), axis=1)
    assert traj.duration == pytest.approx(
        MIN_JERK_PEAK * steps.sum() / math.radians(speed) + dwell * len(PAPER))
    if dwell:       # held still through each dwell
        np.testing.assert_allclose(traj.angles(traj.arrivals + 0.5 * dwell),
                                   traj.angles(traj.arrivals), atol=1e-12)


def test_trajectory_per_eye_positions_and_one_eye():
    rng = np.random.default_rng(1)
    per_eye = rng.uniform(-0.2, 0.2, (5, 2, 2))
    traj = Trajectory(per_eye, 20.0)
    t = rng.uniform(0, traj.duration, 50)
    both = traj.angles(t)
    for e, eye in enumerate(EYES):
        np.testing.assert_array_equal(traj.angles(t, eye), both[:, e])
        np.testing.assert_allclose(traj.angles(traj.arrivals, eye), per_eye[:, e], atol=1e-12)
    # outside [0, duration] the head waits at the ends
    np.testing.assert_allclose(traj.angles([-1.0, traj.duration + 1.0]),
                               per_eye[[0, -1]], atol=1e-12)


def test_trajectory_refuses_bad_input():
    with pytest.raises(InputError, match="speed_deg_s must be a positive"):
        Trajectory(PAPER, 0.0)
    with pytest.raises(InputError, match="positions: expected shape"):
        Trajectory(np.zeros((3, 3)), 10.0)
    with pytest.raises(InputError, match="dwell"):
        Trajectory(PAPER, 10.0, dwell=-1.0)


# ------------------------------------------------------------------------ the clocks

def test_frames_lie_inside_the_motion_and_are_bounded():
    t = frame_times(2.0, 30.0, 0.01, readout=0.02)
    assert t[0] - 0.015 == pytest.approx(0.0)
    assert t[-1] + 0.015 <= 2.0 + 1e-12
    np.testing.assert_allclose(np.diff(t), 1 / 30)
    assert len(t) == 60
    assert len(kept_frames(len(t), 25)) <= 25
    np.testing.assert_array_equal(kept_frames(10, 40), np.arange(10))
    np.testing.assert_array_equal(kept_frames(100, 40), np.arange(0, 100, 3))


@pytest.mark.parametrize("line", [0.0, 7e-5, 1e-3 / 3])
def test_each_row_averages_its_own_exposure(line):
    """A 'render' that is the time itself: each row of the exposure is the weighted mean
    time of its sub-frames, which is the row's own mid-exposure time (to rounding); its
    renders span the row's exposure and no more."""
    rows, exposure, S = 200, 0.01, 5
    times, start = exposure_plan(3.0, exposure, S, line, rows)
    image = expose(lambda t: np.full((rows, 3), t), times, start, S)
    want = 3.0 + (np.arange(rows) - (rows - 1) / 2) * line
    np.testing.assert_allclose(image[:, 0], want, rtol=0, atol=1e-12)
    # the renders' cells cover the first row's exposure start to the last row's end
    h = exposure / S
    assert times[0] == pytest.approx(want[0] - exposure / 2 + h / 2)
    assert want[-1] + exposure / 2 - h / 2 <= times[-1] < want[-1] + exposure / 2 + h / 2
    if line == 0:
        assert len(times) == S


# ----------------------------------------------------------------------- the encoders

@pytest.mark.parametrize("offset, jitter", [(0.0, 0.0), (0.037, 0.0), (-0.021, 2e-4)])
def test_joint_stream_at_t_plus_offset_gives_the_true_angles(tmp_path, offset, jitter):
    """The stream written and read back, interpolated at t_cam + δ, gives the true
    angles to the jitter's size (speed · jitter); at t_cam alone it is off by speed · δ."""
    speed = 30.0
    traj = Trajectory(PAPER, speed)
    stream = sample_joint_stream(traj, 200.0, offset, jitter, np.random.default_rng(4))
    (tmp_path / "joints.csv").write_text(format_joint_stream(stream))
    back = read_joint_stream(tmp_path / "joints.csv")
    t = frame_times(traj.duration, 30.0, 0.01)
    for eye in EYES:
        np.testing.assert_array_equal(back[eye].time, stream[eye].time)
        truth = traj.angles(t, eye)
        err = np.degrees(np.linalg.norm(back.angles(eye, t + offset) - truth, axis=-1))
        # bound: the speed times the largest jitter drawn (4.5 sigma here) plus the
        # spline's own error (measured 2e-5 deg without jitter)
        assert err.max() <= speed * 4.5 * jitter + 1e-4, err.max()
        if offset:
            wrong = np.degrees(np.linalg.norm(back.angles(eye, t) - truth, axis=-1))
            assert wrong.max() > 0.5 * speed * abs(offset)


def test_joint_stream_rates_are_the_trajectory_velocity():
    traj = Trajectory(PAPER, 20.0)
    stream = sample_joint_stream(traj, 500.0, 0.0, 0.0, np.random.default_rng(0))
    t = np.linspace(0.1, traj.duration - 0.1, 301)
    # the spline's rate error at 500 Hz: below 1e-3 rad/s (measured 2e-5)
    np.testing.assert_allclose(stream.rates("left", t), traj.velocity(t, "left"), atol=1e-3)


def test_no_jitter_draws_nothing():
    rng = np.random.default_rng(3)
    state = rng.bit_generator.state
    sample_joint_stream(Trajectory(PAPER, 10.0), 100.0, 0.01, 0.0, rng)
    assert rng.bit_generator.state == state


@pytest.mark.parametrize("text, where", [
    ("time,eye,pan,tilt\n0,left,0,0\n0.01,left,0,0\n0.005,left,0,0\n",
     r"joints.csv: line 4: time 0.005 s does not follow"),
    ("time,eye,pan,tilt\n0,left,0,0\n0.01,left,x,0\n",
     r"joints.csv: line 3: pan: expected a number, got .x."),
    ("time,eye,pan,tilt\n0,left,0,0\n0.01,middle,0,0\n",
     r"joints.csv: line 3: eye must be 'left' or 'right'"),
    ("time,eye,pan\n0,left,0\n", r"joints.csv: line 1: expected the header"),
    ("time,eye,pan,tilt\n0,left,0,0\n0.01,left,0\n", r"joints.csv: line 3: expected 4 cells"),
    ("time,eye,pan,tilt\n0,left,0,0\n0.01,left,nan,0\n", r"joints.csv: line 3: pan: must be"),
    ("time,eye,pan,tilt\n0,left,0,0\n", r"joints.csv: the left eye has 1 reading"),
    ("time,eye,pan,tilt\n0,left,0,0\n0.01,left,12,0\n", r"line 3: pan = 12 rad is more"),
])
def test_joint_stream_refusals_name_file_and_line(tmp_path, text, where):
    (tmp_path / "joints.csv").write_text(text)
    with pytest.raises(InputError, match=where):
        read_joint_stream(tmp_path / "joints.csv")


def test_joint_stream_refuses_a_missing_file_and_times_outside(tmp_path):
    with pytest.raises(InputError, match=r"joints.csv: no such file \(the joint stream\)"):
        read_joint_stream(tmp_path / "joints.csv")
    s = JointStream.from_arrays({"left": ([0.0, 1.0], [0.0, 0.1], [0.0, 0.0])})
    with pytest.raises(InputError, match=r"time 1.5 s is outside the stream \[0, 1\] s"):
        s.angles("left", [0.5, 1.5])
    with pytest.raises(InputError, match="no joint readings of the right eye"):
        s.angles("right", 0.5)


# ------------------------------------------------------------------ continuous renders

from rasc.sim.render import (  # noqa: E402
    CONTINUOUS,
    RenderOptions,
    continuous_of,
    render_dataset,
    render_in_memory,
)

from running import run_rasc  # noqa: E402

#: a small continuous capture: four positions at 30 deg/s, five frames per eye, four
#: sub-frames per 10 ms exposure, the encoders 25 ms ahead of the cameras
CONT = RenderOptions(poses_deg=((0, 0), (8, 8), (-8, -8), (8, -8)), intrinsics_views=3,
                     seed=2, motion_speed_deg_s=30.0, max_frames=5, subframes=4,
                     joint_rate=250.0, clock_offset=0.025, clock_jitter=2e-4)


@pytest.fixture(scope="module")
def continuous(tmp_path_factory):
    from rasc.vision.dataset import load_dataset

    out = tmp_path_factory.mktemp("continuous") / "ds"
    render_dataset(out, CONT, quiet=True)
    return load_dataset(out)


def _trajectory_of(gt) -> Trajectory:
    rec = gt["trajectory"]
    return Trajectory(np.radians(rec["positions_deg"]), rec["speed_deg_s"], rec["dwell"])


def test_continuous_dataset_holds_times_stream_and_truth(continuous):
    ds, gt = continuous, continuous.load_ground_truth()
    delta, speed = CONT.clock_offset, CONT.motion_speed_deg_s
    assert gt["clock"]["clock_offset"] == delta
    assert {k: gt["render_options"][k] for k in continuous_of(CONT)} == continuous_of(CONT)
    assert (ds.root / "joints.csv").is_file() and ds.manifest["joint_stream"] == "joints.csv"
    traj = _trajectory_of(gt)
    poses = ds.select(role="pose")
    assert len(poses) == 2 * CONT.max_frames
    by_view = {}
    for e in poses:
        by_view.setdefault(e.view, set()).add(e.time)
        # the manifest's angles: the stream at the image's own stamp, no offset
        np.testing.assert_allclose([e.pan, e.tilt], ds.joint_stream.angles(e.eye, e.time),
                                   atol=1e-12)
        # the truth: the trajectory at mid-exposure
        v = gt["views"][e.file]
        assert v["time"] == e.time
        np.testing.assert_allclose(np.radians([v["pan"], v["tilt"]]),
                                   traj.angles(e.time, e.eye), atol=1e-12)
    assert all(len(times) == 1 for times in by_view.values())   # both eyes at once
    t = np.array([e.time for e in poses])
    truth = np.array([traj.angles(e.time, e.eye) for e in poses])
    at_delta = np.array([ds.joint_stream.angles(e.eye, e.time + delta) for e in poses])
    read = np.array([[e.pan, e.tilt] for e in poses])
    err = np.degrees(np.linalg.norm(at_delta - truth, axis=1))
    wrong = np.degrees(np.linalg.norm(read - truth, axis=1))
    # the stream at t + δ: the truth to the jitter's size (speed · 4.5 σ, the truncation)
    assert err.max() <= speed * 4.5 * CONT.clock_jitter + 1e-4, err
    # without δ the readings lag by up to speed · δ (0.75 deg): the offset matters
    assert wrong.max() > 0.3 * speed * delta, wrong
    assert len(np.unique(t)) == CONT.max_frames


def test_continuous_corners_lie_at_the_mid_exposure_truth(continuous):
    """The corners of the blurred exposures against the truth projected at mid-exposure.
    Measured (benchmarks/bench_continuous.py, 10 ms, 8 sub-frames): 0.015 px RMS at
    30 deg/s against 0.020 px for still renders; the motion is symmetric about
    mid-exposure, so the blur moves a corner little. The bound, 0.1 px, is 5x that."""
    ds, gt = continuous, continuous.load_ground_truth()
    P = ds.board.object_points()
    errs = []
    for eye in EYES:
        K = np.array(gt[eye]["K"])
        found = ds.detect(eye, "pose", method="saddle")
        assert not found.not_found
        for f, c in found.corners.items():
            T = np.array(gt["views"][f]["T_cam_from_world"])
            p = P @ T[:3, :3].T + T[:3, 3]
            uv = (p @ K.T)[:, :2] / p[:, 2:]
            errs.append(np.linalg.norm(c - uv, axis=1))
    rms = float(np.sqrt(np.mean(np.concatenate(errs) ** 2)))
    print(f"\ncontinuous 30 deg/s, 10 ms: corners {rms:.3f} px RMS from the truth")
    assert rms < 0.1


def test_rolling_shutter_rows_are_exposed_at_their_own_times():
    """With a rolling shutter (20 µs a line: 19 ms to read 960 rows) at 60 deg/s the
    corners lie where the board is at their own row's time, not at the image's stamp.
    Measured: see benchmarks/bench_continuous.py; the bound is the rows' own projection
    below a tenth of the stamp's."""
    from rasc.sim.render import continuous_grey
    from rasc.sim.scene import StereoHeadSim
    from rasc.vision.board import Board
    from rasc.vision.camera import detect_corners

    board = Board((9, 6), 0.05)
    P = board.object_points()
    opts = RenderOptions(motion_speed_deg_s=60.0, subframes=4, rolling_shutter=2e-5)
    traj = Trajectory(np.radians(((0, 0), (8, 8), (-8, 0))), 60.0)
    mid_err, own_err = [], []
    with StereoHeadSim(board=board) as sim:
        sim.set_target(sim.facing_target(1.0))
        rows = sim.image_size[1]
        for t in (0.2, 0.35, 0.7):
            image = continuous_grey(sim, "left", traj, t, opts)
            c = detect_corners(image, board, "saddle")
            assert c is not None
            sim.set_angles("left", *traj.angles(t, "left"))
            mid = sim.project_world_points("left", P)
            own = mid.copy()
            for _ in range(2):      # each corner at the time of the row it lies on
                for i, (_, v) in enumerate(own):
                    sim.set_angles("left", *traj.angles(
                        t + (v - (rows - 1) / 2) * opts.rolling_shutter, "left"))
                    own[i] = sim.project_world_points("left", P[i:i + 1])[0]
            mid_err.append(np.linalg.norm(c - mid, axis=1))
            own_err.append(np.linalg.norm(c - own, axis=1))
    mid_rms = float(np.sqrt(np.mean(np.concatenate(mid_err) ** 2)))
    own_rms = float(np.sqrt(np.mean(np.concatenate(own_err) ** 2)))
    print(f"\nrolling shutter at 60 deg/s: {mid_rms:.3f} px from the stamp's projection, "
          f"{own_rms:.3f} px from the rows' own")
    assert own_rms < 0.1 * mid_rms


def test_in_memory_continuous_render_is_the_folder_render(continuous, tmp_path):
    from rasc.vision.dataset import load_dataset, write_dataset

    memory = render_in_memory(CONT, quiet=True)
    assert memory.joint_stream is not None
    write_dataset(memory, tmp_path / "written")
    for f in ("joints.csv", "manifest.json", "ground_truth.json", "poses/left_004.png"):
        assert (tmp_path / "written" / f).read_bytes() == (continuous.root / f).read_bytes(), f
    back = load_dataset(tmp_path / "written")
    np.testing.assert_array_equal(back.joint_stream["right"].tilt,
                                  continuous.joint_stream["right"].tilt)


# --------------------------------------------------------------------- stop-and-go

def test_stop_and_go_keys_and_truth_are_those_of_before():
    """At speed 0 (the default) no continuous field enters the cache key or the ground
    truth: the renders of before (checked byte for byte against the checkout before the
    fields existed when they were added); any continuous field makes another key."""
    from dataclasses import asdict

    from rasc.datasets.render import render_key, render_what

    options = RenderOptions(seed=3, intrinsics_views=5)
    assert continuous_of(options) == {}
    before = {k: v for k, v in asdict(options).items() if k not in CONTINUOUS}
    assert render_what(options) == render_what(before)
    assert not set(CONTINUOUS) & set(render_what(options)["options"])
    moving = RenderOptions(seed=3, intrinsics_views=5, motion_speed_deg_s=20.0)
    assert render_what(moving)["options"]["motion_speed_deg_s"] == 20.0
    assert render_key(moving) != render_key(options)
    assert render_key(RenderOptions(seed=3, intrinsics_views=5, motion_speed_deg_s=20.0,
                                    clock_offset=0.01)) != render_key(moving)


def test_rasc_render_flags_default_to_the_options_defaults():
    import argparse

    from rasc.commands import render as cmd

    sub = argparse.ArgumentParser().add_subparsers()
    args = cmd.add_parser(sub).parse_args([])
    flag_of = {v: k for k, v in cmd.FLAGS.items()}
    defaults = RenderOptions()
    for field in CONTINUOUS:
        flag = cmd.FLAGS[field]
        assert flag_of[flag] == field
        assert getattr(args, flag[2:].replace("-", "_")) == getattr(defaults, field), field


@pytest.mark.parametrize("fields, message", [
    ({"exposure": 0.02}, r"^exposure is for continuous motion: give motion_speed_deg_s > 0"),
    ({"motion_speed_deg_s": -1.0}, r"^motion_speed_deg_s must be a number from 0 to 500"),
    ({"motion_speed_deg_s": 30.0, "exposure": 0.05},
     r"^exposure 0.05 s is longer than a frame at frame_rate 30"),
    ({"motion_speed_deg_s": 30.0, "exposure": 0.0}, r"^exposure must be positive"),
    ({"motion_speed_deg_s": 30.0, "subframes": 0}, r"^subframes must be an integer from 1"),
    ({"motion_speed_deg_s": 30.0, "max_frames": 2}, r"^max_frames must be an integer from 3"),
    ({"motion_speed_deg_s": 30.0, "clock_jitter": 0.01},
     r"^clock_jitter 0.01 s is more than 0.2 of the joint stream's period"),
    ({"motion_speed_deg_s": 30.0, "clock_offset": float("nan")}, r"^clock_offset: must be"),
])
def test_bad_continuous_option_is_one_line_naming_the_field(fields, message):
    with pytest.raises(InputError, match=message) as info:
        RenderOptions(**fields).validate()
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("args, line", [
    (["--exposure", "0.02"], "--exposure is for continuous motion: give --motion-speed > 0 "
                             "too (0 is stop-and-go)"),
    (["--motion-speed", "30", "--frame-rate", "60", "--exposure", "0.02"],
     "--exposure 0.02 s is longer than a frame at --frame-rate 60 (0.01667 s)"),
    (["--motion-speed", "30", "--rolling-shutter", "0.0001"],
     "--rolling-shutter 0.0001 s: reading 960 rows takes 0.0959 s, longer than a frame at "
     "--frame-rate 30"),
    (["--motion-speed", "500", "--poses", "0,0;0.5,0;0,0.5"],
     # 1.875 · (0.5 + 0.5·√2) deg / 500 deg/s = 0.00453 s, shorter than one exposure
     f"--motion-speed 500: the motion lasts {1.875 * (0.5 + 0.5 * 2 ** 0.5) / 500:.3g} s, 0 "
     "frame(s) at --frame-rate 30; hand-eye needs at least 3: move slower or film faster"),
])
def test_rasc_render_refuses_bad_motion_writing_nothing(tmp_path, capsys, args, line):
    out = tmp_path / "ds"
    status, stdout, err = run_rasc(["render", "--out", out, *args, "--quiet"], capsys)
    assert status == 2 and stdout == ""
    assert err.strip().splitlines() == [f"rasc render: error: {line}"]
    assert not out.exists() and list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------- the dataset's doors

def _manifest(**extra_image):
    return {"format": "rasc-dataset/1", "board": {"inner_corners": [9, 6], "square_size": 0.05},
            "angle_unit": "deg",
            "images": [{"file": "a.png", "eye": "left", "role": "pose", "pan": 0, "tilt": 0,
                        "view": "0", **extra_image}]}


def test_a_manifest_of_before_reads_as_before():
    from rasc.vision.dataset import parse_manifest

    ds = parse_manifest(_manifest(), ".", check_files=False)
    assert ds.images[0].time is None and ds.joint_stream is None
    timed = parse_manifest(_manifest(time=1.25), ".", check_files=False)
    assert timed.images[0].time == 1.25


def test_dataset_refuses_a_bad_time_or_joint_stream(tmp_path):
    import json

    from rasc.vision.dataset import load_dataset, parse_manifest

    with pytest.raises(InputError, match=r"images\[0\] \(a.png\): field 'time': expected a "
                                         "number"):
        parse_manifest(_manifest(time="noon"), ".", check_files=False)
    (tmp_path / "a.png").write_bytes(b"")
    doc = {**_manifest(), "joint_stream": "joints.csv"}
    (tmp_path / "manifest.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match=r"manifest.json: field 'joint_stream': file does "
                                         r"not exist \(.*joints.csv\)$"):
        load_dataset(tmp_path)
    (tmp_path / "joints.csv").write_text("time,eye,pan,tilt\n0,left,0,0\n1e-3,left,0,zero\n")
    with pytest.raises(InputError, match=r"joints.csv: line 3: tilt: expected a number"):
        load_dataset(tmp_path)
