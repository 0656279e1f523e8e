"""The relay child's supervision (relay/child.py), in this process: the command it runs, how a
start is confirmed or refused, and how it is ended. The child here is a small Python script
that behaves as the relay does at its edges (prints ``ready``, reads ``done``, fails with an
error line, hangs, ignores SIGTERM); test_child.py runs the real relay through ``xgo-show run``.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time

import pytest

from xgo_show.errors import SetupError
from xgo_show.net.keys import check_relay_name
from xgo_show.relay import child as child_module
from xgo_show.relay.child import READY_TIMEOUT, RelayChild

READY = "import sys; print('relay ready', flush=True)"
# Ready, then ends when its standard input says the conductor is done (as the relay does).
UNTIL_DONE = READY + "; line = sys.stdin.readline(); sys.exit(0 if line == 'done\\n' else 3)"


def script(code: str) -> list[str]:
    return [sys.executable, "-c", code]


def started(code: str) -> RelayChild:
    child = RelayChild({"rex": "sim:mini"}, {"rex": "mini"}, namespace="xgo-show")
    child.cmd = script(code)
    return child.start()


def test_the_child_is_a_relay_for_the_ports_listening_on_a_free_loopback_port() -> None:
    child = RelayChild({"rex": "/dev/ttyUSB0", "lola": "sim:lite"},
                       {"rex": "mini", "lola": "lite"}, namespace="stage/a")
    assert child.proc is None  # not started yet
    host, _, port = child.endpoint.removeprefix("tcp/").rpartition(":")
    assert host == "127.0.0.1" and 0 < int(port) < 65536
    assert child.cmd == [
        sys.executable, "-m", "xgo_show", "relay", "--name", child.name,
        "--map", "rex=/dev/ttyUSB0", "--model", "rex=mini",
        "--map", "lola=sim:lite", "--model", "lola=lite",
        "--listen", child.endpoint, "--namespace", "stage/a",
        "--parent-pid", str(os.getpid()),
    ]


def test_the_endpoints_port_is_free() -> None:
    child = RelayChild({}, {}, namespace="xgo-show")
    port = int(child.endpoint.rpartition(":")[2])
    assert port >= 1024  # one the system hands out, never a privileged one
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", port))  # nothing holds it


@pytest.mark.parametrize(
    ("options", "flags"),
    [
        ({}, []),
        ({"telemetry": False}, ["--no-telemetry"]),
        ({"allow_unsafe": True}, ["--allow-unsafe"]),
        ({"realtime": "required"}, ["--realtime"]),
        ({"realtime": "off"}, ["--no-realtime"]),
        ({"log": "run.jsonl"}, ["--log", "run.jsonl"]),
        ({"log": ""}, []),
        ({"telemetry": False, "allow_unsafe": True, "realtime": "required", "log": "r.jsonl"},
         ["--no-telemetry", "--allow-unsafe", "--realtime", "--log", "r.jsonl"]),
    ],
)
def test_the_conductors_options_are_passed_on(options: dict[str, object], flags: list[str]
                                              ) -> None:
    child = RelayChild({"rex": "sim:mini"}, {"rex": "mini"}, namespace="xgo-show",
                       **options)  # type: ignore[arg-type]
    tail = child.cmd[child.cmd.index("--parent-pid") + 2:]
    assert tail == flags


@pytest.mark.parametrize(
    ("host", "name"),
    [
        ("stage-pc", "stage-pc"),
        ("stage pc.example.org", "stage-pc"),  # the host part, a space made a dash
        ("büh_ne.local", "b-h_ne"),  # ASCII only: a relay name is a key chunk
        ("x" * 50 + ".lan", "x" * 40),
    ],
)
def test_the_relay_name_is_the_short_host_name_and_the_pid_in_key_safe_characters(
    monkeypatch: pytest.MonkeyPatch, host: str, name: str
) -> None:
    monkeypatch.setattr(socket, "gethostname", lambda: host)
    child = RelayChild({}, {}, namespace="xgo-show")
    assert child.name == f"local-{name}-{os.getpid()}"
    assert check_relay_name(child.name) == child.name  # the relay accepts it


def test_a_child_that_says_ready_is_started_in_its_own_session_and_ended_by_done() -> None:
    child = started(UNTIL_DONE)
    proc = child.proc
    assert proc is not None and proc.poll() is None
    assert os.getsid(proc.pid) == proc.pid  # Ctrl-C in the terminal reaches the conductor only
    child.close()
    assert proc.returncode == 0  # it read "done"
    assert child.proc is None
    assert proc.stdout is not None and proc.stdout.closed
    child.close()  # twice: nothing more to do


def test_as_a_context_manager_it_starts_and_closes() -> None:
    child = RelayChild({"rex": "sim:mini"}, {"rex": "mini"}, namespace="xgo-show")
    child.cmd = script(UNTIL_DONE)
    with child as running:
        assert running is child
        proc = child.proc
        assert proc is not None and proc.poll() is None
    assert proc.returncode == 0 and child.proc is None


def test_a_child_that_fails_to_start_is_reported_by_its_last_error_line() -> None:
    code = ("import sys; print('opening rex', file=sys.stderr); "
            "print('xgo-show: error: rex (/dev/ttyUSB0): no such port', file=sys.stderr); "
            "sys.exit(2)")
    with pytest.raises(SetupError) as info:
        started(code)
    assert str(info.value) == (
        "the process that owns the local ports did not start: rex (/dev/ttyUSB0): no such port")


def test_a_one_line_error_is_reported_whole_and_the_child_is_forgotten() -> None:
    child = RelayChild({"rex": "sim:mini"}, {"rex": "mini"}, namespace="xgo-show")
    child.cmd = script("import sys; sys.stderr.write('xgo-show: error: port busy'); "
                       "sys.exit(2)")
    with pytest.raises(SetupError) as info:
        child.start()
    assert str(info.value) == "the process that owns the local ports did not start: port busy"
    assert child.proc is None
    child.close()  # nothing to close


def test_the_last_of_several_error_lines_is_the_reason() -> None:
    code = ("import sys; [print(line, file=sys.stderr) for line in "
            "('a warning', 'another', 'xgo-show: error: the last')]; sys.exit(2)")
    with pytest.raises(SetupError, match=r"did not start: the last$"):
        started(code)


def test_bytes_that_are_not_utf8_do_not_hide_the_answer() -> None:
    child = started("import sys; sys.stdout.buffer.write(b'relay \\xff ready\\n'); "
                    "sys.stdout.flush(); sys.stdin.readline()")
    child.close()
    code = ("import sys; sys.stderr.buffer.write(b'xgo-show: error: port \\xff busy\\n'); "
            "sys.exit(2)")
    with pytest.raises(SetupError) as info:
        started(code)
    assert str(info.value).endswith("did not start: port \ufffd busy")


def test_a_child_that_says_something_else_first_is_not_started() -> None:
    with pytest.raises(SetupError) as info:
        started("import sys, time; print('hello', flush=True); time.sleep(30)")
    assert str(info.value) == (
        "the process that owns the local ports did not start: no answer in time")


def test_a_child_that_never_answers_is_killed_after_the_ready_timeout(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    assert READY_TIMEOUT == 20.0  # opening ports and a Zenoh session on a slow machine
    monkeypatch.setattr(child_module, "READY_TIMEOUT", 0.3)
    spawned: list[subprocess.Popen[bytes]] = []
    real = subprocess.Popen

    def spying(*args: object, **kwargs: object) -> subprocess.Popen[bytes]:
        proc = real(*args, **kwargs)  # type: ignore[call-overload]
        spawned.append(proc)
        return proc  # type: ignore[no-any-return]

    monkeypatch.setattr(subprocess, "Popen", spying)
    start = time.monotonic()
    with pytest.raises(SetupError, match=r"did not start: no answer in time$"):
        started("import time; time.sleep(30)")
    assert time.monotonic() - start < 10
    assert spawned[0].returncode == -signal.SIGKILL


def test_a_child_that_is_gone_already_is_closed_quietly() -> None:
    child = started(READY)  # says ready and exits at once
    proc = child.proc
    assert proc is not None
    proc.wait(10)
    child.close()  # the pipe to it is broken: nothing to tell it
    assert proc.returncode == 0 and child.proc is None


def test_a_child_that_ignores_done_gets_sigterm_after_the_timeout() -> None:
    child = started(READY + "; import time; time.sleep(30)")
    proc = child.proc
    assert proc is not None
    start = time.monotonic()
    child.close(timeout=0.3)
    assert proc.returncode == -signal.SIGTERM
    assert time.monotonic() - start < 5


def test_a_child_that_ignores_sigterm_is_killed() -> None:
    code = ("import signal, sys, time; signal.signal(signal.SIGTERM, signal.SIG_IGN); "
            "print('relay ready', flush=True); time.sleep(30)")
    child = started(code)
    proc = child.proc
    assert proc is not None
    start = time.monotonic()
    child.close(timeout=0.3)
    assert proc.returncode == -signal.SIGKILL
    assert time.monotonic() - start < 5


@pytest.mark.parametrize(
    ("host", "name"),
    [("stage-pc.example.org", "stage-pc"), ("büh ne", "b-h-ne"), ("x" * 70, "x" * 64),
     ("", "relay")],
)
def test_a_relay_started_by_hand_is_named_after_its_host_the_same_way(
    monkeypatch: pytest.MonkeyPatch, host: str, name: str
) -> None:
    from xgo_show.cli.relay import default_name

    monkeypatch.setattr(socket, "gethostname", lambda: host)
    assert default_name() == name
    assert check_relay_name(name) == name
