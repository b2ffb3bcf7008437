"""All hand-eye methods by name (docs/CONTRACTS.md): ``METHODS`` and :func:`solve`.

Each entry is ``callable(T_cam_from_world, T_gaze_from_ptu, **options) -> HandEyeResult``
returning ``T_cam_from_gaze``; options are the solver's keywords (``check_rigid`` for all,
``pairs`` for "rasc", ``home`` for "li"). The OpenCV entries import cv2 only when called.
``rasc.handeye.METHODS`` is this same dict.
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np

from rasc.errors import InputError
from rasc.handeye import HandEyeResult, solve_rasc
from rasc.li import solve_li
from rasc.opencv_handeye import CV_METHODS, solve_opencv

METHODS: dict[str, Callable[..., HandEyeResult]] = {
    "rasc": solve_rasc,
    "li": solve_li,
    **{f"opencv-{m}": functools.partial(solve_opencv, method=m) for m in CV_METHODS},
}


def solve(method: str, T_cam_from_world: np.ndarray, T_gaze_from_ptu: np.ndarray,
          **options) -> HandEyeResult:
    """Run the hand-eye method ``method`` (a key of ``METHODS``)."""
    try:
        fn = METHODS[method]
    except KeyError:
        raise InputError(f"method: expected one of {sorted(METHODS)}, got {method!r}") from None
    return fn(T_cam_from_world, T_gaze_from_ptu, **options)
