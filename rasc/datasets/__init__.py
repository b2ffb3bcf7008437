"""The dataset service: render → cache → detect → calibrate, with one key and one cache.

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
