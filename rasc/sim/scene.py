"""Simulated stereo head: MuJoCo model, offscreen rendering and ground truth.

The model lives in ``rasc/sim/models/`` (``stereo_head.xml`` = the head, ``scene.xml`` = head +
chessboard target); its frames are those of :mod:`rasc.geometry.frames` (README "Frames") and
``rasc/sim/models/README.md``. Everything this module reports as ground truth is read from the
compiled model, never retyped:

* per eye ``T_cam_from_gaze`` (hand-eye, ``T_cg``), ``T_ptu_from_base`` (``T_pb``), ``K``
  (OpenCV pixel convention, centres at integers) and the image size;
* at the current state, ``T_cam_from_world`` (the target) and ``T_cam_from_base``, so that
  eq. 1–2 hold: ``T_cam_from_base = T_cam_from_gaze @ T_gaze_from_ptu(pan, tilt) @
  T_ptu_from_base`` with eq. 3 for the middle factor.

MuJoCo's global frame is called ``scene`` here (z up), to keep ``world`` for the target
(the chessboard frame w of docs/CONTRACTS.md). Only this module imports ``mujoco``, and
only inside functions: the OpenGL backend (``MUJOCO_GL``) must be chosen before the first
import (:func:`gl_backend`), so code that needs the module calls :func:`import_mujoco`.
Image degradation (noise, blur, lens distortion) is at the end, numpy/scipy only.
"""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from rasc.errors import InputError, RascError
from rasc.geometry.frames import EYES
from rasc.geometry.transforms import invert_transform, make_transform, validate_rigid_transform
from rasc.vision.board import DEFAULT_BOARD, Board

#: The repository's model folder (the package is installed editable from the repository).
MODELS_DIR = Path(__file__).resolve().parent / "models"
HEAD_XML = MODELS_DIR / "stereo_head.xml"
SCENE_XML = MODELS_DIR / "scene.xml"

#: OpenCV camera axes from MuJoCo camera axes (x right; y up → down; z back → forward).
_CV_FROM_MJ = np.diag([1.0, -1.0, -1.0])

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
        raise _gl_error(exc) from None
    return mujoco


# ---------------------------------------------------------------------------------------
# Chessboard and scene



_SCENE_TEMPLATE = """\
<!-- Stereo head and chessboard target{generated}.
  Board frame w (site board_origin): corner (i, j) at (i s, j s, 0), +z into the board,
  the square between corners (0,0) and (1,1) black. Board: {nx}x{ny} inner corners,
  square {s} m; rasc.sim.scene reads these from the custom numerics below. -->
<mujoco model="stereo_head scene">
  <include file="{head}"/>

  <statistic extent="2" center="0.5 0 1.1"/>

  <visual>
    <global offwidth="1280" offheight="960"/>
    <quality offsamples="0"/>
    <headlight ambient=".9 .9 .9" diffuse=".1 .1 .1" specular="0 0 0"/>
    <!-- clipping: znear 0.005 x extent = 1 cm, zfar 5 x extent = 10 m -->
    <map znear="0.005" zfar="5"/>
  </visual>

  <custom>
    <numeric name="rasc_board_inner_corners" data="{nx} {ny}"/>
    <numeric name="rasc_board_square_size" data="{s}"/>
  </custom>

  <asset>
    <!-- the checks' phase at corner (0,0) depends on the parity of the square count -->
    <texture name="board_checker" type="2d" builtin="checker" width="1024" height="1024"
      rgb1="{rgb1}" rgb2="{rgb2}"/>
    <material name="board_checker" texture="board_checker" texrepeat="{rx} {ry}"
      texuniform="false" specular="0"/>
    <material name="board_quiet_zone" rgba="1 1 1 1" specular="0"/>
    <material name="floor" rgba="0.42 0.42 0.44 1" specular="0"/>
  </asset>

  <worldbody>
    <geom name="floor" type="plane" size="0 0 0.05" material="floor" contype="0"
      conaffinity="0"/>
    <!-- for the rig picture: behind the head's right, looking at (0.35, 0, 1.2) -->
    <camera name="overview" pos="-0.45 -0.75 1.6" xyaxes="0.6839 -0.7295 0 0.25 0.2344 0.9395"/>
    <body name="board_link" mocap="true" pos="{px} {py} {pz}" xyaxes="0 -1 0 0 0 -1">
      <site name="board_origin" size="0.005" group="5" rgba="1 0 0 0"/>
      <geom name="board_pattern" type="box" pos="{cx} {cy} {pt}" size="{hx} {hy} {pt}"
        material="board_checker" contype="0" conaffinity="0"/>
      <geom name="board_quiet_zone" type="box" pos="{cx} {cy} {qz}"
        size="{qx} {qy} {qt}" material="board_quiet_zone" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
</mujoco>
"""


def scene_xml(board: Board = DEFAULT_BOARD, head_path: str | os.PathLike | None = None,
              *, generated: bool = True) -> str:
    """MJCF of the head plus a chessboard target (docs/NOTES.md recipe).

    Parameters
    ----------
    board : Board
    head_path : path, optional
        Head model to include (default: ``rasc/sim/models/stereo_head.xml``, absolute). A
        relative path is written as given: MuJoCo resolves it against the scene file's
        folder, so use it only for a scene written to a file.
    generated : bool
        Say in the header comment that the file was generated.

    Returns
    -------
    str
        The scene; the target is a mocap body ``board_link`` whose frame is the board frame
        w, placed 1 m in front of the head (``StereoHeadSim.set_target`` moves it).
    """
    if not isinstance(board, Board):
        raise InputError(f"board: expected a rasc.sim.scene.Board, got {type(board).__name__}")
    head = str(HEAD_XML if head_path is None else head_path)
    nx, ny = board.inner_corners
    s = board.square_size
    thick = 0.001  # half-thickness of the printed board; quiet zone 10 mm thick behind it
    # Cosmetic initial pose (rasc.sim.scene moves it): centre 1 m in front of the default head's
    # base (scene (0, 0, 1.2), facing scene +x), face towards the head, corner (0,0) top left.
    values = dict(
        px=1.0, py=(nx - 1) * s / 2, pz=1.2 + (ny - 1) * s / 2,
        cx=(nx - 1) * s / 2, cy=(ny - 1) * s / 2, pt=thick,
        hx=(nx + 1) * s / 2, hy=(ny + 1) * s / 2,
        qz=2 * thick + 0.005, qx=(nx + 3) * s / 2, qy=(ny + 3) * s / 2, qt=0.005,
        rx=(nx + 1) / 2, ry=(ny + 1) / 2, s=s)
    # The builtin checker's first colour lands on the square between corners (0,0) and
    # (1,1) when the number of squares along x (nx + 1) is even; otherwise swap the colours
    # (the colour rule, checked by sampling renders in tests/test_sim_render.py).
    black, white = "0 0 0", "1 1 1"
    rgb1, rgb2 = (black, white) if (nx + 1) % 2 == 0 else (white, black)
    return _SCENE_TEMPLATE.format(
        generated=" (generated by rasc.sim.scene.scene_xml)" if generated else "",
        head=head, nx=nx, ny=ny, rgb1=rgb1, rgb2=rgb2,
        **{k: f"{v:.12g}" for k, v in values.items()})


def T_base_from_world_facing(board: Board = DEFAULT_BOARD, distance: float = 1.0,
                             centre_base=(0.0, 0.0)) -> np.ndarray:
    """Board pose (4, 4) facing the head upright, its centre ``distance`` ahead (base +y).

    ``centre_base`` = (up, left) offsets of the board centre, metres (base x, z). Seen by
    a camera at home, board +x points right (base −z) and +y down (base −x).
    """
    nx, ny = board.inner_corners
    R = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])  # cols: x_w y_w z_w
    centre = np.array([centre_base[0], distance, centre_base[1]], dtype=float)
    t = centre - R @ np.array([(nx - 1) / 2, (ny - 1) / 2, 0.0]) * board.square_size
    return make_transform(R, t)


# ---------------------------------------------------------------------------------------
# The simulator


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


class StereoHeadSim:
    """The simulated head: set pan/tilt and the target, render, read ground truth.

    Parameters
    ----------
    model_path : path, optional
        MJCF scene to load (default ``rasc/sim/models/scene.xml``). Must contain the bodies
        ``base_link``, ``{eye}_ptu_link``, ``{eye}_tilt_link``, joints ``{eye}_pan_joint``,
        ``{eye}_tilt_joint`` and cameras ``{eye}_camera`` for eye in (left, right); a
        target (mocap body ``board_link``, site ``board_origin``, custom numerics
        ``rasc_board_*``) is optional.
    board : Board, optional
        Instead of ``model_path``: generate the scene for this board (:func:`scene_xml`,
        kept in ``self.scene_xml``) around the head model ``head_path``.
    head_path : path, optional
        Head model for ``board`` (default ``rasc/sim/models/stereo_head.xml``).
    image_size : (width, height), optional
        Render size; default the cameras' ``resolution`` (1280×960). K scales with it.

    Angles are radians. Use as a context manager or call :meth:`close`.
    """

    def __init__(self, model_path: str | os.PathLike | None = None, *,
                 board: Board | None = None, head_path: str | os.PathLike | None = None,
                 image_size: tuple[int, int] | None = None) -> None:
        mujoco = import_mujoco()
        self._renderer = None
        self.scene_xml: str | None = None
        if board is not None:
            if model_path is not None:
                raise InputError("StereoHeadSim: give model_path or board, not both")
            if head_path is not None and not Path(head_path).is_file():
                raise InputError(f"{head_path}: head model file not found")
            self.model_file = Path(HEAD_XML if head_path is None else head_path).resolve()
            self.scene_xml = scene_xml(board, self.model_file)
            self.model = self._load(lambda: mujoco.MjModel.from_xml_string(self.scene_xml),
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
            self.model = self._load(lambda: mujoco.MjModel.from_xml_path(str(self.model_file)),
                                    self.model_file)
        self.data = mujoco.MjData(self.model)
        self._ids = self._lookup_names()
        self.board = self._read_board()
        self.image_size = self._check_image_size(image_size)
        self._read_constants()
        self._dirty = True
        if self.board is not None:
            self.set_target(T_base_from_world_facing(self.board))

    # -- loading -------------------------------------------------------------------------

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
        """Constant transforms from the model at home (a scratch MjData at qpos0)."""
        mujoco = import_mujoco()
        d = mujoco.MjData(self.model)
        mujoco.mj_forward(self.model, d)
        ids = self._ids
        self.T_scene_from_base = _pose(d.xpos[ids["base_link"]], d.xmat[ids["base_link"]])
        self._T_cam_from_gaze, self._T_ptu_from_base = {}, {}
        for eye in EYES:
            b_ptu, b_gaze = ids[f"{eye}_ptu_link"], ids[f"{eye}_tilt_link"]
            cam = ids[f"{eye}_camera"]
            T_scene_from_ptu = _pose(d.xpos[b_ptu], d.xmat[b_ptu])
            T_scene_from_gaze = _pose(d.xpos[b_gaze], d.xmat[b_gaze])
            T_cam_from_scene = T_cam_from_scene_mujoco(d.cam_xpos[cam], d.cam_xmat[cam])
            self._T_cam_from_gaze[eye] = T_cam_from_scene @ T_scene_from_gaze
            self._T_ptu_from_base[eye] = invert_transform(T_scene_from_ptu) @ self.T_scene_from_base

    # -- constants (ground truth) --------------------------------------------------------

    @staticmethod
    def _eye(eye: str) -> str:
        if eye not in EYES:
            raise InputError(f"eye: expected 'left' or 'right', got {eye!r}")
        return eye

    def T_cam_from_gaze(self, eye: str) -> np.ndarray:
        """Hand-eye transform ``T_cg`` (4, 4) of ``eye``, read from the model."""
        return self._T_cam_from_gaze[self._eye(eye)].copy()

    def T_ptu_from_base(self, eye: str) -> np.ndarray:
        """Mount ``T_pb`` (4, 4) of ``eye``'s unit on the base, read from the model."""
        return self._T_ptu_from_base[self._eye(eye)].copy()

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
        """((pan_min, pan_max), (tilt_min, tilt_max)) in radians, from the model."""
        r = self.model.jnt_range
        return tuple(tuple(float(v) for v in r[self._ids[f"{self._eye(eye)}_{j}_joint"]])
                     for j in ("pan", "tilt"))

    # -- state ---------------------------------------------------------------------------

    def set_angles(self, eye: str, pan: float, tilt: float) -> None:
        """Command ``eye``'s unit to (pan, tilt), radians, inside the joint ranges."""
        for j, value, (lo, hi) in zip(("pan", "tilt"), (pan, tilt), self.joint_range(eye),
                                      strict=True):
            value = float(value)
            if not (np.isfinite(value) and lo - 1e-12 <= value <= hi + 1e-12):
                raise InputError(
                    f"{eye} {j} = {np.degrees(value):.6g} deg is outside the joint range "
                    f"[{np.degrees(lo):.6g}, {np.degrees(hi):.6g}] deg")
            self.data.qpos[self.model.jnt_qposadr[self._ids[f"{eye}_{j}_joint"]]] = value
        self._dirty = True

    def angles(self, eye: str) -> tuple[float, float]:
        """(pan, tilt) of ``eye``, radians."""
        return tuple(float(self.data.qpos[self.model.jnt_qposadr[
            self._ids[f"{self._eye(eye)}_{j}_joint"]]]) for j in ("pan", "tilt"))

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

    def render(self, eye: str) -> np.ndarray:
        """Render ``eye``'s camera: RGB uint8 (H, W, 3), row 0 at the top, no distortion."""
        return self.render_camera(f"{self._eye(eye)}_camera")

    def render_grey(self, eye: str) -> np.ndarray:
        """Render ``eye``'s camera as an 8-bit grey image (H, W), as a grey camera gives."""
        from rasc.vision.camera import to_grey

        return to_grey(self.render(eye), order="rgb")

    def render_camera(self, name: str) -> np.ndarray:
        """Render any named camera of the model (e.g. ``overview``) at the image size."""
        mujoco = import_mujoco()
        if mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, name) < 0:
            raise InputError(f"{self.model_file}: no camera named {name!r}")
        if self._renderer is None:
            w, h = self.image_size
            try:
                with warnings.catch_warnings():
                    # MUJOCO_GL=glx without a display: GLFW warns twice before failing;
                    # the one-line error below says what happened and what fixes it
                    warnings.filterwarnings("ignore", module="glfw")
                    self._renderer = mujoco.Renderer(self.model, height=h, width=w)
            except Exception as exc:  # GL context creation fails without a working backend
                raise _gl_error(exc) from None
        self.forward()
        self._renderer.update_scene(self.data, camera=name)
        return self._renderer.render().copy()

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __enter__(self) -> StereoHeadSim:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- ground truth --------------------------------------------------------------------

    def ground_truth(self) -> dict[str, Any]:
        """JSON-ready constants: per eye K, dist, T_cam_from_gaze, T_ptu_from_base, size."""
        gt: dict[str, Any] = {
            "model_file": str(self.model_file),
            "generated_scene": self.scene_xml is not None,
            "image_size": list(self.image_size),
            "board": None if self.board is None else self.board.to_dict(),
            "T_ptuL_from_ptuR": self.T_ptuL_from_ptuR().tolist(),
            "T_scene_from_base": self.T_scene_from_base.tolist(),
            "units": "metres, radians; pixels with centres at integers (OpenCV)",
        }
        for eye in EYES:
            gt[eye] = {"K": self.K(eye).tolist(), "dist": [0.0] * 5,
                       "image_size": list(self.image_size),
                       "T_cam_from_gaze": self.T_cam_from_gaze(eye).tolist(),
                       "T_ptu_from_base": self.T_ptu_from_base(eye).tolist(),
                       "joint_range": [list(r) for r in self.joint_range(eye)]}
        return gt


# ---------------------------------------------------------------------------------------
# Image degradation (numpy/scipy; applied to renders for realism)


def _image(image: np.ndarray, name: str = "image") -> np.ndarray:
    image = np.asarray(image)
    if image.dtype != np.uint8 or image.ndim not in (2, 3):
        raise InputError(f"{name}: expected a uint8 image (H, W) or (H, W, C), got "
                         f"{image.dtype} {image.shape}")
    return image


def _to_uint8(a: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(a), 0, 255).astype(np.uint8)


def add_pixel_noise(image: np.ndarray, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """Add Gaussian noise of ``sigma`` grey levels to every pixel, round and clip to uint8."""
    image = _image(image)
    if not (np.isfinite(sigma) and sigma >= 0):
        raise InputError(f"noise sigma must be >= 0 grey levels, got {sigma}")
    return _to_uint8(image + rng.normal(0.0, sigma, image.shape))


def blur(image: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian blur of ``sigma`` pixels in both image axes (not across channels), uint8."""
    image = _image(image)
    if not (np.isfinite(sigma) and sigma >= 0):
        raise InputError(f"blur sigma must be >= 0 pixels, got {sigma}")
    if sigma == 0:
        return image.copy()
    from scipy.ndimage import gaussian_filter

    sigmas = (sigma, sigma) + (0,) * (image.ndim - 2)
    return _to_uint8(gaussian_filter(image.astype(float), sigmas, mode="nearest"))


def distortion_warp(K: np.ndarray, dist, size: tuple[int, int]):
    """The warp of :func:`distort` for one camera, its remap computed once.

    Returns ``warp(image) -> image`` for images of ``size`` (width, height); the remap
    costs ~0.8 s at 1280×960, the warp itself ~0.03 s, so a renderer builds it once per
    camera.
    """
    from scipy.ndimage import map_coordinates

    from rasc.geometry.lens import distortion_remap

    map_x, map_y = distortion_remap(K, dist, size)
    coords = np.stack([map_y.astype(float), map_x.astype(float)])

    def warp(image: np.ndarray) -> np.ndarray:
        image = _image(image)
        channels = image[..., None] if image.ndim == 2 else image
        out = np.stack([map_coordinates(channels[..., c].astype(float), coords, order=1,
                                        mode="constant", cval=0.0)
                        for c in range(channels.shape[2])], axis=-1)
        return _to_uint8(out.reshape(image.shape))

    return warp


def distort(image: np.ndarray, K: np.ndarray, dist) -> np.ndarray:
    """Warp an ideal render into the image of a camera with lens distortion ``dist``.

    A point whose ideal projection (pinhole ``K``) is ``uv`` lands at
    ``rasc.geometry.lens.project_points`` with ``dist`` (OpenCV model, same ``K``). Bilinear
    interpolation; pixels whose ray falls outside the render are black.
    """
    image = _image(image)
    h, w = image.shape[:2]
    return distortion_warp(K, dist, (w, h))(image)


def degrade(image: np.ndarray, rng: np.random.Generator, *, K: np.ndarray | None = None,
            dist=None, blur_sigma: float = 0.0, noise_sigma: float = 0.0) -> np.ndarray:
    """Lens distortion (if ``dist`` has a non-zero term; needs ``K``), then blur, then noise."""
    image = _image(image)
    if dist is not None and np.any(np.asarray(dist, dtype=float) != 0):
        if K is None:
            raise InputError("degrade: lens distortion needs the camera matrix K")
        image = distort(image, K, dist)
    if blur_sigma:
        image = blur(image, blur_sigma)
    if noise_sigma:
        image = add_pixel_noise(image, noise_sigma, rng)
    return image
