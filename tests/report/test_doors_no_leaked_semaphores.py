"""No stray lines after the reproduction ends (issue 25 item 7): ``make reproduce`` ends
through ``exit_process(..., teardown=False)`` (``os._exit``), which skipped
multiprocessing's exit handlers, and the resource tracker then printed "There appear to
be N leaked semaphore objects" after the report line. The same shape here: a forkserver
pool and executor, finished, then that exit."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

SCRIPT = textwrap.dedent("""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from rasc.interrupt import exit_process


    def square(x):
        return x * x


    if __name__ == "__main__":
        mp = multiprocessing.get_context("forkserver")
        pool = mp.Pool(2)
        print(pool.map(square, range(4)))
        pool.close()
        pool.join()
        with ProcessPoolExecutor(2, mp_context=mp) as ex:
            print(list(ex.map(square, range(4))))
        exit_process(0, teardown=False)
""")


@pytest.mark.slow
def test_no_resource_tracker_lines_after_a_fast_exit(tmp_path):
    script = tmp_path / "pools.py"
    script.write_text(SCRIPT)
    # the tracker holds the stderr pipe until it ends: run() returns after its last word
    run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         timeout=120, check=False)
    assert run.returncode == 0, run.stderr
    assert run.stdout.splitlines() == ["[0, 1, 4, 9]", "[0, 1, 4, 9]"]
    assert run.stderr == ""
