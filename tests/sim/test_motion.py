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


@pytest.mark.parametrize("line", [0.0, 7e-5])
def test_each_row_averages_its_own_exposure(line):
    """A 'render' that is the time itself: each row of the exposure is the mean time of
    its sub-frames, which is the row's own mid-exposure time up to half a sub-frame."""
    rows, exposure, S = 200, 0.01, 5
    times, first = exposure_plan(3.0, exposure, S, line, rows)
    image = expose(lambda t: np.full((rows, 3), t), times, first, S)
    want = 3.0 + (np.arange(rows) - (rows - 1) / 2) * line
    assert np.abs(image[:, 0] - want).max() <= 0.5 * exposure / S + 1e-12
    if line == 0:
        np.testing.assert_allclose(image[:, 0], 3.0)
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
