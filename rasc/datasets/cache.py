"""One cache store: entries named by :func:`rasc.datasets.keys.cache_key`, each verified
by the sha256 of its content when read.

A file entry ``<folder>/<key>.entry`` is one header line and the payload::

    rasc-cache-entry/1 sha256=<64 hex> bytes=<n>
    <n bytes>

A folder entry ``<folder>/<key>/`` holds the artefact in ``data/`` and ``entry.json``
(``{"format": "rasc-cache-entry/1", "sha256": <tree digest of data/>}``).

Reading never trusts and never blocks: the entry is looked at with ``lstat`` (a symbolic
link, FIFO, socket or device is not an entry), opened without following links and
without blocking, read only up to its declared size (and :data:`MAX_ENTRY_BYTES`), and
its digest compared. Anything else, a folder where a file belongs or a file where a
folder belongs, is ignored with one note (``<label>: note: ignored the cache entry PATH
(why); computing it afresh``) and the caller computes the artefact again; storing is best
effort (a note when it cannot be written). ``RASC_CACHE_DIR=none`` (``off``, empty) turns
every store off.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
import stat
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

from rasc import formats
from rasc.errors import InputError
from rasc.io import cache_root, prune_cache, touch_cache_entry, tree_digest, write_bytes_atomic

ENTRY_FORMAT = formats.CACHE_ENTRY.tag
#: the largest file entry read (a bigger one is ignored): no cached document comes near it
MAX_ENTRY_BYTES = 512 * 2**20
_HEADER_MAX = 200


def cache_folder(name: str) -> Path | None:
    """``name`` under :func:`rasc.io.cache_root`, or None when the cache is off."""
    root = cache_root()
    return None if root is None else root / name


class EntryError(Exception):
    """Why a cache entry was not used (the note's reason)."""


def read_regular(path: Path, max_bytes: int) -> bytes | None:
    """The bytes of the regular file ``path`` (None: absent); EntryError for anything
    that is not one (a link, FIFO, device, folder) or too large; never blocks."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise EntryError(f"cannot look at it: {exc.strerror or exc}") from None
    if not stat.S_ISREG(st.st_mode):
        kind = ("a symbolic link" if stat.S_ISLNK(st.st_mode) else
                "a folder" if stat.S_ISDIR(st.st_mode) else
                "a FIFO" if stat.S_ISFIFO(st.st_mode) else "not a regular file")
        raise EntryError(f"{kind}, not a cache entry")
    if st.st_size > max_bytes:
        raise EntryError(f"{st.st_size} bytes, more than any entry")
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        raise EntryError(f"cannot open it: {exc.strerror or exc}") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode) or st.st_size > max_bytes:
            raise EntryError("not a regular file of a sensible size")
        chunks, left = [], st.st_size + 1
        while left > 0:
            chunk = os.read(fd, min(left, 1 << 20))
            if not chunk:
                break
            chunks.append(chunk)
            left -= len(chunk)
        return b"".join(chunks)
    except OSError as exc:
        raise EntryError(f"cannot read it: {exc.strerror or exc}") from None
    finally:
        os.close(fd)


def pack(payload: bytes) -> bytes:
    """A file entry: the header line (format, sha256, length) and ``payload``."""
    digest = hashlib.sha256(payload).hexdigest()
    return f"{ENTRY_FORMAT} sha256={digest} bytes={len(payload)}\n".encode() + payload


def unpack(data: bytes) -> bytes:
    """The payload of a file entry, verified (EntryError: damaged, edited, truncated)."""
    head, sep, payload = data[:_HEADER_MAX].partition(b"\n")
    if not sep:
        raise EntryError("no entry header (not written by this rasc)")
    parts = head.decode("ascii", "replace").split(" ")
    fields = dict(p.split("=", 1) for p in parts[1:] if "=" in p)
    if parts[0] != ENTRY_FORMAT or set(fields) != {"sha256", "bytes"}:
        raise EntryError("no entry header (not written by this rasc)")
    payload = data[len(head) + 1:]
    if str(len(payload)) != fields["bytes"]:
        raise EntryError(f"{len(payload)} bytes, the header says {fields['bytes']} "
                         "(truncated or extended)")
    if hashlib.sha256(payload).hexdigest() != fields["sha256"]:
        raise EntryError("its content does not match its sha256 (damaged or edited)")
    return payload


def _stderr_note(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


class CacheStore:
    """The entries of one cache folder (``name`` under the cache root, or ``folder``).

    ``label`` starts every note (``"rasc study"``, ``"reproduce"``); ``log`` prints it
    (default: stderr). ``store.enabled`` is False when the cache is off."""

    def __init__(self, name: str | None = None, *, folder: str | os.PathLike | None = None,
                 label: str = "rasc", log: Callable[[str], None] | None = None) -> None:
        self.folder = Path(folder) if folder is not None else (
            cache_folder(name) if name is not None else None)
        self.label = label
        self.log = log or _stderr_note
        #: the notes given (for tests and callers that count them)
        self.notes: list[str] = []

    @property
    def enabled(self) -> bool:
        """Whether the store caches at all (False: ``RASC_CACHE_DIR`` is none or off)."""
        return self.folder is not None

    def note(self, text: str) -> None:
        """Say one line about the cache (an entry ignored, a write refused) and keep it."""
        line = f"{self.label}: note: {text}"
        self.notes.append(line)
        self.log(line)

    def _ignored(self, path: Path, why: str) -> None:
        self.note(f"ignored the cache entry {path} ({why}); computing it afresh")

    # ------------------------------------------------------------- file entries

    def path(self, key: str) -> Path | None:
        """Where the file entry of ``key`` lives (None: no cache)."""
        return None if self.folder is None else self.folder / f"{key}.entry"

    def get_bytes(self, key: str) -> bytes | None:
        """The verified payload stored under ``key``, or None (absent, off, or ignored
        with a note)."""
        path = self.path(key)
        if path is None:
            return None
        try:
            data = read_regular(path, MAX_ENTRY_BYTES)
            if data is None:
                return None
            payload = unpack(data)
        except EntryError as exc:
            self._ignored(path, str(exc))
            return None
        touch_cache_entry(path)                    # used: the last to be pruned
        return payload

    def put_bytes(self, key: str, payload: bytes) -> bool:
        """Store ``payload`` under ``key`` atomically (best effort: a note when it cannot
        be written). Returns whether it was stored."""
        path = self.path(key)
        if path is None:
            return False
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            if os.path.lexists(path) and not stat.S_ISREG(os.lstat(path).st_mode):
                _set_aside(path)          # an ignored link, FIFO or folder: replaced
            write_bytes_atomic(path, pack(payload))
            prune_cache(self.folder, keep=path)
            return True
        except (OSError, InputError) as exc:
            self.note(f"could not cache in {self.folder} ({' '.join(str(exc).split())})")
            return False

    def get_json(self, key: str, check: Callable[[dict], None] | None = None) -> dict | None:
        """The JSON object stored under ``key`` (verified; ``check`` may raise ValueError
        for a document of the wrong kind), or None."""
        payload = self.get_bytes(key)
        if payload is None:
            return None
        from rasc.io import parse_json_text
        try:
            doc = parse_json_text(payload.decode("utf-8"), str(self.path(key)), "cache entry")
            if not isinstance(doc, dict):
                raise ValueError("not a JSON object")
            if check is not None:
                check(doc)
        except (InputError, ValueError, UnicodeDecodeError) as exc:
            self._ignored(self.path(key), " ".join(str(exc).split())[:200])
            return None
        return doc

    def put_json(self, key: str, doc: dict) -> bool:
        """Store ``doc`` as a JSON file entry (:meth:`put_bytes`); False when it cannot."""
        from rasc.io import dumps_json
        return self.put_bytes(key, dumps_json(doc).encode("utf-8"))

    # ------------------------------------------------------------- folder entries

    def tree(self, key: str) -> Path | None:
        """Where the folder entry of ``key`` lives (None: no cache)."""
        return None if self.folder is None else self.folder / key

    def get_tree(self, key: str) -> Path | None:
        """The verified folder ``<key>/data`` stored under ``key``, or None."""
        entry = self.tree(key)
        if entry is None:
            return None
        try:
            st = os.lstat(entry)
        except FileNotFoundError:
            return None
        except OSError as exc:
            self._ignored(entry, f"cannot look at it: {exc.strerror or exc}")
            return None
        if not stat.S_ISDIR(st.st_mode):
            self._ignored(entry, "not a folder")
            return None
        try:
            record = read_regular(entry / "entry.json", 1 << 16)
            if record is None:
                raise EntryError("no entry.json (unfinished or not written by this rasc)")
            import json
            want = json.loads(record).get("sha256")
            data = entry / "data"
            if os.path.islink(data) or not data.is_dir():
                raise EntryError("no data folder")
            files = list(data.rglob("*"))
            for f in files:
                if f.is_symlink() or not (f.is_file() or f.is_dir()):
                    raise EntryError(f"{f.relative_to(entry)} is not a regular file")
            if tree_digest(data, files) != want:
                raise EntryError("its content does not match its sha256 (damaged or edited)")
        except (EntryError, ValueError, AttributeError, OSError) as exc:
            self._ignored(entry, " ".join(str(exc).split())[:200])
            return None
        touch_cache_entry(entry)
        return data

    def put_tree(self, key: str, folder: str | os.PathLike, *, move: bool = False
                 ) -> Path | None:
        """Store a copy of ``folder`` (moved with ``move``) under ``key``, whole or not at
        all; an ignored entry in the way is replaced. Returns the stored ``data`` folder,
        or None (off, or a note saying why it could not be stored)."""
        entry = self.tree(key)
        if entry is None:
            return None
        import json
        tmp = None
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            tmp = Path(tempfile.mkdtemp(prefix=".tmp-", dir=self.folder))
            if move:
                shutil.move(str(folder), tmp / "data")
            else:
                shutil.copytree(folder, tmp / "data", symlinks=True)
            digest = tree_digest(tmp / "data", (tmp / "data").rglob("*"))
            (tmp / "entry.json").write_text(json.dumps({"format": ENTRY_FORMAT,
                                                        "sha256": digest}))
            if os.path.lexists(entry):                 # a damaged or foreign entry
                _set_aside(entry)
            try:
                os.rename(tmp, entry)                    # atomic: all or nothing
            except OSError:
                if self.get_tree(key) is None:          # not another process's
                    raise
            prune_cache(self.folder, keep=entry)
            return entry / "data"
        except OSError as exc:
            self.note(f"could not cache in {self.folder} ({' '.join(str(exc).split())})")
            return None
        finally:
            if tmp is not None and tmp.exists():
                shutil.rmtree(tmp, ignore_errors=True)


def _set_aside(path: Path) -> None:
    """Remove what is in a cache entry's place (the link itself, never its target; a
    folder by renaming it aside first, so that no reader sees it half-removed)."""
    if os.path.isdir(path) and not os.path.islink(path):
        aside = Path(tempfile.mkdtemp(prefix=".tmp-", dir=path.parent))
        os.replace(path, aside / "old")
        shutil.rmtree(aside, ignore_errors=True)
    else:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(path)
