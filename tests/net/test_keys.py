"""The Zenoh key expressions and relay names (net/keys.py): where each relay's keys live, what a
relay name may hold (one key chunk), and how a ``zenoh:RELAY/ROBOT`` URL is read, with each
refusal's words."""

from __future__ import annotations

import pytest

from xgo_show.errors import NetworkError
from xgo_show.net.keys import (
    SCHEME,
    check_relay_name,
    is_relay_url,
    parse_relay_url,
    relay_key,
    relay_name_chunk,
    relay_wildcard,
)


def test_a_relays_keys_and_every_relays_wildcard() -> None:
    assert relay_key("xgo-show", "hall", "cmd") == "xgo-show/relay/hall/cmd"
    assert relay_key("acme/a", "r1", "alive") == "acme/a/relay/r1/alive"
    assert relay_wildcard("xgo-show", "info") == "xgo-show/relay/*/info"
    assert SCHEME == "zenoh"


@pytest.mark.parametrize("name", ["a", "A-z_0.9", "x" * 64, "stage-left", "r.1"])
def test_a_relay_name_is_one_key_chunk_of_1_to_64_characters(name: str) -> None:
    assert check_relay_name(name) == name


@pytest.mark.parametrize("name", ["", "x" * 65, "a/b", "a*", "a b", "caf\u00e9", "a$", "a\n"])
def test_anything_else_is_refused_with_what_a_name_may_hold(name: str) -> None:
    with pytest.raises(NetworkError) as info:
        check_relay_name(name)
    assert str(info.value) == (f"relay name {name!r}: use 1 to 64 letters, digits, '_', '-' or "
                               "'.' (one key chunk)")


def test_a_host_name_is_made_a_name_chunk_character_by_character() -> None:
    assert relay_name_chunk("studio.local") == "studio.local"
    assert relay_name_chunk("Mac Book/caf\u00e9:1") == "Mac-Book-caf--1"
    assert check_relay_name(relay_name_chunk("h\u00f4te \u00e9t\u00e9")) == "h-te--t-"


@pytest.mark.parametrize(("url", "relay"), [
    ("zenoh:hall/rex", True), ("ZENOH:hall", True), ("  zenoh:hall/rex ", True),
    ("zenoh", False), ("sim:mini", False), ("/dev/ttyUSB0", False), ("zenohx:hall", False),
])
def test_a_relay_url_is_told_by_its_scheme(url: str, relay: bool) -> None:
    assert is_relay_url(url) is relay


def test_a_relay_url_names_the_relay_and_the_robot() -> None:
    assert parse_relay_url("zenoh:hall/rex") == ("hall", "rex")
    assert parse_relay_url(" Zenoh:/hall/rex/ ") == ("hall", "rex")
    assert parse_relay_url("zenoh:hall", "lola") == ("hall", "lola")  # the performer's name
    assert parse_relay_url("zenoh:hall/rex", "lola") == ("hall", "rex")


@pytest.mark.parametrize(("url", "performer", "says"), [
    ("sim:mini", "", "'sim:mini' is not a zenoh:RELAY/ROBOT URL"),
    ("zenoh", "", "'zenoh' is not a zenoh:RELAY/ROBOT URL"),
    ("zenoh:", "lola", "'zenoh:': name the relay, e.g. zenoh:stage-left/lola"),
    ("zenoh:/", "", "'zenoh:/': name the relay, e.g. zenoh:stage-left/rex"),
    ("zenoh:hall", "", "'zenoh:hall': name the robot too, e.g. zenoh:hall/rex"),
    ("zenoh:ha ll/rex", "", "relay name 'ha ll': use 1 to 64 letters, digits, '_', '-' or '.' "
                            "(one key chunk)"),
    ("zenoh:hall/r*x", "", "relay name 'r*x': use 1 to 64 letters, digits, '_', '-' or '.' "
                           "(one key chunk)"),
])
def test_a_bad_relay_url_says_what_is_missing(url: str, performer: str, says: str) -> None:
    with pytest.raises(NetworkError) as info:
        parse_relay_url(url, performer)
    assert str(info.value) == says


def test_a_url_is_cut_at_its_first_colon_and_its_first_slash() -> None:
    assert is_relay_url("zenoh:hall/r:1")  # a zenoh URL with a bad robot name, not another URL
    with pytest.raises(NetworkError, match=r"^relay name 'r:1': "):
        parse_relay_url("zenoh:hall/r:1")
    assert parse_relay_url("zenoh:Xhall/reX") == ("Xhall", "reX")  # only slashes are trimmed


def test_without_a_performer_a_url_must_name_the_robot() -> None:
    with pytest.raises(NetworkError, match=r"^'zenoh:hall': name the robot too, e\.g\. "
                       r"zenoh:hall/rex$"):
        parse_relay_url("zenoh:hall")
    with pytest.raises(NetworkError, match=r"^'zenoh:': name the relay, e\.g\. "
                       r"zenoh:stage-left/rex$"):
        parse_relay_url("zenoh:")
