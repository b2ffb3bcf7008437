"""A head described in a URDF, compiled by MuJoCo for the bench (docs/topics/urdf-head.md).

:class:`UrdfHead` names a URDF, the four joints that turn the two units (left pan, left
tilt, right pan, right tilt) and the two camera links (REP 103 optical frames: z forward,
x right, y down, OpenCV's camera axes), plus the cameras' intrinsics. :func:`head_spec`
turns it into the ``mujoco.MjSpec`` :class:`rasc.sim.scene.StereoHeadSim` loads
(``StereoHeadSim(UrdfHead(...), board=...)``): MuJoCo compiles the URDF itself, and rasc

* renames the URDF's elements to the names the bench reads (the tree's root link becomes
  body ``base_link``, each named joint ``{eye}_pan_joint`` / ``{eye}_tilt_joint``, the tilt
  joint's child link ``{eye}_tilt_link``) and inserts a link ``{eye}_ptu_link`` (identity
  origin) above each pan joint's link, the unit's frame at home; an element that already
  holds one of these names is renamed ``urdf_<name>``;
* adds a MuJoCo camera ``{eye}_camera`` at each camera link, turned from the optical frame
  to MuJoCo's camera axes (look along −z, y up), with the intrinsics K and image size;
* keeps static links as bodies (``fusestatic="false"``) and gives massless links a token
  mass (``boundmass``, ``boundinertia``): the bench only sets joints and renders, it never
  steps the physics;
* finds ``package://`` meshes (:func:`mesh_file`), which MuJoCo does not resolve.

Encoder zeros and scales: MuJoCo's URDF compiler ignores ``<mimic>``. When a named joint
is the one other joint's ``<mimic joint=... multiplier="s" offset="o"/>`` follows (what
``rasc export --format urdf --joints readings`` writes for a scale s ≠ 1), the follower is
the joint that moves the head, and s, o become the unit's encoder scale and zero
(:class:`rasc.sim.units.UnitBuild`'s ``pan_scale`` / ``pan_zero_deg``): the bench's
readings are the named joint's values, as a driver publishes them. Otherwise the named
joint's values are its angles (``--joints angles``, scale 1, zero 0).
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rasc.errors import InputError
from rasc.geometry.frames import EYES

#: the joints ``rasc export --format urdf`` writes (left pan, left tilt, right pan, right tilt)
DEFAULT_JOINTS = ("left_pan", "left_tilt", "right_pan", "right_tilt")
#: the camera links ``rasc export --format urdf`` writes (left, right): REP 103 optical frames
DEFAULT_CAMERAS = ("left_camera_optical_frame", "right_camera_optical_frame")
#: the prefix given to a URDF element whose name the bench needs for another
RENAMED_PREFIX = "urdf_"
#: MuJoCo camera axes (look along −z, y up) in the optical frame (z forward, y down):
#: a half turn about x, as a quaternion (w, x, y, z)
_QUAT_OPTICAL_FROM_MJCAM = (0.0, 1.0, 0.0, 0.0)
#: sensor pixel pitch given to the added cameras (metres; only the ratio to K matters)
_PIXEL_PITCH = 6e-6


@dataclass(frozen=True)
class UrdfHead:
    """A head in a URDF file (module docstring).

    Attributes
    ----------
    path : path
        The URDF file; meshes are looked up by MuJoCo's rules in its folder.
    joints : 4 names
        Left pan, left tilt, right pan, right tilt (:data:`DEFAULT_JOINTS`).
    cameras : 2 names
        Left and right camera links, REP 103 optical frames (:data:`DEFAULT_CAMERAS`).
    K : {eye: (3, 3)}, optional
        Camera matrices (OpenCV convention, zero skew); default the stock cameras'.
    image_size : (width, height), optional
        Default the stock cameras' 1280×960.
    """

    path: Path
    joints: tuple[str, ...] = DEFAULT_JOINTS
    cameras: tuple[str, ...] = DEFAULT_CAMERAS
    K: dict | None = field(default=None, compare=False)
    image_size: tuple[int, int] | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "path", Path(self.path))
        object.__setattr__(self, "joints", tuple(self.joints))
        object.__setattr__(self, "cameras", tuple(self.cameras))
        if len(self.joints) != 4 or len(set(self.joints)) != 4:
            raise InputError(f"URDF joints: expected four different names (left pan, left "
                             f"tilt, right pan, right tilt), got {','.join(self.joints)}")
        if len(self.cameras) != 2 or len(set(self.cameras)) != 2:
            raise InputError(f"URDF cameras: expected two different link names (left, "
                             f"right), got {','.join(self.cameras)}")

    def joint(self, eye: str, which: str) -> str:
        """The URDF's name of ``eye``'s ``which`` ("pan" or "tilt") joint."""
        return self.joints[2 * EYES.index(eye) + ("pan", "tilt").index(which)]

    def camera(self, eye: str) -> str:
        """The URDF's name of ``eye``'s camera link (an optical frame)."""
        return self.cameras[EYES.index(eye)]


def parse_names(text: str, count: int, flag: str) -> tuple[str, ...]:
    """``count`` comma-separated names from an option (one line naming ``flag`` if not)."""
    names = tuple(n.strip() for n in str(text).split(","))
    if len(names) != count or not all(names):
        raise InputError(f"{flag} {text}: expected {count} comma-separated names")
    return names


def stock_intrinsics(mujoco) -> tuple[dict[str, np.ndarray], tuple[int, int]]:
    """The stock head's cameras' K per eye and image size, read from its compiled model
    (``mujoco``: the module, as :func:`rasc.sim.scene.import_mujoco` gives it)."""
    from rasc.sim.mjcf import HEAD_XML

    m = mujoco.MjModel.from_xml_path(str(HEAD_XML))
    K = {}
    for eye in EYES:
        cam = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, f"{eye}_camera")
        w, h = (int(v) for v in m.cam_resolution[cam])
        sensor = m.cam_sensorsize[cam]
        f, p = m.cam_intrinsic[cam, :2], m.cam_intrinsic[cam, 2:]
        K[eye] = np.array([[f[0] * w / sensor[0], 0.0, w / 2 - p[0] * w / sensor[0] - 0.5],
                           [0.0, f[1] * h / sensor[1], h / 2 - p[1] * h / sensor[1] - 0.5],
                           [0.0, 0.0, 1.0]])
    return K, (w, h)


def _read_urdf(head: UrdfHead) -> ET.Element:
    if not head.path.is_file():
        raise InputError(f"{head.path}: URDF file not found")
    try:
        root = ET.parse(head.path).getroot()
    except ET.ParseError as exc:
        raise InputError(f"{head.path}: not XML ({exc})") from None
    if root.tag != "robot":
        raise InputError(f"{head.path}: not a URDF (root element <{root.tag}>, expected "
                         "<robot>)")
    return root


def _encoders(head: UrdfHead, root: ET.Element) -> tuple[dict[str, str], dict]:
    """(the moving joint of each named joint, {eye: {pan_scale, pan_zero_deg, ...}})."""
    joints = {j.get("name"): j for j in root.findall("joint")}
    followers: dict[str, list] = {}
    for j in joints.values():
        mimic = j.find("mimic")
        if mimic is not None:
            followers.setdefault(mimic.get("joint"), []).append((j.get("name"), mimic))
    moving, encoder = {}, {eye: {} for eye in EYES}
    for eye in EYES:
        for which in ("pan", "tilt"):
            name = head.joint(eye, which)
            if name not in joints:
                raise InputError(f"{head.path}: no joint named {name!r} (the {eye} {which} "
                                 f"joint; name it with --urdf-joints)")
            mimic = joints[name].find("mimic")
            if mimic is not None:
                raise InputError(f"{head.path}: joint {name!r} follows joint "
                                 f"{mimic.get('joint')!r} (<mimic>): name that one, whose "
                                 "values the driver publishes")
            follow = followers.get(name, [])
            if len(follow) > 1:
                raise InputError(f"{head.path}: joint {name!r} is followed by "
                                 f"{len(follow)} <mimic> joints "
                                 f"({', '.join(n for n, _ in follow)}); the bench needs one")
            if follow:
                follower, mimic = follow[0]
                try:
                    scale = float(mimic.get("multiplier", "1"))
                    zero = float(mimic.get("offset", "0"))
                except ValueError:
                    raise InputError(f"{head.path}: joint {follower!r}: <mimic> multiplier "
                                     "and offset must be numbers") from None
                if not (math.isfinite(scale) and math.isfinite(zero) and scale > 0):
                    raise InputError(f"{head.path}: joint {follower!r}: <mimic> multiplier "
                                     f"{scale:g} must be positive and finite")
                moving[name] = follower
                encoder[eye][f"{which}_scale"] = scale
                encoder[eye][f"{which}_zero_deg"] = math.degrees(zero)
            else:
                moving[name] = name
            kind = joints[moving[name]].get("type")
            if kind not in ("revolute", "continuous"):
                raise InputError(f"{head.path}: joint {moving[name]!r} is {kind!r}; the "
                                 f"{eye} {which} joint must be revolute or continuous")
    return moving, encoder


def _rename(root: ET.Element, mapping: dict[str, str], kind: str) -> None:
    """Rename links (``kind`` "link") or joints everywhere the URDF refers to them."""
    if kind == "link":
        for link in root.findall("link"):
            link.set("name", mapping.get(link.get("name"), link.get("name")))
        for joint in root.findall("joint"):
            for end in ("parent", "child"):
                e = joint.find(end)
                if e is not None:
                    e.set("link", mapping.get(e.get("link"), e.get("link")))
    else:
        for joint in root.findall("joint"):
            joint.set("name", mapping.get(joint.get("name"), joint.get("name")))
            mimic = joint.find("mimic")
            if mimic is not None:
                mimic.set("joint", mapping.get(mimic.get("joint"), mimic.get("joint")))


def _free_names(names: set[str], wanted: dict[str, str], reserved=()) -> dict[str, str]:
    """Mapping that moves every name in ``names`` that is a target of ``wanted`` (or
    ``reserved``, names to be added) but not its source aside (``urdf_<name>``), then
    applies ``wanted``."""
    targets = set(wanted.values()) | set(reserved)
    mapping = {}
    taken = set(names) | targets
    for n in names:
        if n in targets and wanted.get(n) != n:
            new = RENAMED_PREFIX + n
            while new in taken:
                new = RENAMED_PREFIX + new
            taken.add(new)
            mapping[n] = new
    mapping.update(wanted)
    return mapping


def mesh_file(name: str, urdf: Path) -> str:
    """A URDF mesh's file name as MuJoCo opens it: ``file://`` dropped; ``package://PKG/REL``
    as ``DIR/REL`` for the nearest folder ``DIR`` named PKG above the URDF (a ROS package
    holding its ``urdf/`` and ``meshes/``), else in a folder named PKG on
    ``ROS_PACKAGE_PATH``, else ``REL``'s file name in the URDF's folder; other names as
    written (MuJoCo resolves them against the URDF's folder)."""
    if name.startswith("file://"):
        return name[len("file://"):]
    if not name.startswith("package://"):
        return name
    package, _, rel = name[len("package://"):].partition("/")
    here = urdf.resolve().parent
    roots = [d for d in (here, *here.parents) if d.name == package]
    for entry in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep):
        if entry:
            roots += [d for d in Path(entry).glob(f"**/{package}") if d.is_dir()][:1]
    for root in roots:
        if (root / rel).is_file():
            return str(root / rel)
    return str(here / Path(rel).name)


def urdf_text(head: UrdfHead) -> tuple[str, dict[str, dict], dict[str, str]]:
    """The URDF rewritten with the bench's names (module docstring): (text, the encoder
    scales/zeros per eye, the camera links' names in the rewritten text)."""
    root = _read_urdf(head)
    moving, encoder = _encoders(head, root)
    links = {link.get("name") for link in root.findall("link")}
    joint_el = {j.get("name"): j for j in root.findall("joint")}
    children = {j.find("child").get("link") for j in joint_el.values() if j.find("child")
                is not None}
    roots = sorted(links - children)
    if len(roots) != 1:
        raise InputError(f"{head.path}: expected one root link, found {len(roots)} "
                         f"({', '.join(roots)})")
    for eye in EYES:
        if head.camera(eye) not in links:
            raise InputError(f"{head.path}: no link named {head.camera(eye)!r} (the {eye} "
                             "camera's optical frame; name it with --urdf-cameras)")
    wanted_links = {roots[0]: "base_link"}
    wanted_joints = {}
    for eye in EYES:
        tilt = joint_el[moving[head.joint(eye, "tilt")]]
        wanted_links[tilt.find("child").get("link")] = f"{eye}_tilt_link"
        for which in ("pan", "tilt"):
            wanted_joints[moving[head.joint(eye, which)]] = f"{eye}_{which}_joint"
    if len(set(wanted_links.values())) != len(wanted_links):
        raise InputError(f"{head.path}: the root link is a tilt joint's child")
    link_map = _free_names(links, wanted_links, {f"{e}_ptu_link" for e in EYES})
    joint_map = _free_names(set(joint_el), wanted_joints)
    # the camera links, and the names the ptu links insert, as renamed
    cameras = {eye: link_map.get(head.camera(eye), head.camera(eye)) for eye in EYES}
    _rename(root, {k: v for k, v in link_map.items() if k in links}, "link")
    _rename(root, joint_map, "joint")
    for eye in EYES:
        pan = joint_el[moving[head.joint(eye, "pan")]]
        parent = pan.find("parent")
        ptu = f"{eye}_ptu_link"
        ET.SubElement(root, "link", name=ptu)
        mount = ET.SubElement(root, "joint", name=f"rasc_{eye}_ptu_mount", type="fixed")
        ET.SubElement(mount, "parent", link=parent.get("link"))
        ET.SubElement(mount, "child", link=ptu)
        parent.set("link", ptu)
    for mesh in root.iter("mesh"):
        if mesh.get("filename"):
            mesh.set("filename", mesh_file(mesh.get("filename"), head.path))
    for old in root.findall("mujoco"):
        root.remove(old)
    ext = ET.SubElement(root, "mujoco")
    ET.SubElement(ext, "compiler", fusestatic="false", discardvisual="false",
                  meshdir=str(head.path.resolve().parent))
    return ET.tostring(root, encoding="unicode"), encoder, cameras


def head_spec(head: UrdfHead, mujoco):
    """(``mujoco.MjSpec`` of the head with the bench's names and cameras, the encoder
    scales and zeros per eye as :class:`rasc.sim.units.UnitBuild` fields); ``mujoco``: the
    module, as :func:`rasc.sim.scene.import_mujoco` gives it (this module does not import
    rasc.sim.scene, which imports it)."""
    text, encoder, cameras = urdf_text(head)
    try:
        spec = mujoco.MjSpec.from_string(text)
    except ValueError as exc:
        msg = " ".join(str(exc).split())
        raise InputError(f"{head.path}: MuJoCo cannot load the URDF: {msg}") from None
    spec.compiler.boundmass = 1e-3
    spec.compiler.boundinertia = 1e-6
    if head.K is None:
        K, size = stock_intrinsics(mujoco)
        size = size if head.image_size is None else head.image_size
    else:
        K, size = head.K, head.image_size
        if size is None:
            raise InputError("UrdfHead: give image_size with K")
    w, h = (int(v) for v in size)
    for eye in EYES:
        Ke = np.asarray(K[eye], dtype=float)
        if Ke.shape != (3, 3) or not np.all(np.isfinite(Ke)) or abs(Ke[0, 1]) > 1e-9 \
                or Ke[0, 0] <= 0 or Ke[1, 1] <= 0:
            raise InputError(f"{eye} K: expected a finite 3x3 camera matrix with positive "
                             "focal lengths and zero skew (MuJoCo's cameras have no skew)")
        body = spec.body(cameras[eye])
        cam = body.add_camera(name=f"{eye}_camera", quat=list(_QUAT_OPTICAL_FROM_MJCAM))
        cam.resolution = [w, h]
        cam.sensor_size = [w * _PIXEL_PITCH, h * _PIXEL_PITCH]
        cam.focal_pixel = [Ke[0, 0], Ke[1, 1]]
        cam.principal_pixel = [w / 2 - 0.5 - Ke[0, 2], h / 2 - 0.5 - Ke[1, 2]]
        for which in ("pan", "tilt"):
            joint = spec.joint(f"{eye}_{which}_joint")
            if joint.range[0] >= joint.range[1]:    # continuous: a full turn
                joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
                joint.range = [-math.pi, math.pi]
    # the stock scene's look (rasc.sim.mjcf._SCENE_TEMPLATE): the target alone is attached
    g = spec.visual.global_
    g.offwidth, g.offheight = max(g.offwidth, w), max(g.offheight, h)
    spec.visual.quality.offsamples = 0
    spec.visual.headlight.ambient = [0.9, 0.9, 0.9]
    spec.visual.headlight.diffuse = [0.1, 0.1, 0.1]
    spec.visual.headlight.specular = [0.0, 0.0, 0.0]
    spec.stat.extent = 2.0
    spec.visual.map.znear = 0.005
    spec.visual.map.zfar = 5.0
    return spec, encoder
