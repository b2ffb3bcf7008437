"""Still moments of joint readings, and the image nearest each (pure functions).

A *still moment* of one reading series is a maximal run of samples whose spread
(max − min) stays within ``threshold`` and that lasts at least ``min_duration``
(first to last sample). Runs are found greedily from the earliest sample: a run grows
while the spread allows, and the next run starts after it. The still moments of a head
are the intersections of its series' moments (every joint steady at once) that still last
``min_duration``. Times are integer nanoseconds throughout (no float round-off in stamps).
"""

from __future__ import annotations

import numpy as np


def still_runs(t_ns: np.ndarray, values: np.ndarray, threshold: float,
               min_duration_ns: int) -> list[tuple[int, int]]:
    """Still moments of one series as (first, last) sample times, ns. ``t_ns`` ascending."""
    t_ns = np.asarray(t_ns, dtype=np.int64)
    v = np.asarray(values, dtype=float)
    out: list[tuple[int, int]] = []
    n = len(v)
    i = 0
    while i < n:
        lo = hi = v[i]
        j = i
        while j + 1 < n:
            x = v[j + 1]
            lo2, hi2 = min(lo, x), max(hi, x)
            if hi2 - lo2 > threshold:
                break
            lo, hi, j = lo2, hi2, j + 1
        if t_ns[j] - t_ns[i] >= min_duration_ns:
            out.append((int(t_ns[i]), int(t_ns[j])))
            i = j + 1
        else:
            i += 1
    return out


def longest_run_ns(t_ns: np.ndarray, values: np.ndarray, threshold: float) -> int:
    """The longest still run of a series (ns), whatever its length: for messages."""
    runs = still_runs(t_ns, values, threshold, 0)
    return max((b - a for a, b in runs), default=0)


def intersect(a: list[tuple[int, int]], b: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """The overlaps of two sorted lists of disjoint closed intervals."""
    out, i, j = [], 0, 0
    while i < len(a) and j < len(b):
        lo, hi = max(a[i][0], b[j][0]), min(a[i][1], b[j][1])
        if lo <= hi:
            out.append((lo, hi))
        if a[i][1] < b[j][1]:
            i += 1
        else:
            j += 1
    return out


def common_still(series: list[tuple[np.ndarray, np.ndarray]], threshold: float,
                 min_duration_ns: int) -> list[tuple[int, int]]:
    """Moments when every series of ``series`` ((t_ns, values) pairs) is still, each at
    least ``min_duration_ns`` long."""
    moments: list[tuple[int, int]] | None = None
    for t, v in series:
        runs = still_runs(t, v, threshold, min_duration_ns)
        moments = runs if moments is None else intersect(moments, runs)
    return [(a, b) for a, b in (moments or []) if b - a >= min_duration_ns]


def nearest(stamps: np.ndarray, t_ns: int, lo: int, hi: int, tolerance_ns: int) -> int | None:
    """Index of the stamp nearest ``t_ns`` among those inside [lo, hi] and within
    ``tolerance_ns`` of ``t_ns``; None if there is none. ``stamps`` ascending."""
    stamps = np.asarray(stamps, dtype=np.int64)
    a = int(np.searchsorted(stamps, max(lo, t_ns - tolerance_ns), side="left"))
    b = int(np.searchsorted(stamps, min(hi, t_ns + tolerance_ns), side="right"))
    if a >= b:
        return None
    k = a + int(np.argmin(np.abs(stamps[a:b] - t_ns)))
    return k
