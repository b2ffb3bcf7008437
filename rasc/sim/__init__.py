"""The simulated stereo head: the MuJoCo model (top-level ``sim/models/`` in a checkout,
shipped in the wheel as the package data ``rasc/sim/models/``), offscreen rendering and
image degradation (:mod:`~rasc.sim.scene`, the only module that imports mujoco, lazily)
and dataset rendering (:mod:`~rasc.sim.render`)."""

from pathlib import Path


def models_dir(package: str | Path | None = None) -> Path:
    """The folder of the MJCF models for the rasc package folder ``package`` (default: the
    imported one): ``rasc/sim/models/`` in an installed wheel (package data, mapped from
    ``sim/models/`` by setup.py), else the checkout's top-level ``sim/models/`` beside it."""
    root = Path(__file__).resolve().parent.parent if package is None else Path(package)
    inside = root / "sim" / "models"
    return inside if inside.is_dir() else root.parent / "sim" / "models"


#: The MJCF models (``stereo_head.xml``, ``scene.xml``) and their README.
MODELS_DIR = models_dir()

#: The default of :attr:`rasc.sim.render.RenderOptions.supersample` (``rasc render
#: --supersample``, the study parameter ``supersample``): each image rendered at twice the
#: width and height and averaged over 2 x 2 pixels, which halves the plain render's
#: corner error (0.0193 -> 0.0098 px RMS, the stock chessboard's pose views) for about 3
#: times its render time, and restores the plan's prediction of the unit's axis angle
#: (docs/results/supersample.md, where the default is chosen). Here, in the package's
#: lightest module, so that building the command line's parser reads it without loading
#: numpy; 1 is the plain render (the default before 2026-11-28).
DEFAULT_SUPERSAMPLE = 2


def __getattr__(name: str):
    """Names the old module ``rasc.sim`` had: forwarded with a DeprecationWarning."""
    from rasc import moved_attribute

    return moved_attribute(__name__, name)
