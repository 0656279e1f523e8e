"""The suite-wide thread-leak check (tests/conftest.py) fails a test that leaks a thread."""

from __future__ import annotations

from pathlib import Path

import pytest

CONFTEST = Path(__file__).with_name("conftest.py")


def test_a_leaked_non_daemon_thread_fails_the_test(pytester: pytest.Pytester) -> None:
    pytester.makeconftest(CONFTEST.read_text(encoding="utf-8"))
    pytester.makepyfile(
        test_leaky="""
        import threading

        stop = threading.Event()

        def test_leaks():
            threading.Thread(target=stop.wait, name="leaky-worker").start()

        def test_daemon_is_fine():
            threading.Thread(target=stop.wait, name="daemon", daemon=True).start()

        def test_leaks_a_runtime_daemon():
            threading.Thread(target=stop.wait, name="xgo-show writer rex", daemon=True).start()

        def test_cleans_up():
            t = threading.Thread(target=lambda: None, name="short")
            t.start()
            stop.set()
        """
    )
    result = pytester.runpytest_inprocess("-p", "no:cacheprovider")
    result.assert_outcomes(passed=4, errors=2)
    result.stdout.fnmatch_lines(
        [
            "*test left threads running: leaky-worker*",
            "*test left threads running: xgo-show writer rex*",
        ]
    )
