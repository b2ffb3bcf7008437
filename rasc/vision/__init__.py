"""Images: the chessboard, corner detection and camera calibration (OpenCV), and rasc's
one dataset class, :class:`~rasc.vision.dataset.Dataset` (the dataset folder format
``rasc-dataset/1``, images in memory, or given corners), with its reader
:func:`~rasc.vision.dataset.load_dataset` and writer
:func:`~rasc.vision.dataset.write_dataset` (importable from here, lazily)."""

_DATASET_NAMES = ("Dataset", "load_dataset", "write_dataset")


def __getattr__(name: str):
    if name in _DATASET_NAMES:
        from rasc.vision import dataset

        return getattr(dataset, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted([*globals(), *_DATASET_NAMES])
