"""Simulated stereo head: MuJoCo model, offscreen rendering and ground truth.

The model lives in ``sim/models/`` (:data:`rasc.sim.MODELS_DIR`;
``stereo_head.xml`` = the head, ``scene.xml`` = head +
chessboard target); its frames are those of :mod:`rasc.geometry.frames` (README "Frames") and
``sim/models/README.md``. Everything this module reports as ground truth is read from the
compiled model, never retyped:

* per eye ``T_cam_from_gaze`` (hand-eye, ``T_cg``), ``T_ptu_from_base`` (``T_pb``), ``K``
  (OpenCV pixel convention, centres at integers) and the image size;
* per eye the pan-tilt unit as the general model :class:`rasc.geometry.kinematics.PanTiltUnit`
  (eq. 3 for the stock model), read from the joints' anchors and axes, and all three in
  the canonical gauge (:func:`rasc.geometry.kinematics.canonical_gauge`);
* at the current state, ``T_cam_from_world`` (the target) and ``T_cam_from_base``, so that
  eq. 1–2 hold: ``T_cam_from_base = T_cam_from_gaze @ unit.T_gaze_from_ptu(pan, tilt) @
  T_ptu_from_base`` (checked against MuJoCo's camera frame by
  :meth:`StereoHeadSim.check_ground_truth`, at every pose ``rasc render`` renders).

Imperfect units (tilt-axis offset, axis skew, encoder zeros and scales, camera placement)
come from :class:`rasc.sim.units.UnitBuild`.

MuJoCo's global frame is called ``scene`` here (z up), to keep ``world`` for the target
(the chessboard frame w of docs/CONTRACTS.md). Only this module imports ``mujoco``, and
only inside functions: the OpenGL backend (``MUJOCO_GL``) must be chosen before the first
import (:func:`gl_backend`), so code that needs the module calls :func:`import_mujoco`.
The scene's MJCF (:func:`scene_xml`, :func:`scene_assets`, the model paths) comes from
:mod:`rasc.sim.mjcf`, image degradation (noise, blur, lens distortion; numpy/scipy only)
from :mod:`rasc.sim.degrade`; both are re-exported here.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from rasc.errors import InputError, RascError
from rasc.geometry.frames import EYES
from rasc.geometry.kinematics import PanTiltUnit, canonical_gauge, cyclopean_base
from rasc.geometry.transforms import (
    invert_transform,
    make_transform,
    rotation_angle,
    validate_rigid_transform,
)
from rasc.sim.degrade import (  # noqa: F401  (re-exported: rasc.sim.scene's names)
    add_pixel_noise,
    blur,
    degrade,
    distort,
    distortion_warp,
)
from rasc.sim.mjcf import (  # noqa: F401  (re-exported: rasc.sim.scene's names)
    CHARUCO_TEXTURE,
    HEAD_XML,
    MODELS_DIR,
    SCENE_XML,
    T_base_from_world_facing,
    scene_assets,
    scene_xml,
)
from rasc.sim.units import IDEAL_BUILD, UnitBuild
from rasc.vision.board import (  # noqa: F401  (DEFAULT_BOARD, CharucoBoard re-exported)
    DEFAULT_BOARD,
    Board,
    CharucoBoard,
    board_from_dict,
)

#: OpenCV camera axes from MuJoCo camera axes (x right; y up → down; z back → forward).
_CV_FROM_MJ = np.diag([1.0, -1.0, -1.0])

#: Largest element of ``T_cam_from_base`` by which the ground truth (unit, hand-eye,
#: mount) may differ from MuJoCo's own camera frame. The chain of a dozen float64
#: transforms of entries ≤ 2 (metres) agrees to ~1e-15; MuJoCo's float64 kinematics
#: likewise. 1e-9 (1 nm, 1e-9 rad) is six orders above round-off and six below any
#: modelling error worth a calibration (0.001 mm).
GROUND_TRUTH_TOL = 1e-9

# ---------------------------------------------------------------------------------------
# OpenGL backend

#: Backends probed, in order, when MUJOCO_GL is unset, with the Debian packages each needs.
GL_BACKENDS = {"egl": "libegl1 libegl-mesa0 libgl1-mesa-dri", "osmesa": "libosmesa6"}
_GL_HELP = ("install the Debian packages libegl1 libegl-mesa0 libgl1-mesa-dri (MUJOCO_GL=egl) "
            "or libosmesa6 (MUJOCO_GL=osmesa)")
_PROBE = ("import mujoco; m = mujoco.MjModel.from_xml_string('<mujoco/>'); "
          "r = mujoco.Renderer(m, 8, 8); r.update_scene(mujoco.MjData(m)); r.render(); r.close()")
_gl_choice: str | None = None


def _probe_backend(name: str) -> bool:
    """True when ``MUJOCO_GL=name`` imports mujoco and renders, in a fresh interpreter."""
    env = dict(os.environ, MUJOCO_GL=name)
    env.pop("PYOPENGL_PLATFORM", None)
    try:
        proc = subprocess.run([sys.executable, "-c", _PROBE], env=env, capture_output=True,
                              timeout=120, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return proc.returncode == 0


def gl_backend() -> str:
    """Choose the OpenGL backend once per process and set ``MUJOCO_GL`` before import.

    A ``MUJOCO_GL`` set by the user is respected as is. Unset: probe ``egl`` then
    ``osmesa`` in subprocesses (the choice is fixed when mujoco is imported, so probing
    in-process cannot retry) and keep the first that renders.

    Raises
    ------
    RascError
        No backend works; the message names the Debian packages that fix it.
    """
    global _gl_choice
    if _gl_choice is None:
        user = os.environ.get("MUJOCO_GL")
        if user or "mujoco" in sys.modules:
            _gl_choice = user or "(already imported)"
        else:
            for name in GL_BACKENDS:
                if _probe_backend(name):
                    os.environ["MUJOCO_GL"] = _gl_choice = name
                    break
            else:
                raise RascError(f"no OpenGL backend for offscreen rendering: MUJOCO_GL=egl and "
                                f"MUJOCO_GL=osmesa both fail; {_GL_HELP}")
    return _gl_choice


def _gl_error(exc: BaseException) -> RascError:
    value = os.environ.get("MUJOCO_GL", "")
    first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return RascError(f"MUJOCO_GL={value!r}: cannot render offscreen ({first}); use "
                     f"MUJOCO_GL=egl or MUJOCO_GL=osmesa, or unset it to probe; {_GL_HELP}")


def import_mujoco():
    """Import mujoco after :func:`gl_backend`; backend failures become one RascError."""
    if "mujoco" not in sys.modules:
        gl_backend()
    try:
        import mujoco
    except Exception as exc:  # RuntimeError (bad value), AttributeError (osmesa missing)
        from rasc.interrupt import received

        if received():  # a signal while mujoco loads surfaces as its import error
            raise KeyboardInterrupt from None
        raise _gl_error(exc) from None
    return mujoco


#: A cyclopean base closer than this to base_link (largest element) is base_link itself:
#: the stock model's two units sit symmetrically on it, and its cyclopean base differs
#: from it by round-off (2e-16) only; taking base_link exactly keeps its renders the bytes
#: they were.
BASE_LINK_ROUNDOFF = 1e-12


def base_from_base_link(T_ptuL_from_base_link: np.ndarray,
                        T_ptuR_from_base_link: np.ndarray) -> np.ndarray:
    """``T_base_from_base_link`` (4, 4): the calibration's base (the cyclopean base of the
    two units' canonical frames, :func:`rasc.geometry.kinematics.cyclopean_base`) in the
    model's ``base_link`` frame, given each unit's canonical mount on ``base_link``.

    Identity (exactly) when the two differ by round-off (:data:`BASE_LINK_ROUNDOFF`)."""
    T_pLpR = T_ptuL_from_base_link @ invert_transform(T_ptuR_from_base_link)
    T_pb_left, _ = cyclopean_base(T_pLpR)
    T = invert_transform(T_pb_left) @ T_ptuL_from_base_link
    if float(np.abs(T - np.eye(4)).max()) < BASE_LINK_ROUNDOFF:
        return np.eye(4)
    return T


# ---------------------------------------------------------------------------------------
# The simulator

#: What ground_truth.json says about its base frame.
BASE = ("the calibration's base: the cyclopean base of the two units' canonical frames "
        "(rasc.geometry.kinematics.cyclopean_base of T_ptuL_from_ptuR), so that every "
        "transform here compares with a calibration's as it is; the model's body base_link "
        "is T_base_from_base_link from it (identity for the stock head; encoder zeros "
        "turn it about the pan axes)")

#: What ground_truth.json says about its gauge.
GAUGE = ("canonical (rasc.geometry.kinematics.canonical_gauge): pan axis = ptu x, tilt axis "
         "in the ptu x-z plane, tilt point on the common normal (0, d, 0), no encoder "
         "offsets; T_cam_from_base(readings) = T_cam_from_gaze . unit.T_gaze_from_ptu(readings)"
         " . T_ptu_from_base")


def _pose(xpos: np.ndarray, xmat: np.ndarray) -> np.ndarray:
    """``T_scene_from_x`` (4, 4) from MuJoCo's position (3,) and flattened axes (9,)."""
    return make_transform(np.asarray(xmat, dtype=float).reshape(3, 3), xpos)


def T_cam_from_scene_mujoco(cam_xpos: np.ndarray, cam_xmat: np.ndarray) -> np.ndarray:
    """OpenCV ``T_cam_from_scene`` (4, 4) of a MuJoCo camera at ``cam_xpos`` (3,), ``cam_xmat``.

    The one place MuJoCo camera axes (look along −z, +y up) become OpenCV's (+z forward,
    +y down): ``R = diag(1, −1, −1) · xmatᵀ``, ``t = −R · xpos`` (docs/NOTES.md).
    """
    R = _CV_FROM_MJ @ np.asarray(cam_xmat, dtype=float).reshape(3, 3).T
    return make_transform(R, -R @ np.asarray(cam_xpos, dtype=float))


#: the prefix of the target's elements while they are attached (:func:`spec_with_target`)
_TARGET_PREFIX = "rasc_target_"
#: the target's elements rasc reads by name (:meth:`StereoHeadSim._read_board`)
_TARGET_NAMES = (("body", "board_link"), ("site", "board_origin"),
                 ("numeric", "rasc_board_inner_corners"), ("numeric", "rasc_board_square_size"),
                 ("text", "rasc_target"))


def spec_with_target(spec, board):
    """A model's ``mujoco.MjSpec`` with its target (the mocap body ``board_link``, the custom
    numerics ``rasc_board_*`` and text ``rasc_target``) replaced by ``board``'s as
    :func:`scene_xml` draws it: the target's body, with its materials, texture and custom
    data, attached from the scene of the target alone; the model's lights, cameras, floor
    and visual settings stay. ``spec`` is edited and returned."""
    import re

    mujoco = import_mujoco()
    for kind, name in _TARGET_NAMES:
        element = getattr(spec, kind)(name)
        if element is not None and kind != "site":       # the site goes with its body
            spec.delete(element)
    assets = scene_assets(board)
    alone = re.sub(r'<include file="[^"]*"/>', "", scene_xml(board), count=1)
    target = mujoco.MjSpec.from_string(alone, assets=assets)
    for kind, name in (("geom", "floor"), ("material", "floor"), ("camera", "overview")):
        target.delete(getattr(target, kind)(name))
    spec.worldbody.add_frame().attach_body(target.body("board_link"), _TARGET_PREFIX, "")
    for kind, name in _TARGET_NAMES:
        element = getattr(spec, kind)(_TARGET_PREFIX + name)
        if element is not None:
            element.name = name
    spec.assets = {**spec.assets, **assets}
    return spec


class StereoHeadSim:
    """The simulated head: set pan/tilt and the target, render, read ground truth.

    Parameters
    ----------
    model_path : path or rasc.sim.urdf.UrdfHead, optional
        A head described in a URDF (:class:`rasc.sim.urdf.UrdfHead`: compiled by MuJoCo,
        renamed and given cameras by :func:`rasc.sim.urdf.head_spec`, the target
        ``board`` or the stock one in front), or the MJCF scene to load (default
        ``sim/models/scene.xml``). Must contain the bodies
        ``base_link``, ``{eye}_ptu_link``, ``{eye}_tilt_link``, joints ``{eye}_pan_joint``,
        ``{eye}_tilt_joint`` and cameras ``{eye}_camera`` for eye in (left, right); a
        target (mocap body ``board_link``, site ``board_origin``, custom numerics
        ``rasc_board_*``) is optional.
    board : Board, optional
        The target, drawn from its description (:func:`scene_xml`): without
        ``model_path``, the generated scene (kept in ``self.scene_xml``) around the head
        model ``head_path``; with a ``model_path`` that has no target (a head alone), the
        same scene around that model; with a ``model_path`` that has its own target, that
        target replaced by this one (the model's lights, cameras and settings kept,
        :func:`spec_with_target`).
    head_path : path, optional
        Head model for ``board`` (default ``sim/models/stereo_head.xml``).
    image_size : (width, height), optional
        Render size; default the cameras' ``resolution`` (1280×960). K scales with it.
    units : {"left": UnitBuild, "right": UnitBuild}, optional
        How each pan-tilt unit is built (:class:`rasc.sim.units.UnitBuild`): tilt-axis
        offset, axis skew, camera placement (applied to the MJCF through ``MjSpec``) and
        encoder zero offsets and scales (applied by :meth:`set_angles`). Default: the
        model as written (the stock model: the paper's ideal unit).

    Angles are radians. :meth:`set_angles` takes encoder *readings*; the joints turn to
    ``scale · reading + zero``. Each unit is read from the compiled model into the
    general model :class:`rasc.geometry.kinematics.PanTiltUnit` (joint anchors and axes),
    and reported in the canonical gauge (:func:`rasc.geometry.kinematics.canonical_gauge`);
    :meth:`check_ground_truth` compares it with MuJoCo's camera frame. Use as a context
    manager or call :meth:`close`.
    """

    def __init__(self, model_path: str | os.PathLike | None = None, *,
                 board: Board | None = None, head_path: str | os.PathLike | None = None,
                 image_size: tuple[int, int] | None = None,
                 units: dict[str, UnitBuild] | None = None) -> None:
        mujoco = import_mujoco()
        self._renderer = None
        self._view_renderers: dict = {}       # render_view's, by size
        self._board = board
        #: the URDF head this simulator renders (:mod:`rasc.sim.urdf`), or None
        self.urdf = None
        self.scene_xml: str | None = None
        self.units = self._check_units(units)
        spec = None
        from rasc.sim.urdf import UrdfHead

        if board is not None and model_path is not None and \
                not isinstance(model_path, UrdfHead):
            if head_path is not None:
                raise InputError("StereoHeadSim: give model_path or head_path, not both")
            if not Path(model_path).is_file():
                raise InputError(f"{model_path}: model file not found")
            where = Path(model_path).resolve()
            spec = self._load(lambda: mujoco.MjSpec.from_file(str(where)), where)
            if spec.body("board_link") is None:     # a head alone: the scene around it
                head_path, model_path, spec = model_path, None, None
        if isinstance(model_path, UrdfHead):
            if head_path is not None:
                raise InputError("StereoHeadSim: give a UrdfHead or head_path, not both")
            self.model_file = model_path.path.resolve()
            self.urdf = model_path
            self.units, edited = self._urdf_units(model_path)
            self.model = self._load(lambda: edited.compile(), self.model_file)
        elif spec is not None:
            self.model_file = where
            edited = spec_with_target(spec, board)
            self.model = self._load(lambda: self._compile(lambda: edited, edited.compile),
                                    self.model_file)
        elif board is not None:
            if head_path is not None and not Path(head_path).is_file():
                raise InputError(f"{head_path}: head model file not found")
            self.model_file = Path(HEAD_XML if head_path is None else head_path).resolve()
            self.scene_xml = scene_xml(board, self.model_file)
            assets = scene_assets(board)
            self.model = self._load(lambda: self._compile(
                lambda: mujoco.MjSpec.from_string(self.scene_xml, assets=assets),
                lambda: mujoco.MjModel.from_xml_string(self.scene_xml, assets)),
                self.model_file)
        else:
            if model_path is None:
                if not SCENE_XML.is_file():
                    raise RascError(f"{SCENE_XML}: default model not found; the rasc package "
                                    "ships it as package data: reinstall rasc, or pass an "
                                    "explicit model_path")
                model_path = SCENE_XML
            self.model_file = Path(model_path).resolve()
            if not self.model_file.is_file():
                raise InputError(f"{model_path}: model file not found")
            self.model = self._load(lambda: self._compile(
                lambda: mujoco.MjSpec.from_file(str(self.model_file)),
                lambda: mujoco.MjModel.from_xml_path(str(self.model_file))), self.model_file)
        self.data = mujoco.MjData(self.model)
        self._ids = self._lookup_names()
        self._readings = {eye: (0.0, 0.0) for eye in EYES}
        self.board = self._read_board()
        self.image_size = self._check_image_size(image_size)
        self._read_constants()
        self._dirty = True
        if self.board is not None:
            self.set_target(self.facing_target())

    # -- loading -------------------------------------------------------------------------

    def _urdf_units(self, head):
        """(the units, the scene's MjSpec) of a URDF head (:mod:`rasc.sim.urdf`): the
        head with the bench's names and cameras and the target in front; the encoder
        scales and zeros its ``<mimic>`` joints state go into the units, which may not
        state them too, nor edit the model (edit the URDF instead)."""
        from rasc.sim.units import merge
        from rasc.sim.urdf import head_spec

        spec, encoder = head_spec(head, import_mujoco())
        units = {}
        for eye in EYES:
            build = self.units[eye]
            if build.edits_model:
                raise InputError(f"{head.path}: the {eye} unit build moves joints or the "
                                 "camera; for a URDF head, edit the URDF instead")
            clash = [k for k in encoder[eye] if getattr(build, k) != getattr(IDEAL_BUILD, k)]
            if clash:
                raise InputError(f"{head.path}: the {eye} unit's {', '.join(clash)} come "
                                 "from the URDF's <mimic> joints; do not also give them")
            units[eye] = merge(build, **encoder[eye])
        return units, spec_with_target(spec, self._board or DEFAULT_BOARD)

    @staticmethod
    def _check_units(units) -> dict[str, UnitBuild]:
        units = {} if units is None else dict(units)
        for eye, build in units.items():
            if eye not in EYES:
                raise InputError(f"units: expected the eyes 'left' and 'right', got {eye!r}")
            if not isinstance(build, UnitBuild):
                raise InputError(f"units[{eye!r}]: expected a rasc.sim.units.UnitBuild, got "
                                 f"{type(build).__name__}")
        return {eye: units.get(eye, IDEAL_BUILD) for eye in EYES}

    def _compile(self, spec_from, model_from):
        """The model as written, or, when a unit build moves joints or cameras, edited
        through ``MjSpec`` (which compiles the unedited model to the same arrays)."""
        if not any(b.edits_model for b in self.units.values()):
            return model_from()
        mujoco = import_mujoco()
        spec = spec_from()
        to_angle = 1.0 if spec.compiler.degree else np.pi / 180.0
        for eye, build in self.units.items():
            def find(kind, name, eye=eye):
                element = getattr(spec, kind)(name)
                if element is None:
                    raise InputError(f"{self.model_file}: no {kind} named {name!r} for the "
                                     f"{eye} unit's build (rasc.sim.units)")
                return element
            if build.tilt_axis_offset_mm is not None:
                find("joint", f"{eye}_tilt_joint").pos = np.array(build.tilt_axis_offset_mm) / 1e3
            if build.axis_skew_deg is not None:
                d = np.radians(build.axis_skew_deg)   # MuJoCo axis = −ẑ' (eq. 3's sign)
                find("joint", f"{eye}_tilt_joint").axis = [-np.sin(d), 0.0, -np.cos(d)]
            if build.camera_position_mm is not None:
                find("body", f"{eye}_camera_link").pos = np.array(build.camera_position_mm) / 1e3
            if build.camera_euler_deg is not None:
                cam = find("camera", f"{eye}_camera")
                cam.alt.type = mujoco.mjtOrientation.mjORIENTATION_EULER
                cam.alt.euler = np.array(build.camera_euler_deg) * to_angle
        return spec.compile()

    @staticmethod
    def _load(compile_model, where: Path):
        try:
            return compile_model()
        except ValueError as exc:
            msg = " ".join(str(exc).split())
            raise InputError(f"{where}: MuJoCo cannot load the model: {msg}") from None

    def _lookup_names(self) -> dict[str, int]:
        mujoco = import_mujoco()
        m = self.model
        wanted = [("body", mujoco.mjtObj.mjOBJ_BODY, "base_link")]
        for eye in EYES:
            wanted += [("body", mujoco.mjtObj.mjOBJ_BODY, f"{eye}_ptu_link"),
                       ("body", mujoco.mjtObj.mjOBJ_BODY, f"{eye}_tilt_link"),
                       ("joint", mujoco.mjtObj.mjOBJ_JOINT, f"{eye}_pan_joint"),
                       ("joint", mujoco.mjtObj.mjOBJ_JOINT, f"{eye}_tilt_joint"),
                       ("camera", mujoco.mjtObj.mjOBJ_CAMERA, f"{eye}_camera")]
        ids = {}
        for kind, obj, name in wanted:
            i = mujoco.mj_name2id(m, obj, name)
            if i < 0:
                raise InputError(f"{self.model_file}: no {kind} named {name!r} "
                                 f"(rasc.sim.scene expects the stereo_head.xml names)")
            ids[name] = i
        for eye in EYES:
            for j in ("pan", "tilt"):
                jid = ids[f"{eye}_{j}_joint"]
                if m.jnt_type[jid] != mujoco.mjtJoint.mjJNT_HINGE:
                    raise InputError(f"{self.model_file}: joint {eye}_{j}_joint is not a hinge")
        ids["board_link"] = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "board_link")
        ids["board_origin"] = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "board_origin")
        return ids

    def _read_board(self) -> Board | None:
        m = self.model
        if self._ids["board_origin"] < 0:
            return None
        if self._ids["board_link"] < 0 or m.body_mocapid[self._ids["board_link"]] < 0:
            raise InputError(f"{self.model_file}: board_link must be a mocap body")
        mujoco = import_mujoco()
        i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_TEXT, "rasc_target")
        text = None if i < 0 else \
            bytes(m.text_data[m.text_adr[i]:m.text_adr[i] + m.text_size[i]]).rstrip(b"\0")
        if text:
            try:
                return board_from_dict(json.loads(text), f"{self.model_file}: rasc_target")
            except ValueError:
                raise InputError(f"{self.model_file}: custom text rasc_target is not "
                                 "JSON") from None
        try:
            corners = m.numeric("rasc_board_inner_corners").data
            square = m.numeric("rasc_board_square_size").data
        except KeyError:
            raise InputError(f"{self.model_file}: board without custom numerics "
                             f"rasc_board_inner_corners / rasc_board_square_size") from None
        return Board((int(corners[0]), int(corners[1])), float(square[0]))

    def _check_image_size(self, image_size) -> tuple[int, int]:
        m = self.model
        if image_size is None:
            res = m.cam_resolution[self._ids["left_camera"]]
            image_size = (int(res[0]), int(res[1])) if min(res) > 1 else (640, 480)
        try:
            w, h = (int(v) for v in image_size)
        except (TypeError, ValueError):
            raise InputError(f"image_size: expected (width, height), got {image_size!r}") from None
        if w < 1 or h < 1:
            raise InputError(f"image_size: must be positive, got {(w, h)}")
        if w > m.vis.global_.offwidth or h > m.vis.global_.offheight:
            raise InputError(f"image_size {(w, h)} exceeds the model's offscreen buffer "
                             f"{(m.vis.global_.offwidth, m.vis.global_.offheight)}; raise "
                             f"<visual><global offwidth offheight> in {self.model_file}")
        return (w, h)

    def _read_constants(self) -> None:
        """Constant transforms and each unit's kinematics from the compiled model at home.

        The mount ``T_ptu_from_base`` comes from the body frames (a scratch MjData at
        qpos0). The unit is read from the model's local data (``body_pos/quat``,
        ``jnt_pos/axis``, ``cam_pos/quat``, exact for identity rotations): the pan and tilt
        joints' anchors and axes in the ptu frame give the general unit (the tilt joint may
        sit off the pan axis, the tilt body anywhere on the pan link), and the camera's pose
        in the ptu frame at home gives ``T_cam_from_gaze`` (the gaze frame equals ptu at
        readings (0, 0)). Both are then put in the canonical gauge.
        """
        mujoco = import_mujoco()
        d = mujoco.MjData(self.model)
        mujoco.mj_forward(self.model, d)
        ids = self._ids
        #: the model's body ``base_link`` in the scene (the frame the MJCF builds in)
        self.T_scene_from_base_link = _pose(d.xpos[ids["base_link"]],
                                            d.xmat[ids["base_link"]])
        self._as_built: dict[str, tuple[PanTiltUnit, np.ndarray, np.ndarray]] = {}
        self._unit, self._T_cam_from_gaze, self._T_ptu_from_base = {}, {}, {}
        for eye in EYES:
            b_ptu = ids[f"{eye}_ptu_link"]
            T_scene_from_ptu = _pose(d.xpos[b_ptu], d.xmat[b_ptu])
            T_ptu_from_base_link = invert_transform(T_scene_from_ptu) @ self.T_scene_from_base_link
            unit, T_cam_from_ptu0, anchor = self._read_unit(eye)
            # pan axis through the anchor a, not the ptu origin: work in ptu shifted by a
            T_cg = T_cam_from_ptu0 @ make_transform(np.eye(3), anchor)
            T_pb = make_transform(np.eye(3), -anchor) @ T_ptu_from_base_link
            self._as_built[eye] = (unit, T_cg, T_pb)
            canon = canonical_gauge(unit, T_cg, T_pb)
            self._unit[eye], self._T_cam_from_gaze[eye], self._T_ptu_from_base[eye] = canon
        # The base: the calibration's (the cyclopean base of the canonical units, docs/
        # CONTRACTS.md), not base_link. They differ by a rotation about the pan axes when the
        # encoders' zeros are off (the canonical gauge puts a pan zero into the mount), and
        # by a shift or turn when the units sit asymmetrically on base_link.
        T_base_from_base_link = base_from_base_link(self._T_ptu_from_base["left"],
                                                    self._T_ptu_from_base["right"])
        T_base_link_from_base = invert_transform(T_base_from_base_link)
        for eye in EYES:
            self._T_ptu_from_base[eye] = self._T_ptu_from_base[eye] @ T_base_link_from_base
        self.T_base_from_base_link = T_base_from_base_link
        self.T_scene_from_base = self.T_scene_from_base_link @ T_base_link_from_base
        # where the cameras look at home: base +y for the stock head; a head whose tilt
        # joints turn the other way (a URDF's, positive tilt looking down) has the
        # canonical base's y backwards, and the target goes to base -y
        look = sum((self._T_ptu_from_base[eye][:3, :3].T
                    @ invert_transform(self._T_cam_from_gaze[eye])[:3, 2] for eye in EYES),
                   np.zeros(3))
        self._ahead = 1.0 if look[1] >= 0 else -1.0

    def _local_chain(self, top: int, body: int, eye: str, what: str) -> list[int]:
        """Bodies from ``top`` (excluded) down to ``body`` (included); ``body`` must lie
        below ``top``."""
        m, chain, b = self.model, [], body
        while b != top:
            if b == 0:
                raise InputError(f"{self.model_file}: {what} is not inside body "
                                 f"{eye}_ptu_link: rasc.sim.scene needs the {eye} unit's "
                                 f"joints and camera below it")
            chain.append(b)
            b = int(m.body_parentid[b])
        return chain[::-1]

    def _read_unit(self, eye: str) -> tuple[PanTiltUnit, np.ndarray, np.ndarray]:
        """One eye's (unit, T_cam_from_ptu (4, 4) at qpos0, pan anchor a (3,)), all in the
        frame of body ``{eye}_ptu_link``; the unit's ``tilt_point`` is relative to a (its pan
        axis passes through its origin), so the caller moves the ptu origin to a."""
        mujoco = import_mujoco()
        m, ids = self.model, self._ids
        j_pan, j_tilt = ids[f"{eye}_pan_joint"], ids[f"{eye}_tilt_joint"]
        cam = ids[f"{eye}_camera"]
        chain = self._local_chain(ids[f"{eye}_ptu_link"], int(m.cam_bodyid[cam]), eye,
                                  f"camera {eye}_camera")
        joints = [j for b in chain for j in range(m.body_jntadr[b],
                                                  m.body_jntadr[b] + m.body_jntnum[b])]
        if joints != [j_pan, j_tilt] or m.jnt_bodyid[j_pan] == m.jnt_bodyid[j_tilt]:
            raise InputError(f"{self.model_file}: between body {eye}_ptu_link and camera "
                             f"{eye}_camera there must be exactly {eye}_pan_joint, then "
                             f"{eye}_tilt_joint on a body below it")

        def local(pos, quat) -> np.ndarray:
            R = np.empty(9)
            mujoco.mju_quat2Mat(R, np.asarray(quat, dtype=float))
            return make_transform(R.reshape(3, 3), np.asarray(pos, dtype=float))

        T_ptu_from = {}
        T = np.eye(4)
        for b in chain:
            T = T @ local(m.body_pos[b], m.body_quat[b])
            T_ptu_from[b] = T

        def axis_and_anchor(j):
            T_b = T_ptu_from[int(m.jnt_bodyid[j])]
            return T_b[:3, :3] @ m.jnt_axis[j], T_b[:3, :3] @ m.jnt_pos[j] + T_b[:3, 3]

        pan_axis, pan_anchor = axis_and_anchor(j_pan)
        tilt_axis, tilt_anchor = axis_and_anchor(j_tilt)
        build = self.units[eye]
        # MuJoCo turns the tilt body by +τ about its axis w: T_gaze_from_ptu has Rot(−w, τ)
        unit = PanTiltUnit(pan_axis=tuple(pan_axis), tilt_axis=tuple(-tilt_axis),
                           tilt_point=tuple(tilt_anchor - pan_anchor),
                           pan_offset=np.radians(build.pan_zero_deg),
                           tilt_offset=np.radians(build.tilt_zero_deg),
                           pan_scale=build.pan_scale, tilt_scale=build.tilt_scale)
        T_ptu_from_mjcam = T_ptu_from[int(m.cam_bodyid[cam])] @ local(m.cam_pos[cam],
                                                                      m.cam_quat[cam])
        T_cam_from_ptu = make_transform(_CV_FROM_MJ, np.zeros(3)) @ invert_transform(
            T_ptu_from_mjcam)
        return unit, T_cam_from_ptu, pan_anchor

    # -- constants (ground truth) --------------------------------------------------------

    @staticmethod
    def _eye(eye: str) -> str:
        if eye not in EYES:
            raise InputError(f"eye: expected 'left' or 'right', got {eye!r}")
        return eye

    def T_cam_from_gaze(self, eye: str) -> np.ndarray:
        """Hand-eye transform ``T_cg`` (4, 4) of ``eye``, read from the model, canonical
        gauge (the model's own for the ideal unit)."""
        return self._T_cam_from_gaze[self._eye(eye)].copy()

    def T_ptu_from_base(self, eye: str) -> np.ndarray:
        """Mount ``T_pb`` (4, 4) of ``eye``'s unit on the base, read from the model,
        canonical gauge."""
        return self._T_ptu_from_base[self._eye(eye)].copy()

    def unit(self, eye: str) -> PanTiltUnit:
        """``eye``'s pan-tilt unit, canonical gauge: ``T_cam_from_base(readings) =
        T_cam_from_gaze · unit.T_gaze_from_ptu(readings) · T_ptu_from_base``."""
        return self._unit[self._eye(eye)]

    def unit_as_built(self, eye: str) -> tuple[PanTiltUnit, np.ndarray, np.ndarray]:
        """(unit, T_cam_from_gaze, T_ptu_from_base) as the model builds them: ptu frame =
        body ``{eye}_ptu_link`` moved to the pan joint's anchor, encoder offsets as set,
        and the mount on the model's body ``base_link`` (not the calibration's base,
        :attr:`T_base_from_base_link`)."""
        unit, T_cg, T_pb = self._as_built[self._eye(eye)]
        return unit, T_cg.copy(), T_pb.copy()

    def T_ptuL_from_ptuR(self) -> np.ndarray:
        """Right unit's frame in the left unit's (eq. 11–12's loop), (4, 4)."""
        return self._T_ptu_from_base["left"] @ invert_transform(self._T_ptu_from_base["right"])

    def K(self, eye: str) -> np.ndarray:
        """Camera matrix (3, 3) for the render size, OpenCV convention (docs/NOTES.md).

        With a sensor size: ``fx = focal_x·W/sensor_w``, ``cx = W/2 − principal_x·W/sensor_w
        − 0.5`` (likewise y); with ``fovy`` only: ``fx = fy = (H/2)/tan(fovy/2)``,
        ``cx = W/2 − 0.5``.
        """
        cam = self._ids[f"{self._eye(eye)}_camera"]
        m = self.model
        w, h = self.image_size
        sensor = m.cam_sensorsize[cam].astype(float)
        if np.all(sensor > 0):
            f = m.cam_intrinsic[cam, :2].astype(float)
            p = m.cam_intrinsic[cam, 2:].astype(float)
            fx, fy = f[0] * w / sensor[0], f[1] * h / sensor[1]
            cx, cy = w / 2 - p[0] * w / sensor[0] - 0.5, h / 2 - p[1] * h / sensor[1] - 0.5
        else:
            fx = fy = (h / 2) / np.tan(np.radians(m.cam_fovy[cam]) / 2)
            cx, cy = w / 2 - 0.5, h / 2 - 0.5
        return np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])

    def joint_range(self, eye: str) -> tuple[tuple[float, float], tuple[float, float]]:
        """((pan_min, pan_max), (tilt_min, tilt_max)) in radians, from the model (joint
        positions ``qpos``: the joint angle plus the joint's ``ref``, 0 in the stock model)."""
        r = self.model.jnt_range
        return tuple(tuple(float(v) for v in r[self._ids[f"{self._eye(eye)}_{j}_joint"]])
                     for j in ("pan", "tilt"))

    # -- state ---------------------------------------------------------------------------

    def set_angles(self, eye: str, pan: float, tilt: float) -> None:
        """Command ``eye``'s unit to the encoder readings (pan, tilt), radians.

        The joints turn to ``scale · reading + zero`` (the unit's encoder model; the
        readings themselves for the ideal unit), which must lie inside the joint ranges.
        """
        unit = self._as_built[self._eye(eye)][0]
        readings = (float(pan), float(tilt))
        angles = tuple(float(a) for a in unit.angles(*readings))
        adrs = [self.model.jnt_qposadr[self._ids[f"{eye}_{j}_joint"]] for j in ("pan", "tilt")]
        qpos = [self.model.qpos0[adr] + angle for adr, angle in zip(adrs, angles, strict=True)]
        for j, reading, angle, q, (lo, hi) in zip(("pan", "tilt"), readings, angles, qpos,
                                                  self.joint_range(eye), strict=True):
            if not (np.isfinite(q) and lo - 1e-12 <= q <= hi + 1e-12):
                joint = "" if angle == reading else \
                    f" (joint angle {np.degrees(angle):.6g} deg)"
                raise InputError(
                    f"{eye} {j} = {np.degrees(reading):.6g} deg{joint} is outside the joint "
                    f"range [{np.degrees(lo):.6g}, {np.degrees(hi):.6g}] deg")
        for adr, q in zip(adrs, qpos, strict=True):
            self.data.qpos[adr] = q
        self._readings[eye] = readings
        self._dirty = True

    def angles(self, eye: str) -> tuple[float, float]:
        """(pan, tilt) readings of ``eye`` last commanded, radians."""
        return self._readings[self._eye(eye)]

    def joint_angles(self, eye: str) -> tuple[float, float]:
        """(φ, τ) of ``eye``'s joints, radians (``qpos − qpos0``)."""
        return tuple(float(self.data.qpos[a] - self.model.qpos0[a]) for a in (
            self.model.jnt_qposadr[self._ids[f"{self._eye(eye)}_{j}_joint"]]
            for j in ("pan", "tilt")))

    def check_ground_truth(self, eye: str, where: str = "") -> float:
        """Compare the ground truth with MuJoCo's own camera frame at the current state.

        ``T_cam_from_gaze · unit.T_gaze_from_ptu(readings) · T_ptu_from_base`` against
        ``T_cam_from_base`` from ``data.cam_xpos/cam_xmat`` after ``mj_forward``.

        Returns
        -------
        float
            The largest element of the difference of the two 4×4 transforms.

        Raises
        ------
        InputError
            Above :data:`GROUND_TRUTH_TOL`, naming the eye, ``where`` (e.g. the pose) and
            the disagreement in degrees and millimetres.
        """
        pan, tilt = self.angles(eye)
        T_truth = (self._T_cam_from_gaze[eye] @ self._unit[eye].T_gaze_from_ptu(pan, tilt)
                   @ self._T_ptu_from_base[eye])
        T_model = self.T_cam_from_base(eye)
        worst = float(np.abs(T_truth - T_model).max())
        if not worst <= GROUND_TRUTH_TOL:
            deg = float(np.degrees(rotation_angle(T_truth[:3, :3] @ T_model[:3, :3].T)))
            mm = 1e3 * float(np.linalg.norm(invert_transform(T_truth)[:3, 3]
                                            - invert_transform(T_model)[:3, 3]))
            at = f" at {where}" if where else ""
            raise InputError(
                f"{self.model_file.name}: the {eye} ground truth disagrees with MuJoCo's "
                f"{eye}_camera frame{at} (readings pan {np.degrees(pan):.6g}, tilt "
                f"{np.degrees(tilt):.6g} deg) by {deg:.3g} deg, {mm:.3g} mm (largest element "
                f"{worst:.2g} > {GROUND_TRUTH_TOL:g}); the model is not the unit read from it, "
                f"nothing written")
        return worst

    def _require_board(self) -> Board:
        if self.board is None:
            raise InputError(f"{self.model_file}: the model has no target (site board_origin)")
        return self.board

    def set_target(self, T_base_from_world: np.ndarray) -> None:
        """Place the target: its board frame w in base coordinates (4, 4)."""
        self._require_board()
        T = validate_rigid_transform(T_base_from_world, name="T_base_from_world")
        T_scene_from_world = self.T_scene_from_base @ T
        mocap = self.model.body_mocapid[self._ids["board_link"]]
        q = np.empty(4)
        import_mujoco().mju_mat2Quat(q, np.ascontiguousarray(T_scene_from_world[:3, :3]).ravel())
        self.data.mocap_pos[mocap] = T_scene_from_world[:3, 3]
        self.data.mocap_quat[mocap] = q
        self._dirty = True

    def facing_target(self, distance: float = 1.0, centre_base=(0.0, 0.0)) -> np.ndarray:
        """``T_base_from_world`` (4, 4) of the target facing the head upright, its centre
        ``distance`` ahead of the cameras at home: :func:`T_base_from_world_facing` (base
        +y ahead) for a head whose cameras look along base +y, as the stock head's do; for
        one whose cameras look along base −y (a URDF head whose positive tilt looks down,
        :mod:`rasc.sim.urdf`), the same pose turned half a turn about the base's x axis."""
        T = T_base_from_world_facing(self._require_board(), distance, centre_base)
        if self._ahead < 0:
            T = np.diag([1.0, -1.0, -1.0, 1.0]) @ T
        return T

    def forward(self) -> None:
        """Bring ``data`` (bodies, cameras, sites) up to date with the last set angles/target."""
        if self._dirty:
            import_mujoco().mj_forward(self.model, self.data)
            self._dirty = False

    @property
    def T_base_from_world(self) -> np.ndarray:
        """The target's pose in base coordinates, read back from the model's site (4, 4)."""
        self._require_board()
        self.forward()
        i = self._ids["board_origin"]
        return invert_transform(self.T_scene_from_base) @ _pose(self.data.site_xpos[i],
                                                                self.data.site_xmat[i])

    def T_cam_from_scene(self, eye: str) -> np.ndarray:
        """OpenCV pose of ``eye``'s camera at the current angles, from MuJoCo (4, 4)."""
        self.forward()
        cam = self._ids[f"{self._eye(eye)}_camera"]
        return T_cam_from_scene_mujoco(self.data.cam_xpos[cam], self.data.cam_xmat[cam])

    def T_cam_from_base(self, eye: str) -> np.ndarray:
        """Eq. 1–2 at the current angles, read from the rendered camera pose (4, 4)."""
        return self.T_cam_from_scene(eye) @ self.T_scene_from_base

    def T_cam_from_world(self, eye: str) -> np.ndarray:
        """The target's pose in ``eye``'s camera (the extrinsics ``T_cw``), (4, 4)."""
        self._require_board()
        return self.T_cam_from_base(eye) @ self.T_base_from_world

    def project_world_points(self, eye: str, P_world: np.ndarray) -> np.ndarray:
        """Ideal (pinhole, distortion-free) pixels (N, 2) of target points ``P_world`` (N, 3)."""
        P_world = np.asarray(P_world, dtype=float)
        if P_world.ndim != 2 or P_world.shape[1] != 3:
            raise InputError(f"P_world: expected shape (N, 3), got {P_world.shape}")
        T = self.T_cam_from_world(eye)
        p_cam = P_world @ T[:3, :3].T + T[:3, 3]
        if np.any(p_cam[:, 2] <= 0):
            raise InputError(f"P_world[{int(np.argmax(p_cam[:, 2] <= 0))}]: behind the "
                             f"{eye} camera")
        uvw = p_cam @ self.K(eye).T
        return uvw[:, :2] / uvw[:, 2:]

    # -- rendering -----------------------------------------------------------------------

    def render(self, eye: str, supersample: int = 1) -> np.ndarray:
        """Render ``eye``'s camera: RGB uint8 (H, W, 3), row 0 at the top, no distortion
        (``supersample``: :meth:`render_camera`)."""
        return self.render_camera(f"{self._eye(eye)}_camera", supersample)

    def render_grey(self, eye: str, supersample: int = 1) -> np.ndarray:
        """Render ``eye``'s camera as an 8-bit grey image (H, W), as a grey camera gives."""
        from rasc.vision.camera import to_grey

        return to_grey(self.render(eye, supersample), order="rgb")

    def render_camera(self, name: str, supersample: int = 1) -> np.ndarray:
        """Render any named camera of the model (e.g. ``overview``) at the image size.

        ``supersample`` S > 1: rendered at S times the width and height and reduced by the
        mean of each S x S block (``cv2.INTER_AREA`` at an integer factor: an exact box
        filter). With OpenCV's convention (pixel centres at integers) output pixel u
        averages rendered pixels S·u … S·u + S − 1, centred at S·(u + 0.5) − 0.5, and the
        rendered camera's matrix is the output's with fx·S, fy·S, S·(cx + 0.5) − 0.5,
        S·(cy + 0.5) − 0.5 (:meth:`K` at the larger size): the same map, so the output's
        camera matrix is :meth:`K` exactly. The model's offscreen buffer
        (``<visual><global offwidth offheight>``) is raised in this simulator's compiled
        copy when S times the image size exceeds it."""
        mujoco = import_mujoco()
        if mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, name) < 0:
            raise InputError(f"{self.model_file}: no camera named {name!r}")
        w, h = self.image_size
        S = int(supersample)
        if S < 1:
            raise InputError(f"supersample must be an integer of at least 1, got {supersample!r}")
        if self._renderer is not None and (self._renderer.width, self._renderer.height) \
                != (S * w, S * h):
            self.close()
        if self._renderer is None:
            g = self.model.vis.global_
            g.offwidth, g.offheight = max(g.offwidth, S * w), max(g.offheight, S * h)
            try:
                with warnings.catch_warnings():
                    # MUJOCO_GL=glx without a display: GLFW warns twice before failing;
                    # the one-line error below says what happened and what fixes it
                    warnings.filterwarnings("ignore", module="glfw")
                    self._renderer = mujoco.Renderer(self.model, height=S * h, width=S * w)
            except Exception as exc:  # GL context creation fails without a working backend
                if S > 1:
                    first = str(exc).strip().splitlines()[0] if str(exc).strip() else \
                        type(exc).__name__
                    raise RascError(f"supersample {S}: cannot render offscreen at "
                                    f"{S * w}x{S * h} ({first}); use a smaller supersample"
                                    ) from None
                raise _gl_error(exc) from None
        self.forward()
        self._renderer.update_scene(self.data, camera=name)
        image = self._renderer.render()
        if S == 1:
            return image.copy()
        import cv2

        return cv2.resize(image, (w, h), interpolation=cv2.INTER_AREA)

    def render_depth(self, eye: str, supersample: int = 1) -> np.ndarray:
        """The depth (metres along the optical axis, float (H, W)) of what ``eye``'s camera
        sees, from MuJoCo's depth buffer, at the image size (rendered as
        :meth:`render_camera` renders, ``supersample`` blocks averaged)."""
        self.render_camera(f"{self._eye(eye)}_camera", supersample)  # the renderer, sized
        self._renderer.enable_depth_rendering()
        try:
            self._renderer.update_scene(self.data, camera=f"{self._eye(eye)}_camera")
            depth = self._renderer.render().astype(float)
        finally:
            self._renderer.disable_depth_rendering()
        if int(supersample) == 1:
            return depth
        import cv2

        w, h = self.image_size
        return cv2.resize(depth, (w, h), interpolation=cv2.INTER_AREA)

    def render_view(self, eye: str, R_cam_from_view: np.ndarray, K_view: np.ndarray,
                    size: tuple[int, int]) -> np.ndarray:
        """Render a virtual pinhole camera at ``eye``'s camera centre: RGB uint8 (h, w, 3).

        Its axes are ``eye``'s camera axes turned by ``R_cam_from_view`` (3, 3; OpenCV
        axes, columns the view's x, y, z in the camera frame), its camera matrix is
        ``K_view`` (OpenCV convention, no skew) at ``size`` (w, h). The pieces
        :mod:`rasc.sim.lens_render` resamples into the image of a wide lens. MuJoCo's
        camera is set for the one render (its sensor, intrinsics and frame) and restored;
        the headlight keeps ``eye``'s direction, so every view of one image is lit alike.
        """
        mujoco = import_mujoco()
        name = f"{self._eye(eye)}_camera"
        cam = self._ids[name]
        w, h = (int(v) for v in size)
        R = np.asarray(R_cam_from_view, dtype=float)
        K_view = np.asarray(K_view, dtype=float)
        renderer = self._view_renderers.get((w, h))
        if renderer is None:
            g = self.model.vis.global_
            g.offwidth, g.offheight = max(g.offwidth, w), max(g.offheight, h)
            try:
                renderer = mujoco.Renderer(self.model, height=h, width=w)
            except Exception as exc:
                first = str(exc).strip().splitlines()[0] if str(exc).strip() else \
                    type(exc).__name__
                raise RascError(f"cannot render a lens view offscreen at {w}x{h} "
                                f"({first}); use a smaller supersample") from None
            self._view_renderers[(w, h)] = renderer
        self.forward()
        m, d = self.model, self.data
        saved = (m.cam_sensorsize[cam].copy(), m.cam_intrinsic[cam].copy(),
                 d.cam_xmat[cam].copy())
        R_scene_from_mj = saved[2].reshape(3, 3)
        try:
            # sensor and intrinsics in pixels (MuJoCo needs only their ratios):
            # fx = focal·w/sensor_w, cx = w/2 − principal·w/sensor_w − 0.5 (:meth:`K`)
            m.cam_sensorsize[cam] = (w, h)
            m.cam_intrinsic[cam] = (K_view[0, 0], K_view[1, 1], w / 2 - 0.5 - K_view[0, 2],
                                    h / 2 - 0.5 - K_view[1, 2])
            d.cam_xmat[cam] = (R_scene_from_mj @ _CV_FROM_MJ @ R @ _CV_FROM_MJ).ravel()
            renderer.update_scene(d, camera=name)
            scene = renderer.scene
            for light in scene.lights[:scene.nlight]:
                if light.headlight:        # along the eye's own axis, as in its render
                    light.dir = -R_scene_from_mj[:, 2]
            return renderer.render().copy()
        finally:
            m.cam_sensorsize[cam], m.cam_intrinsic[cam], d.cam_xmat[cam] = saved

    def close(self) -> None:
        """Release the offscreen renderers (their GL contexts); rendering again opens new ones."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        for renderer in getattr(self, "_view_renderers", {}).values():
            renderer.close()
        self._view_renderers = {}

    def __enter__(self) -> StereoHeadSim:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- ground truth --------------------------------------------------------------------

    def ground_truth(self) -> dict[str, Any]:
        """JSON-ready constants: per eye K, dist, size, and the kinematics in the canonical
        gauge (``T_cam_from_gaze``, ``unit``, ``T_ptu_from_base``; ``T_ptuL_from_ptuR`` from
        the same mounts), plus ``unit_as_built`` (the model's own frames and the build)."""
        gt: dict[str, Any] = {
            "model_file": str(self.model_file),
            "generated_scene": self.scene_xml is not None,
            "image_size": list(self.image_size),
            "board": None if self.board is None else self.board.to_dict(),
            "T_ptuL_from_ptuR": self.T_ptuL_from_ptuR().tolist(),
            "T_scene_from_base": self.T_scene_from_base.tolist(),
            "T_scene_from_base_link": self.T_scene_from_base_link.tolist(),
            "T_base_from_base_link": self.T_base_from_base_link.tolist(),
            "base": BASE,
            "units": "metres, radians; pixels with centres at integers (OpenCV)",
            "gauge": GAUGE,
        }
        if self.urdf is not None:      # which of the URDF's joints and links are the units'
            gt["urdf"] = {"joints": list(self.urdf.joints), "cameras": list(self.urdf.cameras)}
        for eye in EYES:
            unit, T_cg, T_pb = self.unit_as_built(eye)
            gt[eye] = {"K": self.K(eye).tolist(), "dist": [0.0] * 5,
                       "image_size": list(self.image_size),
                       "T_cam_from_gaze": self.T_cam_from_gaze(eye).tolist(),
                       "T_ptu_from_base": self.T_ptu_from_base(eye).tolist(),
                       "unit": self.unit(eye).to_dict(),
                       "unit_as_built": {"unit": unit.to_dict(), "T_cam_from_gaze": T_cg.tolist(),
                                         "T_ptu_from_base": T_pb.tolist(),
                                         "build": self.units[eye].to_dict()},
                       "joint_range": [list(r) for r in self.joint_range(eye)]}
        return gt


# ---------------------------------------------------------------------------------------
