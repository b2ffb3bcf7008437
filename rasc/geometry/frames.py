"""The frames of the stereo head, declared once (docs/METHOD.md §1). The README repeats this table.

``T_a_from_b`` maps coordinates in frame b into frame a (``q_a = T_a_from_b q_b``);
the paper writes it ``T_ab``. A point in base coordinates reaches camera coordinates
through eq. 1–2::

    T_cam_from_base = T_cam_from_gaze @ T_gaze_from_ptu(pan, tilt) @ T_ptu_from_base

``T_cam_from_gaze`` (the paper's ``T_cg``, hand-eye) and ``T_ptu_from_base`` (``T_pb``)
are constant per eye; ``T_gaze_from_ptu`` (``T_gp``) is the pan-tilt motion, eq. 3.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Frame:
    name: str
    symbol: str
    meaning: str


FRAMES = (
    Frame("base", "b", "robot-centric, midway between the two pan-tilt units (cyclopean)"),
    Frame("ptu", "p", "fixed to one pan-tilt unit at its home pose; x up, y forward, z left"),
    Frame("gaze", "g", "moves with the pan-tilt unit; equals ptu at pan = tilt = 0"),
    Frame("cam", "c", "optical centre; OpenCV axes: +z optical axis, +x right, +y down"),
    Frame("world", "w", "a calibration target (chessboard) or any landmark"),
)

EYES = ("left", "right")

TRANSFORMS = (
    ("T_cam_from_gaze", "T_cg", "hand-eye, constant per eye; found by RASC (eq. 6–9)"),
    ("T_gaze_from_ptu", "T_gp", "pan-tilt motion, eq. 3; pure rotation"),
    ("T_ptu_from_base", "T_pb", "mount of each unit on the base; loop closure or measured"),
    ("T_cam_from_world", "T_cw", "target pose from camera calibration (extrinsics)"),
    ("T_ptuL_from_ptuR", "T_pLpR", "right unit in left unit's frame (eq. 11–12)"),
)
