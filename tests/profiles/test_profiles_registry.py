"""Looking profiles up by name and by firmware string."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace

import pytest

from xgo_show.errors import ProfileError, XgoShowError
from xgo_show.profiles import (
    MODELS,
    Link,
    Profile,
    get_profile,
    model_from_firmware,
    register_profile,
    unregister_profile,
)
from xgo_show.profiles.registry import PROFILES, register_units


def test_models() -> None:
    assert MODELS == ("mini", "lite", "rider", "xarm")
    for model in MODELS:
        assert get_profile(model).model == model


@pytest.mark.parametrize(
    ("name", "model"),
    [
        ("MINI", "mini"),
        ("Mini", "mini"),
        ("xgomini", "mini"),
        ("XGO-Mini", "mini"),
        ("xgo_mini", "mini"),
        ("xgolite", "lite"),
        ("xgo-lite", "lite"),
        ("xgorider", "rider"),
        ("XGO-Rider", "rider"),
        (" rider ", "rider"),
        ("xArm", "xarm"),
    ],
)
def test_aliases_and_case(name: str, model: str) -> None:
    assert get_profile(name).model == model


@pytest.mark.parametrize("name", ["", "xgo", "minii", "go2", "mini3w"])
def test_unknown_model_lists_the_valid_ones(name: str) -> None:
    with pytest.raises(ProfileError) as err:
        get_profile(name)
    message = str(err.value)
    assert repr(name) in message
    for model in MODELS:
        assert model in message
    assert isinstance(err.value, XgoShowError)


@pytest.mark.parametrize(
    ("firmware", "model"),
    [
        ("M-1.4.1", "mini"),
        ("MW-1.0.2", "mini"),  # XGO-mini2SW, driven with Mini parameters by the vendor
        ("W-2.0", "mini"),
        ("L-1.2.0", "lite"),
        ("R-1.2.3", "rider"),  # the document's own example
        ("R-1.2.3\0\0\0", "rider"),  # as read from the 10-byte register
        ("RA-1.0", None),  # XGO-RA: other ranges than the Rider's
        ("Null", None),  # what the vendor library returns when the read fails
        ("", None),
        ("m-1.0", None),  # the model letter is upper case
        ("X-1.0", None),
        ("XM-2.0", None),  # another letter first: not a Mini, whatever follows
        ("\0 M-1.4.1\r\n", "mini"),  # padding and line ends on either side are ignored
    ],
)
def test_model_from_firmware(firmware: str, model: str | None) -> None:
    assert model_from_firmware(firmware) == model


def test_firmware_prefixes_do_not_overlap_across_models() -> None:
    owners: dict[str, str] = {}
    for model in MODELS:
        for prefix in get_profile(model).firmware_prefixes:
            assert owners.setdefault(prefix, model) == model


# --- registering a model ------------------------------------------------------------------------

_PAN = Profile(model="pan", family="turret", title="Pan turret", link=Link(115200, 0.002))


@pytest.fixture
def pan() -> Iterator[Profile]:
    register_profile(_PAN, aliases=[" Pan-Turret ", "PT"])
    try:
        yield _PAN
    finally:
        unregister_profile("pan")


def test_a_registered_model_is_found_by_name_and_aliases(pan: Profile) -> None:
    assert get_profile("pan") is pan
    # Aliases are kept as written but trimmed and in lower case; lookups ignore case.
    assert get_profile("pan-turret") is pan and get_profile("PAN-TURRET") is pan
    assert get_profile("pt") is pan
    assert "pan" in PROFILES and "pan" not in MODELS
    with pytest.raises(ProfileError, match=r"valid: mini, lite, rider, xarm, pan$"):
        get_profile("tilt")


def test_registering_a_taken_name_or_alias_is_refused_and_changes_nothing(pan: Profile) -> None:
    other = Profile(model="tilt", family="turret", title="Tilt", link=Link(115200, 0.002))
    for model, aliases in (("mini", []), ("pan", []), ("tilt", ["pt"]), ("tilt", ["xgomini"]),
                           ("tilt", ["lite"])):  # fmt: skip
        with pytest.raises(ProfileError, match="is already known"):
            register_profile(replace(other, model=model), aliases=aliases)
    # The refused registration added neither the model nor its other aliases.
    assert "tilt" not in PROFILES
    with pytest.raises(ProfileError):
        get_profile("tilt")
    assert get_profile("mini").title == "XGO-Mini"


def test_unregistering_forgets_the_model_and_only_its_aliases(pan: Profile) -> None:
    other = Profile(model="tilt", family="turret", title="Tilt", link=Link(115200, 0.002))
    register_profile(other, aliases=["tilt-turret"])
    unregister_profile("tilt")
    for name in ("tilt", "tilt-turret"):
        with pytest.raises(ProfileError, match="unknown robot model"):
            get_profile(name)
    assert get_profile("pan-turret") is pan and get_profile("xgomini").model == "mini"
    # The name and its alias are free again.
    register_profile(other, aliases=["tilt-turret"])
    unregister_profile("tilt")
    unregister_profile("never-registered")  # nothing to forget: no error


@pytest.mark.parametrize("model", MODELS)
def test_built_in_models_cannot_be_unregistered(model: str) -> None:
    with pytest.raises(ProfileError, match=f"^'{model}' is a built-in model$"):
        unregister_profile(model)
    assert get_profile(model).model == model


def test_register_units_per_model_in_model_order() -> None:
    # One unit where every model agrees; vx is a stride on the dogs and a speed on the Rider.
    assert register_units("vx") == ("mm/step", "m/s")
    assert register_units("body_z") == ("mm",)
    assert register_units("battery") == ("%",)
    assert register_units("led1") == ("",)  # a colour has no unit
    assert register_units("nope") == ()


def test_register_units_include_a_registered_model(pan: Profile) -> None:
    gripper = replace(get_profile("mini").register("gripper"), unit="mm")
    wide = Profile(model="wide", family="turret", title="Wide", link=Link(115200, 0.002),
                   registers=(gripper,))
    register_profile(wide)
    try:
        assert register_units("gripper") == ("%", "mm")
    finally:
        unregister_profile("wide")


@pytest.mark.parametrize("firmware", ["M-1.4.1", " M-1.4.1\0\0", "\tL-1.0\r\n", "ra-2", "Ra-2"])
def test_model_from_firmware_trims_and_refuses_the_ra_in_any_case(firmware: str) -> None:
    expected = {"M": "mini", "L": "lite"}.get(firmware.strip("\0 \t\r\n")[0])
    assert model_from_firmware(firmware) == expected


def test_model_from_firmware_prefers_the_longest_prefix() -> None:
    # "MW" and "W" firmware is a Mini; a registered model whose prefix is longer than a
    # built-in one wins over it, whatever the order of registration.
    wide = Profile(model="wide", family="turret", title="Wide", link=Link(115200, 0.002),
                   firmware_prefixes=("MWX",))
    register_profile(wide)
    try:
        assert model_from_firmware("MWX-1.0") == "wide"
        assert model_from_firmware("MW-1.0") == "mini"
        assert model_from_firmware("MX-1.0") == "mini"
    finally:
        unregister_profile("wide")
