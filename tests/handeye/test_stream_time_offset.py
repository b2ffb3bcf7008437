"""Hand-eye from two timestamped pose streams: the clocks' offset δ and its σ
(rasc.handeye.time_offset), the streams in the rasc-handeye/1 document, and the
``rasc handeye`` door.

The streams (rasc.handeye.pose_streams.make_pose_streams): a pan-tilt unit moving along
sums of sines, its poses at 200 Hz, the camera's at 30 Hz with 0.002 rad / 1 mm of
eq. 13–14 noise, 0.2 ms of stamp jitter, seeded. Tolerances:

- δ within 1 ms of the truth: the issue's target. At this noise σ(δ) is about 0.1 ms
  (benchmarks/bench_handeye_time_offset.py, 20 seeds: median 0.09 ms, largest error
  0.15 ms), so 1 ms holds with a wide margin and fails for a wrong sign or a δ off by a
  sampling interval (5 ms of the unit, 33 ms of the camera).
- σ against the error over seeds: the RMS of z = (δ̂ − δ)/σ within [0.4, 2.5] (σ right to
  within a factor of 2.5 either way; the RMS of 12 draws of a standard normal lies in
  [0.6, 1.4] 95 % of the time, so the band leaves room for the model's small misfit —
  the stamps' jitter is not in it), and no |z| above 5.
"""

from __future__ import annotations

import copy
import json
import math
import re

import numpy as np
import pytest

from rasc.errors import DegenerateDataError, InputError
from rasc.geometry.transforms import rotation_error_deg
from rasc.handeye.document import parse_handeye_document
from rasc.handeye.methods import solve
from rasc.handeye.pose_streams import make_pose_streams
from rasc.handeye.robust_refine import refine_handeye
from rasc.handeye.time_offset import (
    DEFAULT_MAX_OFFSET,
    TimeOffsetOptions,
    nearest_pairs,
    parse_time_offset,
    solve_streams,
)

#: The issue's target for δ (module docstring).
OFFSET_TOL_S = 1e-3

#: Streams short enough to keep the tests quick (12 s of motion, 345 camera poses).
DURATION = 12.0


def _offset(seed: int) -> float:
    return float(np.random.default_rng(500 + seed).uniform(-0.05, 0.05))


def _streams(seed: int, **kw):
    kw.setdefault("time_offset", _offset(seed))
    kw.setdefault("duration", DURATION)
    return make_pose_streams(seed, **kw)


def _solve(s, options=None):
    return solve_streams(s.times, s.T_cam_from_world, s.unit_times, s.T_gaze_from_ptu,
                         options)


def _errors(X, truth):
    return (float(rotation_error_deg(X[:3, :3], truth[:3, :3])),
            float(np.linalg.norm(X[:3, 3] - truth[:3, 3])))


# ------------------------------------------------------------------------ the estimate

@pytest.fixture(scope="module")
def over_seeds():
    """12 seeds: (true δ, estimate, δ held at the truth, streams)."""
    out = []
    for seed in range(12):
        s = _streams(seed)
        out.append((s.time_offset, _solve(s),
                    _solve(s, TimeOffsetOptions(time_offset=s.time_offset)), s))
    return out


def test_offset_recovered_within_1_ms(over_seeds):
    for delta, est, _, _ in over_seeds:
        assert est.time_offset_mode == "estimate"
        assert abs(est.time_offset - delta) < OFFSET_TOL_S, (delta, est.time_offset)


def test_sigma_covers_the_error_over_seeds(over_seeds):
    z = np.array([(est.time_offset - delta) / est.std_time_offset
                  for delta, est, _, _ in over_seeds])
    assert np.all(np.isfinite(z))
    rms = float(np.sqrt(np.mean(z ** 2)))
    assert 0.4 <= rms <= 2.5, (rms, z)
    assert np.abs(z).max() < 5, z


def test_handeye_with_estimated_offset_is_that_of_the_true_offset(over_seeds):
    """The estimated δ costs nothing measurable: the hand-eye with it is within a
    fifth of its own std of the hand-eye with δ held at the truth, and both are as far
    from the truth as their std says (within 4 std)."""
    for _, est, held, s in over_seeds:
        rot, trans = _errors(est.T_cam_from_gaze, held.T_cam_from_gaze)
        assert rot < 0.2 * est.std_rotation_deg and trans < 0.2 * est.std_translation
        rot, trans = _errors(est.T_cam_from_gaze, s.T_cam_from_gaze)
        assert rot < 4 * est.std_rotation_deg and trans < 4 * est.std_translation


def test_naive_pairing_is_worse_than_the_estimate(over_seeds):
    """The offset matters: a refined solution on nearest-stamp pairs (δ taken as 0) has
    over twice the rotation error of the estimate, averaged over the seeds (the
    benchmark measured 5.8× over 20 seeds with offsets in ±50 ms)."""
    ours, naive = [], []
    for _, est, _, s in over_seeds[:6]:
        G = nearest_pairs(s.times, s.unit_times, s.T_gaze_from_ptu)
        ref = refine_handeye(s.T_cam_from_world, G, solve("rasc", s.T_cam_from_world, G))
        ours.append(_errors(est.T_cam_from_gaze, s.T_cam_from_gaze)[0])
        naive.append(_errors(ref.T_cam_from_gaze, s.T_cam_from_gaze)[0])
    assert np.mean(naive) > 2 * np.mean(ours), (naive, ours)


def test_sign_convention_and_clock_origin():
    """δ is the unit's clock minus the camera's; a clock that starts at Unix time gives
    the same δ."""
    s = _streams(3, time_offset=-0.04, start=1.7e9)
    r = _solve(s)
    assert abs(r.time_offset - (-0.04)) < OFFSET_TOL_S


def test_held_offset_has_no_sigma_and_hold_means_zero():
    s = _streams(1, time_offset=0.0)
    r = _solve(s, TimeOffsetOptions(time_offset="hold"))
    assert r.time_offset_mode == "hold" and r.time_offset == 0.0
    assert math.isnan(r.std_time_offset)
    assert r.to_dict()["time_offset"]["std"] is None


# ------------------------------------------------------------------------ refusals

@pytest.mark.parametrize("kw, max_offset, words", [
    ({"motion": "still"}, DEFAULT_MAX_OFFSET, "no motion"),
    ({"motion": "circle", "amplitude_deg": (20.0, 20.0)}, DEFAULT_MAX_OFFSET,
     "rotation speed is nearly constant"),
    ({"motion": "periodic"}, 2.5, "two time offsets match"),
    ({"camera_span": (11.8, 16.0)}, DEFAULT_MAX_OFFSET, "the streams overlap for at most"),
    ({"camera_span": (30.0, 40.0)}, DEFAULT_MAX_OFFSET, "the streams overlap for at most"),
    ({"camera_span": (19.8, 25.0), "duration": 20.0}, 2.5,
     r"the streams overlap for at most 2\.\d+ s"),
], ids=["no-motion", "constant-speed", "periodic", "short-overlap", "no-overlap",
        "overlap-only-at-a-wrong-offset"])
def test_degenerate_streams_are_refused(kw, max_offset, words):
    s = _streams(2, **kw)
    with pytest.raises(DegenerateDataError, match=words) as info:
        _solve(s, TimeOffsetOptions(max_offset=max_offset))
    assert "\n" not in str(info.value)


def test_periodic_motion_within_a_narrow_range_is_timed():
    """The same periodic motion, searched within ±0.5 s (under half its 1 s speed
    period), is not ambiguous."""
    s = _streams(2, motion="periodic")
    assert abs(_solve(s).time_offset - s.time_offset) < OFFSET_TOL_S


def test_offset_beyond_the_range_is_refused_then_found_in_a_wider_one():
    s = _streams(2, time_offset=0.45)
    with pytest.raises(DegenerateDataError, match=r"the best time offset, \+0\.3000 s, is at "
                                                  "the edge of the range searched"):
        _solve(s, TimeOffsetOptions(max_offset=0.3))
    assert abs(_solve(s).time_offset - 0.45) < OFFSET_TOL_S


def test_held_offset_outside_the_unit_stream_is_refused():
    s = _streams(2)
    with pytest.raises(DegenerateDataError, match="camera poses lie inside the unit stream"):
        _solve(s, TimeOffsetOptions(time_offset=50.0))


@pytest.mark.parametrize("value, words", [
    ("soon", "expected 'estimate', 'hold' or a number"),
    ("nan", "finite"),
    (True, "time_offset"),
])
def test_bad_time_offset_values(value, words):
    with pytest.raises(InputError, match=words):
        parse_time_offset(value)


def test_bad_max_offset():
    with pytest.raises(InputError, match="positive"):
        TimeOffsetOptions(max_offset=0.0)


# ------------------------------------------------------------------------ the document

@pytest.fixture(scope="module")
def stream_doc():
    return _streams(4, duration=8.0).to_document()


def test_document_reads_both_streams(stream_doc):
    data = parse_handeye_document(stream_doc)
    assert data.is_stream and data.from_angles
    assert data.n_positions == len(stream_doc["positions"])
    assert data.unit_stream.shape == (len(stream_doc["unit_stream"]), 4, 4)
    assert np.array_equal(data.times, [p["time"] for p in stream_doc["positions"]])


@pytest.mark.parametrize("edit, words", [
    (lambda d: d["positions"][5].update(time=d["positions"][4]["time"]),
     r"positions\[5\]\.time = .* is not after positions\[4\]\.time"),
    (lambda d: d["unit_stream"][9].update(time=d["unit_stream"][3]["time"]),
     r"unit_stream\[9\]\.time = .* is not after unit_stream\[8\]\.time"),
    (lambda d: d["positions"][2].pop("time"), r"positions\[2\]: missing 'time'"),
    (lambda d: d["unit_stream"][2].pop("time"), r"unit_stream\[2\]: missing 'time'"),
    (lambda d: d["positions"][1].update(time="0.5"), r"positions\[1\]\.time"),
    (lambda d: d["positions"][0].update(pan=1.0, tilt=2.0),
     r"positions\[0\]: has pan but the document has a unit_stream"),
    (lambda d: d.update(unit_stream=d["unit_stream"][:3]), "at least 4"),
    (lambda d: d["unit_stream"][0].update(speed=1), r"unit_stream\[0\]: unknown key 'speed'"),
], ids=["position-time-repeats", "unit-time-back", "position-no-time", "unit-no-time",
        "time-string", "motion-in-position", "short-unit-stream", "unknown-key"])
def test_bad_stream_documents(stream_doc, edit, words):
    doc = copy.deepcopy(stream_doc)
    edit(doc)
    with pytest.raises(InputError, match=words):
        parse_handeye_document(doc)


def test_time_without_a_unit_stream_is_refused(stream_doc):
    from rasc.handeye.corruption import pan_tilt_poses

    T_cw, T_gp, _ = pan_tilt_poses(5, np.random.default_rng(0))
    doc = {"positions": [{"time": 0.1 * k, "T_gaze_from_ptu": G.tolist(),
                          "T_cam_from_world": T.tolist()}
                         for k, (G, T) in enumerate(zip(T_gp, T_cw, strict=True))]}
    with pytest.raises(InputError, match=r"positions\[0\]\.time: a time is only read with "
                                         "a unit_stream"):
        parse_handeye_document(doc)


# ------------------------------------------------------------------------ the command

LINE = re.compile(r"^rasc handeye: time offset ([+-]\d+\.\d+) ms ± (\d+\.\d+) ms ")


@pytest.fixture(scope="module")
def streams_file(tmp_path_factory):
    s = _streams(5, duration=8.0)
    path = tmp_path_factory.mktemp("streams") / "streams.json"
    path.write_text(json.dumps(s.to_document()), encoding="utf-8")
    return s, path


def test_cli_estimates_and_prints_offset_with_sigma(rasc_cli, streams_file, tmp_path):
    s, path = streams_file
    out = tmp_path / "result.json"
    status, stdout, stderr = rasc_cli("handeye", path, "--out", out)
    assert status == 0, stderr
    assert stdout == ""
    line = stderr.splitlines()[0]
    m = LINE.match(line)
    assert m, stderr
    doc = json.loads(out.read_text(encoding="utf-8"))
    block = doc["time_offset"]
    assert block["mode"] == "estimate"
    assert abs(block["seconds"] - s.time_offset) < OFFSET_TOL_S
    assert float(m.group(1)) == pytest.approx(1e3 * block["seconds"], abs=1e-3)
    assert float(m.group(2)) == pytest.approx(1e3 * block["std"], abs=1e-3)
    assert doc["uncertainty"]["rotation_deg"] > 0
    assert _errors(np.array(doc["T_cam_from_gaze"]), s.T_cam_from_gaze)[1] < 0.01


def test_cli_holds_offset(rasc_cli, streams_file, tmp_path):
    s, path = streams_file
    out = tmp_path / "held.json"
    status, _, stderr = rasc_cli("handeye", path, "--time-offset", str(s.time_offset),
                                 "--out", out)
    assert status == 0, stderr
    assert "time offset held at" in stderr.splitlines()[0]
    block = json.loads(out.read_text(encoding="utf-8"))["time_offset"]
    assert block["mode"] == "hold" and block["std"] is None
    assert block["seconds"] == s.time_offset


def _refused(rasc_cli, tmp_path, argv, words):
    out = tmp_path / "result.json"
    status, stdout, stderr = rasc_cli("handeye", *argv, "--out", out)
    assert status == 2, stderr
    assert stdout == ""
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rasc handeye: error: "), stderr
    assert re.search(words, lines[0]), lines[0]
    assert not out.exists()


def test_cli_bad_timestamps_one_line_exit_2_no_file(rasc_cli, streams_file, tmp_path):
    s, _ = streams_file
    doc = s.to_document()
    doc["positions"][7]["time"] = doc["positions"][3]["time"]
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(doc), encoding="utf-8")
    _refused(rasc_cli, tmp_path, [bad],
             rf"{re.escape(str(bad))}: positions\[7\]\.time = .* is not after "
             r"positions\[6\]\.time")


def test_cli_degenerate_streams_one_line_exit_2_no_file(rasc_cli, tmp_path):
    s = _streams(6, duration=8.0, motion="still")
    path = tmp_path / "still.json"
    path.write_text(json.dumps(s.to_document()), encoding="utf-8")
    _refused(rasc_cli, tmp_path, [path], "no motion")


@pytest.mark.parametrize("flags, words", [
    (["--time-offset", "soon"], "--time-offset = 'soon': expected 'estimate', 'hold'"),
    (["--max-time-offset", "-1"], "--max-time-offset = -1: expected a positive"),
    (["--method", "li", "--home", "0"], "--home 0: .* has a unit_stream"),
])
def test_cli_bad_flags_with_streams(rasc_cli, streams_file, tmp_path, flags, words):
    _, path = streams_file
    _refused(rasc_cli, tmp_path, [path, *flags], words)


def test_cli_time_offset_needs_streams(rasc_cli, tmp_path):
    from rasc.handeye.corruption import pan_tilt_poses

    T_cw, T_gp, _ = pan_tilt_poses(6, np.random.default_rng(1))
    path = tmp_path / "poses.json"
    path.write_text(json.dumps({"positions": [
        {"T_gaze_from_ptu": G.tolist(), "T_cam_from_world": T.tolist()}
        for G, T in zip(T_gp, T_cw, strict=True)]}), encoding="utf-8")
    _refused(rasc_cli, tmp_path, [path, "--time-offset", "estimate"],
             "--time-offset: .* has no unit_stream")


def test_command_default_matches_library():
    from rasc.commands import handeye

    assert handeye.DEFAULT_MAX_OFFSET == DEFAULT_MAX_OFFSET


def test_poorly_determined_offset_is_warned(monkeypatch):
    """The note's rule, checked by lowering its threshold below the σ of a good stream
    (its σ, about 0.1 ms, is 0.003 of the 33 ms camera interval)."""
    import rasc.handeye.time_offset as module

    s = _streams(8)
    assert not any("poorly determined" in n for n in _solve(s).notes)
    monkeypatch.setattr(module, "POOR_STD_FRACTION", 1e-4)
    notes = [n for n in _solve(s).notes if "poorly determined" in n]
    assert len(notes) == 1 and "ms, is over 0.0001 of the camera's interval" in notes[0]
