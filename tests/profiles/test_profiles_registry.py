"""Looking profiles up by name and by firmware string."""

from __future__ import annotations

import pytest

from xgo_show.errors import ProfileError, XgoShowError
from xgo_show.profiles import MODELS, get_profile, model_from_firmware


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
    ],
)
def test_model_from_firmware(firmware: str, model: str | None) -> None:
    assert model_from_firmware(firmware) == model


def test_firmware_prefixes_do_not_overlap_across_models() -> None:
    owners: dict[str, str] = {}
    for model in MODELS:
        for prefix in get_profile(model).firmware_prefixes:
            assert owners.setdefault(prefix, model) == model
