"""A calibration as a URDF robot description (what robot_state_publisher, MoveIt, yourdfpy
and MuJoCo read), docs/topics/export.md.

The tree, per eye (``{eye}`` = left, right); every rasc frame is a link::

    base_link                      REP 103 body axes (x forward, y left, z up), at the
     └ rasc_base                   rasc's base (x up, y forward, z left), same origin
        └ {eye}_ptu                fixed: T_ptu_from_base⁻¹
           └ {eye}_pan_link        revolute {eye}_pan about x̂_p (the pan axis, through
              │                    the ptu origin): the panned frame
              └ {eye}_tilt_link    revolute {eye}_tilt about −ẑ' through q (tilt_point):
                 │                 the gaze frame's axes, origin at q
                 └ {eye}_gaze      fixed: Trans(−q), rasc's gaze frame
                    └ {eye}_camera_link           fixed: REP 103 body axes at the camera
                       └ {eye}_camera_optical_frame   fixed rpy (−π/2, 0, −π/2): rasc's
                                                      camera frame = OpenCV's = REP 103's
                                                      optical frame (z forward, x right,
                                                      y down)

so that ``T_{eye}_camera_optical_frame_from_rasc_base`` at joint values (pan, tilt) is
rasc's ``T_cam_from_base(pan, tilt)`` (eq. 1–2 with the general unit, METHOD §10).

Encoder zeros and scales (:data:`JOINT_VALUES`):

* ``"readings"`` (the default): the joint values a driver publishes on ``/joint_states``
  are the encoder readings, as rasc calibrated them. The zeros o_φ, o_τ are folded into
  the joint origins (a turn about the joint's own axis commutes with it: exact). URDF has
  no joint scale, so an eye whose scale s ≠ 1 gets the one construct that applies one:
  the joint ``{eye}_pan`` the driver publishes turns a bodiless leaf link
  (``{eye}_pan_encoder``), and the joint that moves the head, ``{eye}_pan_joint``,
  ``<mimic joint="{eye}_pan" multiplier="s" offset="0"/>`` (robot_state_publisher,
  MoveIt, yourdfpy apply it); with s = 1 exactly the joint ``{eye}_pan`` moves the
  head itself and no mimic is written.
* ``"angles"``: the joint values are the unit's joint angles φ = s_φ·pan + o_φ,
  τ = s_τ·tilt + o_τ (:meth:`rasc.geometry.kinematics.PanTiltUnit.angles`), which the
  driver computes; the origins are geometry only and no mimic is written (for readers
  without mimic support: pytransform3d, MuJoCo's URDF compiler).

No ``<calibration rising=...>`` is written: URDF defines it as a reference (homing
switch) position, and forward kinematics (robot_state_publisher, MoveIt, yourdfpy)
ignores it, so an encoder zero written there would silently not be applied.

Lengths are metres (REP 103); joint limits are placeholders (±π), not calibrated.
"""

from __future__ import annotations

import math
from xml.sax.saxutils import quoteattr

import numpy as np

from rasc.export._text import number, rpy
from rasc.geometry.frames import EYES
from rasc.geometry.transforms import invert_transform, matrix_from_rotvec

#: what the URDF's joint values are: encoder readings or the unit's joint angles
JOINT_VALUES = ("readings", "angles")

#: rasc's base frame (x up, y forward, z left) in REP 103 body axes (x forward, y left, z up)
R_REP103_FROM_RASC_BASE = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
#: the optical frame (z forward, x right, y down) in the camera's body axes: REP 103's
#: ``rpy="-pi/2 0 -pi/2"``
R_CAMERA_LINK_FROM_OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def frame_names(eye: str) -> dict[str, str]:
    """The link and joint names of one eye's chain (module docstring)."""
    return {"ptu": f"{eye}_ptu", "pan_link": f"{eye}_pan_link",
            "tilt_link": f"{eye}_tilt_link", "gaze": f"{eye}_gaze",
            "camera_link": f"{eye}_camera_link",
            "optical": f"{eye}_camera_optical_frame",
            "pan": f"{eye}_pan", "tilt": f"{eye}_tilt"}


def _rotation(axis, angle: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = matrix_from_rotvec(np.asarray(axis, dtype=float) * angle)
    return T


def _origin(T: np.ndarray, metres: float) -> str:
    roll, pitch, yaw = rpy(T[:3, :3])
    return (f'<origin xyz="{number(T[0, 3] * metres)} {number(T[1, 3] * metres)} '
            f'{number(T[2, 3] * metres)}" rpy="{number(roll)} {number(pitch)} '
            f'{number(yaw)}"/>')


def _fixed(name: str, parent: str, child: str, T: np.ndarray, metres: float) -> str:
    return (f'  <joint name="{name}" type="fixed">\n    <parent link="{parent}"/>\n'
            f'    <child link="{child}"/>\n    {_origin(T, metres)}\n  </joint>\n')


def _revolute(name: str, parent: str, child: str, T: np.ndarray, axis, metres: float,
              mimic: tuple[str, float] | None = None) -> str:
    lines = [f'  <joint name="{name}" type="revolute">', f'    <parent link="{parent}"/>',
             f'    <child link="{child}"/>', f"    {_origin(T, metres)}",
             f'    <axis xyz="{number(axis[0])} {number(axis[1])} {number(axis[2])}"/>',
             f'    <limit lower="{number(-math.pi)}" upper="{number(math.pi)}" '
             'effort="0.0" velocity="0.0"/>']
    if mimic is not None:
        lines.append(f'    <mimic joint="{mimic[0]}" multiplier="{number(mimic[1])}" '
                     'offset="0.0"/>')
    return "\n".join(lines) + "\n  </joint>\n"


def _eye_chain(eye: str, cal, joints: str, metres: float) -> tuple[list[str], str]:
    """Links and joints of one eye (``cal`` an EyeCalibration)."""
    u = cal.unit
    n = frame_names(eye)
    p = np.asarray(u.pan_axis)
    z = -np.asarray(u.tilt_axis)            # the mechanism turns by τ about −ẑ' (eq. 3)
    q = np.asarray(u.tilt_point)
    readings = joints == "readings"
    links = [n["ptu"], n["pan_link"], n["tilt_link"], n["gaze"], n["camera_link"],
             n["optical"]]
    text = _fixed(f"{eye}_mount", "rasc_base", n["ptu"],
                  invert_transform(cal.T_ptu_from_base), metres)
    # T_ptu_from_pan_link = Rot(x̂_p, o_φ) · Rot(x̂_p, s_φ·pan)   (readings)
    #                     = Rot(x̂_p, φ)                          (angles)
    T_pan = _rotation(p, u.pan_offset) if readings else np.eye(4)
    # T_pan_link_from_tilt_link = Trans(q) · Rot(−ẑ', o_τ) · Rot(−ẑ', s_τ·tilt), or τ
    T_tilt = np.eye(4)
    T_tilt[:3, 3] = q
    if readings:
        T_tilt = T_tilt @ _rotation(z, u.tilt_offset)
    for joint, parent, child, T, axis, scale in (
            ("pan", n["ptu"], n["pan_link"], T_pan, p, u.pan_scale),
            ("tilt", n["pan_link"], n["tilt_link"], T_tilt, z, u.tilt_scale)):
        if readings and scale != 1.0:
            encoder = f"{n[joint]}_encoder"
            links.append(encoder)
            text += _revolute(n[joint], parent, encoder, np.eye(4), axis, metres)
            text += _revolute(f"{n[joint]}_joint", parent, child, T, axis, metres,
                              mimic=(n[joint], scale))
        else:
            text += _revolute(n[joint], parent, child, T, axis, metres)
    T_tilt_from_gaze = np.eye(4)
    T_tilt_from_gaze[:3, 3] = -q
    text += _fixed(f"{eye}_gaze_joint", n["tilt_link"], n["gaze"], T_tilt_from_gaze, metres)
    T_gaze_from_optical = invert_transform(cal.T_cam_from_gaze)
    T_link_from_optical = np.eye(4)
    T_link_from_optical[:3, :3] = R_CAMERA_LINK_FROM_OPTICAL
    text += _fixed(f"{eye}_camera_joint", n["gaze"], n["camera_link"],
                   T_gaze_from_optical @ invert_transform(T_link_from_optical), metres)
    text += _fixed(f"{eye}_camera_optical_joint", n["camera_link"], n["optical"],
                   T_link_from_optical, metres)
    return links, text


def to_urdf(head, *, joints: str = "readings", metres_per_unit: float = 1.0,
            robot_name: str = "rasc_head", source: str | None = None) -> str:
    """The URDF text of a :class:`rasc.head.model.HeadCalibration` (module docstring).

    Parameters
    ----------
    head : HeadCalibration
    joints : {"readings", "angles"}
        What the joint values are (:data:`JOINT_VALUES`).
    metres_per_unit : float
        Metres per length unit of the calibration (URDF lengths are metres).
    robot_name : str
    source : str, optional
        Named in the header comment (the calibration file).
    """
    from rasc import __version__

    note = ""
    if source:
        note = f" from {source}"
        while "--" in note:                       # an XML comment holds no "--"
            note = note.replace("--", "- -")

    links = ["base_link", "rasc_base"]
    body = ""
    T_rep_from_rasc = np.eye(4)
    T_rep_from_rasc[:3, :3] = R_REP103_FROM_RASC_BASE
    body += _fixed("rasc_base_joint", "base_link", "rasc_base", T_rep_from_rasc, metres_per_unit)
    for eye in EYES:
        eye_links, text = _eye_chain(eye, getattr(head, eye), joints, metres_per_unit)
        links += eye_links
        body += text
    what = ("encoder readings (radians); zeros in the joint origins, scales as <mimic> "
            "multipliers" if joints == "readings" else
            "joint angles phi = pan_scale * pan + pan_offset, tau = tilt_scale * tilt + "
            "tilt_offset (radians), computed by the driver")
    header = (f"<?xml version=\"1.0\"?>\n<!-- written by rasc {__version__} (rasc export, "
              f"format urdf){note}.\n"
              f"     Joint values: {what}.\n"
              "     Lengths in metres. {eye}_camera_optical_frame is rasc's (OpenCV's) camera "
              "frame.\n     Joint limits are placeholders. -->\n")
    return (header + f"<robot name={quoteattr(robot_name)}>\n"
            + "".join(f'  <link name="{link}"/>\n' for link in links) + body + "</robot>\n")
