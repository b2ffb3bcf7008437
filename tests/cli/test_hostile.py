"""The hostile-input sweep of issue 7: mistakes a user makes, plus a few malicious inputs.

Every case belongs to one class of the issue and asserts the documented promise
(docs/guide/refusals.md, "What rasc refuses and what it warns"):

* ``refused``: exit status 2, exactly one line on stderr (``rasc <cmd>: error: ...``,
  containing the case's fragment), nothing on stdout, and NO file created, changed or
  removed anywhere in the case's folder (inputs, dataset, output folder, temporaries);
* ``warned``: exit status 0, the result written, every stderr line a
  ``rasc <cmd>: warning: ...`` line and one of them containing the fragment, and no
  input changed.

The classes: ``data-loss`` (an output that would overwrite an input), ``wrong-numbers``
(a number the data contradict, silently), ``traceback`` (a crash instead of one line),
``leftovers`` (temporaries left behind by an interrupt), ``unclear`` (a message that
misleads or drowns in noise), and ``reader`` (the one JSON reader, rasc.io, applied to
each of the four input documents). In-process through :func:`rasc.cli.main` wherever
possible; subprocesses only for signals, devices and standard output. One small dataset
(6 intrinsics views per eye, the paper's nine positions) is rendered once per run.
Reading a FIFO blocks and reading /dev/zero never ends in a reader without limits, so
those cases run under an alarm (in-process) or a memory limit (subprocess): a hang or a
memory error is a failure like any other.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

import hashlib
import json
import re
import resource
import shlex
import shutil
import signal
import struct
import subprocess
import sys
import time
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from rasc.cli import main

from shared_fixtures import locked, shared_root

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "handeye_nine_poses.json"
#: a case that takes longer than this in-process is a hang (a FIFO read, an endless loop)
ALARM_S = 20
#: RASC_HOSTILE_PROMISE_ONLY=1: check the promise (exit status, one line, nothing
#: written, a warning where one is due) but not the wording, to measure code whose
#: messages differ (the before/after table of issue 7 ran this sweep on main's code)
PROMISE_ONLY = os.environ.get("RASC_HOSTILE_PROMISE_ONLY") == "1"


# ------------------------------------------------------------------------------ cases

@dataclass(frozen=True)
class Case:
    cls: str                 # data-loss | wrong-numbers | traceback | leftovers | unclear | reader
    name: str
    setup: Callable          # (ws: Path) -> argv (list) ; may change files in ws
    expect: str = "refused"  # refused | warned
    fragment: str = ""       # must appear in the error / one warning line
    output: str | None = None  # warned: the file that must be written (relative to ws)
    subprocess: bool = False   # run as `python -m rasc` (devices, unbounded reads)

    @property
    def id(self) -> str:
        return f"{self.cls}/{self.name}"


CASES: list[Case] = []


def case(cls, name, setup, **kw) -> None:
    CASES.append(Case(cls, name, setup, **kw))


def handeye(ws: Path, poses="poses.json", out="out/result.json", *extra) -> list:
    argv = ["handeye", ws / poses if poses else poses]
    return argv + (["--out", out if out in ("", ".") or out.startswith("/") else ws / out]
                   if out is not None else []) + list(extra)


def calibrate(ws: Path, *extra, out="out/cal.json") -> list:
    argv = ["calibrate", ws / "ds", "--quiet"]
    return argv + (["--out", out if out in ("", ".") else ws / out]
                   if out is not None else []) + list(extra)


def render(ws: Path, out="out/new", *extra) -> list:
    return ["render", "--out", out if out in ("", ".") else ws / out, "--quiet",
            "--intrinsics-views", "3", "--poses", "0,0;8,0;0,8", *extra]


def load(path: Path):
    return json.loads(path.read_text())


def dump(path: Path, obj) -> None:
    path.write_text(json.dumps(obj))


def edit(path: Path, change) -> None:
    obj = load(path)
    change(obj)
    dump(path, obj)


def mounts_text(ws: Path) -> str:
    gt = load(ws / "ds" / "ground_truth.json")
    return json.dumps({"format": "rasc-mounts/1", "T_ptuL_from_ptuR": gt["T_ptuL_from_ptuR"]})


# --- the reader matrix: every hostile text for each of the four input documents --------

def _first_number(text: str, replacement: str) -> str:
    """``text`` with its first number (depth first, outside strings) written as
    ``replacement``, raw: the number's place is marked with a string, then replaced."""
    doc = json.loads(text)
    mark = "@@number@@"

    def put(node) -> bool:
        items = node.items() if isinstance(node, dict) else enumerate(node) \
            if isinstance(node, list) else ()
        for key, value in items:
            if isinstance(value, int | float) and not isinstance(value, bool):
                node[key] = mark
                return True
            if put(value):
                return True
        return False

    assert put(doc), "no number in the document"
    return json.dumps(doc).replace(json.dumps(mark), replacement)


def _dup_top(text: str) -> str:
    doc = json.loads(text)
    key = next(iter(doc))
    return "{" + json.dumps(key) + ": " + json.dumps(doc[key]) + ", " + text.lstrip()[1:]


def _dup_nested(text: str) -> str:
    braces = list(re.finditer(r'\{(\s*)"([^"]+)"', text))
    if len(braces) < 2:  # no nested object: a duplicate at the top instead
        return _dup_top(text)
    m = braces[1]
    return text[:m.start() + 1] + f'"{m.group(2)}": 0, ' + text[m.start() + 1:]


def _not_utf8(text: str) -> bytes:
    i = text.index('"') + 1
    return text[:i].encode() + b"\xe9\xff" + text[i:].encode()


HOSTILE_TEXTS: dict[str, tuple[Callable[[str], str | bytes], str]] = {
    # name: (valid text -> hostile text or bytes, fragment of the error)
    "duplicate top-level key": (_dup_top, "duplicate key"),
    "duplicate nested key": (_dup_nested, "duplicate key"),
    "nested 40 deep": (lambda t: _first_number(t, "[" * 40 + "1" + "]" * 40), "nested deeper"),
    "nested 100000 deep": (lambda t: _first_number(t, "[" * 100000 + "]" * 100000),
                           "nested deeper"),
    "30-digit integer": (lambda t: _first_number(t, "1" * 30), "an integer of 30 digits"),
    "5000-digit integer": (lambda t: _first_number(t, "9" * 5000), "an integer of 5000 digits"),
    "1e308": (lambda t: _first_number(t, "1e308"), "larger in size than"),
    "-1e300": (lambda t: _first_number(t, "-1e300"), "larger in size than"),
    "1e400 overflows": (lambda t: _first_number(t, "1e400"), "overflows to infinity"),
    "NaN": (lambda t: _first_number(t, "NaN"), "NaN is not a finite number"),
    "-Infinity": (lambda t: _first_number(t, "-Infinity"), "-Infinity is not a finite"),
    "not UTF-8": (_not_utf8, "not UTF-8 text"),
    "UTF-16": (lambda t: t.encode("utf-16"), "not UTF-8 text"),
    "empty": (lambda t: "", "malformed JSON at line 1, column 1"),
    "whitespace only": (lambda t: "\n  \n", "malformed JSON at line 3"),
    "top-level array": (lambda t: "[" + t + "]", "JSON object"),
    "top-level string": (lambda t: '"manifest"', "JSON object"),
    "null": (lambda t: "null", "JSON object"),
    "truncated": (lambda t: t[:len(t) // 2], "malformed JSON"),
    "binary junk": (lambda t: bytes(range(256)) * 4, "not UTF-8"),
    "trailing garbage": (lambda t: t + "}", "malformed JSON"),
}

READERS = {
    # name: (the file in ws, valid text of it, argv, prefix of the one error line)
    "poses": ("poses.json", lambda ws: EXAMPLE.read_text(), lambda ws: handeye(ws)),
    "manifest": ("ds/manifest.json", lambda ws: (ws / "ds/manifest.json").read_text(),
                 lambda ws: calibrate(ws)),
    "mounts": ("mounts.json", mounts_text,
               lambda ws: calibrate(ws, "--mounts", ws / "mounts.json")),
    "ground truth": ("ds/ground_truth.json",
                     lambda ws: (ws / "ds/ground_truth.json").read_text(),
                     lambda ws: calibrate(ws)),
}

_TOP_OK = {"poses": ("top-level array", "top-level string", "null")}  # handeye's own words


def _reader_setup(reader: str, mutate):
    file, valid, argv = READERS[reader]

    def setup(ws: Path) -> list:
        text = valid(ws)
        bad = mutate(text)
        path = ws / file
        if isinstance(bad, bytes):
            path.write_bytes(bad)
        else:
            path.write_text(bad)
        return argv(ws)
    return setup


for _reader in READERS:
    for _name, (_mutate, _fragment) in HOSTILE_TEXTS.items():
        if _name in _TOP_OK.get(_reader, ()):
            _fragment = "top level must be a JSON object"
        case("reader", f"{_reader}: {_name}", _reader_setup(_reader, _mutate),
             fragment=_fragment)


def _replace_by(reader: str, make):
    file, valid, argv = READERS[reader]

    def setup(ws: Path) -> list:
        valid(ws)
        path = ws / file
        if path.exists():
            path.unlink()
        make(path)
        return argv(ws)
    return setup


def _fifo(path: Path) -> None:
    os.mkfifo(path)


def _sparse_65_mib(path: Path) -> None:
    with open(path, "wb") as f:
        f.truncate(65 * 2**20)


for _reader in READERS:
    case("reader", f"{_reader}: a folder", _replace_by(_reader, lambda p: p.mkdir()),
         fragment="is a folder")
    case("reader", f"{_reader}: a FIFO", _replace_by(_reader, _fifo),
         fragment="not a regular file")
    case("reader", f"{_reader}: link to /dev/null",
         _replace_by(_reader, lambda p: p.symlink_to("/dev/null")),
         fragment="not a regular file")
    case("reader", f"{_reader}: link to /dev/zero",
         _replace_by(_reader, lambda p: p.symlink_to("/dev/zero")),
         fragment="not a regular file", subprocess=True)
    case("reader", f"{_reader}: 65 MiB", _replace_by(_reader, _sparse_65_mib),
         fragment="more than the 67108864 bytes")
    case("reader", f"{_reader}: dangling link",
         _replace_by(_reader, lambda p: p.symlink_to(p.parent / "nowhere.json")),
         fragment="no such file")


# --- data loss: an output path that is an input -----------------------------------------

def _link(ws: Path, target: str, name: str = "out/link.json", hard=False) -> Path:
    link = ws / name
    (os.link if hard else os.symlink)(ws / target, link)
    return link


case("data-loss", "handeye --out is the input", lambda ws: handeye(ws, out="poses.json"),
     fragment="is the input file")
case("data-loss", "handeye --out is a symlink to the input",
     lambda ws: handeye(ws, out=str(_link(ws, "poses.json"))), fragment="is the input file")
case("data-loss", "handeye --out is a hard link to the input",
     lambda ws: handeye(ws, out=str(_link(ws, "poses.json", hard=True))),
     fragment="is the input file")
case("data-loss", "handeye --out is the input through ..",
     lambda ws: handeye(ws, out="out/../poses.json"), fragment="is the input file")
for _target in ("ds/manifest.json", "ds/poses/left_03.png", "ds/intrinsics/right_000.png",
                "ds/ground_truth.json"):
    case("data-loss", f"calibrate --out is {_target}",
         lambda ws, t=_target: calibrate(ws, out=t), fragment="is the input file")
    case("data-loss", f"calibrate --out is a symlink to {_target}",
         lambda ws, t=_target: calibrate(ws, out=str(_link(ws, t))),
         fragment="is the input file")
case("data-loss", "calibrate --out is a hard link to an image",
     lambda ws: calibrate(ws, out=str(_link(ws, "ds/poses/right_05.png", hard=True))),
     fragment="is the input file")
case("data-loss", "calibrate --out is the --mounts file",
     lambda ws: ((ws / "mounts.json").write_text(mounts_text(ws)),
                 calibrate(ws, "--mounts", ws / "mounts.json", out="mounts.json"))[1],
     fragment="is the input file")
case("data-loss", "calibrate --out is a file of the dataset not in the manifest",
     lambda ws: ((ws / "ds/notes.txt").write_text("rig notes"),
                 calibrate(ws, out="ds/notes.txt"))[1],
     fragment="is a file of the input dataset")
case("data-loss", "calibrate --out is the manifest by a relative path",
     lambda ws: calibrate(ws, out="ds/poses/../manifest.json"), fragment="is the input file")
case("data-loss", "render --out holds a dataset", lambda ws: render(ws, out="ds"),
     fragment="holds a dataset")
case("data-loss", "render --out is a non-empty folder",
     lambda ws: ((ws / "out/keep.txt").write_text("mine"), render(ws, out="out"))[1],
     fragment="exists and is not empty")
case("data-loss", "render --out is a file", lambda ws: render(ws, out="poses.json"),
     fragment="exists as a file")
case("data-loss", "render --out is the --model file",
     lambda ws: (shutil.copy(ROOT / "sim/models/scene.xml", ws / "scene.xml"),
                 render(ws, "scene.xml", "--model", ws / "scene.xml"))[1],
     fragment="exists as a file")


# --- output paths that are no file --------------------------------------------------------

case("traceback", "handeye --out .", lambda ws: handeye(ws, out="."), fragment="folder")
case("traceback", "handeye --out empty", lambda ws: handeye(ws, out=""), fragment="empty path")
case("traceback", "handeye --out a folder", lambda ws: handeye(ws, out="out"),
     fragment="is a folder")
case("traceback", "handeye --out ends with /",
     lambda ws: handeye(ws, out=f"{ws}/out/x/"),
     fragment="folder")
case("traceback", "handeye --out a symlink to a folder",
     lambda ws: (os.symlink(ws / "out", ws / "lnk"), handeye(ws, out="lnk"))[1],
     fragment="symbolic link to a folder")
case("traceback", "handeye --out in a missing folder",
     lambda ws: handeye(ws, out="nowhere/r.json"), fragment="does not exist")
# Not /dev/null itself: a reader without this rule, run as root, REPLACES the device by a
# regular file (measured on main's code: /dev/null and /dev/full became files, and had to
# be re-created). A FIFO inside the case's folder is a non-regular file as good.
case("traceback", "handeye --out a FIFO (as /dev/null)",
     lambda ws: (os.mkfifo(ws / "out/fifo"), handeye(ws, out="out/fifo"))[1],
     fragment="not a regular file")
case("traceback", "calibrate --out a symlink to a FIFO",
     lambda ws: (os.mkfifo(ws / "fifo"), os.symlink(ws / "fifo", ws / "out/link"),
                 calibrate(ws, out="out/link"))[2], fragment="not a regular file")
case("traceback", "calibrate --out .", lambda ws: calibrate(ws, out="."), fragment="folder")
case("traceback", "calibrate --out empty", lambda ws: calibrate(ws, out=""),
     fragment="empty path")
case("traceback", "calibrate --out the dataset folder", lambda ws: calibrate(ws, out="ds"),
     fragment="is a folder")
case("traceback", "calibrate --out a symlink to a folder",
     lambda ws: (os.symlink(ws / "out", ws / "lnk"), calibrate(ws, out="lnk"))[1],
     fragment="symbolic link to a folder")
case("traceback", "render --out .", lambda ws: render(ws, out="."), fragment="current")
case("traceback", "render --out empty", lambda ws: render(ws, out=""), fragment="empty path")
case("traceback", "render --out ..", lambda ws: render(ws, out="out/.."), fragment="current")
case("traceback", "render --out a symlink to a folder",
     lambda ws: (os.symlink(ws / "out", ws / "lnk"), render(ws, out="lnk"))[1],
     fragment="symbolic link")
case("traceback", "render --out a dangling symlink",
     lambda ws: (os.symlink(ws / "nowhere", ws / "lnk"), render(ws, out="lnk"))[1],
     fragment="symbolic link")
case("traceback", "render --out in a missing folder", lambda ws: render(ws, out="a/b/c"),
     fragment="does not exist")


# --- tracebacks from values -------------------------------------------------------------

def _poses_edit(change):
    def setup(ws: Path) -> list:
        edit(ws / "poses.json", change)
        return handeye(ws)
    return setup


def _manifest_edit(change, *extra):
    def setup(ws: Path) -> list:
        edit(ws / "ds/manifest.json", change)
        return calibrate(ws, *extra)
    return setup


def _pose_image(m, k=0):
    return [im for im in m["images"] if im["role"] == "pose"][k]


for _name, _value, _fragment in (("1e308", 1e308, "larger in size"),
                                 ("1e11", 1e11, "more than a full turn"),
                                 ("-1e12", -1e12, "more than a full turn")):
    case("traceback", f"manifest pan {_name}",
         _manifest_edit(lambda m, v=_value: _pose_image(m).__setitem__("pan", v)),
         fragment=_fragment)
case("traceback", "manifest square_size 1e308",
     _manifest_edit(lambda m: m["board"].__setitem__("square_size", 1e308)),
     fragment="larger in size")
case("traceback", "manifest square_size 1e50",
     _manifest_edit(lambda m: m["board"].__setitem__("square_size", 1e50)),
     fragment="square_size 1e+50 is outside")
case("traceback", "handeye one translation 1e50",
     _poses_edit(lambda d: d["positions"][4]["T_cam_from_world"][1].__setitem__(3, 1e50)),
     expect="warned", fragment="positions[4]: the target is", output="out/result.json")
case("traceback", "manifest inner_corners of 25 digits",
     lambda ws: ((ws / "ds/manifest.json").write_text(
         (ws / "ds/manifest.json").read_text().replace('"inner_corners": [9, 6]',
                                                       '"inner_corners": [' + "9" * 25 + ', 6]')),
         calibrate(ws))[1], fragment="an integer of 25 digits")
case("traceback", "manifest inner_corners 10**15",
     _manifest_edit(lambda m: m["board"].__setitem__("inner_corners", [10**15, 6])),
     fragment="inner_corners")
case("traceback", "manifest square_size 0",
     _manifest_edit(lambda m: m["board"].__setitem__("square_size", 0)),
     fragment="square_size")
case("traceback", "manifest square_size -0.05",
     _manifest_edit(lambda m: m["board"].__setitem__("square_size", -0.05)),
     fragment="square_size")
case("traceback", "manifest square_size a string",
     _manifest_edit(lambda m: m["board"].__setitem__("square_size", "5cm")),
     fragment="square_size")
case("traceback", "manifest images is an object",
     _manifest_edit(lambda m: m.__setitem__("images", {"a": 1})), fragment="images")
case("traceback", "manifest image file is absolute",
     _manifest_edit(lambda m: m["images"][0].__setitem__("file", "/etc/passwd")),
     fragment="inside the dataset folder")
case("traceback", "manifest image file escapes with ..",
     _manifest_edit(lambda m: m["images"][0].__setitem__("file", "../../poses.json")),
     fragment="inside the dataset folder")
case("traceback", "manifest image is a folder",
     _manifest_edit(lambda m: m["images"][0].__setitem__("file", "poses")),
     fragment="does not exist")
case("traceback", "manifest view is a list",
     _manifest_edit(lambda m: _pose_image(m).__setitem__("view", [1])), fragment="view")
case("traceback", "manifest angle_unit grad",
     _manifest_edit(lambda m: m.__setitem__("angle_unit", "grad")), fragment="angle_unit")
case("traceback", "manifest ground_truth is a number",
     _manifest_edit(lambda m: m.__setitem__("ground_truth", 5)), fragment="ground_truth")
for _name, _value, _fragment in (("1e308", 1e308, "larger in size"),
                                 ("30 digits", 10**29, "an integer of 30 digits"),
                                 ("1e11", 1e11, "more than a full turn"),
                                 ("361", 361, "more than a full turn")):
    case("traceback", f"handeye pan {_name}",
         _poses_edit(lambda d, v=_value: d["positions"][1].__setitem__("pan", v)),
         fragment=_fragment)
case("traceback", "handeye translation 1e300",
     _poses_edit(lambda d: d["positions"][2]["T_cam_from_world"][0].__setitem__(3, 1e300)),
     fragment="larger in size")
case("traceback", "handeye translations all 1e11 (the jackknife squares them)",
     _poses_edit(lambda d: [p["T_cam_from_world"][r].__setitem__(3, p["T_cam_from_world"][r][3]
                                                                 * 1e11)
                            for p in d["positions"] for r in range(3)]),
     expect="warned", fragment="", output="out/result.json")
case("traceback", "handeye positions is a number", _poses_edit(
    lambda d: d.__setitem__("positions", 5)), fragment="positions")
case("traceback", "handeye --home past the end", lambda ws: handeye(
    ws, "poses.json", "out/result.json", "--method", "li", "--home", "99"), fragment="home")
case("traceback", "handeye --home negative", lambda ws: handeye(
    ws, "poses.json", "out/result.json", "--method", "li", "--home", "-1"), fragment="home")


def _huge_png(w: int, h: int) -> bytes:
    """A valid PNG header (and one row of pixels) claiming w x h pixels."""
    def chunk(tag: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + tag + data + \
            struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(b"\x00" * (w + 1))) + chunk(b"IEND", b""))


def _all_left_images_huge(ws: Path) -> list:
    png = _huge_png(40000, 40000)
    for im in load(ws / "ds/manifest.json")["images"]:
        if im["eye"] == "left":
            (ws / "ds" / im["file"]).write_bytes(png)
    return calibrate(ws)


case("traceback", "images beyond OpenCV's pixel limit", _all_left_images_huge,
     fragment="more pixels than OpenCV reads")
case("traceback", "an image that is a FIFO",
     lambda ws: ((ws / "ds/poses/left_04.png").unlink(), os.mkfifo(ws / "ds/poses/left_04.png"),
                 calibrate(ws))[2], fragment="left_04.png")
for _opt, _value, _fragment in (
        ("--blur", "1e308", "--blur must be a number from 0 to 50"),
        ("--blur", "500", "--blur must be a number from 0 to 50"),
        ("--noise", "1e308", "--noise must be a number from 0 to 255"),
        ("--noise", "nan", "--noise: must be finite"),
        ("--distance", "1e308", "--distance 1e+308"),
        ("--distance", "inf", "--distance: must be finite"),
        ("--distance", "-1", "--distance must be"),
        ("--distance", "1e-300", "--distance"),
        ("--seed", "1" + "0" * 30, "--seed must be"),
        ("--seed", "-1", "--seed must be"),
        ("--intrinsics-views", "2", "--intrinsics-views"),
        ("--poses", "1e308,0;0,0;8,8", "--poses"),
        ("--poses", "nan,0;0,0;8,8", "--poses"),
        ("--poses", "", "--poses"),
        ("--poses", "0,0;8,8", "--poses"),
        ("--distortion", "1e308", "--distortion"),
        ("--distortion", "nan", "--distortion"),
        ("--distortion", "0,0,0,0,0,0", "--distortion"),
        ("--model", "/dev/null", "--model"),
):
    case("traceback", f"render {_opt} {_value or 'empty'}",
         lambda ws, o=_opt, v=_value: render(ws, "out/new", f"{o}={v}"), fragment=_fragment)


# --- silently wrong numbers -----------------------------------------------------------------

def _position_in_mm(k: int, factor=1000.0):
    def change(d):
        T = d["positions"][k]["T_cam_from_world"]
        for r in range(3):
            T[r][3] *= factor
    return _poses_edit(change)


for _k in (0, 3, 8):
    case("wrong-numbers", f"handeye position {_k} in mm among m", _position_in_mm(_k),
         expect="warned", fragment=f"positions[{_k}]: the target is ",
         output="out/result.json")
case("wrong-numbers", "handeye position 5 in m among mm",
     lambda ws: (edit(ws / "poses.json", lambda d: [
         p["T_cam_from_world"][r].__setitem__(3, p["T_cam_from_world"][r][3] * 1000)
         for i, p in enumerate(d["positions"]) if i != 5 for r in range(3)]), handeye(ws))[1],
     expect="warned", fragment="positions[5]: the target is 0.00099", output="out/result.json")
case("wrong-numbers", "handeye two positions' translations swapped",
     _poses_edit(lambda d: [d["positions"][1]["T_cam_from_world"][r].__setitem__(
         3, d["positions"][7]["T_cam_from_world"][r][3] + 0.4) for r in range(3)]),
     expect="warned", fragment="the translations contradict each other",
     output="out/result.json")
case("wrong-numbers", "manifest square_size twice",
     lambda ws: ((ws / "ds/manifest.json").write_text(
         (ws / "ds/manifest.json").read_text().replace(
             '"square_size": ', '"square_size": 0.001, "square_size": ', 1)),
         calibrate(ws))[1], fragment="duplicate key 'square_size'")
case("wrong-numbers", "manifest eye twice in one image",
     lambda ws: ((ws / "ds/manifest.json").write_text(
         (ws / "ds/manifest.json").read_text().replace(
             '"eye": "left"', '"eye": "right", "eye": "left"', 1)),
         calibrate(ws))[1], fragment="duplicate key 'eye'")
case("wrong-numbers", "handeye pan twice in one position",
     lambda ws: ((ws / "poses.json").write_text(EXAMPLE.read_text().replace(
         '"pan": 8.0', '"pan": -8.0, "pan": 8.0', 1)), handeye(ws))[1],
     fragment="duplicate key 'pan'")
case("wrong-numbers", "mounts T_ptuL_from_ptuR twice",
     lambda ws: ((ws / "mounts.json").write_text(mounts_text(ws).replace(
         '"T_ptuL_from_ptuR": ', '"T_ptuL_from_ptuR": 1, "T_ptuL_from_ptuR": ')),
         calibrate(ws, "--mounts", ws / "mounts.json"))[1], fragment="duplicate key")


def _swap_eyes(ws: Path) -> list:
    edit(ws / "ds/manifest.json", lambda m: [
        im.__setitem__("eye", {"left": "right", "right": "left"}[im["eye"]])
        for im in m["images"]])
    dump(ws / "ds/ground_truth.json", {})   # ground truth would name the swap itself
    edit(ws / "ds/manifest.json", lambda m: m.pop("ground_truth"))
    return calibrate(ws)


case("wrong-numbers", "left and right swapped in the manifest", _swap_eyes, expect="warned",
     fragment="to the RIGHT of the right unit", output="out/cal.json")


# --- unclear ---------------------------------------------------------------------------------

case("unclear", "render --distortion that pushes the board out",
     lambda ws: render(ws, "out/new", "--distortion=0.9,0.9"),
     fragment="rasc render: error: --distortion")
case("unclear", "render --distance 20 (no corner detectable)",
     lambda ws: render(ws, "out/new", "--distance=20"), fragment="--distance 20: board squares")
case("unclear", "render --distance 20 --quiet is still refused",
     lambda ws: render(ws, "out/new", "--distance=20", "--quiet"), fragment="--distance 20")
case("unclear", "handeye non-finite input is named, not a numpy warning",
     _poses_edit(lambda d: d["positions"][0]["T_cam_from_world"][0].__setitem__(0, 1e300)),
     fragment="larger in size")
case("unclear", "handeye all target translations zero",
     _poses_edit(lambda d: [p["T_cam_from_world"][r].__setitem__(3, 0.0)
                            for p in d["positions"] for r in range(3)]),
     expect="warned", fragment="", output="out/result.json")


# ----------------------------------------------------------------------------- running

def snapshot(root: Path) -> dict[str, str]:
    """Every file and link below ``root`` (hidden ones too) → a digest of its content."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            rel = p.relative_to(root).as_posix()
            if p.is_symlink():
                out[rel] = "link:" + os.readlink(p)
            elif p.is_dir():
                out[rel] = "dir"
            elif p.is_file():
                out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
            else:
                out[rel] = "special"
    return out


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> Path:
    """The module's small dataset, rendered once per run (the xdist workers share it under
    a file lock, as conftest's default dataset). Read-only: each case works on a copy."""
    shared = shared_root(tmp_path_factory)
    ds = shared / "hostile" / "ds"
    with locked(shared / "hostile.lock"):
        if not (ds / "manifest.json").is_file():     # rasc render renames it into place
            ds.parent.mkdir(exist_ok=True)
            assert main(["render", "--out", str(ds), "--intrinsics-views", "6",
                         "--quiet"]) == 0
    return ds


@pytest.fixture
def ws(dataset, tmp_path) -> Path:
    shutil.copytree(dataset, tmp_path / "ds")
    shutil.copy(EXAMPLE, tmp_path / "poses.json")
    (tmp_path / "out").mkdir()
    return tmp_path


class _Alarm(Exception):
    pass


def _on_alarm(signum, frame):
    raise _Alarm(f"no answer within {ALARM_S} s")


def run_in_process(argv: list, capsys) -> tuple[int, str, str]:
    capsys.readouterr()
    previous = signal.signal(signal.SIGALRM, _on_alarm)
    signal.alarm(ALARM_S)
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:       # argparse's usage errors
        code = exc.code
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    cap = capsys.readouterr()
    return code, cap.out, cap.err


def _limit_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (3 * 2**30, 3 * 2**30))


def run_subprocess(argv: list, **kw) -> tuple[int, str, str]:
    proc = subprocess.run([sys.executable, "-m", "rasc", *map(str, argv)], capture_output=True,
                          text=True, timeout=120, preexec_fn=_limit_memory, check=False, **kw)
    return proc.returncode, proc.stdout, proc.stderr


@pytest.mark.parametrize("c", CASES, ids=[c.id for c in CASES])
def test_hostile_input(c: Case, ws: Path, capsys):
    argv = c.setup(ws)
    command = argv[0]
    before = snapshot(ws)
    code, out, err = run_subprocess(argv) if c.subprocess else run_in_process(argv, capsys)
    lines = err.splitlines()
    assert "Traceback" not in err, err[-2000:]
    after = snapshot(ws)
    if c.expect == "refused":
        assert code == 2 and out == "", (code, err[-2000:])
        assert len(lines) == 1, err[-2000:]
        assert lines[0].startswith(f"rasc {command}: error: "), lines[0]
        assert PROMISE_ONLY or c.fragment in lines[0], lines[0]
        assert after == before, "files changed: " + ", ".join(
            sorted(set(after.items()) ^ set(before.items()), key=str)[:5].__repr__())
    else:
        assert code == 0, (code, err[-2000:])
        assert all(line.startswith(f"rasc {command}: warning: ") for line in lines), err
        assert any(c.fragment in line for line in lines) or not c.fragment \
            or (PROMISE_ONLY and lines), err
        assert (ws / c.output).is_file()
        changed = {k for k in set(before) | set(after) if before.get(k) != after.get(k)}
        assert changed <= {c.output, *(k for k in after if k.startswith("out/"))}, changed


def test_the_sweep_covers_every_class_with_at_least_150_inputs():
    by_class: dict[str, int] = {}
    for c in CASES:
        by_class[c.cls] = by_class.get(c.cls, 0) + 1
    assert len(CASES) + len(SUBPROCESS_CASES) >= 150, by_class
    assert set(by_class) >= {"data-loss", "wrong-numbers", "traceback", "unclear", "reader"}
    assert len({c.id for c in CASES}) == len(CASES)        # no case hides another


# ------------------------------------------------- signals, devices and standard output

def _spawn(argv: list, **kw) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "rasc", *map(str, argv)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def _render_interrupted(ws: Path, sig: int) -> None:
    """Start a render, wait until its hidden folder holds images, send ``sig``."""
    proc = _spawn(render(ws, "out/new"))
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        tmp = [p for p in (ws / "out").iterdir() if p.name.startswith(".new.")]
        if tmp and any(tmp[0].rglob("*.png")):
            break
        time.sleep(0.02)
    else:
        proc.kill()
        pytest.fail("render never started writing images")
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert err.splitlines() == [f"rasc render: interrupted: nothing written (removed the "
                                f"partial dataset {tmp[0]})"], err
    assert out == "" and os.listdir(ws / "out") == []


def _wait_until_loaded(proc: subprocess.Popen, library: str, timeout: float = 60) -> None:
    """Until the process has mapped ``library``'s shared objects (/proc/PID/maps): it is
    then inside rasc's own start-up, loading the libraries (not in the interpreter's)."""
    maps = Path(f"/proc/{proc.pid}/maps")
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and proc.poll() is None:
        try:
            if f"/{library}/" in maps.read_text():
                return
        except OSError:
            pass
        time.sleep(0.001)
    raise AssertionError(f"{library} never loaded")


def _startup_interrupted(ws: Path, sig: int, library: str = "numpy") -> None:
    """A signal while the libraries load (numpy, scipy, OpenCV): one line, exit 130.

    The signal is sent as soon as the process maps ``library``, so it arrives during
    rasc's start-up whatever the machine's load (a fixed delay landed in the
    interpreter's own start-up when the machine was busy, where no program can answer
    it). Before ``rasc.cli.run`` this sometimes ended by SIGINT (-2) after printing the
    right line (CPython gh-128130), and numpy turned an interrupt into an ImportError."""
    if not Path("/proc/self/maps").is_file():
        pytest.skip("needs /proc/PID/maps")
    proc = _spawn(handeye(ws))
    _wait_until_loaded(proc, library)
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert err.splitlines() == ["rasc handeye: interrupted: nothing written"], err
    assert out == "" and os.listdir(ws / "out") == []


def _stdout_full(ws: Path, _sig=None) -> None:
    with open("/dev/full", "w") as full:
        proc = subprocess.run([sys.executable, "-m", "rasc", "handeye", ws / "poses.json"],
                              stdout=full, stderr=subprocess.PIPE, text=True, timeout=60,
                              check=False)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.splitlines() == [
        "rasc handeye: error: standard output: cannot write: No space left on device"]


def _two_renders_one_out(ws: Path, _sig=None) -> None:
    """Two renders into one --out at once: the second to finish finds the folder taken
    and refuses; the first one's dataset stays whole (the same files as rendered alone)."""
    argv = render(ws, "out/new")
    procs = [_spawn(argv) for _ in range(2)]
    results = [(p.wait(timeout=300), p.stdout.read(), p.stderr.read()) for p in procs]
    codes = sorted(r[0] for r in results)
    assert codes == [0, 2], results
    err = next(r[2] for r in results if r[0] == 2)
    assert err.splitlines()[-1].startswith("rasc render: error: --out "), err
    assert len(err.splitlines()) == 1, err
    assert sorted(os.listdir(ws / "out")) == ["new"]
    assert main(["calibrate", str(ws / "out/new"), "--quiet", "--out",
                 str(ws / "cal.json")]) == 0


SUBPROCESS_CASES = {
    "leftovers/render SIGTERM": (_render_interrupted, signal.SIGTERM),
    "leftovers/render SIGINT": (_render_interrupted, signal.SIGINT),
    "traceback/SIGINT during start-up": (_startup_interrupted, signal.SIGINT),
    "leftovers/SIGTERM during start-up": (_startup_interrupted, signal.SIGTERM),
    "traceback/SIGINT while scipy loads": (
        lambda ws, sig: _startup_interrupted(ws, sig, "scipy"), signal.SIGINT),
    "traceback/standard output on a full device": (_stdout_full, None),
    "traceback/two renders into one --out": (_two_renders_one_out, None),
}


#: cases that take seconds (whole renders in a subprocess): marked slow, out of
#: `make test-fast`
_SLOW_PROCESS_CASES = {"traceback/two renders into one --out", "leftovers/render SIGTERM",
                       "leftovers/render SIGINT"}


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow)
                                  if n in _SLOW_PROCESS_CASES else n
                                  for n in SUBPROCESS_CASES])
def test_hostile_process(name, ws):
    fn, sig = SUBPROCESS_CASES[name]
    fn(ws, sig)


def test_a_render_that_loses_the_race_removes_its_folder(ws, capsys, monkeypatch):
    """Deterministic version of the race: the --out folder appears (with a file) while
    this render works; the rename fails, the hidden folder goes, the other's file stays."""
    import rasc.sim.render as sim_render

    real = sim_render.render_dataset

    def racing(out, *args, **kwargs):
        (ws / "out/new").mkdir()
        (ws / "out/new/theirs.txt").write_text("another render's file")
        return real(out, *args, **kwargs)

    monkeypatch.setattr(sim_render, "render_dataset", racing)
    code, out, err = run_in_process(render(ws, "out/new"), capsys)
    assert code == 2 and out == ""
    assert err.startswith(f"rasc render: error: --out {ws / 'out/new'}: appeared meanwhile")
    assert len(err.splitlines()) == 1
    assert os.listdir(ws / "out") == ["new"]
    assert os.listdir(ws / "out/new") == ["theirs.txt"]


def test_numpy_warnings_never_print_beside_the_error_line(ws, capsys, monkeypatch):
    """A RuntimeWarning raised on the way to an error is dropped (the error speaks); on
    success it becomes one warning line."""
    import rasc.handeye.document as document  # run() imports its reader from there

    real = document.load_handeye_input

    def noisy(path):
        np.float64(1e308) * 10  # RuntimeWarning: overflow encountered
        return real(path)

    monkeypatch.setattr(document, "load_handeye_input", noisy)
    edit(ws / "poses.json", lambda d: d.__setitem__("positions", d["positions"][:2]))
    code, out, err = run_in_process(handeye(ws), capsys)
    assert code == 2 and len(err.splitlines()) == 1 and "error" in err, err
    shutil.copy(EXAMPLE, ws / "poses.json")
    code, out, err = run_in_process(handeye(ws), capsys)
    assert code == 0
    assert err.splitlines() == ["rasc handeye: warning: numerical trouble during the "
                                "computation (overflow encountered in scalar multiply); "
                                "check the result"], err


# -------------------------------------------------- the refusals a user meets first

#: (command, expected output lines) in a folder holding ``poses.json`` (the handeye example)
#: and ``ds`` (the default dataset); a line ending in "..." matches as a prefix. The same
#: commands are the examples of docs/guide/refusals.md.
SESSION: list[tuple[str, list[str]]] = [
    ('printf \'{"positions": [], "positions": []}\' > twice.json',
     []),
    ('rasc handeye twice.json --out result.json',
     ["rasc handeye: error: twice.json: /: duplicate key 'positions' (a JSON object names each key once; which one was meant?)"]),  # noqa: E501
    ('sed \'s/"pan": 8.0/"pan": 1e999/\' poses.json > inf.json',
     []),
    ('rasc handeye inf.json --out result.json',
     ['rasc handeye: error: inf.json: /positions/1/pan: 1e999 overflows to infinity']),
    ('rasc handeye /dev/zero',
     ['rasc handeye: error: /dev/zero: not a regular file (a device, pipe or socket); the POSES.json must be a file']),  # noqa: E501
    ('rasc handeye poses.json --out poses.json',
     ['rasc handeye: error: --out poses.json is the input file; choose another path']),
    ('rasc calibrate ds --out ds/poses/left_03.png',
     ['rasc calibrate: error: --out ds/poses/left_03.png is the input file; choose another path']),
    ('rasc calibrate ds --out .',
     ['rasc calibrate: error: --out .: names a folder; give a file name']),
    ('rasc render --out ds',
     ['rasc render: error: --out ds: holds a dataset (manifest.json); rasc render never replaces files: name a new folder, or remove this one first']),  # noqa: E501
    ('rasc render --out new --distance 20',
     ['rasc render: error: --distance 20: board squares would be only 2.9 px in the pose views, where corner detection fails (measured: none found at 12.5 px); bring the board closer']),  # noqa: E501
    ('rasc render --out new --distortion=0.9',
     ['rasc render: error: --distortion 0.9,0,0,0,0: at pan, tilt = (8, 8) deg the distortion moves corners of the board outside the left image (1280x960, 12 px margin), which fits without it; use smaller coefficients']),  # noqa: E501
    ('timeout 3 rasc render --out new --quiet --intrinsics-views 200',
     ['rasc render: interrupted: nothing written...']),
    ('rasc handeye poses.json > /dev/full',
     ['rasc handeye: error: standard output: cannot write: No space left on device']),
    ('printf \'name = "tiny"\\nseed = 0\\nsamples = 2\\nmethods = ["rasc"]\\n\' > tiny.toml',
     []),
    ('RASC_CACHE_MAX_MB=ten rasc study tiny.toml --out tiny',
     ["rasc study: error: RASC_CACHE_MAX_MB: expected a number of MiB >= 0, got 'ten'"]),
    ('python3 -c "import json; d = json.load(open(\'poses.json\')); d[\'positions\'][3][\'T_cam_from_world\'][2][3] *= 1000; json.dump(d, open(\'mm.json\', \'w\'))"',  # noqa: E501
     []),
    ('rasc handeye mm.json --out result.json',
     ["rasc handeye: warning: the closed form's data look contaminated (the translations contradict each other; positions[3]: the target is 965× as far from the camera as at the median position, a translation in another length unit?): rasc-robust rejected 2 of 9 positions: positions[3] (translation residual 991 (1.23e+06 σ > 4.03 σ)); positions[7] (rotation residual 0.0757° (4.3 σ > 4.03 σ)); the closed form (and any refinement) starts from the 7 others"]),  # noqa: E501
]


#: what only a shell and a real process give: redirections, devices, signals, other programs
_SHELL_ONLY = re.compile(r"[<>|;&$`]|/dev/|^(?!rasc )")


@pytest.mark.slow
def test_refusal_session_is_true(ws, capsys, monkeypatch):
    """Each command of the session, in a folder as SESSION describes; its
    output must be what SESSION shows, and an error exits 2. Commands that need a shell
    or a process (redirections, /dev/zero, /dev/full, ``timeout``, other programs) run in
    bash; a plain ``rasc ARGS`` runs as ``rasc.cli.main(ARGS)`` in this process, the same
    code ``rasc`` runs after start-up (its output and status are main's), saving a Python
    start-up each."""
    shutil.copytree(ws / "ds", ws / "run" / "ds")
    shutil.copy(EXAMPLE, ws / "run" / "poses.json")
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}:{os.environ['PATH']}")
    session = SESSION
    monkeypatch.chdir(ws / "run")
    ran = {"bash": 0, "in-process": 0}
    for command, expected in session:
        if _SHELL_ONLY.search(command):
            proc = subprocess.run(["bash", "-c", command], cwd=ws / "run", env=env, text=True,
                                  capture_output=True, timeout=120, check=False)
            code, out, err = proc.returncode, proc.stdout, proc.stderr
            ran["bash"] += 1
        else:
            code, out, err = run_in_process(shlex.split(command)[1:], capsys)
            ran["in-process"] += 1
        got = (out + err).splitlines()
        assert len(got) == len(expected), (command, got)
        for g, e in zip(got, expected, strict=True):
            assert g.startswith(e[:-3]) if e.endswith("...") else g == e, (command, g)
        if any(": error: " in e for e in expected):
            assert code == 2, (command, code)
    assert ran["bash"] >= 3 and ran["in-process"] >= 3, ran
    assert sorted(p.name for p in (ws / "run").iterdir() if p.name.startswith(".")) == []


@pytest.mark.parametrize("method, suggested", [("rasc", "li"), ("li", "rasc"),
                                               ("opencv-park", "rasc")])
def test_a_non_finite_result_never_suggests_the_same_method(method, suggested, ws, capsys,
                                                            monkeypatch):
    """A method that returns NaN: one error line that suggests ANOTHER method."""
    import rasc.commands.handeye as cmd
    from rasc.handeye.methods import METHODS

    real = METHODS[method]

    def broken(*args, **kwargs):
        result = real(*args, **kwargs)
        T = np.array(result.T_cam_from_gaze, dtype=float)
        T[0, 3] = np.nan
        return type("Broken", (), {"T_cam_from_gaze": T, "quality": result.quality,
                                   "to_dict": result.to_dict})()

    from rasc.handeye.methods import Method

    # the command calls its method through rasc.handeye.methods.Method (the one policy
    # of rasc handeye and rasc calibrate, robust_calibrate.closed_form)
    monkeypatch.setattr(cmd, "_solver", lambda name: Method(method, broken, "built-in"))
    code, out, err = run_in_process(handeye(ws, "poses.json", "out/result.json",
                                            "--method", method), capsys)
    assert code == 2 and out == "" and os.listdir(ws / "out") == []
    (line,) = err.splitlines()
    assert f"method {method} returned a non-finite result" in line, line
    assert line.endswith(f"or try --method {suggested}"), line


def test_an_opencv_assertion_no_validation_caught_is_one_line(ws, capsys, monkeypatch):
    """The last net: cv2.error (an OpenCV assertion on data that passed every check)
    is one error line, exit 2, no traceback, no output."""
    import cv2

    import rasc.handeye.document as document  # run() imports its reader from there

    def fails(path):
        raise cv2.error("OpenCV(4.x) x.cpp:1: error: (-215:Assertion failed) fabs(sc) > 0")

    monkeypatch.setattr(document, "load_handeye_input", fails)
    code, out, err = run_in_process(handeye(ws), capsys)
    assert code == 2 and out == "" and os.listdir(ws / "out") == []
    assert err.splitlines() == ["rasc handeye: error: OpenCV could not process the input "
                                "(OpenCV(4.x) x.cpp:1: error: (-215:Assertion failed) fabs(sc) "
                                "> 0)"], err
