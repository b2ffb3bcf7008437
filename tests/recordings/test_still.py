"""Still moments and nearest images (rasc.recordings.still): constructed series whose
still moments are known by construction."""

import numpy as np

from rasc.recordings.still import common_still, intersect, nearest, still_runs

MS = 1_000_000


def _series(segments, rate_hz=100, seed=0, jitter=0.0):
    """Piecewise series: (duration_s, start_value, end_value) segments at rate_hz."""
    rng = np.random.default_rng(seed)
    t, v, now = [], [], 0
    dt = int(1e9 / rate_hz)
    for dur, a, b in segments:
        n = int(round(dur * rate_hz))
        for k in range(n):
            t.append(now + k * dt)
            v.append(a + (b - a) * k / n + jitter * rng.standard_normal())
        now += n * dt
    return np.array(t, np.int64), np.array(v)


def test_still_runs_find_the_rests_and_only_them():
    # rest 1 s at 0, move 0.5 s to 1, rest 1 s, move 0.3 s to 2, rest 0.3 s (too short)
    t, v = _series([(1.0, 0, 0), (0.5, 0, 1), (1.0, 1, 1), (0.3, 1, 2), (0.3, 2, 2)])
    runs = still_runs(t, v, threshold=1e-3, min_duration_ns=500 * MS)
    assert len(runs) == 2
    # a move's first sample still reads the rest's value: the first rest is 0..1.0 s;
    # the second runs from the move's end (1.5 s) to the next move's first sample (2.5 s)
    assert runs == [(0, 1000 * MS), (1500 * MS, 2500 * MS)]


def test_still_runs_tolerate_reading_noise_within_the_threshold():
    # encoder noise of 0.01 (uniform spread ±0.03 at most for 3 sigma) within 0.1: one run
    t, v = _series([(2.0, 5.0, 5.0)], jitter=0.01, seed=3)
    assert still_runs(t, v, threshold=0.1, min_duration_ns=500 * MS) == [(0, int(t[-1]))]
    # the same noise against a threshold below it breaks the rest into short pieces
    assert still_runs(t, v, threshold=0.001, min_duration_ns=500 * MS) == []


def test_common_still_needs_every_joint_at_rest():
    a = _series([(1.0, 0, 0), (1.0, 0, 1), (1.0, 1, 1)])
    b = _series([(1.5, 0, 0), (0.5, 0, 1), (1.0, 1, 1)])   # moves later, for less long
    m = common_still([a, b], 1e-3, 500 * MS)
    assert m == [(0, 1000 * MS), (2000 * MS, 2990 * MS)]
    # the minimum duration applies to the overlap: 0.995 s drops the 0.99 s one
    assert common_still([a, b], 1e-3, 995 * MS) == [(0, 1000 * MS)]


def test_intersect():
    assert intersect([(0, 10), (20, 30)], [(5, 25)]) == [(5, 10), (20, 25)]
    assert intersect([(0, 1)], [(2, 3)]) == []


def test_nearest_respects_interval_and_tolerance():
    stamps = np.array([0, 100, 200, 300, 400], np.int64)
    assert nearest(stamps, 210, 0, 400, 1000) == 2
    assert nearest(stamps, 210, 250, 400, 1000) == 3          # inside the moment only
    assert nearest(stamps, 250, 0, 400, 10) is None            # none within 10 of 250
    assert nearest(stamps, 150, 120, 180, 1000) is None        # none inside [120, 180]
