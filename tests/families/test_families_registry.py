"""The family registry: lookup, clear errors, and every built-in family answering every hook."""

from __future__ import annotations

import dataclasses
import inspect

import pytest

from xgo_show.errors import ProfileError
from xgo_show.families import (
    RobotFamily,
    family_names,
    get_family,
    register_family,
    unregister_family,
)
from xgo_show.families.xarm.family import XARM
from xgo_show.families.xgo.family import XGO
from xgo_show.profiles import get_profile
from xgo_show.profiles.registry import PROFILES

HOOKS = sorted(RobotFamily.__abstractmethods__)


def test_built_in_families() -> None:
    assert family_names() == ("xarm", "xgo")
    assert get_family("xgo") is XGO
    assert get_family("xarm") is XARM
    assert get_family(get_profile("mini")) is XGO
    assert get_family(get_profile("rider")) is XGO
    assert get_family(get_profile("xarm")) is XARM


def test_every_profile_names_a_registered_family() -> None:
    for profile in PROFILES.values():
        assert get_family(profile).name == profile.family


def test_unknown_family_is_a_clear_profile_error() -> None:
    with pytest.raises(ProfileError, match=r"^unknown robot family 'go2'; registered: xarm, xgo$"):
        get_family("go2")
    orphan = dataclasses.replace(get_profile("mini"), family="go2")
    with pytest.raises(ProfileError, match=r"^profile 'mini' names unknown robot family 'go2'"):
        get_family(orphan)


@pytest.mark.parametrize("name", ["xgo", "xarm"])
def test_each_family_provides_every_hook(name: str) -> None:
    family = get_family(name)
    assert HOOKS  # the protocol has hooks, and each one is the family's own code
    for hook in HOOKS:
        own = getattr(type(family), hook)
        assert own is not getattr(RobotFamily, hook), f"{name} lacks {hook}"
        assert inspect.getdoc(getattr(RobotFamily, hook)), f"{hook} has no docstring"
    assert family.protocol and family.robots


def test_a_family_missing_a_hook_cannot_be_made() -> None:
    class Half(RobotFamily):
        name = "half"

    with pytest.raises(TypeError, match="abstract"):
        Half()  # type: ignore[abstract]


def test_register_refuses_a_taken_or_empty_name() -> None:
    with pytest.raises(ProfileError, match="'xgo' is already registered"):
        register_family(XGO)
    nameless = type(XGO)()
    nameless.name = ""
    with pytest.raises(ProfileError, match="has no family name"):
        register_family(nameless)
    unregister_family("no-such-family")  # forgetting an unknown name is a no-op
    assert family_names() == ("xarm", "xgo")


@pytest.mark.parametrize("model", sorted(PROFILES))
def test_hooks_agree_with_each_other(model: str) -> None:
    # What one hook makes, the others accept: stop and rest frames are valid frames of the
    # protocol, decode with its decoder and are not unsafe; telemetry requests are frames too.
    profile = get_profile(model)
    family = get_family(profile)
    frames = [f.data for f in family.stop_frames(profile)]
    frames += [f.data for f in family.rest_frames(profile)]
    frames += [item.request for item in family.telemetry_items(profile)]
    assert family.stop_frames(profile)
    for data in frames:
        assert family.frame_problem(data) is None, data.hex(" ")
        assert len(family.decoder().feed(data)) == 1
    for sf in family.stop_frames(profile) + family.rest_frames(profile):
        assert family.unsafe_problems(profile, sf.data) == []
    assert family.frame_problem(b"\x00\x01") is not None
