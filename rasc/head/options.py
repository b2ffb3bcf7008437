"""The calibration's options: one object, one default per decision, one validation.

:class:`CalibrationOptions` is what :func:`rasc.head.pipeline.calibrate_dataset` takes
and what ``rasc calibrate`` builds from its flags (the command's defaults and choices are
read from here), so the Python door and the command door calibrate the same way: the
general pan-tilt model (the closed form refined over every corner, :mod:`rasc.head.refine`)
unless ``model="paper"`` is asked for.

This module imports only the standard library at its top: the command line builds its
parser from it without loading numpy.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from rasc.errors import InputError

if TYPE_CHECKING:
    import numpy as np

#: the pan-tilt models: "paper" = the closed form with the paper's unit (eq. 3);
#: "general" = that closed form refined over every corner with a general unit per eye
MODELS = ("paper", "general")
#: corner detectors (rasc.vision.camera.DETECTORS; a test checks they agree)
DETECTORS = ("classic", "saddle", "sb")
#: lens models (the keys of rasc.geometry.lens.DIST_MODELS, the one table of each one's
#: lens and coefficients; a test checks they agree)
DIST_MODEL_NAMES = ("opencv5", "k1k2", "none", "rational", "fisheye")
#: encoder scales under the general model (rasc.head.refine.SCALES says what each costs)
SCALES_MODES = ("auto", "estimate", "hold")
#: the camera-to-encoder time offset of a continuous capture under the general model
#: (rasc.head.refine.timing says how it is estimated)
TIME_OFFSET_MODES = ("auto", "estimate", "hold")


@dataclass
class CalibrationOptions:
    """How a dataset is calibrated (``rasc calibrate``'s flags, the same defaults).

    Attributes
    ----------
    method : str
        The hand-eye method (a name :func:`rasc.handeye.methods.get_method` resolves;
        default ``"rasc"``, the paper's). Under ``model="paper"`` its closed form is the
        calibration; under ``model="general"`` it seeds the whole-head refinement, and the
        calibration records its closed form beside the refined result
        (``refinement.seed``).
    detector : {"classic", "saddle", "sb"}
    dist_model : {"opencv5", "k1k2", "none", "rational", "fisheye"}
        k1 k2 by default: with 20 views the full five-term model over-fits (measured on
        renders: pose extrinsics 0.046° worst with "opencv5" against 0.012° with "k1k2").
        "rational": OpenCV's rational model (k1-k6, p1 p2); "fisheye": OpenCV's
        equidistant fisheye model (k1-k4), for lenses of 120° and more
        (docs/topics/lenses.md). A lens the chosen model does not fit is warned
        (:func:`rasc.vision.camera.is_wrong_lens`).
    exclude_outliers : bool
        Drop intrinsics views flagged as outliers.
    T_ptuL_from_ptuR_measured : ndarray (4, 4) or None
        Measured mounts (docs/METHOD.md §5), used instead of loop closure.
    model : {"general", "paper"}
        Default ``"general"``: on a unit whose tilt axis misses the pan axis by 20 mm the
        paper's model puts ~10 mm into the hand-eye, the general one 0.06 mm.
    scales : {"auto", "estimate", "hold"} or None
        Under the general model, the encoder scales; None means "auto" (held at 1 unless
        the corners reject 1). Refused under the paper model, which has none.
    min_corners : int
        A target seen in part (ChArUco): the fewest corners a view must show to be used
        (default 8, :data:`rasc.vision.board.MIN_VIEW_CORNERS`); views with fewer are
        skipped, and the log says so.
    time_offset : {"auto", "estimate", "hold"} or None
        Under the general model, the offset δ between the camera and encoder clocks of a
        continuous capture (pose images with times and a joint stream,
        docs/topics/recordings.md): None means "auto" (estimated when the dataset has a
        joint stream, else nothing to estimate); "estimate" refuses a dataset without
        one; "hold" keeps δ = 0 (the dataset's readings). Refused under the paper model.
    """

    method: str = "rasc"
    detector: str = "saddle"
    dist_model: str = "k1k2"
    exclude_outliers: bool = True
    T_ptuL_from_ptuR_measured: np.ndarray | None = None
    model: str = "general"
    scales: str | None = None
    min_corners: int = 8
    time_offset: str | None = None

    @property
    def time_offset_mode(self) -> str:
        """``time_offset`` with its default filled in ("auto")."""
        return "auto" if self.time_offset is None else self.time_offset

    @property
    def scales_mode(self) -> str:
        """``scales`` with its default filled in ("auto")."""
        return "auto" if self.scales is None else self.scales

    def validate(self, names: dict[str, str] | None = None) -> CalibrationOptions:
        """Refuse options no calibration can run with, before any image is read.

        ``names`` maps a field to how the caller's user wrote it (``rasc calibrate``
        passes its flags, ``{"scales": "--scales", ...}``); messages name the field
        otherwise. Resolves the hand-eye method (an unknown name or a broken plugin is
        refused here). Returns ``self``. Raises :class:`InputError`, one line.
        """
        names = names or {}

        def name(field: str) -> str:
            return names.get(field, f"options.{field}")

        for field, allowed in (("model", MODELS), ("detector", DETECTORS),
                               ("dist_model", DIST_MODEL_NAMES)):
            value = getattr(self, field)
            if value not in allowed:
                raise InputError(f"{name(field)}: expected one of {', '.join(allowed)}, "
                                 f"got {value!r}")
        if self.scales is not None:
            if self.scales not in SCALES_MODES:
                raise InputError(f"{name('scales')}: expected one of "
                                 f"{', '.join(SCALES_MODES)}, got {self.scales!r}")
            if self.model != "general":
                raise InputError(f"{name('scales')}: only the whole-head refinement "
                                 f"estimates scales; use it with {name('model')} general")
        if self.time_offset is not None:
            if self.time_offset not in TIME_OFFSET_MODES:
                raise InputError(f"{name('time_offset')}: expected one of "
                                 f"{', '.join(TIME_OFFSET_MODES)}, got {self.time_offset!r}")
            if self.model != "general":
                raise InputError(f"{name('time_offset')}: only the whole-head refinement "
                                 f"estimates the time offset; use it with {name('model')} "
                                 "general")
        if isinstance(self.min_corners, bool) or not isinstance(self.min_corners, int) \
                or self.min_corners < 4:
            raise InputError(f"{name('min_corners')}: expected a whole number of at least 4 "
                             f"(a pose needs 4 corners), got {self.min_corners!r}")
        if not isinstance(self.exclude_outliers, bool):
            raise InputError(f"{name('exclude_outliers')}: expected true or false, got "
                             f"{self.exclude_outliers!r}")
        if self.T_ptuL_from_ptuR_measured is not None:
            from rasc.geometry.transforms import validate_rigid_transform

            validate_rigid_transform(self.T_ptuL_from_ptuR_measured,
                                     name=name("T_ptuL_from_ptuR_measured"))
        from rasc.handeye.methods import get_method

        get_method(self.method)     # its messages name the method already
        return self

    def to_dict(self) -> dict[str, Any]:
        """The options as the calibration file records them."""
        return {"method": self.method, "detector": self.detector,
                "dist_model": self.dist_model, "exclude_outliers": self.exclude_outliers,
                "model": self.model, "scales": self.scales_mode,
                "time_offset": self.time_offset_mode, "min_corners": self.min_corners}


def default(field: str) -> Any:
    """The default of one :class:`CalibrationOptions` field (for a parser's help)."""
    return {f.name: f.default for f in dataclasses.fields(CalibrationOptions)}[field]
