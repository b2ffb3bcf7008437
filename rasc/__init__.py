"""rasc: Robust Active Stereo Calibration (Neubert & Ferrier, ICRA 2002).

Frames and notation: :mod:`rasc.geometry.frames`; the frame tables are in the
documentation's reference (docs/reference/frames.md).
The mathematics (``transforms``, ``kinematics``, ``handeye``, ``li``, ``base_to_ptu``,
``triangulation``, ``noise``) needs only numpy and scipy; ``camera`` imports cv2 and
``sim`` imports mujoco, lazily.

``rasc.load_calibration(path)`` reads the file ``rasc calibrate`` writes and returns the
:class:`rasc.head.model.HeadCalibration` (:func:`rasc.head.use.load_calibration`); it is
imported on first use, so ``import rasc`` stays cheap.
"""

__version__ = "0.2.0"

__all__ = ["__version__", "load_calibration"]

import sys as _sys
import warnings as _warnings

#: Modules that moved when rasc became subpackages (the layout of 0.1.0): each old path
#: still imports, for one minor version (until 0.3), with a DeprecationWarning naming the
#: new path (:class:`_MovedFinder`); found with ``git log --diff-filter=R -- rasc``.
MOVED_MODULES = {
    "rasc.base_to_ptu": "rasc.head.base_to_ptu",
    "rasc.board": "rasc.vision.board",
    "rasc.camera": "rasc.vision.camera",
    "rasc.dataset": "rasc.vision.dataset",
    "rasc.frames": "rasc.geometry.frames",
    "rasc.handeye_io": "rasc.handeye.document",
    "rasc.kinematics": "rasc.geometry.kinematics",
    "rasc.lens": "rasc.geometry.lens",
    "rasc.li": "rasc.handeye.li",
    "rasc.methods": "rasc.handeye.methods",
    "rasc.noise": "rasc.handeye.noise",
    "rasc.opencv_handeye": "rasc.handeye.opencv",
    "rasc.pipeline": "rasc.head.pipeline",
    "rasc.render": "rasc.sim.render",
    "rasc.transforms": "rasc.geometry.transforms",
    "rasc.triangulation": "rasc.geometry.triangulation",
}

#: Modules that became packages of the same name: the public names the module had, and
#: the modules that hold them now (``rasc.handeye.solve_rasc`` →
#: ``rasc.handeye.solver.solve_rasc``); each package's ``__getattr__`` forwards them with
#: a DeprecationWarning (:func:`moved_attribute`).
MOVED_NAMES = {
    "rasc.handeye": (
        ("Logarithms", "MIN_PAIR_ROTATION_RAD", "MIN_AXIS_SPREAD", "WEAK_AXIS_SPREAD",
         "QUALITY_UNUSABLE", "MAX_ROTATION_UNCERTAINTY_DEG", "MAX_COND_CTC", "PAIRS",
         "HandEyeDiagnostics", "HandEyeResult", "HandEyeUncertainty", "HandEyeBatchResult",
         "validate_poses", "pair_rotvecs", "quality_eq10", "MAX_MOTION_ANGLE_RATIO",
         "motion_angle_ratio", "check_motions_match", "input_warnings",
         "solution_warnings", "solve_rasc", "solve_rasc_batch", "diagnose"),
        ("rasc.handeye.solver", "rasc.handeye.advice")),
    "rasc.head": (("FORMAT", "EYE_FIELDS", "EyeCalibration", "HeadCalibration"),
                  ("rasc.head.model",)),
    "rasc.sim": (("MODELS_DIR", "HEAD_XML", "SCENE_XML", "GL_BACKENDS", "gl_backend",
                  "import_mujoco", "scene_xml", "T_base_from_world_facing",
                  "T_cam_from_scene_mujoco", "StereoHeadSim", "add_pixel_noise", "blur",
                  "distortion_warp", "distort", "degrade"),
                 ("rasc.sim.scene",)),
}


def _warn_moved(old: str, new: str) -> None:
    """A DeprecationWarning attributed to the user's line (not importlib's, not rasc's),
    so that Python's default filters show it in a script."""
    here = __file__.rsplit("/", 1)[0] if "/" in __file__ else __file__
    # warnings.warn itself steps over importlib's frames: count only rasc's own
    level, frame = 2, _sys._getframe(1)
    while frame is not None:
        name = frame.f_code.co_filename
        if not name.startswith(("<frozen", here)):
            break
        level += 0 if name.startswith("<frozen importlib") else 1
        frame = frame.f_back
    _warnings.warn(f"{old} moved to {new}; the old path works until rasc 0.3: import "
                   f"{new} instead", DeprecationWarning, stacklevel=level)


class _MovedModule:
    """Loader of an old module path: a module that forwards every attribute to the new
    one (PEP 562), so ``import rasc.kinematics`` and ``from rasc.kinematics import
    T_gaze_from_ptu`` work and give the new module's objects."""

    def __init__(self, new: str) -> None:
        self.new = new

    def create_module(self, spec):
        return None

    def exec_module(self, module) -> None:
        import importlib

        _warn_moved(module.__name__, self.new)
        target = importlib.import_module(self.new)
        module.__doc__ = f"Deprecated alias of :mod:`{self.new}` (until rasc 0.3)."
        module.__getattr__ = lambda name: getattr(target, name)
        module.__dir__ = lambda: dir(target)


class _MovedFinder:
    """The ``sys.meta_path`` finder of :data:`MOVED_MODULES`."""

    @staticmethod
    def find_spec(fullname, path=None, target=None):
        if fullname not in MOVED_MODULES:
            return None
        from importlib.machinery import ModuleSpec

        return ModuleSpec(fullname, _MovedModule(MOVED_MODULES[fullname]))


if not any(isinstance(f, _MovedFinder) for f in _sys.meta_path):
    _sys.meta_path.append(_MovedFinder())


def moved_attribute(package: str, name: str):
    """``package.name`` for a name the old module ``package`` had (:data:`MOVED_NAMES`),
    with a DeprecationWarning naming where it lives now; else AttributeError."""
    import importlib

    names, homes = MOVED_NAMES.get(package, ((), ()))
    if name in names:
        for home in homes:
            module = importlib.import_module(home)
            if hasattr(module, name):
                _warn_moved(f"{package}.{name}", f"{home}.{name}")
                return getattr(module, name)
    raise AttributeError(f"module {package!r} has no attribute {name!r}")


def __getattr__(name: str):
    if name == "load_calibration":
        from rasc.head.use import load_calibration

        return load_calibration
    if f"rasc.{name}" in MOVED_MODULES:
        __import__(f"rasc.{name}")       # the builtin: no importlib frame before the user's
        return _sys.modules[f"rasc.{name}"]
    raise AttributeError(f"module 'rasc' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | {"load_calibration"})
