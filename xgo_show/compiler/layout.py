"""Fast, cached look-ups on a profile's register table for the compiler's inner loops.

:meth:`Profile.register_at` and :meth:`Profile.walk` scan the register tuple; the compiler asks
the same questions hundreds of thousands of times, so this wraps them in dictionaries. The layout
itself stays :meth:`Profile.walk` (every answer here comes from it, then is cached).
"""

from __future__ import annotations

from xgo_show.compiler.bytetable import ByteTable
from xgo_show.errors import ProfileError
from xgo_show.profiles.model import Access, Profile, Register

__all__ = ["ACTION_REGISTER", "FILLER_GROUPS", "Layout"]

# The register that starts a preset action (XGO dogs): it takes the robot over.
ACTION_REGISTER = "action"

# Registers that only hold state (re-sending the value they already hold changes nothing), so
# the compiler may re-send them to bridge a gap between two registers it writes in one frame.
# Settings are not among them: some are triggers (set_origin, calibration), and so is "action".
FILLER_GROUPS = frozenset({"speed", "posture", "periodic", "leg", "servo", "gripper", "arm", "led"})


class Layout:
    """One profile's registers indexed by address and name, with a cached field walk."""

    def __init__(self, profile: Profile) -> None:
        self.profile = profile
        self.by_address: dict[int, Register] = {r.address: r for r in profile.registers}
        self.by_name: dict[str, Register] = {r.name: r for r in profile.registers}
        self._walks: dict[tuple[int, int], tuple[Register, ...] | None] = {}
        self._tables: dict[str, ByteTable] = {}

    def register(self, name: str) -> Register:
        """The register called ``name`` (ProfileError listing valid names otherwise)."""
        reg = self.by_name.get(name)
        return reg if reg is not None else self.profile.register(name)

    def walk(self, address: int, nbytes: int) -> tuple[Register, ...] | None:
        """:meth:`Profile.walk`, cached; None where the walk is not a valid layout."""
        key = (address, nbytes)
        if key not in self._walks:
            try:
                self._walks[key] = tuple(self.profile.walk(address, nbytes))
            except ProfileError:
                self._walks[key] = None
        return self._walks[key]

    def byte_table(self, reg: Register) -> ByteTable:
        """``reg.to_byte`` as a fast table (built once per register)."""
        table = self._tables.get(reg.name)
        if table is None:
            table = self._tables[reg.name] = ByteTable(reg)
        return table

    def can_fill(self, reg: Register) -> bool:
        """Whether ``reg`` may be re-sent with its current value to bridge a gap."""
        return (
            reg.access is not Access.READ
            and not reg.unsafe
            and reg.group in FILLER_GROUPS
        )
