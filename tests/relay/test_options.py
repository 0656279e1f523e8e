"""The conductor's relay options (relay/options.py), in-process: what the command line gives,
which performers go through relays, and how a show's local ports are handed to a relay child
(the child is built, not started)."""

from __future__ import annotations

import argparse
import sys
from types import SimpleNamespace

import pytest

from xgo_show.compiler.schedule import PerformerSchedule, Schedule
from xgo_show.errors import UsageError
from xgo_show.net.session import SessionOptions
from xgo_show.profiles import get_profile
from xgo_show.relay import conductor
from xgo_show.relay.options import (
    RELAY_STOP_TIMEOUT,
    ConductorOptions,
    add_conductor_arguments,
    close_session,
    conductor_options,
    guard_local_ports,
    use_relays,
)
from xgo_show.relay.performer import NETWORK_LEAD

LINK = get_profile("mini").link
PLAY = SimpleNamespace(telemetry=True, allow_unsafe=False, realtime=None)


def parse(*argv: str) -> ConductorOptions:
    parser = argparse.ArgumentParser()
    add_conductor_arguments(parser)
    return conductor_options(parser.parse_args(list(argv)))


def show(**ports: str | None) -> Schedule:
    performers = tuple(PerformerSchedule(name, "mini", LINK, (), 1.0, port)
                       for name, port in ports.items())
    return Schedule("s", "s.yaml", performers, 20.0)


@pytest.fixture
def keep_conductor(monkeypatch: pytest.MonkeyPatch) -> None:
    """use_relays configures the relay conductor of this process: put its options back."""
    monkeypatch.setattr(conductor, "_options", conductor._options)


def test_the_defaults_stop_the_robots_after_half_a_second_of_silence() -> None:
    options = parse()
    assert options == ConductorOptions()
    assert (options.link_loss, options.watchdog, options.timeout) == ("stop", 0.5, 3.0)
    assert options.session == SessionOptions()


def test_the_command_line_sets_the_policy_the_watchdog_and_the_session() -> None:
    options = parse("--link-loss", "continue", "--watchdog-ms", "750", "--namespace", "stage/a",
                    "--connect", "tcp/10.0.0.2:7447", "--listen", "tcp/0.0.0.0:7448",
                    "--zenoh-config", "z.json5")
    assert options.link_loss == "continue"
    assert options.watchdog == 0.75
    assert options.session == SessionOptions(
        connect=("tcp/10.0.0.2:7447",), listen=("tcp/0.0.0.0:7448",), config_file="z.json5",
        namespace="stage/a")


def test_stop_can_be_asked_for_explicitly() -> None:
    assert parse("--link-loss", "stop", "--link-loss", "continue").link_loss == "continue"
    assert parse("--link-loss", "continue", "--link-loss", "stop").link_loss == "stop"


def test_the_help_has_a_relay_section_that_says_what_each_option_does(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("COLUMNS", "300")  # no line breaks inside a hyphenated word
    parser = argparse.ArgumentParser(prog="xgo-show run")
    add_conductor_arguments(parser)
    text = " ".join(parser.format_help().split())
    assert "relays (performers mapped to zenoh:RELAY/ROBOT): --link-loss {stop,continue} " in text
    assert ("{stop,continue} what a relay does when it loses this conductor: safe-stop its "
            "robots (default) or finish the uploaded show on its own --watchdog-ms MS "
            "silence after which a relay and this conductor give each other up (default 500)"
            ) in text
    assert "--connect ENDPOINT" in text  # and the Zenoh session's options


def test_an_unknown_link_loss_policy_is_refused_by_the_parser(
    capsys: pytest.CaptureFixture[str],
) -> None:
    with pytest.raises(SystemExit):
        parse("--link-loss", "pause")
    assert "invalid choice: 'pause'" in capsys.readouterr().err


@pytest.mark.parametrize("ms", [50, 60_000])
def test_the_watchdog_range_includes_its_ends(ms: int) -> None:
    assert parse("--watchdog-ms", str(ms)).watchdog == ms / 1000


@pytest.mark.parametrize("ms", [49, 60_001, 0, -500])
def test_a_watchdog_outside_50_to_60000_ms_is_a_usage_error(ms: int) -> None:
    with pytest.raises(UsageError) as info:
        parse("--watchdog-ms", str(ms))
    assert str(info.value) == f"--watchdog-ms {ms}: give 50 to 60000"


def test_no_relayed_performer_needs_no_relay_options(keep_conductor: None) -> None:
    assert use_relays({"rex": "/dev/ttyUSB0", "rita": "sim:mini"}, None, fast=True) == {}
    assert use_relays({}, None, fast=False, schedule=show(rex="/dev/ttyUSB0", rita=None)) == {}


def test_relayed_performers_get_the_relay_stop_timeout_and_the_network_lead(
    keep_conductor: None,
) -> None:
    options = ConductorOptions(link_loss="continue", watchdog=1.5)
    got = use_relays({"rex": "zenoh:hall/rex"}, options, fast=False)
    assert got == {"stop_timeout": RELAY_STOP_TIMEOUT, "command_lead": NETWORK_LEAD}
    assert conductor._options is options  # the relays are conducted with these options


def test_without_options_the_relays_are_conducted_with_the_defaults(
    keep_conductor: None, monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(conductor, "_options", ConductorOptions(watchdog=9.0))
    assert use_relays({"rex": "zenoh:hall/rex"}, None, fast=False) != {}
    assert conductor._options == ConductorOptions()


def test_fast_is_refused_naming_the_relayed_performers_in_order(keep_conductor: None) -> None:
    schedule = show(zed="zenoh:hall/zed", amy="zenoh:hall/amy", bob="/dev/ttyUSB0")
    with pytest.raises(UsageError) as info:
        use_relays({}, None, fast=True, schedule=schedule)
    assert str(info.value) == (
        "--fast cannot drive relayed performers (amy, zed): relays play in real time")


def test_the_map_overrides_the_show_file_and_simulated_performers_are_not_relayed(
    keep_conductor: None,
) -> None:
    schedule = show(rex="zenoh:hall/rex", rita="zenoh:hall/rita")
    # --map puts rex on a local port; --sim plays rita on a simulator: no relay left.
    assert use_relays({"rex": "/dev/ttyUSB0"}, None, fast=True, schedule=schedule,
                      simulated=("rita",)) == {}
    # --map can also send a performer of a local port to a relay.
    with pytest.raises(UsageError, match=r"\(rex\)"):
        use_relays({"rex": "zenoh:hall/rex"}, None, fast=True, schedule=show(rex="/dev/ttyS0"))
    # Not simulated: the show file's relay counts.
    with pytest.raises(UsageError, match=r"\(rita\)"):
        use_relays({}, None, fast=True, schedule=schedule, simulated=("rex",))


def test_close_session_closes_the_conductors_session_only_if_it_was_loaded(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    closed: list[bool] = []
    monkeypatch.setitem(sys.modules, "xgo_show.relay.conductor",
                        SimpleNamespace(close_session=lambda: closed.append(True)))
    close_session()
    assert closed == [True]
    monkeypatch.delitem(sys.modules, "xgo_show.relay.conductor")
    close_session()  # nothing to close, nothing imported
    assert "xgo_show.relay.conductor" not in sys.modules
    assert closed == [True]


def test_a_show_without_local_ports_keeps_its_maps_and_options() -> None:
    schedule = show(a="sim:mini", b="zenoh:hall/b", c=None, d="/dev/ttyUSB0")
    options = ConductorOptions(watchdog=2.0)
    maps = {"d": " SIM:lite"}
    got = guard_local_ports(schedule, maps, options, ("e",), PLAY)
    assert got == (maps, options, None)
    assert got[0] is not maps  # a copy: the caller's map is not the child's to change
    # A performer played on a simulator (--sim) is not a local port either.
    assert guard_local_ports(show(d="/dev/ttyUSB0"), {}, None, ("d",), PLAY) == ({}, None, None)


def test_local_ports_go_to_a_relay_child_over_a_private_link() -> None:
    schedule = show(rex="/dev/ttyUSB0", rita="sim:mini", zed="zenoh:hall/zed")
    maps = {"zed": "/dev/ttyUSB1"}  # --map brings zed home to a local port
    got_maps, options, child = guard_local_ports(schedule, maps, None, (), PLAY)
    assert child is not None
    assert got_maps == {"rex": f"zenoh:{child.name}/rex", "zed": f"zenoh:{child.name}/zed"}
    assert maps == {"zed": "/dev/ttyUSB1"}
    assert options is not None
    # Nothing else reaches relays: the conductor connects to the child only, and listens on
    # nothing (no well-known port taken for a private link).
    assert options.session == SessionOptions(connect=(child.endpoint,))
    assert options.link_loss == "stop"
    cmd = child.cmd
    assert cmd[cmd.index("--namespace") + 1] == "xgo-show"
    maps_given = [cmd[i + 1] for i, arg in enumerate(cmd) if arg == "--map"]
    models_given = [cmd[i + 1] for i, arg in enumerate(cmd) if arg == "--model"]
    assert sorted(maps_given) == ["rex=/dev/ttyUSB0", "zed=/dev/ttyUSB1"]
    assert sorted(models_given) == ["rex=mini", "zed=mini"]
    assert "--no-telemetry" not in cmd and "--allow-unsafe" not in cmd


@pytest.mark.parametrize(
    "session",
    [
        SessionOptions(connect=("tcp/10.0.0.2:7447",)),
        SessionOptions(listen=("tcp/0.0.0.0:7447",)),
        SessionOptions(config_file="z.json5"),
    ],
)
def test_with_endpoints_asked_for_the_child_is_connected_in_addition(
    session: SessionOptions,
) -> None:
    options = ConductorOptions(session=session, link_loss="continue")
    _, got, child = guard_local_ports(show(rex="/dev/ttyUSB0"), {}, options, (), PLAY)
    assert child is not None and got is not None
    assert got.session.also_connect == (child.endpoint,)
    assert (got.session.connect, got.session.listen, got.session.config_file) == (
        session.connect, session.listen, session.config_file)
    assert got.link_loss == "continue"


def test_with_a_relay_in_the_show_the_child_is_connected_in_addition() -> None:
    options = ConductorOptions(session=SessionOptions(namespace="stage"))
    schedule = show(rex="/dev/ttyUSB0", zed="zenoh:hall/zed")
    got_maps, got, child = guard_local_ports(schedule, {}, options, (), PLAY)
    assert child is not None and got is not None
    assert got.session == SessionOptions(namespace="stage", also_connect=(child.endpoint,))
    assert got_maps == {"rex": f"zenoh:{child.name}/rex"}  # zed stays on its relay
    assert child.cmd[child.cmd.index("--namespace") + 1] == "stage"


def test_the_child_plays_as_the_conductor_was_asked_to() -> None:
    play = SimpleNamespace(telemetry=False, allow_unsafe=True, realtime="required")
    _, _, child = guard_local_ports(show(rex="/dev/ttyUSB0"), {}, None, (), play)
    assert child is not None
    assert {"--no-telemetry", "--allow-unsafe", "--realtime"} <= set(child.cmd)
