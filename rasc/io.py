"""Files in and out, by one set of rules (README, "What rasc refuses and what it warns").

* :func:`read_json_document`: the ONE reader of every JSON input document (the handeye
  input, the dataset manifest, ``--mounts``, ``ground_truth.json``). Regular files only,
  at most :data:`MAX_DOCUMENT_BYTES`, UTF-8, no duplicate keys, nesting at most
  :data:`MAX_DEPTH`, integers of at most :data:`MAX_INT_DIGITS` digits, every number
  finite and at most :data:`MAX_MAGNITUDE` in size. Every refusal is one
  :class:`~rasc.errors.InputError` line naming the file and where (line:column for
  syntax, a JSON pointer such as ``/images/3/pan`` for values).
* :func:`check_output`: the ONE output rule, checked before any long work: an output path
  never resolves (symbolic links followed, hard links compared) to an input, to an
  existing file inside an input folder, or to a folder where a file is expected.
* :func:`write_bytes_atomic` / :func:`write_json_atomic`: a result file appears whole or
  not at all; :func:`write_stdout`: standard output that cannot be written (a full
  device) is one error line.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import stat
import sys
import tempfile
import threading
from pathlib import Path
from typing import Any

import numpy as np

from rasc.errors import DegenerateDataError, InputError


def cache_root() -> Path | None:
    """Where rasc keeps files between runs (the reproduction's default dataset and its
    calibration, a study's rendered datasets): ``$RASC_CACHE_DIR`` (``none``, ``off``
    or empty: no cache, None), else ``$XDG_CACHE_HOME/rasc`` or ``~/.cache/rasc``. Each
    cache folder under it keeps at most :func:`cache_max_bytes` (:func:`prune_cache`)."""
    root = os.environ.get("RASC_CACHE_DIR")
    if root is not None and root.strip().lower() in ("none", "off", ""):
        return None
    if not root:
        root = str(Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "rasc")
    cache_max_bytes()                  # a bad RASC_CACHE_MAX_MB is refused before any work
    return Path(root)


#: The most each of rasc's caches (a folder under :func:`cache_root`) keeps, in bytes, unless
#: ``$RASC_CACHE_MAX_MB`` says otherwise: beyond it the least recently used entries go.
CACHE_MAX_BYTES = 256 * 2**20


def cache_max_bytes() -> int:
    """The size each cache folder is pruned to: ``$RASC_CACHE_MAX_MB`` (a number of MiB
    ≥ 0; anything else is refused) or :data:`CACHE_MAX_BYTES`."""
    value = os.environ.get("RASC_CACHE_MAX_MB")
    if value is None or not value.strip():
        return CACHE_MAX_BYTES
    try:
        mb = float(value)
    except ValueError:
        mb = math.nan
    if not (math.isfinite(mb) and mb >= 0):
        raise InputError(f"RASC_CACHE_MAX_MB: expected a number of MiB >= 0, got {value!r}")
    return int(mb * 2**20)


def touch_cache_entry(path: str | os.PathLike) -> None:
    """Mark a cache entry as just used (its modification time: :func:`prune_cache` removes
    the least recently used first). Best effort."""
    with contextlib.suppress(OSError):
        os.utime(path)


def _entry_bytes(path: Path) -> int:
    if path.is_dir() and not path.is_symlink():
        total = 0
        for folder, _, files in os.walk(path):
            for f in files:
                with contextlib.suppress(OSError):
                    total += os.lstat(os.path.join(folder, f)).st_size
        return total
    return path.lstat().st_size


def prune_cache(folder: str | os.PathLike, max_bytes: int | None = None,
                keep: str | os.PathLike | None = None) -> list[Path]:
    """Remove a cache folder's least recently used entries (the files and folders directly
    in it, oldest modification time first; readers :func:`touch_cache_entry` what they use)
    until the rest take at most ``max_bytes`` (default :func:`cache_max_bytes`).

    ``keep`` (the entry just written) is never removed, nor an entry being written
    (``.tmp-*``, ``.*.tmp``). Best effort: an entry another process removes or uses at the
    same time is skipped or, at worst, rebuilt by its next reader. Returns what was removed.
    """
    import shutil

    folder = Path(folder)
    budget = cache_max_bytes() if max_bytes is None else max_bytes
    keep = None if keep is None else Path(keep).resolve()
    entries = []
    try:
        children = list(folder.iterdir())
    except OSError:
        return []
    for p in children:
        if p.name.startswith(".") or p.name.endswith(".tmp"):
            continue
        try:
            entries.append((p.lstat().st_mtime, p.name, p, _entry_bytes(p)))
        except OSError:
            continue
    total = sum(e[3] for e in entries)
    removed = []
    for _, _, p, size in sorted(entries):
        if total <= budget:
            break
        if keep is not None and p.resolve() == keep:
            continue
        try:
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p)
            else:
                p.unlink()
        except OSError:
            continue
        total -= size
        removed.append(p)
    return removed


@contextlib.contextmanager
def folder_built_atomically(out: str | os.PathLike, flag: str = "--out",
                            meanwhile: str = ""):
    """A temporary folder beside ``out`` (with the usual permissions, not mkdtemp's 0700)
    to build a dataset folder in; renamed to ``out`` when the block ends without error
    (atomic: it replaces an empty folder and fails on a non-empty one, so two writers
    cannot mix their files), removed otherwise. An interrupt removes it and raises
    :class:`rasc.interrupt.Interrupted` saying nothing was written. ``meanwhile`` is added
    to the message when ``out`` appeared during the work (e.g. " (another render?)")."""
    import shutil

    from rasc.interrupt import Interrupted, shielded

    out = Path(out)
    parent = out.parent if str(out.parent) else Path(".")
    try:
        tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".tmp", dir=parent))
    except OSError as exc:
        raise InputError(f"{flag} {out}: cannot create a folder in {parent}: "
                         f"{exc.strerror or exc}") from None
    try:
        umask = os.umask(0)
        os.umask(umask)
        tmp.chmod(0o777 & ~umask)
        yield tmp
        try:
            os.rename(tmp, out)
        except OSError as exc:
            raise InputError(f"{flag} {out}: appeared meanwhile{meanwhile}: "
                             f"{exc.strerror or exc}; nothing written") from None
    except KeyboardInterrupt:
        with shielded(reraise=False):
            shutil.rmtree(tmp, ignore_errors=True)
        raise Interrupted(f"nothing written (removed the partial dataset {tmp})") from None
    except BaseException:
        with shielded():
            shutil.rmtree(tmp, ignore_errors=True)
        raise


def tree_digest(root: str | os.PathLike, files) -> str:
    """sha256 over the path relative to ``root``, the length and the bytes of every
    regular file of ``files`` (in sorted order; ``__pycache__`` and ``.pyc`` left out):
    what a cache entry built from those files depends on."""
    import hashlib

    root = Path(root)
    h = hashlib.sha256()
    for p in sorted(Path(f) for f in files):
        if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc":
            data = p.read_bytes()
            h.update(p.relative_to(root).as_posix().encode() + b"\0"
                     + len(data).to_bytes(8, "little") + data)
    return h.hexdigest()


def module_files(root: str | os.PathLike, modules) -> list[Path]:
    """The source files of the ``modules`` (dotted names of the package whose folder is
    ``root``, e.g. ``rasc.sim.render``) and of every module of that package they import,
    transitively, with the ``__init__.py`` of each package on the way: the code a cache
    entry built by those modules depends on, for :func:`tree_digest`.

    Found by the standard library's :class:`modulefinder.ModuleFinder`, which reads the
    compiled sources without running them: every ``import`` counts, including those
    inside functions (they run when the function does), relative ones and ``from p import
    module``. It searches only the folder that holds ``root``, so other packages and the
    standard library are not followed. Sorted; a name that is no module of the package is
    left out (it is not its code)."""
    import modulefinder

    root = Path(root)
    finder = modulefinder.ModuleFinder(path=[str(root.parent)])
    for name in modules:
        top, *rest = name.split(".")
        base = root.joinpath(*rest)
        if top == root.name and ((base / "__init__.py").is_file()
                                 or base.with_suffix(".py").is_file()):
            finder.import_hook(name)
    files = {Path(m.__file__) for m in finder.modules.values() if m.__file__}
    return sorted(p for p in files if p.is_relative_to(root))


def write_bytes_atomic(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise InputError(f"{path}: cannot write: folder {folder} does not exist")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise InputError(f"{path}: cannot write: {exc.strerror or exc}") from None
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(exc, OSError):
            raise InputError(f"{path}: cannot write: {exc.strerror or exc}") from None
        raise


def write_text_atomic(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` as UTF-8 to ``path`` atomically (:func:`write_bytes_atomic`)."""
    write_bytes_atomic(path, text.encode("utf-8"))


def to_jsonable(obj: Any) -> Any:
    """``json.dumps``'s ``default``: numpy arrays and scalars, and paths, as JSON data."""
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    raise TypeError(f"value of type {type(obj).__name__} is not JSON data")


#: an array holding only numbers (no nested array or object), as json.dumps(indent=2)
#: writes it: one number a line. The newline after "[" cannot occur inside a JSON string
#: (strings escape newlines), so text inside strings is never touched.
_FLAT_NUMBER_ARRAY = re.compile(
    r"\[\n\s*(-?[0-9][-+0-9.eE]*(?:,\n\s*-?[0-9][-+0-9.eE]*)*)\n\s*\]")


_native_stderr_lock = threading.Lock()


@contextlib.contextmanager
def native_stderr_captured():
    """Redirect file descriptor 2 into a temporary file while the block runs: what C
    libraries print there themselves (libpng's ``libpng error: Read Error`` before
    OpenCV returns nothing) never reaches the user beside rasc's one line. Yields a list
    that receives the captured text (decoded, stripped) when the block ends, for the
    message. One block at a time in a process (a lock: the descriptor is process-wide)."""
    said: list[str] = []
    with _native_stderr_lock:
        try:
            sys.stderr.flush()
            saved = os.dup(2)
        except (OSError, ValueError, AttributeError):   # no descriptor 2 to redirect
            yield said
            return
        try:
            with tempfile.TemporaryFile() as tmp:
                os.dup2(tmp.fileno(), 2)
                try:
                    yield said
                finally:
                    os.dup2(saved, 2)
                    tmp.seek(0)
                    said.append(tmp.read(4096).decode("utf-8", "replace").strip())
        finally:
            os.close(saved)


def _non_finite_field(obj: Any, path: str = "") -> str | None:
    """The first field of ``obj`` (``a.b[3]``) holding NaN or infinity, else None."""
    if isinstance(obj, dict):
        for key in sorted(obj, key=str):
            found = _non_finite_field(obj[key], f"{path}.{key}" if path else str(key))
            if found:
                return found
        return None
    if isinstance(obj, list | tuple | np.ndarray):
        for i, value in enumerate(obj):
            found = _non_finite_field(value, f"{path}[{i}]")
            if found:
                return found
        return None
    if isinstance(obj, float | np.floating) and not math.isfinite(obj):
        return path or "value"
    return None


def dumps_json(obj: Any) -> str:
    """Deterministic JSON (sorted keys, fixed indentation): same data, same bytes.

    Arrays of plain numbers stay on one line, so a 4×4 matrix reads as four rows.
    """
    try:
        text = json.dumps(obj, indent=2, sort_keys=True, default=to_jsonable, allow_nan=False)
    except ValueError:        # NaN or infinity: never written; say which field
        where = _non_finite_field(obj)
        if where is None:
            raise
        raise DegenerateDataError(f"the result's {where} is not a finite number: the data "
                                  "do not determine it; nothing written") from None
    text = _FLAT_NUMBER_ARRAY.sub(lambda m: "[" + re.sub(r",\s+", ", ", m.group(1)) + "]", text)
    return text + "\n"


def write_json_atomic(path: str | os.PathLike, obj: Any) -> None:
    """Write ``obj`` as deterministic JSON (:func:`dumps_json`) to ``path`` atomically."""
    write_text_atomic(path, dumps_json(obj))


def write_stdout(text: str) -> None:
    """Write ``text`` to standard output and flush it; a full device or a closed pipe is
    an :class:`InputError` (one line) instead of a traceback at exit."""
    try:
        sys.stdout.write(text)
        sys.stdout.flush()
    except OSError as exc:
        _silence_stdout()
        raise InputError(f"standard output: cannot write: {exc.strerror or exc}") from None


def _silence_stdout() -> None:
    """Point file descriptor 1 at /dev/null, so that Python's flush at exit cannot fail
    a second time (and print "Exception ignored ...") after the error line."""
    with contextlib.suppress(OSError, ValueError, AttributeError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)


# ------------------------------------------------------------------------ reading JSON

#: Largest input document read (bytes). Far above any real one: a manifest lists about
#: 120 bytes per image (a 100 000-image manifest is 12 MB), a handeye position about 500.
#: A larger file (or a device such as /dev/zero named by mistake) is refused unread.
MAX_DOCUMENT_BYTES = 64 * 1024 * 1024

#: Deepest nesting of arrays and objects accepted. The deepest valid document is 4
#: (a 4x4 matrix inside a position inside a list inside the top object); Python's
#: parser itself gives up near 1000 with a RecursionError.
MAX_DEPTH = 32

#: Longest integer accepted (digits). Every integer rasc reads (board corners, counts,
#: seeds, angles written as whole numbers) has far fewer; Python refuses to parse more
#: than 4300 digits, and numbers beyond 10**308 cannot become floats.
MAX_INT_DIGITS = 20

#: Largest magnitude of any non-integer number accepted (integers are exact and bounded
#: by MAX_INT_DIGITS instead, so that seeds up to 2**64 pass). Products of up to three
#: such numbers (a 3x3 determinant, a transform applied to a point, a jackknife's squared
#: deviations) stay below float overflow (1.8e308), so no later arithmetic turns an
#: accepted input into infinity; and no value a rasc document holds comes near it (a
#: solver's condition number, the largest, stays below 1e17 in double precision).
#: Whether a value is plausible (an angle within a full turn, a positive square size)
#: is the business of each field's validation.
MAX_MAGNITUDE = 1e100


class _Bad:
    """A number the JSON parser met that the reader refuses once it knows where it is."""

    __slots__ = ("problem",)

    def __init__(self, problem: str):
        self.problem = problem


class _Pairs(list):
    """A JSON object as the parser saw it: (key, value) pairs, duplicates kept."""


def _parse_int(text: str):
    digits = len(text.lstrip("-"))
    if digits > MAX_INT_DIGITS:
        return _Bad(f"an integer of {digits} digits (at most {MAX_INT_DIGITS} accepted)")
    return int(text)


def _parse_float(text: str):
    value = float(text)
    if not math.isfinite(value):
        return _Bad(f"{text[:24]} overflows to infinity")
    return value


def _parse_constant(text: str):
    return _Bad(f"{text} is not a finite number")


def _pointer(path: tuple) -> str:
    """RFC 6901 JSON pointer of ``path`` (keys and indices); "" (the whole document) as "/"."""
    if not path:
        return "/"
    # control characters (a newline in a key) escaped as JSON writes them: one line
    return "".join("/" + json.dumps(str(p))[1:-1].replace("~", "~0").replace("/", "~1")
                   for p in path)


def _validated(node, path: tuple, depth: int, where: str):
    """Pairs → dicts (duplicate keys refused), bad numbers refused, depth bounded."""
    if depth >= MAX_DEPTH and isinstance(node, list):    # _Pairs is a list too
        raise InputError(f"{where}: {_pointer(path)}: nested deeper than {MAX_DEPTH} levels")
    if isinstance(node, _Bad):
        raise InputError(f"{where}: {_pointer(path)}: {node.problem}")
    if isinstance(node, _Pairs):
        out: dict = {}
        for key, value in node:
            if key in out:
                raise InputError(f"{where}: {_pointer(path)}: duplicate key {key!r} (a JSON "
                                 "object names each key once; which one was meant?)")
            out[key] = _validated(value, (*path, key), depth + 1, where)
        return out
    if isinstance(node, list):
        return [_validated(v, (*path, k), depth + 1, where) for k, v in enumerate(node)]
    if isinstance(node, float) and abs(node) > MAX_MAGNITUDE:
        raise InputError(f"{where}: {_pointer(path)}: {node:.6g} is larger in size than "
                         f"{MAX_MAGNITUDE:g}, too large to compute with")
    return node


def parse_json_text(text: str, where: str, what: str = "document") -> Any:
    """Parse JSON ``text`` by :func:`read_json_document`'s rules; ``where`` names it."""
    if text.startswith("\ufeff"):          # a byte-order mark some editors write
        text = text[1:]
    try:
        node = json.loads(text, object_pairs_hook=_Pairs, parse_int=_parse_int,
                          parse_float=_parse_float, parse_constant=_parse_constant)
    except json.JSONDecodeError as exc:
        raise InputError(f"{where}: malformed JSON at line {exc.lineno}, column {exc.colno}: "
                         f"{exc.msg}") from None
    except RecursionError:
        raise InputError(f"{where}: arrays or objects nested deeper than {MAX_DEPTH} "
                         f"levels; not a {what}") from None
    return _validated(node, (), 0, where)


def read_text_file(path: str | os.PathLike, what: str, max_bytes: int) -> str:
    """The UTF-8 text of a regular file of at most ``max_bytes`` (a byte-order mark is
    dropped): the one way rasc reads an input document (JSON, CSV).

    Raises :class:`InputError`, one line starting with the path: empty path, missing, a
    folder, not a regular file (a device, FIFO or socket is refused before anything is
    read: ``/dev/zero`` would never end), larger than ``max_bytes``, unreadable, not UTF-8.
    """
    where = str(path)
    if where in ("", "."):
        raise InputError(f"{what}: empty path")
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise InputError(f"{where}: no such file (the {what})") from None
    except OSError as exc:
        raise InputError(f"{where}: cannot read: {exc.strerror or exc}") from None
    if stat.S_ISDIR(st.st_mode):
        raise InputError(f"{where}: is a folder, not a {what} file")
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"{where}: not a regular file (a device, pipe or socket); the "
                         f"{what} must be a file")
    if st.st_size > max_bytes:
        raise InputError(f"{where}: {st.st_size} bytes, more than the {max_bytes} "
                         f"bytes a {what} may have")
    try:
        # O_NONBLOCK: a FIFO swapped in after the check cannot block the open
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(fd, "rb") as f:
            if not stat.S_ISREG(os.fstat(f.fileno()).st_mode):
                raise InputError(f"{where}: not a regular file; the {what} must be a file")
            data = f.read(max_bytes + 1)
    except OSError as exc:
        raise InputError(f"{where}: cannot read: {exc.strerror or exc}") from None
    if len(data) > max_bytes:
        raise InputError(f"{where}: more than the {max_bytes} bytes a {what} may have")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"{where}: not UTF-8 text (byte {exc.start}); save the {what} "
                         "as UTF-8") from None


def read_json_document(path: str | os.PathLike, what: str = "document", *,
                       top: type | None = dict) -> Any:
    """Read the JSON input document ``path`` (a ``what``: "manifest", "mounts file", ...).

    Parameters
    ----------
    path : the file (symbolic links followed)
    what : what the file is, for messages
    top : the required type of the top-level value (``dict``: a JSON object), or None

    Returns
    -------
    The document as dicts, lists, str, int, float (finite, at most MAX_MAGNITUDE in
    size), bool and None.

    Raises
    ------
    InputError
        One line starting with the path: missing, a folder, not a regular file (a
        device, FIFO or socket is refused before anything is read), larger than
        MAX_DOCUMENT_BYTES, unreadable, not UTF-8 (with the byte offset), malformed JSON
        (line, column), duplicate keys, nesting deeper than MAX_DEPTH, integers longer
        than MAX_INT_DIGITS digits, NaN, Infinity, numbers that overflow or exceed
        MAX_MAGNITUDE (each with its JSON pointer), or the wrong top-level type.
    """
    where = str(path)
    text = read_text_file(path, what, MAX_DOCUMENT_BYTES)
    doc = parse_json_text(text, where, what)
    if top is dict and not isinstance(doc, dict):
        raise InputError(f"{where}: the {what} must be a JSON object {{...}} at the top "
                         f"level, got {_json_type(doc)}")
    if top is list and not isinstance(doc, list):
        raise InputError(f"{where}: the {what} must be a JSON array at the top level, "
                         f"got {_json_type(doc)}")
    return doc


def _json_type(value: Any) -> str:
    return {dict: "an object", list: "an array", str: "a string", bool: "a boolean",
            int: "a number", float: "a number", type(None): "null"}.get(type(value),
                                                                       type(value).__name__)


# ------------------------------------------------------------------------- output rule

def _identity(path: str | os.PathLike) -> tuple[int, int] | None:
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return None
    return st.st_dev, st.st_ino


def check_output(path: str | os.PathLike | None, *, inputs=(), input_folders=(),
                 kind: str = "file", flag: str = "--out") -> Path:
    """The output rule, checked before any long work; returns ``path`` as a Path.

    Parameters
    ----------
    path : the output path as the user gave it
    inputs : every input file of the command (documents, images, ...), any order
    input_folders : input folders (a dataset): no existing file inside one may be an output
    kind : "file" (a result file, written atomically) or "folder" (a new folder)
    flag : the option's name, for messages

    Raises
    ------
    InputError
        One line: an empty path, ``.``, a file path that is a folder (or a link to one) or
        not a regular file (a device: atomic writing would replace it), a path that
        resolves to an input (symbolic links followed, hard links compared) or to an
        existing file inside an input folder, a folder path that exists as a file or is a
        symbolic link, a missing or unwritable parent folder. An existing output file
        that is no input is replaced (atomically).
    """
    if path is None or str(path).strip() == "":
        raise InputError(f"{flag}: empty path; name a {kind}")
    text = os.fspath(path)
    p = Path(text)
    if kind not in ("file", "folder"):
        raise ValueError(f"kind must be 'file' or 'folder', got {kind!r}")
    if kind == "file":
        if text.endswith(("/", os.sep)) or p.name in ("", ".", ".."):
            raise InputError(f"{flag} {text}: names a folder; give a file name")
        if p.is_dir():
            link = " (a symbolic link to a folder)" if p.is_symlink() else ""
            raise InputError(f"{text}: cannot write: it is a folder{link}; give {flag} a "
                             "file name")
        if p.exists() and not p.is_file():
            raise InputError(f"{flag} {text}: not a regular file (a device or pipe); write "
                             "to standard output and redirect it instead")
    else:
        if p.name in ("", ".", "..") or os.path.realpath(text) == os.path.realpath("."):
            raise InputError(f"{flag} {text}: the current or parent folder; name a new "
                             "folder for the output")
        if p.is_symlink():
            raise InputError(f"{flag} {text}: is a symbolic link; name the folder itself")
        if p.exists() and not p.is_dir():
            raise InputError(f"{flag} {text}: exists as a file; name a new folder")
    out_real = os.path.realpath(text)
    out_id = _identity(text)
    for inp in inputs:
        if inp is None:
            continue
        same = os.path.realpath(inp) == out_real or (out_id is not None
                                                      and _identity(inp) == out_id)
        if same:
            also = "" if os.fspath(inp) == text else f" ({inp})"
            what = "folder" if Path(inp).is_dir() else "file"
            raise InputError(f"{flag} {text} is the input {what}{also}; choose another path")
        if kind == "folder" and Path(inp).is_file() and \
                os.path.realpath(inp).startswith(out_real.rstrip(os.sep) + os.sep):
            raise InputError(f"{flag} {text}: holds an input of this command ({inp}); "
                             "choose another folder")
    for folder in input_folders:
        if folder is None:
            continue
        root = os.path.realpath(folder).rstrip(os.sep) + os.sep
        if kind == "file" and out_real.startswith(root) and os.path.lexists(text):
            raise InputError(f"{flag} {text}: is a file of the input dataset {folder}; "
                             "choose a new file name")
        if kind == "folder" and (out_real + os.sep).startswith(root):
            raise InputError(f"{flag} {text}: is inside the input folder {folder}; choose "
                             "another folder")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"{text}: cannot write: folder {parent} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{text}: cannot write: folder {parent} is not writable")
    return p


def _probe_writable(folder: Path, what: str) -> None:
    """Create and remove a temporary file in ``folder``: the atomic writers' first step.
    ``os.access`` says yes to root everywhere, also in /proc and /sys, where nothing can
    be created: this asks the file system itself."""
    try:
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".rasc-probe-"):
            pass
    except OSError as exc:
        raise InputError(f"{what}: cannot write: {exc.strerror or exc}") from None


def check_outputs(outputs, *, inputs=(), input_folders=()) -> None:
    """Every output of a command against every input, and against each other, before any
    work (one mechanism for every command and option that writes).

    Parameters
    ----------
    outputs : iterable of ``(flag, path, kind, files)``
        ``kind`` "file" (written atomically) or "folder" (created if missing, then
        ``files``, the names the command writes into it, each written atomically);
        an entry whose path is None is skipped.
    inputs, input_folders : as :func:`check_output`

    Each output obeys :func:`check_output`; a folder's files are outputs too (an input
    image named like one of them is never overwritten); two outputs may not be the same
    path; the folder each output is written in must take a file (probed: a path under
    /proc or /sys is refused here, not after the work). Raises :class:`InputError`.
    """
    seen: dict[str, str] = {}
    folders: dict[str, str] = {}
    for flag, path, kind, files in outputs:
        if path is None:
            continue
        check_output(path, inputs=inputs, input_folders=input_folders, kind=kind, flag=flag)
        targets = [Path(path)] if kind == "file" else [Path(path) / f for f in files]
        for target in targets:
            if kind == "folder" and Path(path).is_dir():
                check_output(target, inputs=inputs, input_folders=input_folders,
                             flag=f"{flag} {path}:")
            real = os.path.realpath(target)
            if real in folders:
                raise InputError(f"{flag} {path}: is the output folder of "
                                 f"{folders[real]}; give another path")
            if real in seen:
                raise InputError(f"{flag} {path}: would write {target}, which "
                                 f"{seen[real]} also writes; give different paths")
            seen[real] = f"{flag} {path}"
        if kind == "folder":
            real = os.path.realpath(path)
            if real in seen:
                raise InputError(f"{flag} {path}: is the output file of "
                                 f"{seen[real]}; give a folder")
            folders[real] = f"{flag} {path}"
        folder = Path(path).parent if kind == "file" else Path(path)
        if kind == "folder" and not folder.exists():
            folder = folder.parent if str(folder.parent) else Path(".")
            probe = Path(path)
            try:      # make the folder now (a path under /proc is refused before work)
                probe.mkdir()
            except OSError as exc:
                raise InputError(f"{flag} {path}: cannot create the folder: "
                                 f"{exc.strerror or exc}") from None
            try:
                _probe_writable(probe, f"{flag} {path}")
            finally:
                probe.rmdir()
            continue
        _probe_writable(folder if str(folder) else Path("."), f"{flag} {path}")


# ----------------------------------------------------------------- checking values

def shown(value: Any, limit: int = 40) -> str:
    """A value as the user wrote it (JSON spelling where it has one: ``"8"``, ``true``,
    ``null``), cut to ``limit`` characters, for error messages."""
    try:
        text = json.dumps(value, allow_nan=True)
    except (TypeError, ValueError):
        text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def finite_number(value: Any, where: str, *, text: bool = False,
                  max_abs: float | None = None) -> float:
    """The ONE check of a single number read from a file or an option: a finite int or
    float (a numpy number too), not a boolean, string or null; with ``text`` a string
    such as a table cell or an option value, parsed by ``float``. With ``max_abs`` also
    ``|value| <= max_abs``. Returns it as a float; otherwise raises one
    :class:`~rasc.errors.InputError` line starting with ``where``:

    * ``<where>: expected a number, got <value>`` (``empty; expected a number`` for an
      empty cell);
    * ``<where>: must be finite, got <value>`` (NaN or infinity);
    * ``<where>: <value> is out of range (|value| > <max_abs>)``.

    An empty ``where`` gives the problem alone (``expected a number, got "x"``), for a
    caller that puts the place in front itself (the study spec's value checkers:
    ``<file>: <key>: <problem>``).
    """
    at = f"{where}: " if where else ""
    if text and isinstance(value, str):
        s = value.strip()
        if not s:
            raise InputError(f"{at}empty; expected a number")
        try:
            x = float(s)
        except ValueError:
            raise InputError(f"{at}expected a number, got {shown(s)}") from None
    else:
        if isinstance(value, bool | np.bool_) or not isinstance(value, int | float | np.number):
            raise InputError(f"{at}expected a number, got {shown(value)}")
        try:
            x = float(value)
        except OverflowError:                     # an integer beyond the float range
            raise InputError(f"{at}{shown(value)} is out of range") from None
    if not math.isfinite(x):
        raise InputError(f"{at}must be finite, got {shown(value)}")
    if max_abs is not None and abs(x) > max_abs:
        raise InputError(f"{at}{shown(value)} is out of range (|value| > {max_abs:g})")
    return x


def finite_numbers(values: Any, where: str, *, count: int | None = None, what: str = "",
                   text: bool = False, max_abs: float | None = None) -> tuple[float, ...]:
    """:func:`finite_number` over a list: a list, tuple or 1-D array of numbers, or with
    ``text`` a comma-separated string (``"-0.2,0.05"``; an empty string is no numbers).
    With ``count``, exactly that many. Returns them as a tuple of floats; otherwise one
    :class:`~rasc.errors.InputError` line:

    * ``<where>: expected <count> numbers (<what>), got <n>: <values>`` (or ``expected a
      list of numbers (<what>), got <value>``);
    * item k (from 0) as :func:`finite_number` with ``<where>[k]``.
    """
    about = f" ({what})" if what else ""
    if text and isinstance(values, str):
        items: list = [] if not values.strip() else values.split(",")
    elif isinstance(values, list | tuple) or (isinstance(values, np.ndarray)
                                              and values.ndim == 1):
        items = list(values)
    else:
        raise InputError(f"{where}: expected a list of numbers{about}, got {shown(values)}")
    if count is not None and len(items) != count:
        raise InputError(f"{where}: expected {count} numbers{about}, got {len(items)}: "
                         f"{shown(values)}")
    return tuple(finite_number(v, f"{where}[{k}]", text=text, max_abs=max_abs)
                 for k, v in enumerate(items))
