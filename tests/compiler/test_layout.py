"""layout.py: the compiler's look-ups on a profile's table give what the profile gives (a walk,
a register by name or address, its byte table), and only state registers fill gaps.
"""

from __future__ import annotations

import pytest

from xgo_show.compiler.layout import FILLER_GROUPS, Layout
from xgo_show.errors import ProfileError
from xgo_show.profiles import get_profile
from xgo_show.profiles.model import Access, Link, Profile, Register

MINI = get_profile("mini")
RIDER = get_profile("rider")


@pytest.mark.parametrize("profile", [MINI, RIDER], ids=["mini", "rider"])
def test_registers_by_address_and_by_name_are_the_profiles(profile: Profile) -> None:
    layout = Layout(profile)
    assert layout.profile is profile
    assert layout.by_address == {r.address: r for r in profile.registers}
    assert layout.by_name == {r.name: r for r in profile.registers}
    for reg in profile.registers:
        assert layout.register(reg.name) is reg


def test_an_unknown_register_name_is_refused_with_the_valid_names() -> None:
    with pytest.raises(ProfileError, match=r"mini has no register 'wings'; valid: .*body_z"):
        Layout(MINI).register("wings")


@pytest.mark.parametrize(("address", "nbytes"), [
    (0x33, 6), (0x50, 15), (0x62, 12), (0x07, 10), (0x3E, 1), (0x33, 1),
])
def test_a_valid_walk_is_the_profiles_walk_asked_again_or_not(address: int, nbytes: int) -> None:
    layout = Layout(MINI)
    expected = tuple(MINI.walk(address, nbytes))
    assert layout.walk(address, nbytes) == expected
    assert layout.walk(address, nbytes) == expected  # from the cache


@pytest.mark.parametrize(("address", "nbytes"), [
    (0x3F, 1),  # no register there
    (0x3E, 2),  # runs past the action register into nothing
    (0x62, 3),  # cuts imu_roll (4 bytes) short
])
def test_an_invalid_walk_is_none_asked_again_or_not(address: int, nbytes: int) -> None:
    layout = Layout(MINI)
    assert layout.walk(address, nbytes) is None
    assert layout.walk(address, nbytes) is None


def test_a_registers_byte_table_is_its_to_byte_and_made_once() -> None:
    layout = Layout(MINI)
    body_z = MINI.register("body_z")
    table = layout.byte_table(body_z)
    assert table.reg is body_z
    assert [table(v) for v in (75.0, 90.0, 97.5, 120.0)] == [
        body_z.to_byte(v) for v in (75.0, 90.0, 97.5, 120.0)]
    assert layout.byte_table(body_z) is table
    assert layout.byte_table(MINI.register("roll")).reg is MINI.register("roll")


def _reg(group: str, access: Access = Access.READ_WRITE, *, unsafe: bool = False) -> Register:
    return Register(0x10, "r", access, group=group, unsafe=unsafe)


def test_only_writable_safe_state_registers_fill_gaps() -> None:
    layout = Layout(Profile("t", "xgo", "T", Link(115200, 0.001)))
    for group in FILLER_GROUPS:
        assert layout.can_fill(_reg(group)), group
        assert layout.can_fill(_reg(group, Access.WRITE)), group
        assert not layout.can_fill(_reg(group, Access.READ)), group
        assert not layout.can_fill(_reg(group, unsafe=True)), group
    for group in ("setting", "action", "telemetry", ""):
        assert not layout.can_fill(_reg(group)), group
    # On the Mini: the speeds, postures, legs, servos fill; settings and the action never.
    mini = Layout(MINI)
    fill = {r.name for r in MINI.registers if mini.can_fill(r)}
    assert {"vx", "body_z", "leg1_x", "servo_11", "gripper", "arm_x"} <= fill
    assert not fill & {"pace", "gait", "action", "battery", "servo_speed", "calibration"}
