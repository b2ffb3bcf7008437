"""Scripts written against the previous layout keep working for one minor version
(issue 25 item 6): every module path that moved (``git log --diff-filter=R -- rasc``)
imports, gives the new module's objects, and warns with a DeprecationWarning naming the
new path, attributed to the script's own line (so Python's default filters show it)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

import rasc


def _run(tmp_path, code: str) -> subprocess.CompletedProcess:
    script = tmp_path / "old_script.py"
    script.write_text(textwrap.dedent(code))
    return subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          cwd=tmp_path, check=False, timeout=120)


def test_every_moved_module_imports_with_a_warning_naming_the_new_path(tmp_path):
    """One fresh process imports each old path in turn, records its warnings, and checks
    that the old path's objects are the new module's (the default warning filters)."""
    code = f"""
    import importlib, warnings
    moved = {rasc.MOVED_MODULES!r}
    for old, new in sorted(moved.items()):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            module = importlib.import_module(old)
        target = importlib.import_module(new)
        public = [n for n in dir(target) if not n.startswith("_")]
        assert public and all(getattr(module, n) is getattr(target, n) for n in public), old
        dep = [w for w in caught if issubclass(w.category, DeprecationWarning)]
        assert len(dep) == 1, (old, [str(w.message) for w in caught])
        assert f"{{old}} moved to {{new}}" in str(dep[0].message), dep[0].message
        print("ok", old)
    """
    run = _run(tmp_path, code)
    assert run.returncode == 0, run.stderr
    assert run.stdout.count("ok ") == len(rasc.MOVED_MODULES) >= 16


def test_a_script_of_the_old_layout_runs_and_is_told_where_each_name_went(tmp_path):
    run = _run(tmp_path, """
    import rasc.kinematics
    from rasc.handeye import solve_rasc
    from rasc.head import HeadCalibration
    from rasc import transforms
    from rasc.geometry.kinematics import T_gaze_from_ptu
    from rasc.handeye.solver import solve_rasc as new_solve
    from rasc.head.model import HeadCalibration as NewHead
    assert rasc.kinematics.T_gaze_from_ptu is T_gaze_from_ptu
    assert solve_rasc is new_solve and HeadCalibration is NewHead
    assert transforms.make_transform is __import__("rasc.geometry.transforms",
                                                   fromlist=["x"]).make_transform
    print("ran")
    """)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "ran"
    lines = [line for line in run.stderr.splitlines() if "DeprecationWarning" in line]
    # Python's default filters show them: each attributed to the script's line
    assert [line.split(":")[1] for line in lines] == ["2", "3", "4", "5"], run.stderr
    assert "rasc.kinematics moved to rasc.geometry.kinematics" in lines[0]
    assert "rasc.handeye.solve_rasc moved to rasc.handeye.solver.solve_rasc" in lines[1]
    assert "rasc.head.HeadCalibration moved to rasc.head.model.HeadCalibration" in lines[2]
    assert "rasc.transforms moved to rasc.geometry.transforms" in lines[3]


def test_unknown_names_still_fail():
    with pytest.raises(AttributeError, match="no attribute 'no_such_module'"):
        rasc.no_such_module  # noqa: B018
    with pytest.raises(ModuleNotFoundError):
        __import__("rasc.no_such_module")
    handeye = __import__("rasc.handeye", fromlist=["x"])
    with pytest.raises(AttributeError, match="no attribute 'nothing_here'"):
        handeye.nothing_here  # noqa: B018
