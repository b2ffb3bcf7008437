"""The house: one room (subpackage) per concept, imports that only run down, no circle.

Every ``import rasc...`` / ``from rasc... import`` in the library counts, including the
ones inside functions (a lazy import hides a circle at run time, not from a reader).
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

from rasc.layout import ROOMS

RASC = Path(__file__).resolve().parents[2] / "rasc"

#: Rooms and their floors, from the one layout table (rasc/layout.py): a room may import
#: its own floor and the floors below it. The ground floor ("") is rasc/*.py's shared
#: utilities (errors, formats, io, interrupt, layout, progress).
def _room_of(where: str) -> str:
    parts = where.split(",")[0].strip().rstrip("/").split("/")
    return "" if parts[-1].endswith(".py") and len(parts) == 2 and parts[-1] in GROUND \
        else parts[-1].removesuffix(".py")


GROUND = ("errors.py", "formats.py", "guard.py", "io.py", "interrupt.py", "layout.py",
          "progress.py")
FLOORS = {_room_of(r.where): r.floor for r in ROOMS if r.floor is not None}

#: Rooms on one floor that must not import each other.
SAME_FLOOR_FORBIDDEN = {("handeye", "vision"), ("vision", "handeye"), ("sim", "head"),
                        ("head", "sim"), ("recordings", "head"), ("recordings", "sim"),
                        ("head", "recordings"), ("sim", "recordings")}


def module_name(path: Path) -> str:
    rel = path.relative_to(RASC.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def room(module: str) -> str:
    parts = module.split(".")
    if len(parts) == 1:
        return ""
    name = parts[1]
    if len(parts) == 2 and f"{name}.py" in GROUND:
        return ""
    return name


def rasc_imports(path: Path) -> set[str]:
    """Modules of rasc that ``path`` imports (absolute names), anywhere in the file."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    me = module_name(path)
    package = me if path.name == "__init__.py" else me.rpartition(".")[0]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.split(".")[0] == "rasc")
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if mod.split(".")[0] != "rasc":
                continue
            for a in node.names:  # ``from rasc.x import y``: y may be a module
                candidate = f"{mod}.{a.name}"
                found.add(candidate if _exists(candidate) else mod)
    found.discard(me)
    return found


def _exists(module: str) -> bool:
    p = RASC.parent.joinpath(*module.split("."))
    return p.with_suffix(".py").is_file() or (p / "__init__.py").is_file()


def import_graph() -> dict[str, set[str]]:
    return {module_name(p): rasc_imports(p) for p in sorted(RASC.rglob("*.py"))}


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in graph:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    return out


#: The package's public entry points, re-exported by ``rasc/__init__.py`` through a lazy
#: module ``__getattr__`` (``rasc.load_calibration``): imported on first attribute access,
#: never by ``import rasc``, so no floor below loads them (checked in
#: tests/head/test_use_calibration.py).
FACADE = {"rasc": {"rasc.head.use"}}


def upward_imports(graph: dict[str, set[str]]) -> list[str]:
    bad = []
    for mod, deps in graph.items():
        r = room(mod)
        for dep in deps:
            d = room(dep)
            if r == d or dep in FACADE.get(mod, ()):
                continue
            if r not in FLOORS or d not in FLOORS:
                bad.append(f"{mod} -> {dep} (room not in FLOORS)")
            elif FLOORS[d] > FLOORS[r] or (r, d) in SAME_FLOOR_FORBIDDEN:
                bad.append(f"{mod} -> {dep}")
    return sorted(bad)


def test_no_import_circle():
    assert cycles(import_graph()) == []


def test_imports_only_run_down():
    assert upward_imports(import_graph()) == []


def test_every_room_is_a_package_and_the_ground_floor_is_small():
    top = sorted(p.name for p in RASC.iterdir() if p.suffix == ".py")
    assert set(top) <= {"__init__.py", "__main__.py", "cli.py", "testing.py", *GROUND}, top


def test_the_checks_can_fail():
    """The detectors themselves: a made-up circle and an upward import are found."""
    g = {"rasc.handeye.solver": {"rasc.handeye.li"}, "rasc.handeye.li": {"rasc.handeye.solver"},
         "rasc.geometry.lens": {"rasc.head.model"}, "rasc.head.model": set()}
    assert cycles(g) == [["rasc.handeye.li", "rasc.handeye.solver"]]
    assert upward_imports(g) == ["rasc.geometry.lens -> rasc.head.model"]


#: the mathematics, room by room (docs: "The mathematics ... must import with numpy and
#: scipy alone")
MATHEMATICS = (
    ("rasc.geometry.transforms", "rasc.geometry.kinematics", "rasc.geometry.lens",
     "rasc.geometry.triangulation", "rasc.geometry.frames"),
    ("rasc.handeye.solver", "rasc.handeye.advice", "rasc.handeye.li", "rasc.handeye.noise",
     "rasc.handeye.methods", "rasc.handeye.document"),
    ("rasc.head.model", "rasc.head.base_to_ptu", "rasc.head.use"),
)


def test_the_mathematics_needs_numpy_and_scipy_alone():
    """One fresh process imports the rooms one after another and lists, after each, the
    libraries loaded: importing only adds modules, so a room whose list is still empty
    loaded none, and the first non-empty list names the room that did. (One process
    instead of one per room: about 0.8 s of CPU each.)"""
    code = ("import importlib, sys\n"
            f"for room in {MATHEMATICS!r}:\n"
            "    for name in room:\n"
            "        importlib.import_module(name)\n"
            "    print(sorted(m for m in ('cv2', 'mujoco', 'matplotlib') if m in sys.modules))\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=False)
    assert proc.returncode == 0, proc.stderr
    loaded = proc.stdout.splitlines()
    assert len(loaded) == len(MATHEMATICS)
    for room, libraries in zip(MATHEMATICS, loaded, strict=True):
        assert libraries == "[]", (room, libraries)


def test_every_command_module_is_registered_and_none_is_hidden():
    """rasc/commands/<name>.py (not _private) is exactly rasc.cli.COMMANDS, and each one
    builds its parser: a command whose module fails to import is an error, not skipped."""
    from rasc.cli import COMMANDS, build_parser, command_name

    modules = {p.stem for p in (RASC / "commands").glob("*.py") if not p.stem.startswith("_")}
    assert set(COMMANDS) == modules
    names = set(build_parser()._subparsers._group_actions[0].choices)
    assert names == {command_name(c) for c in COMMANDS}
