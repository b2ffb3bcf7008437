"""The MJCF of the simulated scene: the head model's paths and the scene that adds a target
(the chessboard from MuJoCo's builtin checker, a ChArUco board from its own pattern as an
image texture) in front of it; the target's pose facing the head. Text and bytes only:
:mod:`rasc.sim.scene` loads them into MuJoCo (and re-exports these names)."""

from __future__ import annotations

import json
import os

import numpy as np

from rasc.errors import InputError
from rasc.geometry.transforms import make_transform
from rasc.sim import models_dir
from rasc.vision.board import DEFAULT_BOARD, AprilGrid, Board, CharucoBoard

#: The repository's model folder (the package is installed editable from the repository).
MODELS_DIR = models_dir()
HEAD_XML = MODELS_DIR / "stereo_head.xml"
SCENE_XML = MODELS_DIR / "scene.xml"


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
    <numeric name="rasc_board_square_size" data="{s}"/>{target_text}
  </custom>

  <asset>
{texture}
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
        Head model to include (default: ``sim/models/stereo_head.xml``, absolute). A
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
    if not isinstance(board, (Board, CharucoBoard, AprilGrid)):
        raise InputError(f"board: expected a rasc.vision.board.Board, CharucoBoard or "
                         f"AprilGrid, got {type(board).__name__}")
    head = str(HEAD_XML if head_path is None else head_path)
    nx, ny = board.inner_corners
    s = board.square_size
    thick = 0.001  # half-thickness of the printed board; quiet zone 10 mm thick behind it
    # Cosmetic initial pose (rasc.sim.scene moves it): centre 1 m in front of the default head's
    # base (scene (0, 0, 1.2), facing scene +x), face towards the head, corner (0,0) top left.
    # the printed face and its quiet zone (centred on it) from the target (Board.face,
    # Board.quiet_box)
    centre, (fx0, fy0, fx1, fy1), (qx0, qy0, qx1, qy1) = \
        board.centre(), board.face(), board.quiet_box()
    values = dict(
        px=1.0, py=centre[0], pz=1.2 + centre[1],
        cx=(fx0 + fx1) / 2, cy=(fy0 + fy1) / 2, pt=thick,
        hx=(fx1 - fx0) / 2, hy=(fy1 - fy0) / 2,
        qz=2 * thick + 0.005, qx=(qx1 - qx0) / 2, qy=(qy1 - qy0) / 2, qt=0.005,
        rx=(nx + 1) / 2, ry=(ny + 1) / 2, s=s)
    # The builtin checker's first colour lands on the square between corners (0,0) and
    # (1,1) when the number of squares along x (nx + 1) is even; otherwise swap the colours
    # (the colour rule, checked by sampling renders in tests/sim/test_sim_render.py).
    black, white = "0 0 0", "1 1 1"
    rgb1, rgb2 = (black, white) if (nx + 1) % 2 == 0 else (white, black)
    if isinstance(board, (CharucoBoard, AprilGrid)):
        # the pattern drawn by OpenCV (CharucoBoard.generateImage), once over the face;
        # its orientation on the box face is checked by detecting renders
        # (tests/sim/test_charuco_render.py)
        texture = (f'    <texture name="board_checker" type="2d" file="{CHARUCO_TEXTURE}"/>\n'
                   '    <material name="board_checker" texture="board_checker" texrepeat="1 1"'
                   '\n      texuniform="false" specular="0"/>')
        target_text = ("\n    <text name=\"rasc_target\" data=\""
                       + json.dumps(board.to_dict(), sort_keys=True).replace('"', "&quot;")
                       + "\"/>")
    else:
        texture = ('    <!-- the checks\' phase at corner (0,0) depends on the parity of the '
                   'square count -->\n'
                   '    <texture name="board_checker" type="2d" builtin="checker" width="1024" '
                   'height="1024"\n'
                   f'      rgb1="{rgb1}" rgb2="{rgb2}"/>\n'
                   '    <material name="board_checker" texture="board_checker" '
                   f'texrepeat="{values["rx"]:.12g} {values["ry"]:.12g}"\n'
                   '      texuniform="false" specular="0"/>')
        target_text = ""
    return _SCENE_TEMPLATE.format(
        generated=" (generated by rasc.sim.scene.scene_xml)" if generated else "",
        head=head, nx=nx, ny=ny, texture=texture, target_text=target_text,
        **{k: f"{v:.12g}" for k, v in values.items()})


#: the name of a ChArUco scene's texture asset (:func:`scene_assets`)
CHARUCO_TEXTURE = "rasc_charuco_pattern.png"


#: The fewest texels per metre of a target's image texture (:func:`texture_image`): the
#: simulated cameras see about 1.15 px per mm at 1 m, so 2 texels per mm keep the texture
#: minified (mipmapped) for a target 1 m away or farther. A magnified texture's edges are
#: bilinear ramps whose corners the saddle refinement locates worse (measured on a 20x15
#: board of 170 mm squares at 1 m, 706 texels/m: 0.019-0.042 px RMS against the truth;
#: the same pattern replicated 3x, 2118 texels/m: 0.013-0.019 px).
MIN_TEXELS_PER_METRE = 2000.0


def _face_width_m(board) -> float:
    """The width (metres) the target's texture covers: the target's ``face()`` (x0, y0, x1,
    y1) when it has one, else its squares (the chessboard grid around the inner corners)."""
    face = getattr(board, "face", None)
    if callable(face):
        x0, _, x1, _ = face()
        return float(x1 - x0)
    return float((board.inner_corners[0] + 1) * board.square_size)


def texture_image(board) -> np.ndarray:
    """The target's printed pattern as the renderer's texture: ``board.texture()`` with each
    texel repeated k×k times, k the smallest integer giving at least
    :data:`MIN_TEXELS_PER_METRE` (the pattern's edges lie on texel boundaries, so the
    repeated image is the same drawing, only finer), rows reversed for MuJoCo."""
    art = np.asarray(board.texture())
    k = max(1, int(np.ceil(MIN_TEXELS_PER_METRE * _face_width_m(board) / art.shape[1]
                           - 1e-9)))
    if k > 1:
        art = np.repeat(np.repeat(art, k, axis=0), k, axis=1)
    # MuJoCo puts a 2-D texture's first row at the face's far edge in y (measured: the
    # unflipped pattern renders mirrored, its corner 0 at the board's last row), so the
    # rows go in reversed
    return np.ascontiguousarray(art[::-1])


def scene_assets(board) -> dict[str, bytes]:
    """The files :func:`scene_xml`'s scene needs besides the head: for a ChArUco target its
    pattern as a PNG (grey, OpenCV's drawing, :func:`texture_image`); nothing for a
    chessboard (a builtin texture). Pass them to MuJoCo's loaders (``assets=``), or write
    them beside the scene."""
    if not isinstance(board, (CharucoBoard, AprilGrid)):
        return {}
    from rasc.vision.camera import encode_png

    return {CHARUCO_TEXTURE: encode_png(texture_image(board))}


def T_base_from_world_facing(board: Board = DEFAULT_BOARD, distance: float = 1.0,
                             centre_base=(0.0, 0.0)) -> np.ndarray:
    """Board pose (4, 4) facing the head upright, its centre ``distance`` ahead (base +y).

    ``centre_base`` = (up, left) offsets of the board centre, metres (base x, z). Seen by
    a camera at home, board +x points right (base −z) and +y down (base −x).
    """
    R = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])  # cols: x_w y_w z_w
    centre = np.array([centre_base[0], distance, centre_base[1]], dtype=float)
    t = centre - R @ board.centre()
    return make_transform(R, t)
