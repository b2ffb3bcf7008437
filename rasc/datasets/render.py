"""Rendered dataset folders through the dataset service: one key per render, entries in
one verified store (:class:`rasc.datasets.CacheStore`)."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from dataclasses import asdict
from pathlib import Path
from typing import Any

from rasc.datasets.cache import CacheStore
from rasc.datasets.keys import cache_key


def render_what(options: Any, model_path: str | os.PathLike | None = None,
                units: dict | None = None, board: Any = None) -> dict:
    """What a rendered dataset depends on beside the code: its
    :class:`rasc.sim.render.RenderOptions` (as a dict), the sha256 of the model file
    it was rendered from (None: the package's model, part of the code digest; for a
    :class:`rasc.sim.urdf.UrdfHead` that of the URDF with its names and intrinsics), for
    an imperfect head its units (``{eye: rasc.sim.units.UnitBuild}``) and for a target
    drawn from its description (``rasc render --target``) the target's manifest object
    (None, the ideal units, the model's board, ``supersample`` 1, a camera degradation,
    a continuous-motion field or the lens at its default (:data:`rasc.sim.render.DEGRADATIONS`,
    :data:`~rasc.sim.render.CONTINUOUS`, :data:`~rasc.sim.render.LENS_FIELDS`) adds nothing,
    so the keys of the stock head and board are those of before). ``supersample`` is left
    out at 1, the plain render (the keys of before the option), not at its default (2): the
    default's renders have a key of their own, and a plain render is never served for a
    supersampled one."""
    opts = dict(options) if isinstance(options, dict) else asdict(options)
    if opts.get("supersample", 1) == 1:     # the plain render adds nothing: keys of before
        opts.pop("supersample", None)
    from rasc.sim.render import (
        CONTINUOUS,
        DEGRADATIONS,
        LENS_FIELDS,
        continuous_of,
        degradations_of,
        lens_fields_of,
    )

    # a camera degradation, a continuous-motion field or the lens at its default adds nothing
    kept = {**degradations_of(opts), **continuous_of(opts), **lens_fields_of(opts)}
    for k in (*DEGRADATIONS, *CONTINUOUS, *LENS_FIELDS):
        if k not in kept:
            opts.pop(k, None)
    model = None if model_path is None else hashlib.sha256(
        Path(getattr(model_path, "path", model_path)).read_bytes()).hexdigest()
    if hasattr(model_path, "cameras"):    # a rasc.sim.urdf.UrdfHead: the file and its names
        model = {"urdf": model, "joints": list(model_path.joints),
                 "cameras": list(model_path.cameras), "image_size": model_path.image_size,
                 "K": None if model_path.K is None else
                 {eye: [[float(v) for v in row] for row in k]
                  for eye, k in model_path.K.items()}}
    what = {"options": opts, "model": model}
    if units is not None:
        what["units"] = {eye: asdict(b) for eye, b in sorted(units.items())}
    if board is not None:
        what["board"] = board.to_dict()
    return json.loads(json.dumps(what, default=list))


def render_key(options: Any, model_path: str | os.PathLike | None = None,
               units: dict | None = None, board: Any = None) -> str:
    """The one cache key (:func:`rasc.datasets.cache_key`, kind ``render-folder``) of
    the dataset ``options`` render (with ``model_path``, ``units``, ``board``)."""
    return cache_key("render-folder", render_what(options, model_path, units, board))


_SCRATCH: list[Path] = []


def _scratch() -> Path:
    """This process's temporary folder for datasets rendered without a cache (removed
    when the process exits)."""
    if not _SCRATCH:
        import atexit
        _SCRATCH.append(Path(tempfile.mkdtemp(prefix="rasc-rendered-")))
        atexit.register(shutil.rmtree, _SCRATCH[0], True)
    return _SCRATCH[0]


def rendered(options: Any, model_path: str | os.PathLike | None = None,
             store: CacheStore | None = None, units: dict | None = None,
             board: Any = None) -> tuple[Path, str]:
    """``(folder, key)`` of the dataset ``options`` render (of the model at
    ``model_path``, or of the stock head with the target ``board``; ``units`` the
    imperfect pan-tilt units): the store's verified entry, else rendered now (into a
    temporary folder, then moved into the store whole; without a store, or when it
    cannot be written, into this process's scratch folder)."""
    from rasc.sim.render import render_dataset

    key = render_key(options, model_path, units, board)
    path = store.get_tree(key) if store is not None and store.enabled else None
    if path is not None:
        return path, key
    tmp = Path(tempfile.mkdtemp(prefix="rasc-render-"))
    try:
        render_dataset(tmp / "data", options, model_path=model_path, quiet=True, units=units,
                       board=board)
        if store is not None and store.enabled:
            path = store.put_tree(key, tmp / "data", move=True)
        if path is None:
            path = _scratch() / key / "data"
            if not path.is_dir():
                path.parent.mkdir(parents=True, exist_ok=True)
                shutil.move(str(tmp / "data"), path)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return path, key
