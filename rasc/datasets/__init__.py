"""The dataset service: render → cache → detect → calibrate, with one key and one cache.

The dataset is rasc's one dataset class, :class:`rasc.vision.dataset.Dataset` (a folder,
images in memory, or given corners). Render: :func:`rasc.sim.render.render_in_memory`
(what a study renders: no file), or :func:`rasc.datasets.render.rendered` (a dataset
folder kept in the cache: ``rasc.testing``, the reproduction, the tests). Detect:
``Dataset.detect`` (from the files or the arrays). Calibrate:
:func:`rasc.datasets.calibration.calibrate`, whose document — the service's calibration
of a dataset, :data:`rasc.formats.DATASET_CALIBRATION` — is what a study caches.

Every cached artefact rasc makes between runs (a rendered dataset folder, a study's
calibrated dataset document, the reproduction's calibration) goes through
:class:`rasc.datasets.cache.CacheStore` under one key, :func:`cache_key`, made from one
code digest, :func:`code_digest`. Each entry carries the sha256 of its content and is
verified when read: a corrupt, edited or truncated entry, a symbolic link, a FIFO, a
device or a folder in place of an entry is ignored with a note and computed afresh
(never trusted, never blocking). ``RASC_CACHE_DIR=none`` means no cache, everywhere.
"""

from rasc.datasets.cache import CacheStore, cache_folder
from rasc.datasets.keys import cache_key, code_digest, content_key

__all__ = ["CacheStore", "cache_folder", "cache_key", "code_digest", "content_key"]
