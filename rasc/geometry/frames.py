"""The frames of the stereo head, its transforms and the pan-tilt unit's parameters,
declared once (docs/METHOD.md §1, §10). Pages show them generated: :func:`render_tables`
fills a page's marked blocks (docs/METHOD.md's two;
tests/io/test_tables.py checks that they are current), and README.md's "Frames" section
lists the same rows (tests/geometry/test_frames_table.py compares them).

``T_a_from_b`` maps coordinates in frame b into frame a (``q_a = T_a_from_b q_b``);
the paper writes it ``T_ab``. A point in base coordinates reaches camera coordinates
through eq. 1–2::

    T_cam_from_base = T_cam_from_gaze @ T_gaze_from_ptu(pan, tilt) @ T_ptu_from_base

``T_cam_from_gaze`` (the paper's ``T_cg``, hand-eye) and ``T_ptu_from_base`` (``T_pb``)
are constant per eye; ``T_gaze_from_ptu`` (``T_gp``) is the pan-tilt motion: eq. 3 for the
paper's unit, :class:`rasc.geometry.kinematics.PanTiltUnit` for a real one.
"""

from __future__ import annotations

from dataclasses import dataclass

from rasc import layout


@dataclass(frozen=True)
class Frame:
    """A coordinate frame of the head: its name in code, the paper's symbol and its meaning."""
    name: str
    symbol: str
    meaning: str


@dataclass(frozen=True)
class Transform:
    """A transform between two frames, ``T_a_from_b``: the paper's symbol and its meaning."""
    name: str
    symbol: str
    meaning: str


@dataclass(frozen=True)
class UnitParameter:
    """A parameter of the general pan-tilt unit (``PanTiltUnit`` field or property)."""

    name: str
    symbol: str
    meaning: str
    unit: str


FRAMES = (
    Frame("base", "b", "robot-centric, midway between the two pan-tilt units (cyclopean); "
                       "x up, y forward, z left"),
    Frame("ptu", "p", "fixed to one pan-tilt unit at its home pose (readings pan = tilt = 0); "
                      "x up along the pan axis, y forward, z left; origin on the pan axis"),
    Frame("gaze", "g", "moves with the pan-tilt unit; equals ptu at home"),
    Frame("cam", "c", "optical centre; OpenCV axes: +z optical axis, +x right, +y down"),
    Frame("world", "w", "the calibration target: corner (i, j) of the chessboard at "
                        "(i·s, j·s, 0), +z into the board"),
)

EYES = ("left", "right")

TRANSFORMS = (
    Transform("T_cam_from_gaze", "T_cg", "hand-eye, constant per eye; found by RASC (eq. 6–10)"),
    Transform("T_gaze_from_ptu(pan, tilt)", "T_gp",
              "pan-tilt motion; eq. 3 for the paper's unit: Rz(tilt) · Rx(−pan), no "
              "translation; PanTiltUnit.T_gaze_from_ptu in general"),
    Transform("T_ptu_from_base", "T_pb",
              "mount of each unit; loop closure (eq. 11–12) or measured"),
    Transform("T_cam_from_world", "T_cw", "target pose from camera calibration (extrinsics)"),
    Transform("T_ptuL_from_ptuR", "T_pLpR", "the right unit in the left unit's frame"),
)

#: The general unit, docs/METHOD.md §10: φ = s_φ · pan + o_φ, τ = s_τ · tilt + o_τ,
#: T_gaze_from_ptu = [Trans(q) · Rot(ẑ', τ) · Trans(−q)] · Rot(x̂_p, −φ). "canonical" is the
#: gauge of rasc.geometry.kinematics.canonical_gauge, in which ground truth is written.
UNIT_PARAMETERS = (
    UnitParameter("pan_axis", "x̂_p", "direction of the pan axis, which passes through the ptu "
                  "origin; ideal and canonical (1, 0, 0)", "unit vector, ptu frame"),
    UnitParameter("tilt_axis", "ẑ'", "direction of the tilt axis, signed as in eq. 3 (the joint "
                  "turns the gaze by −τ about it); ideal (0, 0, 1), canonical (cos α, 0, sin α)",
                  "unit vector, panned frame"),
    UnitParameter("tilt_point", "q", "a point of the tilt axis; ideal 0, canonical (0, d, 0), "
                  "the foot of the common normal; moving q along the tilt axis changes nothing",
                  "length unit of the dataset, panned frame"),
    UnitParameter("pan_offset", "o_φ", "pan encoder zero; canonical 0 (absorbed by "
                  "T_ptu_from_base)", "rad"),
    UnitParameter("tilt_offset", "o_τ", "tilt encoder zero; canonical 0 (absorbed by "
                  "T_cam_from_gaze)", "rad"),
    UnitParameter("pan_scale", "s_φ", "pan encoder scale, joint angle per reading; ideal 1",
                  "1"),
    UnitParameter("tilt_scale", "s_τ", "tilt encoder scale, joint angle per reading; ideal 1",
                  "1"),
    UnitParameter("axis_angle_deg", "α", "(derived) angle between the two axes; ideal 90",
                  "deg"),
    UnitParameter("axis_distance", "d", "(derived) common-normal distance between the two "
                  "axes: the one observable offset; ideal 0", "length unit of the dataset"),
)


# ------------------------------------------------------------------- the tables as text

#: The Markdown tables, by name: header and rows, each cell as printed.
TABLES = {
    "frames": (("frame", "paper", "meaning"), [(f.name, f.symbol, f.meaning) for f in FRAMES]),
    "transforms": (("transform", "paper", "what"),
                   [(f"`{t.name}`", t.symbol, t.meaning) for t in TRANSFORMS]),
    "unit-parameters": (("parameter", "symbol", "meaning", "unit"),
                        [(f"`{p.name}`", p.symbol, p.meaning, p.unit)
                         for p in UNIT_PARAMETERS]),
}


def render_tables(text: str) -> str:
    """``text`` (Markdown) with every generated table brought up to date: each block between
    ``<!-- table: NAME (generated from rasc/...) -->`` and ``<!-- end table -->`` becomes
    table NAME of :data:`TABLES` or :data:`rasc.layout.TABLES` (:func:`rasc.layout.render_tables`).
    A page is current when ``render_tables(page) == page`` (tests/io/test_tables.py)."""
    return layout.render_tables(text, {**layout.TABLES, **TABLES})
