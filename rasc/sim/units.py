"""How each simulated pan-tilt unit is built: the imperfections ``rasc render`` can give it.

A real unit's tilt axis misses the pan axis, the two axes are not quite orthogonal, the
encoders have zero offsets and scale errors, and the camera sits wherever it was bolted
on (docs/METHOD.md §10). :class:`UnitBuild` states these for one simulated unit in the
units a person measures them in (millimetres, degrees); :func:`read_unit_file` reads them
from the TOML parameter file of ``rasc render --unit FILE`` (README "rasc render")::

    [both]                              # applies to both units; [left]/[right] override
    tilt_axis_offset_mm = [0, 30, 0]    # a point of the tilt axis, tilt-link frame, mm
    axis_skew_deg = 1.0                 # tilt axis turned about forward (y): 89° between axes
    [left]
    pan_zero_deg = 0.5                  # encoder zero offsets: angle = scale·reading + zero
    tilt_zero_deg = -0.5
    pan_scale = 1.002
    tilt_scale = 0.998
    camera_position_mm = [48, 36, 21]   # the camera's origin on the tilt link, mm
    camera_euler_deg = [1.3, -2.1, 0.8] # its misalignment (MuJoCo camera euler, degrees)

Keys left out keep the model's value (the stock model's unit is the paper's ideal one).
Frames: the tilt link's frame at home, which for the stock model is the unit's ptu frame
(x up, y forward, z left, origin at the pan axis). numpy only; :mod:`rasc.sim.scene`
applies a build to the MuJoCo model.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, fields
from pathlib import Path

from rasc.errors import InputError
from rasc.geometry.frames import EYES
from rasc.io import finite_number, read_text_file

_VECTORS = ("tilt_axis_offset_mm", "camera_position_mm", "camera_euler_deg")
_NUMBERS = ("axis_skew_deg", "pan_zero_deg", "tilt_zero_deg", "pan_scale", "tilt_scale")
#: |axis_skew_deg| must stay below this: at 90° the two axes would be parallel
MAX_SKEW_DEG = 45.0


@dataclass(frozen=True)
class UnitBuild:
    """The imperfections of one simulated pan-tilt unit (all optional).

    Attributes
    ----------
    tilt_axis_offset_mm : (3,) tuple or None
        A point of the tilt axis in the tilt link's frame at home (stock model: the ptu
        frame, x up, y forward, z left), millimetres; None keeps the model's joint anchor
        (stock: the pan axis's point, no offset). Its component along the common normal
        of the two axes (for the stock axes: y) is the observable axis distance.
    axis_skew_deg : float or None
        Non-orthogonality: the tilt axis is turned by this angle about the tilt link's
        forward (y) axis, towards the pan axis (x); the angle between the axes becomes
        90° − skew. None (default) keeps the model's joint axis.
    pan_zero_deg, tilt_zero_deg : float
        Encoder zero offsets o in degrees: the joint turns to ``scale · reading + o``
        when the reading (what the manifest records) is commanded.
    pan_scale, tilt_scale : float
        Encoder scales (positive; 1 is exact).
    camera_position_mm : (3,) tuple or None
        The camera's origin (optical centre) on the tilt link, in the tilt link's frame,
        millimetres (sets body ``{eye}_camera_link``'s pos); None keeps the model's.
    camera_euler_deg : (3,) tuple or None
        The camera's MuJoCo ``euler`` (its misalignment in the housing, degrees, in the
        camera's own axes); None keeps the model's.
    """

    tilt_axis_offset_mm: tuple[float, float, float] | None = None
    axis_skew_deg: float | None = None
    pan_zero_deg: float = 0.0
    tilt_zero_deg: float = 0.0
    pan_scale: float = 1.0
    tilt_scale: float = 1.0
    camera_position_mm: tuple[float, float, float] | None = None
    camera_euler_deg: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        _check(self, "UnitBuild")

    @property
    def edits_model(self) -> bool:
        """True when the MuJoCo model itself must change (joint or camera placement)."""
        return any(getattr(self, k) is not None
                   for k in ("tilt_axis_offset_mm", "axis_skew_deg", "camera_position_mm",
                             "camera_euler_deg"))

    def to_dict(self) -> dict:
        """JSON-ready, every key (None for 'as in the model')."""
        return {f.name: (list(v) if isinstance(v := getattr(self, f.name), tuple) else v)
                for f in fields(self)}


def _check(build: UnitBuild, where: str) -> None:
    for name in _VECTORS:
        value = getattr(build, name)
        if value is not None:
            object.__setattr__(build, name, _vector(value, f"{where}.{name}"))
    for name in _NUMBERS:
        value = getattr(build, name)
        if value is None and name == "axis_skew_deg":
            continue
        object.__setattr__(build, name, finite_number(value, f"{where}.{name}"))
    for name in ("pan_scale", "tilt_scale"):
        if getattr(build, name) <= 0:
            raise InputError(f"{where}.{name}: must be positive, got {getattr(build, name)}")
    if build.axis_skew_deg is not None and abs(build.axis_skew_deg) >= MAX_SKEW_DEG:
        raise InputError(f"{where}.axis_skew_deg: must be within ±{MAX_SKEW_DEG:g} degrees, "
                         f"got {build.axis_skew_deg}")


def _vector(value, where: str) -> tuple[float, float, float]:
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise InputError(f"{where}: expected 3 numbers [x, y, z], got {value!r}")
    return tuple(finite_number(v, f"{where}[{k}]") for k, v in enumerate(value))  # type: ignore


#: The model as written (the stock model's units are the paper's).
IDEAL_BUILD = UnitBuild()


def build_from_dict(data: dict, where: str) -> UnitBuild:
    """A :class:`UnitBuild` from a table; unknown keys raise InputError naming ``where``."""
    known = _VECTORS + _NUMBERS
    for key in data:
        if key not in known:
            raise InputError(f"{where}.{key}: unknown key (known: {', '.join(known)})")
    build = UnitBuild.__new__(UnitBuild)
    defaults = {f.name: f.default for f in fields(UnitBuild)}
    for name, default in defaults.items():
        object.__setattr__(build, name, data.get(name, default))
    _check(build, where)
    return build


def merge(base: UnitBuild, **changes) -> UnitBuild:
    """``base`` with the non-None ``changes`` applied (checked again)."""
    values = {f.name: getattr(base, f.name) for f in fields(UnitBuild)}
    values.update({k: v for k, v in changes.items() if v is not None})
    return build_from_dict({k: v for k, v in values.items() if v is not None}, "UnitBuild")


def read_unit_file(path: str | Path) -> dict[str, UnitBuild]:
    """Read ``rasc render --unit FILE``: tables ``[both]``, ``[left]``, ``[right]``.

    Returns ``{"left": UnitBuild, "right": UnitBuild}``: [both] first, then each eye's
    own table key by key. Errors (missing file, bad TOML, unknown table or key, wrong
    type, non-finite value) are one-line :class:`InputError`\\ s naming file and key.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: unit parameter file not found")
    # the one reader of input text (a device such as /dev/zero is refused unread)
    text = read_text_file(path, "unit parameter file", 1 << 20)
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML: {' '.join(str(exc).split())}") from None
    tables = ("both",) + EYES
    for key, value in doc.items():
        if key not in tables:
            raise InputError(f"{path}: {key}: unknown table or key (expected the tables "
                             f"[both], [left], [right])")
        if not isinstance(value, dict):
            raise InputError(f"{path}: {key}: expected a table [{key}], got a value")
    both = doc.get("both", {})
    build_from_dict(both, f"{path}: both")
    out = {}
    for eye in EYES:
        own = doc.get(eye, {})
        build_from_dict(own, f"{path}: {eye}")
        out[eye] = build_from_dict({**both, **own}, f"{path}: {eye}")
    return out
