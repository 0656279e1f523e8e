"""Find the family of a profile, the way transports find the scheme of a URL.

Built-in families are named here as ``"module:attribute"`` and imported on first use, so asking
for the XGO family loads nothing of the xArm's (and nothing of the compiler until a hook needs
it). :func:`register_family` adds one more: a new robot is its profiles plus one family object.
"""

from __future__ import annotations

import importlib

from xgo_show.errors import ProfileError
from xgo_show.families.base import RobotFamily
from xgo_show.profiles.model import Profile

__all__ = ["family_names", "get_family", "register_family", "unregister_family"]

# family name -> "module:attribute" (imported on first use) or the family object itself.
_FAMILIES: dict[str, str | RobotFamily] = {
    "xgo": "xgo_show.families.xgo.family:XGO",
    "xarm": "xgo_show.families.xarm.family:XARM",
}


def register_family(family: RobotFamily) -> None:
    """Make profiles whose ``family`` is ``family.name`` use ``family``.

    Raises :class:`ProfileError` when the name is empty or already taken (unregister first).
    """
    if not family.name:
        raise ProfileError(f"{type(family).__name__} has no family name")
    if family.name in _FAMILIES:
        raise ProfileError(f"robot family {family.name!r} is already registered")
    _FAMILIES[family.name] = family


def unregister_family(name: str) -> None:
    """Forget the family ``name`` (a no-op when it is not registered)."""
    _FAMILIES.pop(name, None)


def family_names() -> tuple[str, ...]:
    """The registered family names, sorted."""
    return tuple(sorted(_FAMILIES))


def get_family(which: str | Profile) -> RobotFamily:
    """The family named ``which``, or the family of the profile ``which``.

    Raises :class:`ProfileError` naming the registered families for an unknown name.
    """
    name = which.family if isinstance(which, Profile) else which
    entry = _FAMILIES.get(name)
    if entry is None:
        owner = f"profile {which.model!r} names " if isinstance(which, Profile) else ""
        raise ProfileError(
            f"{owner}unknown robot family {name!r}; registered: {', '.join(family_names())}"
        )
    if isinstance(entry, str):
        module_name, _, attr = entry.partition(":")
        family = getattr(importlib.import_module(module_name), attr)
        assert isinstance(family, RobotFamily), entry
        _FAMILIES[name] = entry = family
    return entry
