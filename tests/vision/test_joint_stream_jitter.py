"""The joint stream's interpolant under timestamp jitter (rasc.vision.joint_stream,
"Timestamp jitter"; issue 33): the regular stamps t0 + k·T of a constant-rate driver
against the true sampling instants, the readings at the frame times against the
trajectory's truth, the stamps as given kept where they are the smooth ones (no jitter,
accurate stamps of an irregular sampling, a variable rate), and the timing noise the
stream reports against the jitter drawn."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from rasc.geometry.kinematics import PAPER_POSES_DEG
from rasc.sim.motion import STREAM_MARGIN_S, Trajectory, frame_times, sample_joint_stream
from rasc.vision.joint_stream import EyeStream, regular_stamps

DELTA = 0.03


def _capture(speed: float, rate: float, jitter: float, seed: int = 0):
    traj = Trajectory(np.radians(np.asarray(PAPER_POSES_DEG, float)), speed)
    stream = sample_joint_stream(traj, rate, DELTA, jitter, np.random.default_rng([seed, 1]))
    times = frame_times(traj.duration, 10.0, 0.0)
    return traj, stream["left"], times


def _rms_deg(a, b) -> float:
    return float(np.degrees(np.sqrt(np.mean(np.sum((a - b) ** 2, axis=-1)))))


@pytest.mark.parametrize("speed,rate,jitter", [(20, 100, 5e-4), (20, 200, 5e-4),
                                               (60, 200, 1e-3), (20, 1000, 1e-4)])
def test_jittered_stamps_are_made_regular(speed, rate, jitter):
    """Stamps jittered by σ (up to 0.2 of the period, the bench's bound): the stream
    uses the regular stamps, which lie on the true instants (sample time + δ) within a
    few σ/√n (their mean jitter, which ``offset_std_s`` states); its angles at the frame
    times are 10x closer to the truth than the spline through the stamps as given
    (measured 21-129x)."""
    traj, es, times = _capture(speed, rate, jitter)
    assert es.regularised
    pad = STREAM_MARGIN_S + DELTA
    true_stamps = -pad + np.arange(len(es.time)) / rate + DELTA
    n = len(es.time)
    assert 0.5 * jitter / np.sqrt(n) < es.offset_std_s < 2 * jitter / np.sqrt(n)
    assert np.abs(es.stamps - true_stamps).max() < 6 * es.offset_std_s
    truth = traj.angles(times, "left")
    as_given = CubicSpline(es.time, np.column_stack([es.pan, es.tilt]), axis=0)
    before = _rms_deg(as_given(times + DELTA), truth)
    after = _rms_deg(es.angles(times + DELTA), truth)
    assert after < 0.1 * before, (after, before)
    # what is left is timing noise below a hundredth of the jitter
    assert es.timing_noise_s < 0.01 * jitter


def test_exact_stamps_are_kept_bit_for_bit():
    """No jitter: the stamps as given, the interpolant the not-a-knot spline through
    them, number for number, and nothing added to δ's σ."""
    _, es, times = _capture(20, 200, 0.0)
    assert not es.regularised and es.stamps is es.time
    spline = CubicSpline(es.time, np.column_stack([es.pan, es.tilt]), axis=0)
    assert np.array_equal(es.angles(times + DELTA), spline(times + DELTA))
    assert np.array_equal(es.rates(times + DELTA), spline(times + DELTA, 1))
    assert es.offset_std_s == 0.0 and es.timing_noise_s < 1e-8


def test_accurate_stamps_of_an_irregular_sampling_are_kept():
    """A driver whose sampling instants jitter but whose stamps are those instants: the
    readings are smooth at the stamps as given, rough at regular ones; kept as given,
    exact at the frame times."""
    traj = Trajectory(np.radians(np.asarray(PAPER_POSES_DEG, float)), 20)
    rng = np.random.default_rng(3)
    t = -0.3 + np.arange(int((traj.duration + 0.6) * 200)) / 200
    t = t + np.clip(rng.normal(0, 5e-4, len(t)), -2e-3, 2e-3)
    a = traj.angles(t, "left")
    es = EyeStream(t, a[:, 0], a[:, 1])
    assert regular_stamps(t) is not None and not es.regularised
    times = frame_times(traj.duration, 10.0, 0.0)
    assert _rms_deg(es.angles(times), traj.angles(times, "left")) < 1e-6


def test_variable_rate_and_gaps():
    """A stream with a tenth of its samples missing and 0.5 ms jitter: still a constant
    rate, regularised (a missing sample skips one number); a stream at a variable rate
    has no regular stamps."""
    traj, es, _ = _capture(20, 200, 5e-4, seed=5)
    keep = np.random.default_rng(6).random(len(es.time)) > 0.1
    holed = EyeStream(es.time[keep], es.pan[keep], es.tilt[keep])
    assert holed.regularised
    assert np.abs(holed.stamps - es.stamps[keep]).max() < 1e-4
    t = np.cumsum(np.random.default_rng(7).uniform(0.002, 0.008, 1000))
    assert regular_stamps(t) is None
    a = traj.angles(t, "left")
    assert not EyeStream(t, a[:, 0], a[:, 1]).regularised


def test_stamps_jittering_by_a_period_are_numbered():
    """Jitter of σ half a period and more (1 kHz, 0.5 and 1 ms, truncated at 0.45 of
    the period so that the stamps stay in order): no sample's number is certain, the
    line through the samples' places gives the regular stamps, on the true instants
    within a few σ/√n, and the angles 10x closer to the truth (measured 109x and 195x)."""
    for jitter in (5e-4, 1e-3):
        traj, es, times = _capture(60, 1000, jitter)
        assert es.regularised
        pad = STREAM_MARGIN_S + DELTA
        true_stamps = -pad + np.arange(len(es.time)) / 1000 + DELTA
        assert np.abs(es.stamps - true_stamps).max() < 6 * es.offset_std_s
        truth = traj.angles(times, "left")
        as_given = CubicSpline(es.time, np.column_stack([es.pan, es.tilt]), axis=0)
        assert (_rms_deg(es.angles(times + DELTA), truth)
                < 0.1 * _rms_deg(as_given(times + DELTA), truth))


def test_timing_noise_of_stamps_kept_as_given():
    """A stream at a variable rate (2-8 ms between samples) whose stamps jitter by
    0.3 ms: no regular stamps fit it, the stamps stay as given, and the stream reports
    their timing noise within 0.7-1.5x of the RMS of the jitter drawn (measured 1.06x),
    which δ's σ then counts."""
    traj = Trajectory(np.radians(np.asarray(PAPER_POSES_DEG, float)), 20)
    rng = np.random.default_rng(11)
    true_t = -0.3 + np.cumsum(rng.uniform(0.002, 0.008, int((traj.duration + 0.6) / 0.005)))
    drawn = rng.normal(0.0, 3e-4, len(true_t))
    a = traj.angles(true_t, "left")
    es = EyeStream(true_t + drawn, a[:, 0], a[:, 1])
    rms = float(np.sqrt(np.mean(drawn ** 2)))
    assert not es.regularised and es.offset_std_s == 0.0
    assert 0.7 * rms < es.timing_noise_s < 1.5 * rms, (es.timing_noise_s, rms)
