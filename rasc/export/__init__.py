"""Exports of a calibration for the tools robots use (``rasc export``,
docs/topics/export.md): a URDF (:mod:`rasc.export.urdf`), ROS camera_info YAML, OpenCV
FileStorage YAML and a Kalibr camchain (:mod:`rasc.export.yaml_formats`).

:func:`export_calibration` is the one entry point the command and the Python API share:
a calibration (a :class:`rasc.head.use.CalibrationFile` as read from a file, or a
:class:`rasc.head.model.HeadCalibration`) and :class:`ExportOptions` give the files to
write, by name, as text. Each format is checked in tests/export by a reader rasc did not
write: yourdfpy's forward kinematics, PyYAML, ``cv2.FileStorage``.
"""

from __future__ import annotations

from dataclasses import dataclass

from rasc.errors import InputError

#: the formats, in the order ``rasc export --help`` lists them
FORMATS = ("urdf", "camera-info", "opencv", "kalibr")
#: the file (or, for camera-info, the files in a folder) each format writes
FILE_NAMES = {"urdf": ("head.urdf",), "camera-info": ("left.yaml", "right.yaml"),
              "opencv": ("stereo.yaml",), "kalibr": ("camchain.yaml",)}
#: the formats whose content depends on the gaze (the stereo extrinsics at readings)
GAZE_FORMATS = ("opencv", "kalibr")
HOME = (0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class ExportOptions:
    """What to export.

    Attributes
    ----------
    format : {"urdf", "camera-info", "opencv", "kalibr"}
    gaze : 4 floats or None
        Readings (pan_left, tilt_left, pan_right, tilt_right) in radians at which the
        stereo extrinsics of ``opencv`` and ``kalibr`` are taken; None: home, all zero.
        Refused for ``urdf`` (its joints move) and ``camera-info`` (intrinsics only).
    joints : {"readings", "angles"}
        URDF only: what its joint values are (:data:`rasc.export.urdf.JOINT_VALUES`).
    robot_name : str
        URDF only: the robot's name.
    """

    format: str
    gaze: tuple[float, float, float, float] | None = None
    joints: str = "readings"
    robot_name: str = "rasc_head"

    def __post_init__(self) -> None:
        from rasc.export.urdf import JOINT_VALUES
        from rasc.head.model import MAX_ABS_ANGLE_RAD
        from rasc.io import finite_number

        if self.format not in FORMATS:
            raise InputError(f"format {self.format!r}: expected one of {', '.join(FORMATS)}")
        if self.joints not in JOINT_VALUES:
            raise InputError(f"joints {self.joints!r}: expected one of "
                             f"{', '.join(JOINT_VALUES)}")
        if self.gaze is not None:
            if self.format not in GAZE_FORMATS:
                why = ("its pan and tilt joints move: publish the readings on /joint_states"
                       if self.format == "urdf" else
                       "camera_info holds the intrinsics only, the same at every gaze; the "
                       "pose is the URDF's")
                raise InputError(f"gaze: not for format {self.format}: {why}")
            if isinstance(self.gaze, str | bytes) or len(self.gaze) != 4:
                raise InputError("gaze: expected 4 readings (pan_left, tilt_left, "
                                 f"pan_right, tilt_right) in radians, got {self.gaze!r}")
            object.__setattr__(self, "gaze", tuple(
                finite_number(a, f"gaze[{i}] (radians)", max_abs=MAX_ABS_ANGLE_RAD)
                for i, a in enumerate(self.gaze)))
        if self.format != "urdf" and self.joints != "readings":
            raise InputError(f"joints: only for format urdf, not {self.format}")


@dataclass(frozen=True)
class Export:
    """The files of an export: ``files`` maps a file name (:data:`FILE_NAMES`) to its text."""

    format: str
    files: dict[str, str]


def export_calibration(calibration, options: ExportOptions) -> Export:
    """Export a calibration.

    Parameters
    ----------
    calibration : CalibrationFile or HeadCalibration
        As :func:`rasc.head.use.read_calibration` reads it (its ``length_unit`` converts
        lengths to metres) or a bare head (lengths taken as metres).
    options : ExportOptions

    Returns
    -------
    Export

    Raises
    ------
    InputError
        A length unit rasc cannot convert to metres; readings beyond ±2π; for Kalibr a
        camera with skew or k3..k6 ≠ 0 (its pinhole-radtan model has neither).
    """
    from rasc.export._text import metres_per_unit
    from rasc.head.model import HeadCalibration

    head = calibration if isinstance(calibration, HeadCalibration) else calibration.head
    length_unit = None if isinstance(calibration, HeadCalibration) else calibration.length_unit
    source = None if isinstance(calibration, HeadCalibration) else calibration.source
    try:
        metres = metres_per_unit(length_unit)
        texts = _texts(head, options, metres, source)
    except InputError as exc:                 # name the calibration file, where there is one
        if source is None:
            raise
        raise InputError(f"{source}: {exc}") from None
    return Export(options.format, dict(zip(FILE_NAMES[options.format], texts, strict=True)))


def _texts(head, options: ExportOptions, metres: float, source: str | None) -> list[str]:
    from rasc.export import urdf, yaml_formats

    gaze = HOME if options.gaze is None else options.gaze
    if options.format == "urdf":
        return [urdf.to_urdf(head, joints=options.joints, metres_per_unit=metres,
                             robot_name=options.robot_name, source=source)]
    if options.format == "camera-info":
        return [yaml_formats.to_camera_info(head.left, "left"),
                yaml_formats.to_camera_info(head.right, "right")]
    if options.format == "opencv":
        return [yaml_formats.to_opencv(head, gaze, metres_per_unit=metres)]
    return [yaml_formats.to_kalibr(head, gaze, metres_per_unit=metres)]
