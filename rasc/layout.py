"""The house, written once: where each part of rasc lives, what it holds, and on which
floor (imports only run down: a room imports its own floor and those below;
tests/project/test_layout.py checks the code against :data:`ROOMS`).

Pages show the table generated, never copied: :func:`markdown_table` renders a table and
:func:`render_tables` fills a page's marked blocks (``<!-- table: NAME (generated from
rasc/...) -->`` ... ``<!-- end table -->``); :func:`rasc.geometry.frames.render_tables`
fills every generated table, the frames' too (tests/io/test_tables.py keeps docs/ current).
"""

from __future__ import annotations

import re
from typing import NamedTuple


class Room(NamedTuple):
    """One row of the layout: ``where`` (a path), its ``floor`` (None: outside the
    package's import rule) and ``what`` it holds."""

    where: str
    floor: int | None
    what: str


ROOMS = (
    Room("rasc/io.py, errors.py, formats.py, guard.py, interrupt.py, progress.py, layout.py", 0,
         "the ground floor: reading and writing files (the one JSON reader, atomic output, "
         "the one number check), the one-line errors, every file format "
         "(`rasc.formats`), one interrupt path for SIGINT and SIGTERM, progress bars, "
         "this table"),
    Room("rasc/geometry/", 1, "`transforms` (rigid transforms, exp/log through scipy, the one "
         "transform check), `kinematics` (eq. 3 and the general unit), `frames` (the frame "
         "tables), `lens` (the lens models in numpy: OpenCV's pinhole with radial-tangential "
         "or rational distortion, and its fisheye), `triangulation` (eq. 15–19)"),
    Room("rasc/handeye/", 2, "`paper` (RASC's eq. 6–10 written plainly: the reference), "
         "`solver` (the entry points: `solve_rasc`, the batched form, `diagnose`), "
         "`_kernels`, `_checks`, `_linalg` (the speed work and the input and degeneracy "
         "checks, private), `result` (thresholds, result types); "
         "`advice`, `li`, `opencv`, `methods` (every method by name, plugins, the "
         "jackknife), `inverse`, `noise` (eq. 13–14), `document` (the `rasc-handeye/1` "
         "reader, still positions or two timestamped streams), `time_offset` (hand-eye "
         "from two pose streams with the clocks' offset and its σ), `pose_streams` "
         "(seeded streams with a known truth)"),
    Room("rasc/vision/", 2, "`board` (the targets), `images` (image files, grey, PNG), "
         "`subpixel` (cornerSubPix's rule, saddle points), `detect` (corner detection), "
         "`aprilgrid` (its detector), `camera` (intrinsics, extrinsics; re-exports images "
         "and detect; cv2), `dataset` (the `rasc-dataset/1` folder, the one dataset class), "
         "`joint_stream` (a dataset's timestamped joint readings, `joints.csv`), "
         "`points` (`rasc detect`)"),
    Room("rasc/sim/", 3, "`scene` (the MuJoCo head: the only mujoco importer, lazily), "
         "`mjcf` (the scene's MJCF and target texture), `degrade` (noise, blur, "
         "distortion), `render` (dataset rendering), `motion` (continuous motion: trajectory, "
         "exposures, the cameras' and encoders' clocks), `lens_render` (a wide lens's image "
         "from several pinhole views), `units` (imperfect pan-tilt units), `urdf` (heads "
         "from a URDF), `synthetic`"),
    Room("sim/models/", None, "the MJCF models of the head and scene, shipped in the wheel as "
         "`rasc/sim/models/` (setup.py)"),
    Room("rasc/head/", 3, "`model` (the calibrated head), `base_to_ptu` (eq. 11–12), "
         "`pipeline` (dataset → calibration), `refine` (whole-head refinement), `use` "
         "(projection, triangulation, look-at)"),
    Room("rasc/recordings/", 3, "`rasc import`'s readers: ROS 1 / ROS 2 bags (rosbags) and "
         "image folders with a CSV of angles, into rasc-dataset/1 folders"),
    Room("rasc/report/", 4, "`rasc report`: the calibration report (PDF) and its verdict"),
    Room("rasc/plan/", 4, "`rasc plan`: capture planning (greedy D-/A-optimal pan-tilt "
         "positions on the refinement's information matrix)"),
    Room("rasc/export/", 4, "`rasc export`: a calibration as a URDF (`urdf`), ROS "
         "camera_info, OpenCV FileStorage and Kalibr camchain YAML (`yaml_formats`)"),
    Room("rasc/datasets/", 4, "the dataset service: the one cache key over the one code "
         "digest (`keys`), the one verified cache store (`cache`), rendered datasets "
         "through it (`render`)"),
    Room("rasc/stereo/", 4, "stereo at any gaze: `rectify` (the rectification of a "
         "calibrated head at a pair of pan-tilt readings: OpenCV's R1, R2, P1, P2, Q and "
         "remap tables; `rasc rectify`)"),
    Room("rasc/study/", 4, "declarative studies in stages: `params` (every study "
         "parameter), `spec` (the TOML file, cells), `datasets`, `cells`, `summary`, "
         "`figures`, `engine` (the run), `executors` (in process, a process pool, dask)"),
    Room("rasc/testing.py", 5, "the pytest plugin: noisy pose sets, rendered datasets, "
         "`assert_handeye_close`"),
    Room("rasc/commands/", 5, "one module per `rasc` subcommand"),
    Room("rasc/cli.py", 6, "the `rasc` command line's dispatcher"),
    Room("rasc/__main__.py", 7, "`python -m rasc`"),
    Room("experiments/", None, "one module per paper output, `reproduce`, the study specs"),
    Room("benchmarks/", None, "timing scripts that print tables"),
    Room("docs/", None, "`METHOD.md` (the method, notation, errata), `NOTES.md`, "
         "`CONTRACTS.md`, `topics/`"),
)

#: The generated tables of this module, by name: header and rows.
TABLES = {"layout": (("where", "what"), [(f"`{r.where}`" if "," not in r.where else
                                          ", ".join(f"`{w.strip()}`"
                                                    for w in r.where.split(",")), r.what)
                                         for r in ROOMS])}


def markdown_table(header: tuple[str, ...], rows) -> str:
    """A Markdown table (header, rule, rows; each line ending in a newline)."""
    lines = [tuple(header), ("---",) * len(header), *map(tuple, rows)]
    return "".join("| " + " | ".join(cells) + " |\n" for cells in lines)


_MARK = re.compile(r"(<!-- table: ([a-z-]+) \(generated from (rasc/[a-z/_.]+)\) -->\n)"
                   r"(.*?)(<!-- end table -->)", re.S)


def render_tables(text: str, tables: dict | None = None) -> str:
    """``text`` with every marked block replaced by its table from ``tables`` (name →
    (header, rows); default :data:`TABLES`); a block whose name is not there is left as
    it is. A page is current when ``render_tables(page) == page``."""
    tables = TABLES if tables is None else tables

    def fill(m: re.Match) -> str:
        if m.group(2) not in tables:
            return m.group(0)
        return m.group(1) + markdown_table(*tables[m.group(2)]) + m.group(5)

    return _MARK.sub(fill, text)
