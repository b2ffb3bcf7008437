"""rasc.guard: a plugin call cannot print on stdout, end the process or hang it."""

from __future__ import annotations

import os
import sys
import time

import pytest

from rasc.guard import PluginExited, PluginTimedOut, guarded


def test_print_goes_to_stderr(capfd):
    assert guarded(lambda: print("from the plugin") or 7) == 7
    out = capfd.readouterr()
    assert out.out == "" and "from the plugin" in out.err


@pytest.mark.parametrize(("fn", "words"), [(lambda: sys.exit(0), "sys.exit(0)"),
                                           (lambda: sys.exit("bye"), "sys.exit('bye')"),
                                           (lambda: os._exit(3), "os._exit(3)")])
def test_exits_become_an_error_naming_the_plugin(fn, words):
    with pytest.raises(PluginExited) as info:
        guarded(fn, who="method 'mine'")
    assert str(info.value) == f"method 'mine': called {words}"
    assert os._exit.__module__ == "posix" or os._exit.__name__ == "_exit"   # restored


def test_a_hang_is_cut_at_the_time_limit():
    t0 = time.perf_counter()
    with pytest.raises(PluginTimedOut, match="time limit of 0.2 s"):
        guarded(lambda: time.sleep(30), who="method 'slow'", time_limit_s=0.2)
    assert time.perf_counter() - t0 < 5          # generous: a loaded 2-core machine
    # the timer is off afterwards: a later slow call is not cut
    guarded(lambda: time.sleep(0.4), time_limit_s=None)


def test_other_errors_pass_unchanged():
    with pytest.raises(ZeroDivisionError):
        guarded(lambda: 1 / 0)


def test_a_guarded_call_inside_another_keeps_the_outer_time_limit():
    """A study's cell guards a plugin method whose call guards its plugin again: the inner
    guard leaves the outer timer running (it would otherwise cancel it on return), so a
    hang after the inner call still ends at the outer limit."""
    import signal

    def inner():
        return guarded(lambda: 1, who="inner", time_limit_s=5.0)

    def outer():
        assert inner() == 1
        remaining = signal.getitimer(signal.ITIMER_REAL)[0]
        assert 0 < remaining <= 0.5          # the outer timer, still running
        time.sleep(5)                         # a hang: ended by the outer limit

    with pytest.raises(PluginTimedOut, match="outer: did not return within"):
        guarded(outer, who="outer", time_limit_s=0.5)
    assert signal.getitimer(signal.ITIMER_REAL)[0] == 0
