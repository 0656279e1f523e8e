"""Look profiles up by model name (with aliases) or by the firmware string a robot reports."""

from __future__ import annotations

from collections.abc import Mapping

from xgo_show.errors import ProfileError
from xgo_show.profiles.model import Profile
from xgo_show.profiles.xarm import XARM
from xgo_show.profiles.xgo_dog import LITE, MINI
from xgo_show.profiles.xgo_rider import RIDER

__all__ = ["MODELS", "PROFILES", "get_profile", "model_from_firmware"]

MODELS: tuple[str, ...] = ("mini", "lite", "rider", "xarm")

PROFILES: Mapping[str, Profile] = {p.model: p for p in (MINI, LITE, RIDER, XARM)}

# Other spellings users write (the vendor library's names included).
_ALIASES: Mapping[str, str] = {
    "xgomini": "mini",
    "xgo-mini": "mini",
    "xgo_mini": "mini",
    "xgolite": "lite",
    "xgo-lite": "lite",
    "xgo_lite": "lite",
    "xgorider": "rider",
    "xgo-rider": "rider",
    "xgo_rider": "rider",
    "lewansoul-xarm": "xarm",
    "hiwonder-xarm": "xarm",
    "xarm6": "xarm",
}


def get_profile(model: str) -> Profile:
    """The profile of ``model`` (case-insensitive, aliases such as "xgomini" accepted).

    Raises :class:`ProfileError` naming the valid models for anything else.
    """
    key = model.strip().lower()
    key = _ALIASES.get(key, key)
    try:
        return PROFILES[key]
    except KeyError:
        raise ProfileError(f"unknown robot model {model!r}; valid: {', '.join(MODELS)}") from None


def model_from_firmware(firmware: str) -> str | None:
    """The model a firmware string (register 0x07) belongs to, or None if unknown.

    Follows the vendor's auto-detection: "M...", "MW..." and "W..." (XGO-mini2SW, driven with
    Mini parameters) are a Mini, "L..." a Lite, "R..." a Rider. "RA..." is the XGO-RA, which the
    vendor drives with different ranges than the Rider's, so it is not recognised (None).
    """
    text = firmware.strip("\0 \t\r\n")
    if text.upper().startswith("RA"):
        return None
    # Longest prefix first, so "MW" is checked before "M".
    candidates = sorted(
        ((prefix, p.model) for p in PROFILES.values() for prefix in p.firmware_prefixes),
        key=lambda item: -len(item[0]),
    )
    for prefix, name in candidates:
        if text.startswith(prefix):
            return name
    return None
