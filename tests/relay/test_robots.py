"""The robots a relay owns (relay/robots.py) and the parent-death signal (relay/parent.py),
in-process on simulated robots: the --map/--model pairs, opening and identifying, what a
refresh reads, the stop sequence a robot is sent, and its row in the relay's description."""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import time
from collections.abc import Iterator

import pytest

from xgo_show.client import XarmClient, XgoClient
from xgo_show.errors import SetupError, TransportError, UsageError
from xgo_show.profiles import get_profile
from xgo_show.profiles.xarm import battery_percent
from xgo_show.relay.parent import watch_parent
from xgo_show.relay.robots import OwnedRobot, close_robots, open_robots, parse_pairs
from xgo_show.runtime.safety import stop_frames
from xgo_show.transports.base import Transport


class Recording(Transport):
    """A transport that passes everything on to ``inner`` and keeps what was written; it can
    be told to fail writes (an unplugged cable)."""

    def __init__(self, inner: Transport, fail: BaseException | None = None) -> None:
        super().__init__(inner.url)
        self.inner = inner
        self.written: list[bytes] = []
        self.fail = fail
        self.closed = False

    def open(self) -> None:
        self.inner.open()

    def close(self) -> None:
        self.closed = True
        self.inner.close()

    @property
    def is_open(self) -> bool:
        return self.inner.is_open

    def write(self, data: bytes) -> None:
        if self.fail is not None:
            raise self.fail
        self.written.append(bytes(data))
        self.inner.write(data)

    def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
        return self.inner.read(size, timeout)



@pytest.fixture
def owned() -> Iterator[dict[str, OwnedRobot]]:
    robots = open_robots({"rex": "sim:mini", "arm": "sim:xarm", "rita": "sim:rider"}, {})
    yield robots
    close_robots(robots)


# --- --map NAME=PORT and --model NAME=MODEL ---------------------------------------------------

def test_pairs_are_split_at_the_first_equals_sign_and_trimmed() -> None:
    assert parse_pairs([" rex = /dev/ttyUSB0 ", "arm=hex+sim:xarm=1"], "--map", "rex=PORT") == {
        "rex": "/dev/ttyUSB0", "arm": "hex+sim:xarm=1"}
    assert parse_pairs([], "--map", "rex=PORT") == {}


@pytest.mark.parametrize("item", ["rex", "=sim:mini", "rex=", " = ", "rex= "])
def test_a_pair_without_a_name_or_a_value_is_a_usage_error_with_an_example(item: str) -> None:
    with pytest.raises(UsageError) as info:
        parse_pairs(["rita=sim:mini", item], "--map", "rex=/dev/ttyUSB0")
    assert str(info.value) == f"--map {item!r}: write NAME=VALUE, e.g. rex=/dev/ttyUSB0"


def test_a_name_given_twice_is_a_usage_error() -> None:
    with pytest.raises(UsageError) as info:
        parse_pairs(["rex=mini", "rita=rider", " rex=lite"], "--model", "rex=mini")
    assert str(info.value) == "--model ' rex=lite': rex is given twice"


# --- opening ------------------------------------------------------------------------------

def test_each_robot_is_identified_and_read_when_its_port_opens(
    owned: dict[str, OwnedRobot],
) -> None:
    assert list(owned) == ["rex", "arm", "rita"]
    rex, arm, rita = owned["rex"], owned["arm"], owned["rita"]
    assert (rex.name, rex.url, rex.model) == ("rex", "sim:mini", "mini")
    assert rex.firmware == get_profile("mini").firmware_default
    assert rita.model == "rider" and rita.firmware == get_profile("rider").firmware_default
    assert rex.battery == 100.0 and rex.voltage is None
    assert arm.model == "xarm" and arm.firmware == "xArm controller"
    millivolts = arm.client().battery_mv()
    assert arm.voltage == millivolts / 1000
    assert arm.battery == battery_percent(millivolts)
    assert all(r.transport.is_open and not r.problems for r in owned.values())


def test_a_model_given_is_used_without_asking_the_robot() -> None:
    robots = open_robots({"rex": "sim:mini"}, {"rex": "lite"})
    try:
        assert robots["rex"].model == "lite"
        assert robots["rex"].profile is get_profile("lite")
    finally:
        close_robots(robots)


def test_a_model_for_a_robot_no_map_names_is_a_usage_error() -> None:
    with pytest.raises(UsageError) as info:
        open_robots({"rex": "sim:mini"}, {"zed": "mini", "amy": "lite", "rex": "mini"})
    assert str(info.value) == "--model for amy, zed, which no --map names"


def test_a_port_that_fails_closes_the_ports_opened_before_it() -> None:
    opened: list[Transport] = []
    import xgo_show.relay.robots as robots_module

    real = robots_module.open_client

    def spying(url: str, model: str | None = None, **kw: object) -> object:
        client = real(url, model, **kw)  # type: ignore[arg-type]
        opened.append(client.transport)
        return client

    mp = pytest.MonkeyPatch()
    mp.setattr(robots_module, "open_client", spying)
    try:
        with pytest.raises(SetupError) as info:
            open_robots({"rex": "sim:mini", "bad": "sim:nosuchmodel", "rita": "sim:rider"}, {})
    finally:
        mp.undo()
    assert str(info.value).startswith("bad (sim:nosuchmodel): ")
    assert isinstance(info.value.__cause__, Exception)
    assert len(opened) == 1 and not opened[0].is_open


def test_a_failure_while_reading_closes_every_port(monkeypatch: pytest.MonkeyPatch) -> None:
    opened: list[OwnedRobot] = []

    def failing(self: OwnedRobot, timeout: float = 0.3) -> None:
        opened.append(self)
        if len(opened) == 2:
            raise KeyboardInterrupt  # Ctrl-C while the relay starts

    monkeypatch.setattr(OwnedRobot, "refresh", failing)
    with pytest.raises(KeyboardInterrupt):
        open_robots({"rex": "sim:mini", "rita": "sim:rider"}, {})
    assert [r.name for r in opened] == ["rex", "rita"]
    assert not any(r.transport.is_open for r in opened)


def test_close_robots_closes_every_port(owned: dict[str, OwnedRobot]) -> None:
    close_robots(owned)
    assert not any(r.transport.is_open for r in owned.values())


# --- a robot's clients, refresh, stop and description --------------------------------------

def test_the_client_matches_the_family_and_the_timeout(owned: dict[str, OwnedRobot]) -> None:
    arm, rex = owned["arm"].client(timeout=0.25), owned["rex"].client(timeout=0.125)
    assert isinstance(arm, XarmClient) and arm.transport is owned["arm"].transport
    assert isinstance(rex, XgoClient) and rex.transport is owned["rex"].transport
    assert (arm.profile, rex.profile) == (get_profile("xarm"), get_profile("mini"))
    assert (arm.timeout, rex.timeout) == (0.25, 0.125)
    assert owned["arm"].client().timeout == owned["rita"].client().timeout == 0.5


class Silent(Recording):
    """A robot that never answers: each read waits its whole timeout, which is kept."""

    def __init__(self, inner: Transport) -> None:
        super().__init__(inner)
        self.waits: list[float] = []

    def read(self, size: int = 4096, timeout: float = 0.0) -> bytes:
        if timeout > 0:
            self.waits.append(timeout)
            time.sleep(timeout)
        return b""


@pytest.mark.parametrize("name", ["rex", "arm"])
def test_a_refresh_waits_for_a_silent_robot_no_longer_than_its_timeout(
    owned: dict[str, OwnedRobot], name: str,
) -> None:
    robot = owned[name]
    silent = Silent(robot.transport)
    robot.transport = silent
    robot.refresh(timeout=0.05)
    assert silent.waits and max(silent.waits) <= 0.05
    assert len(robot.problems) == 1
    silent.waits.clear()
    robot.refresh()  # by default 0.3 s: the relay's description stays quick
    assert 0.25 < max(silent.waits) <= 0.3


def test_open_robots_gives_each_robot_the_timeout_to_answer(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import xgo_show.relay.robots as robots_module

    asked: list[tuple[str, float]] = []
    real = robots_module.open_client

    def spying(url: str, model: str | None = None, *, timeout: float) -> object:
        asked.append(("open", timeout))
        return real(url, model, timeout=timeout)

    def refresh(self: OwnedRobot, timeout: float = 99.0) -> None:
        asked.append(("refresh", timeout))

    monkeypatch.setattr(robots_module, "open_client", spying)
    monkeypatch.setattr(OwnedRobot, "refresh", refresh)
    close_robots(open_robots({"rex": "sim:mini"}, {}))
    close_robots(open_robots({"rex": "sim:mini"}, {}, timeout=0.125))
    assert asked == [("open", 0.5), ("refresh", 0.5), ("open", 0.125), ("refresh", 0.125)]


def test_a_refresh_reads_the_battery_again_and_forgets_old_problems(
    owned: dict[str, OwnedRobot],
) -> None:
    rex = owned["rex"]
    robot = rex.transport.robot  # type: ignore[attr-defined]
    robot.set_battery(42)
    rex.problems.append("an old problem")
    rex.refresh()
    assert rex.battery == 42.0 and rex.problems == []


@pytest.mark.parametrize("name", ["rex", "arm"])
def test_a_refresh_that_cannot_read_says_why_in_problems(
    owned: dict[str, OwnedRobot], name: str,
) -> None:
    robot = owned[name]
    before = (robot.firmware, robot.battery)
    robot.transport.close()
    robot.refresh()
    robot.refresh()  # once, not once a refresh
    assert robot.problems == [f"{robot.url} is not open"]
    assert (robot.firmware, robot.battery) == before


def test_a_safe_stop_sends_the_models_stop_sequence(owned: dict[str, OwnedRobot]) -> None:
    for robot in owned.values():
        recording = Recording(robot.transport)
        robot.transport = recording
        assert robot.safe_stop() == ""
        assert recording.written == [f.data for f in stop_frames(robot.profile)]
        assert recording.written  # every model has one


@pytest.mark.parametrize("error", [OSError("cable pulled"), TransportError("cable pulled")])
def test_a_safe_stop_that_cannot_write_says_why(
    owned: dict[str, OwnedRobot], error: BaseException,
) -> None:
    rex = owned["rex"]
    rex.transport = Recording(rex.transport, fail=error)
    assert rex.safe_stop() == "cable pulled"


def test_the_description_row_copies_the_problems(owned: dict[str, OwnedRobot]) -> None:
    arm = owned["arm"]
    arm.problems.append("low battery")
    row = arm.describe("playing")
    assert row == {
        "name": "arm", "model": "xarm", "port": "sim:xarm", "firmware": "xArm controller",
        "battery": arm.battery, "voltage": arm.voltage, "state": "playing",
        "problems": ["low battery"],
    }
    arm.problems.clear()
    assert row["problems"] == ["low battery"]


# --- the parent-death signal ----------------------------------------------------------------

_PR_SET_PDEATHSIG, _PR_GET_PDEATHSIG = 1, 2


def _death_signal() -> int:
    libc = ctypes.CDLL(None, use_errno=True)
    value = ctypes.c_int(-1)
    assert libc.prctl(_PR_GET_PDEATHSIG, ctypes.byref(value), 0, 0, 0) == 0
    return value.value


@pytest.fixture
def no_death_signal() -> Iterator[None]:
    """The test process asks for the signal itself: clear it again afterwards."""
    yield
    ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, 0, 0, 0, 0)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
def test_watching_the_parent_asks_the_kernel_for_sigterm(no_death_signal: None) -> None:
    assert _death_signal() == 0
    assert watch_parent(os.getppid()) is True
    assert _death_signal() == signal.SIGTERM


def test_elsewhere_no_signal_is_promised(monkeypatch: pytest.MonkeyPatch) -> None:
    # Not Linux: the relay polls getppid() and its watchdog notices the silent conductor.
    from types import SimpleNamespace

    import xgo_show.relay.parent as parent_module

    monkeypatch.setattr(parent_module, "sys", SimpleNamespace(platform="darwin"))
    assert watch_parent(os.getppid()) is False
    assert _death_signal() == 0


@pytest.mark.parametrize("error", [OSError("no libc"), AttributeError("no prctl")])
def test_without_prctl_no_signal_is_promised(
    monkeypatch: pytest.MonkeyPatch, error: Exception
) -> None:
    import xgo_show.relay.parent as parent_module

    def no_libc(*args: object, **kwargs: object) -> object:
        raise error

    monkeypatch.setattr(parent_module.ctypes, "CDLL", no_libc)
    assert watch_parent(os.getppid()) is False


def test_a_parent_that_is_gone_already_is_a_setup_error(no_death_signal: None) -> None:
    gone = os.getppid() + 1_000_000
    with pytest.raises(SetupError) as info:
        watch_parent(gone)
    assert str(info.value) == f"the conductor (pid {gone}) is gone already"
