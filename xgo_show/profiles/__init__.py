"""Device profiles: per-model register tables, action catalogues and link parameters as data.

Use :func:`get_profile` to look a model up by name and :func:`model_from_firmware` to recognise a
model from the firmware string read at register 0x07.
"""

from __future__ import annotations

from xgo_show.profiles.model import Access, Action, Encoding, Limits, Link, Profile, Register
from xgo_show.profiles.registry import (
    MODELS,
    get_profile,
    model_from_firmware,
    register_profile,
    unregister_profile,
)

__all__ = [
    "MODELS",
    "Access",
    "Action",
    "Encoding",
    "Limits",
    "Link",
    "Profile",
    "Register",
    "get_profile",
    "model_from_firmware",
    "register_profile",
    "unregister_profile",
]
