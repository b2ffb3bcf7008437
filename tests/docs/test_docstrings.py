"""Every public module, class and function of the API reference has a docstring.

The API reference (docs/reference/api.md, autosummary over the package) documents the
modules of :mod:`rasc` except the command implementations (``rasc.commands``, documented
from their parsers on the command-line page), ``rasc.__main__`` and private modules
(``_name``). Of each such module: the module itself, and every class and function it
defines (not imports) whose name does not start with an underscore, and the public
methods and properties those classes define. A missing docstring is an empty entry in
the reference; this test names each one.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import pytest

import rasc

#: Exempt, by name within its module (so that a move between modules keeps the entry):
#: these live in modules that other branches of this release restructure (the solver's
#: split, the pipeline's options, the study engine and spec); their docstrings are added
#: there. Remove an entry once its object has a docstring.
ALLOWED_WITHOUT_DOCSTRING: frozenset[str] = frozenset({
    "HandEyeResult.to_dict", "HandEyeUncertainty.to_dict",           # rasc.handeye.solver
    "CalibrationOptions", "Calibration", "Calibration.to_dict",      # rasc.head.pipeline
    "ImageResidual.to_dict", "RefinementResult.to_dict",             # rasc.head.refine
    "csv_text", "sample_rng", "StudyResult",                         # rasc.study.engine
    "Cell.render_value", "Spec.digest",                              # rasc.study.spec
})


def reference_modules() -> list[str]:
    """The modules the API reference documents (see the module docstring)."""
    names = ["rasc"]
    for info in pkgutil.walk_packages(rasc.__path__, "rasc."):
        parts = info.name.split(".")
        if parts[1] in ("commands", "__main__") or any(p.startswith("_") for p in parts):
            continue
        names.append(info.name)
    return sorted(names)


def public_objects(modname: str) -> list[tuple[str, object]]:
    """(module.name, object) of the module and of the public API it defines."""
    module = importlib.import_module(modname)
    out: list[tuple[str, object]] = [(modname, module)]
    for name, obj in vars(module).items():
        if name.startswith("_") or getattr(obj, "__module__", None) != modname:
            continue
        if inspect.isclass(obj):
            out.append((f"{modname}.{name}", obj))
            for attr, member in vars(obj).items():
                if attr.startswith("_"):
                    continue
                if isinstance(member, staticmethod | classmethod):
                    member = member.__func__
                if inspect.isfunction(member) or isinstance(member, property):
                    out.append((f"{modname}.{name}.{attr}", member))
        elif inspect.isfunction(obj):
            out.append((f"{modname}.{name}", obj))
    return out


def test_reference_covers_the_rooms():
    # the walk must see the package's rooms, or the test below would pass on nothing
    modules = reference_modules()
    for room in ("rasc.geometry.frames", "rasc.handeye.noise", "rasc.head.model",
                 "rasc.vision.camera", "rasc.sim.synthetic", "rasc.study", "rasc.testing"):
        assert room in modules
    assert not any(m.startswith("rasc.commands") for m in modules)


def docstring(obj) -> str:
    """The object's own docstring: a method may inherit its base's (as the reference shows
    it), a class may not, and a dataclass's generated ``Name(field: type, ...)`` is none."""
    if inspect.isfunction(obj):
        doc = inspect.getdoc(obj)
    else:
        doc = obj.__doc__
        if inspect.isclass(obj) and doc and doc.startswith(f"{obj.__name__}("):
            doc = None
    return (doc or "").strip()


@pytest.mark.slow   # imports every module of the package (OpenCV, MuJoCo, matplotlib): ~5 s
def test_every_public_object_has_a_docstring():
    missing = [qualname for modname in reference_modules()
               for qualname, obj in public_objects(modname)
               if not docstring(obj)
               and qualname.removeprefix(modname + ".") not in ALLOWED_WITHOUT_DOCSTRING]
    assert not missing, f"{len(missing)} public objects without a docstring: " + \
        ", ".join(missing)
