"""Look profiles up by model name (with aliases) or by the firmware string a robot reports.

The built-in models are :data:`MODELS`; :func:`register_profile` adds another (its family, named
by ``Profile.family``, is registered with :func:`xgo_show.families.register_family`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from types import MappingProxyType

from xgo_show.errors import ProfileError
from xgo_show.profiles.model import Profile
from xgo_show.profiles.xarm import XARM
from xgo_show.profiles.xgo_dog import LITE, MINI
from xgo_show.profiles.xgo_rider import RIDER

__all__ = [
    "MODELS",
    "PROFILES",
    "get_profile",
    "model_from_firmware",
    "register_profile",
    "register_units",
    "unregister_profile",
]

#: The built-in models (the command line offers these).
MODELS: tuple[str, ...] = ("mini", "lite", "rider", "xarm")

_PROFILES: dict[str, Profile] = {p.model: p for p in (MINI, LITE, RIDER, XARM)}
#: Every known profile by model name, built-in and registered (read-only view).
PROFILES: Mapping[str, Profile] = MappingProxyType(_PROFILES)

# Other spellings users write (the vendor library's names included).
_ALIASES: dict[str, str] = {
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
        return _PROFILES[key]
    except KeyError:
        valid = ", ".join(_PROFILES)
        raise ProfileError(f"unknown robot model {model!r}; valid: {valid}") from None


def register_profile(profile: Profile, *, aliases: Iterable[str] = ()) -> None:
    """Make :func:`get_profile` know ``profile`` (by its model name and ``aliases``).

    Raises :class:`ProfileError` when the name or an alias is taken.
    """
    names = [profile.model, *(a.strip().lower() for a in aliases)]
    for name in names:
        if name in _PROFILES or name in _ALIASES:
            raise ProfileError(f"robot model {name!r} is already known")
    _PROFILES[profile.model] = profile
    _ALIASES.update((alias, profile.model) for alias in names[1:])


def unregister_profile(model: str) -> None:
    """Forget a registered model and its aliases (built-in models stay)."""
    if model in MODELS:
        raise ProfileError(f"{model!r} is a built-in model")
    _PROFILES.pop(model, None)
    for alias in [a for a, m in _ALIASES.items() if m == model]:
        del _ALIASES[alias]


def register_units(name: str) -> tuple[str, ...]:
    """The units a register called ``name`` has on the known models (one for nearly all;
    ``vx`` is mm/step on a dog and m/s on the Rider), in model order."""
    units = (r.unit or "" for p in PROFILES.values() for r in p.registers if r.name == name)
    return tuple(dict.fromkeys(units))


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
