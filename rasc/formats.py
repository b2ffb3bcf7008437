"""Every file format rasc reads or writes, in one place: name, version, what it holds,
and where its reader and writer are.

A document names its format in its ``"format"`` field, ``<name>/<version>`` (for
example ``"rasc-head/1"``). Modules take that tag from here (``formats.HEAD.tag``), never
spell it themselves (tests/io/test_formats.py checks); the reader and the writer are
given as ``"module:qualified.name"`` (this module sits on the ground floor and imports
none of them), and the same test resolves each one.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Format:
    """One file format: ``name`` and ``version`` make its tag ``name/version``."""

    name: str
    version: int
    what: str
    reader: str            # "module:qualified.name" of the function that reads it
    writer: str            # ... and of the one that writes it

    @property
    def tag(self) -> str:
        """The value of a document's ``"format"`` field, e.g. ``"rasc-head/1"``."""
        return f"{self.name}/{self.version}"


HEAD = Format("rasc-head", 1, "a stereo head's calibration: per eye K, dist, "
              "T_cam_from_gaze, T_ptu_from_base",
              "rasc.head.model:HeadCalibration.from_dict",
              "rasc.head.model:HeadCalibration.to_dict")
CALIBRATION = Format("rasc-calibration", 1, "what rasc calibrate writes: the head "
                     "(rasc-head/1) with diagnostics, uncertainties and warnings",
                     "rasc.head.use:read_calibration", "rasc.head.pipeline:Calibration.to_dict")
DATASET = Format("rasc-dataset", 1, "a dataset folder's manifest.json: the board, each "
                 "image's file, eye and pan/tilt",
                 "rasc.vision.dataset:load_dataset", "rasc.vision.dataset:write_dataset")
HANDEYE = Format("rasc-handeye", 1, "the input of rasc handeye: per position the target's "
                 "pose and the unit's pan/tilt or pose",
                 "rasc.handeye.document:load_handeye_input",
                 "rasc.handeye.document:HandEyeInput")
HANDEYE_RESULT = Format("rasc-handeye-result", 1, "what rasc handeye writes",
                        "rasc.commands.handeye:result_document",
                        "rasc.commands.handeye:result_document")
MOUNTS = Format("rasc-mounts", 1, "rasc calibrate --mounts: a measured T_ptuL_from_ptuR",
                "rasc.commands.calibrate:_read_mounts", "rasc.commands.calibrate:_read_mounts")
PROJECTION = Format("rasc-projection", 1, "what rasc project writes",
                    "rasc.commands.project:run", "rasc.commands.project:run")
TRIANGULATION = Format("rasc-triangulation", 1, "what rasc triangulate writes",
                       "rasc.commands.triangulate:run", "rasc.commands.triangulate:run")
LOOK_AT = Format("rasc-look-at", 1, "what rasc look-at writes",
                 "rasc.commands.look_at:run", "rasc.commands.look_at:run")
RECTIFICATION = Format("rasc-rectification", 1, "what rasc rectify writes: the stereo "
                      "rectification at a pair of readings (R1, R2, P1, P2, Q)",
                      "rasc.commands.rectify:run",
                      "rasc.stereo.rectify:StereoRectification.to_dict")
STUDY = Format("rasc-study", 1, "a study's TOML specification (and the spec echoed in "
               "its summary.json)", "rasc.study.spec:load_spec", "rasc.study.spec:Spec.to_dict")
DATASET_CALIBRATION = Format("rasc-study-dataset", 1, "the dataset service's calibration "
                             "of a dataset: per eye the poses, angles, pose corners, "
                             "intrinsics and reference hand-eye the cells need (a study's "
                             "datasets/<key>.json, and its cache entry; the tag keeps the "
                             "name it was first written under)",
                             "rasc.datasets.calibration:check_calibration_document",
                             "rasc.datasets.calibration:calibration_document")
#: the old name of :data:`DATASET_CALIBRATION`
STUDY_DATASET = DATASET_CALIBRATION
CACHE_KEY = Format("rasc-cache", 2, "the record a cache key hashes (the one code digest, "
                   "the kind and the parameters; never written out as a file)",
                   "rasc.datasets.keys:cache_key", "rasc.datasets.keys:cache_key")
CACHE_ENTRY = Format("rasc-cache-entry", 1, "a cache entry's header line (file entries) "
                     "or entry.json (folder entries): the sha256 its content is verified "
                     "against when read", "rasc.datasets.cache:CacheStore.get_bytes",
                     "rasc.datasets.cache:CacheStore.put_bytes")
REPRODUCE_DATASET = Format("rasc-reproduce-dataset", 1, "the reproduction's cached "
                           "default dataset record", "experiments._common",
                           "experiments._common")
REPRODUCE_CALIBRATION = Format("rasc-reproduce-calibration", 2, "the reproduction's cached "
                               "calibration of the default dataset", "experiments._common",
                               "experiments._common")

HEAD_COVARIANCE = Format("rasc-head-covariance", 1, "the covariance of a refined head's "
                         "parameters (kept in a calibration's refinement)",
                         "rasc.head.uncertainty:HeadCovariance.from_dict",
                         "rasc.head.uncertainty:HeadCovariance.to_dict")

PIXEL_POINTS = Format("rasc-pixel-points", 1, "what rasc detect writes: the pixel points "
                      "CSV that rasc triangulate reads, each image's detection status "
                      "as comment lines", "rasc.commands._use_common:read_points_csv",
                      "rasc.vision.points:PixelPoints.to_csv")

#: Every format by tag.
FORMATS: dict[str, Format] = {f.tag: f for f in (
    HEAD, CALIBRATION, DATASET, HANDEYE, HANDEYE_RESULT, MOUNTS, PROJECTION, TRIANGULATION,
    LOOK_AT, STUDY, DATASET_CALIBRATION, CACHE_KEY, CACHE_ENTRY, REPRODUCE_DATASET,
    REPRODUCE_CALIBRATION, HEAD_COVARIANCE, PIXEL_POINTS, RECTIFICATION)}
