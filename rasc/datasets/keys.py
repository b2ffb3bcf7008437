"""The one key of the dataset service: a content key of JSON-able parameters, and the
cache key that adds the one code digest (:func:`code_digest`)."""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
from pathlib import Path
from typing import Any

from rasc import formats

#: the distributions whose versions enter the code digest (the first of each group found)
CACHE_LIBRARIES = (("numpy",), ("scipy",), ("mujoco",),
                   ("opencv-python-headless", "opencv-python", "opencv-contrib-python",
                    "opencv-contrib-python-headless"))
#: the format of a cache key's record (bump it when an entry's layout changes)
KEY_FORMAT = formats.CACHE_KEY.tag

_CODE_DIGEST: list[str] = []


def _plain(v: Any) -> Any:
    return list(v) if isinstance(v, tuple) else v


def content_key(what: Any, length: int = 20) -> str:
    """sha256 of ``what`` as canonical JSON (sorted keys, tuples as lists), its first
    ``length`` hex digits: the identity of a set of parameters (a study's dataset, cell)."""
    blob = json.dumps(what, sort_keys=True, default=_plain, separators=(",", ":"))
    return hashlib.sha256(blob.encode()).hexdigest()[:length]


def code_digest() -> str:
    """sha256 over rasc's version, every file of the installed package (its code and
    models) and the versions of the libraries that render, detect and solve: what every
    cached artefact depends on. Computed once per process."""
    if not _CODE_DIGEST:
        import rasc
        from rasc.io import tree_digest

        root = Path(rasc.__file__).parent
        h = hashlib.sha256(f"rasc {rasc.__version__}\0".encode())
        h.update(tree_digest(root, root.rglob("*")).encode())
        from rasc.sim import MODELS_DIR  # a checkout's top-level sim/models/ (not in root)
        if root not in MODELS_DIR.parents:
            h.update(tree_digest(MODELS_DIR, MODELS_DIR.rglob("*")).encode())
        for names in CACHE_LIBRARIES:
            for name in names:
                try:
                    h.update(f"{name} {importlib.metadata.version(name)}\0".encode())
                    break
                except importlib.metadata.PackageNotFoundError:
                    continue
        _CODE_DIGEST.append(h.hexdigest())
    return _CODE_DIGEST[0]


def cache_key(kind: str, what: dict[str, Any], code: str | None = None) -> str:
    """The cache key (32 hex digits) of an artefact of ``kind`` ("render-folder",
    "study-dataset", "study-poses", "calibration") made from ``what``, by the code of
    :func:`code_digest` (or ``code``)."""
    return content_key({"format": KEY_FORMAT, "code": code or code_digest(), "kind": kind,
                        "what": what}, 32)
