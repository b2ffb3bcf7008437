"""Property tests of every reader of an input document (issue 7).

For rasc.io.read_json_document itself, the rasc-handeye/1 reader, the dataset manifest,
the --mounts file and ground_truth.json: random documents and random mutations of valid
ones (a value replaced by any JSON value or hostile token, a key removed, the text cut,
a character inserted, a key written twice) never produce a traceback and never a
number from invalid input: the reader either returns validated values or raises
InputError with one line that starts with the file's path. Hypothesis runs derandomized
(the same examples on every run and machine) so that CI is stable.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rasc.commands.calibrate import _read_mounts
from rasc.errors import InputError
from rasc.geometry.transforms import RIGID_ATOL
from rasc.handeye.document import load_handeye_input
from rasc.io import MAX_DEPTH, MAX_INT_DIGITS, MAX_MAGNITUDE, read_json_document
from rasc.vision.dataset import load_dataset

from json_strategies import json_documents

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "handeye_nine_poses.json"

SETTINGS = settings(max_examples=150, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.function_scoped_fixture,
                                           HealthCheck.too_slow])

#: tokens a careless or hostile writer puts where a number belongs
HOSTILE_TOKENS = ["NaN", "Infinity", "-Infinity", "1e400", "-1e999", "1e308", "1e101",
                  "9" * 25, "-" + "9" * 5000, "[" * 60 + "]" * 60, "[" * 5000 + "]" * 5000,
                  "0x10", "01", "+1", ".5", "1.", "true", "null", '"1"', "{}", "[]"]

json_leaves = (st.none() | st.booleans() | st.integers(-10**30, 10**30)
               | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=6))
json_values = json_documents(json_leaves, key_size=4, max_leaves=12)


def assert_validated(value, depth: int = 0) -> None:
    """Only JSON types, every number within the reader's limits, at most MAX_DEPTH
    arrays and objects nested."""
    if isinstance(value, dict | list):
        assert depth < MAX_DEPTH
    if isinstance(value, dict):
        for k, v in value.items():
            assert isinstance(k, str)
            assert_validated(v, depth + 1)
    elif isinstance(value, list):
        for v in value:
            assert_validated(v, depth + 1)
    elif isinstance(value, float):
        assert math.isfinite(value) and abs(value) <= MAX_MAGNITUDE
    elif isinstance(value, int) and not isinstance(value, bool):
        assert len(str(abs(value))) <= MAX_INT_DIGITS
    else:
        assert value is None or isinstance(value, str | bool)


def assert_one_line_error(exc: InputError, path: Path) -> None:
    msg = str(exc)
    assert "\n" not in msg and msg.startswith(f"{path}"), msg


#: what :func:`read_or_refused` returns for a refused file
REFUSED = object()


def read_or_refused(read, path: Path):
    """What ``read()`` returns, or :data:`REFUSED` where it refused the file with one
    :class:`InputError` line starting with ``path``."""
    try:
        return read()
    except InputError as exc:
        assert_one_line_error(exc, path)
        return REFUSED


# ------------------------------------------------------------------ mutations

def _paths(node, prefix=()):
    """Every (path, value) in a JSON value, containers included."""
    yield prefix, node
    items = node.items() if isinstance(node, dict) else enumerate(node) \
        if isinstance(node, list) else ()
    for key, value in items:
        yield from _paths(value, (*prefix, key))


def _get(doc, path):
    for key in path:
        doc = doc[key]
    return doc


MARK = "@@hostile@@"


@st.composite
def mutated_text(draw, valid_text: str) -> str | bytes:
    """One mutation of a valid document, as text (or bytes)."""
    doc = json.loads(valid_text)
    kind = draw(st.sampled_from(["replace", "token", "delete", "cut", "insert", "duplicate",
                                 "bytes"]))
    paths = [p for p, _ in _paths(doc) if p]
    if kind in ("replace", "token", "delete") and paths:
        path = draw(st.sampled_from(paths))
        parent = _get(doc, path[:-1])
        if kind == "delete":
            del parent[path[-1]]
            return json.dumps(doc)
        if kind == "replace":
            value = draw(json_values)
            parent[path[-1]] = value
            return json.dumps(doc)             # NaN and Infinity written as tokens
        parent[path[-1]] = MARK
        return json.dumps(doc).replace(json.dumps(MARK), draw(st.sampled_from(HOSTILE_TOKENS)))
    if kind == "cut":
        return valid_text[:draw(st.integers(0, len(valid_text)))]
    if kind == "insert":
        i = draw(st.integers(0, len(valid_text)))
        return valid_text[:i] + draw(st.sampled_from(list('{}[],:"0-eE\\ \x00'))) + valid_text[i:]
    if kind == "duplicate":
        objects = [p for p, v in _paths(doc) if isinstance(v, dict) and v]
        path = draw(st.sampled_from(objects))
        obj = _get(doc, path)
        key = draw(st.sampled_from(sorted(obj)))
        text = json.dumps({MARK: 0, **obj}) if path == () else None
        if text is None:
            parent = _get(doc, path[:-1])
            parent[path[-1]] = {MARK: 0, **obj}
            text = json.dumps(doc)
        value = draw(json_values.map(json.dumps))
        return text.replace(f'"{MARK}": 0', f"{json.dumps(key)}: {value}")
    raw = valid_text.encode()
    i = draw(st.integers(0, len(raw)))
    return raw[:i] + draw(st.binary(min_size=1, max_size=3)) + raw[i:]


def write(path: Path, content: str | bytes) -> None:
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8", errors="surrogatepass")


# ------------------------------------------------------------------- the reader itself

@pytest.mark.slow  # a large property test: ~2.5 s
@SETTINGS
@given(value=json_values)
def test_reader_on_random_documents(value, tmp_path):
    path = tmp_path / "doc.json"
    path.write_text(json.dumps(value))
    got = read_or_refused(lambda: read_json_document(path, top=None), path)
    if got is REFUSED:
        return
    assert_validated(got)
    assert got == json.loads(json.dumps(value))   # what was accepted is what was written


@SETTINGS
@given(data=st.binary(max_size=200))
def test_reader_on_random_bytes(data, tmp_path):
    path = tmp_path / "doc.json"
    path.write_bytes(data)
    got = read_or_refused(lambda: read_json_document(path, top=None), path)
    if got is REFUSED:
        return
    assert_validated(got)


def test_reader_limits_are_exact(tmp_path):
    """At each limit accepted, one beyond refused (with the JSON pointer)."""
    path = tmp_path / "doc.json"
    cases = [
        ("[" * MAX_DEPTH + "]" * MAX_DEPTH, None),
        ("[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1), "nested deeper than"),
        ('{"a": [' + "9" * MAX_INT_DIGITS + "]}", None),
        ('{"a": [' + "9" * (MAX_INT_DIGITS + 1) + "]}", "/a/0: an integer of 21 digits"),
        ('{"a": 1e100}', None),
        ('{"a": {"b": -1.0000001e100}}', "/a/b: -1e+100 is larger in size than 1e+100"),
        ('{"a~/b": NaN}', "/a~0~1b: NaN is not a finite number"),
        ('{"x": 1, "y": {"x": 2, "x": 3}}', "/y: duplicate key 'x'"),
    ]
    for text, error in cases:
        path.write_text(text)
        if error is None:
            read_json_document(path, top=None)
        else:
            with pytest.raises(InputError, match=f"^{path}: .*" + error.replace("+", r"\+")
                               .replace("[", r"\[")):
                read_json_document(path, top=None)


# ------------------------------------------------------------------------- handeye

@SETTINGS
@given(data=st.data())
def test_handeye_reader_on_mutated_documents(data, tmp_path):
    path = tmp_path / "poses.json"
    write(path, data.draw(mutated_text(EXAMPLE.read_text())))
    got = read_or_refused(lambda: load_handeye_input(path), path)
    if got is REFUSED:
        return
    for T in (got.T_cam_from_world, got.T_gaze_from_ptu):
        assert T.ndim == 3 and T.shape[1:] == (4, 4) and np.all(np.isfinite(T))
        # rigid within the validator's own tolerance (a mutated digit may stay inside it)
        RtR = T[:, :3, :3] @ np.swapaxes(T[:, :3, :3], 1, 2)
        assert np.all(np.abs(RtR - np.eye(3)) <= RIGID_ATOL)
    assert got.n_positions >= 3


# ------------------------------------------------------------------------ manifest

MANIFEST = {
    "format": "rasc-dataset/1", "board": {"inner_corners": [9, 6], "square_size": 0.05},
    "length_unit": "m", "angle_unit": "deg",
    "images": [{"file": "i/l0.png", "eye": "left", "role": "intrinsics"},
               {"file": "p/l0.png", "eye": "left", "role": "pose", "pan": 8.0, "tilt": -8.0,
                "view": "00"},
               {"file": "p/r0.png", "eye": "right", "role": "pose", "pan": 0, "tilt": 8,
                "view": "00"}],
    "ground_truth": "gt.json"}


@pytest.fixture
def dataset_folder(tmp_path):
    for name in ("i/l0.png", "p/l0.png", "p/r0.png"):
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_bytes(b"")
    (tmp_path / "gt.json").write_text('{"left": {}, "right": {}}')
    return tmp_path


@SETTINGS
@given(data=st.data())
def test_manifest_reader_on_mutated_manifests(data, dataset_folder):
    path = dataset_folder / "manifest.json"
    write(path, data.draw(mutated_text(json.dumps(MANIFEST))))
    ds = read_or_refused(lambda: load_dataset(dataset_folder), path)
    if ds is REFUSED:
        return
    nx, ny = ds.board.inner_corners
    assert isinstance(nx, int) and isinstance(ny, int) and nx > 0 and ny > 0
    assert math.isfinite(ds.board.square_size) and ds.board.square_size > 0
    for e in ds.images:
        assert e.eye in ("left", "right") and e.role in ("intrinsics", "pose")
        assert e.path.is_file() and dataset_folder in e.path.resolve().parents
        if e.role == "pose":
            assert abs(e.pan) <= 2 * math.pi and abs(e.tilt) <= 2 * math.pi


# ------------------------------------------------------------------ mounts, ground truth

MOUNTS = {"format": "rasc-mounts/1", "description": "measured",
          "T_ptuL_from_ptuR": [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0],
                               [0.0, 0.0, 1.0, -0.3], [0.0, 0.0, 0.0, 1.0]]}


@SETTINGS
@given(data=st.data())
def test_mounts_reader_on_mutated_files(data, tmp_path):
    path = tmp_path / "mounts.json"
    write(path, data.draw(mutated_text(json.dumps(MOUNTS))))
    T = read_or_refused(lambda: _read_mounts(str(path)), path)
    if T is REFUSED:
        return
    assert T.shape == (4, 4) and np.all(np.isfinite(T))
    assert np.all(np.abs(T[:3, :3] @ T[:3, :3].T - np.eye(3)) <= RIGID_ATOL)


GROUND_TRUTH = {"left": {"K": [[1000.0, 0, 640], [0, 1000.0, 480], [0, 0, 1]],
                         "T_cam_from_gaze": np.eye(4).tolist()},
                "right": {"dist": [0.0] * 5}, "render_options": {"seed": 2**63 - 1},
                "model_file": "scene.xml"}


@SETTINGS
@given(data=st.data())
def test_ground_truth_reader_on_mutated_files(data, dataset_folder):
    (dataset_folder / "manifest.json").write_text(json.dumps(MANIFEST))
    path = dataset_folder / "gt.json"
    write(path, data.draw(mutated_text(json.dumps(GROUND_TRUTH))))
    truth = read_or_refused(lambda: load_dataset(dataset_folder).load_ground_truth(), path)
    if truth is REFUSED:
        return
    assert isinstance(truth, dict)
    assert_validated(truth)
