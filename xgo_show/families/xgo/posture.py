"""The reset action (255) and the default posture it restores: the one home of that rule.

The resolver (minimum move durations), the planner (where later moves start) and the safe stop
all use it; the simulator applies it to its register memory.
"""

from __future__ import annotations

from xgo_show.profiles.model import Profile

__all__ = ["RESET_ACTION", "posture_after"]

#: Preset action 255 restores the default posture (:attr:`Profile.default_posture`) on every
#: XGO robot; the vendor's reset() sends it.
RESET_ACTION = 255


def posture_after(profile: Profile, action_id: int) -> dict[str, float]:
    """The registers' physical values once action ``action_id`` has run (empty: none change).

    Only the reset action changes tracked state: every default-posture register goes back to
    its initial value.
    """
    if action_id != RESET_ACTION:
        return {}
    out: dict[str, float] = {}
    for name in profile.default_posture:
        reg = profile.register(name)
        if reg.linear and reg.initial:
            out[name] = reg.to_physical(reg.initial[0])
    return out
