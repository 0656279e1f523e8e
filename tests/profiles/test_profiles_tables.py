"""The register tables and action catalogues against the seed documents and the brief's names."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.profiles.built import build_profile
from xgo_show.errors import ProfileError
from xgo_show.profiles import Access, Encoding, Profile, get_profile, model_from_firmware
from xgo_show.profiles.xgo_dog import LEG_NAMES, LITE_RANGES, MINI_RANGES, SERVO_IDS

MINI = get_profile("mini")
LITE = get_profile("lite")
RIDER = get_profile("rider")
XARM = get_profile("xarm")
# The table tests check profiles built within the test (tests/profiles/built.py says why).
XGO_MODELS = ("mini", "lite", "rider")

# --- the seed documents (copied to seeds/), parsed ---------------------------------------------
# The tests compare the profiles against these parses, so a table in the code that drifts from
# the documents fails, instead of being compared with a second hand-typed copy.
SEEDS = Path(__file__).parent / "seeds"
MINI_LITE_DOC = SEEDS / "xgo-serial-protocol-mini-lite.txt"
RIDER_DOC = SEEDS / "xgo-serial-protocol-rider.md"
RIDER_ZH_DOC = SEEDS / "xgo-serial-protocol-zh.md"

_ADDRESS = re.compile(r"0x([0-9A-Fa-f]{2})\b")
_BYTE = re.compile(r"0x([0-9A-Fa-f]{2})")


def _cells(line: str) -> list[str]:
    return [c.strip() for c in line.strip().strip("|").split("|")]


def memory_table(doc: Path) -> dict[int, int | None]:
    """Address -> documented initial byte (None where the document gives none)."""
    rows: dict[int, int | None] = {}
    in_table = False
    for line in doc.read_text(encoding="utf-8").splitlines():
        if "memory table" in line.lower() or "内存表" in line:
            in_table = True
            continue
        if not in_table:
            continue
        cells = _cells(line)
        match = _ADDRESS.match(cells[0])
        if match is None or len(cells) < 4:
            continue
        initial = _BYTE.fullmatch(cells[3])
        rows[int(match.group(1), 16)] = int(initial.group(1), 16) if initial else None
    return rows


# The access column's words, English and Chinese.
_ACCESS = {"read": Access.READ, "write": Access.WRITE, "read and write": Access.READ_WRITE,
           "读": Access.READ, "写": Access.WRITE, "读写": Access.READ_WRITE}  # fmt: skip


def memory_access(doc: Path) -> dict[int, Access]:
    """Address -> documented access (the memory table's read/write column)."""
    rows: dict[int, Access] = {}
    in_table = False
    for line in doc.read_text(encoding="utf-8").splitlines():
        if "memory table" in line.lower() or "内存表" in line:
            in_table = True
            continue
        cells = _cells(line)
        match = _ADDRESS.match(cells[0])
        if in_table and match is not None and len(cells) >= 4:
            rows[int(match.group(1), 16)] = _ACCESS[cells[2].lower()]
    return rows


def dog_actions(doc: Path = MINI_LITE_DOC) -> dict[int, tuple[str, float]]:
    """Action id -> (document name, seconds) from the Mini/Lite action table."""
    out: dict[int, tuple[str, float]] = {}
    for line in doc.read_text(encoding="utf-8").splitlines():
        cells = _cells(line)
        if len(cells) >= 3 and cells[0].isdigit() and re.fullmatch(r"\d+", cells[2]):
            out[int(cells[0])] = (cells[1], float(cells[2]))
    return out


def rider_action_ids(doc: Path = RIDER_DOC) -> list[int]:
    """Action ids listed in the Rider's action table."""
    ids = []
    for line in doc.read_text(encoding="utf-8").splitlines():
        cells = _cells(line)
        if len(cells) == 2 and cells[0].isdigit():
            ids.append(int(cells[0]))
    return ids


# The canonical names of the team brief (address -> name), which every layer relies on.
_DOG_CANONICAL = {
    0x00: "status", 0x01: "battery", 0x03: "show_mode", 0x04: "calibration",
    0x05: "firmware_update", 0x07: "firmware", 0x09: "gait", 0x13: "bt_name",
    0x20: "servo_unload", 0x21: "servo_zero", 0x30: "vx", 0x31: "vy", 0x32: "vyaw",
    0x33: "body_x", 0x34: "body_y", 0x35: "body_z", 0x36: "roll", 0x37: "pitch", 0x38: "yaw",
    0x39: "periodic_roll", 0x3A: "periodic_pitch", 0x3B: "periodic_yaw", 0x3C: "mark_time",
    0x3D: "pace", 0x3E: "action",
    **{0x40 + 3 * (leg - 1) + i: f"leg{leg}_{axis}" for leg in range(1, 5)
       for i, axis in enumerate("xyz")},
    **{0x50 + 3 * (leg - 1) + (j - 1): f"servo_{leg}{j}" for leg in range(1, 5)
       for j in range(1, 4)},
    0x5C: "servo_speed", 0x5D: "servo_52", 0x5E: "servo_53", 0x61: "imu_mode",
    0x62: "imu_roll", 0x63: "imu_pitch", 0x64: "imu_yaw", 0x65: "imu_block",
    0x66: "imu_roll_i16", 0x67: "imu_pitch_i16", 0x68: "imu_yaw_i16",
    0x71: "gripper", 0x72: "arm_mode", 0x73: "arm_x", 0x74: "arm_z",
    0x80: "periodic_x", 0x81: "periodic_y", 0x82: "periodic_z",
}  # fmt: skip
_RIDER_CANONICAL = {
    0x01: "battery", 0x02: "status", 0x03: "show_mode", 0x04: "calibration",
    0x05: "firmware_update", 0x06: "set_origin", 0x07: "firmware", 0x08: "auto_feedback",
    0x0A: "steering_hold", 0x13: "bt_name", 0x30: "vx", 0x32: "vyaw", 0x35: "body_z",
    0x36: "roll", 0x39: "periodic_roll", 0x3E: "action", 0x61: "imu_mode", 0x62: "imu_roll",
    0x63: "imu_pitch", 0x64: "imu_yaw", 0x65: "imu_block", 0x66: "imu_roll_i16",
    0x67: "imu_pitch_i16", 0x68: "imu_yaw_i16", 0x69: "led1", 0x6A: "led2", 0x6B: "led3",
    0x6C: "led4", 0x82: "periodic_z",
}  # fmt: skip

# The documents give battery 0xFF as initial value but a 0..100 % range: we start at 100.
_BATTERY = 0x01


def test_the_registry_serves_the_table_modules_profiles() -> None:
    # What get_profile hands out is what the table modules built at import (the tests below
    # check the same code building the tables again within the test).
    from xgo_show.profiles import xarm, xgo_dog, xgo_rider

    assert get_profile("mini") is xgo_dog.MINI and get_profile("lite") is xgo_dog.LITE
    assert get_profile("rider") is xgo_rider.RIDER and get_profile("xarm") is xarm.XARM


def test_seed_parse_found_the_tables() -> None:
    # Guards the parser: a parse that finds nothing would make the next test vacuous.
    assert len(memory_table(MINI_LITE_DOC)) == 62
    assert len(memory_table(RIDER_DOC)) == 28
    assert memory_table(RIDER_ZH_DOC) == memory_table(RIDER_DOC)


@pytest.mark.parametrize(
    ("model", "doc"),
    [
        ("mini", MINI_LITE_DOC),
        ("lite", MINI_LITE_DOC),
        ("rider", RIDER_DOC),
        ("rider", RIDER_ZH_DOC),
    ],
    ids=lambda v: v if isinstance(v, str) else v.name,
)
def test_every_documented_address_with_its_initial_value(model: str, doc: Path) -> None:
    profile = build_profile(model)
    for address, initial in memory_table(doc).items():
        reg = profile.register_at(address)
        assert reg is not None, f"{model}: 0x{address:02X} from {doc.name} missing"
        assert reg.initial is not None and len(reg.initial) == reg.size, reg.name
        if address == _BATTERY:
            assert initial == 0xFF and reg.initial == bytes((100,))
        elif initial is not None:
            assert reg.initial == bytes((initial,)), f"{reg.name} initial"


@pytest.mark.parametrize(
    ("model", "doc"),
    [
        ("mini", MINI_LITE_DOC),
        ("lite", MINI_LITE_DOC),
        ("rider", RIDER_DOC),
        ("rider", RIDER_ZH_DOC),
    ],
    ids=lambda v: v if isinstance(v, str) else v.name,
)
def test_every_documented_address_with_its_access(model: str, doc: Path) -> None:
    documented = memory_access(doc)
    assert len(documented) == len(memory_table(doc))  # every row has a known access word
    profile = build_profile(model)
    for address, access in documented.items():
        reg = profile.register_at(address)
        assert reg is not None and reg.access is access, f"{model}: 0x{address:02X} access"


@pytest.mark.parametrize(
    ("model", "canonical"),
    [("mini", _DOG_CANONICAL), ("lite", _DOG_CANONICAL), ("rider", _RIDER_CANONICAL)],
    ids=["mini", "lite", "rider"],
)
def test_canonical_names_and_nothing_else(model: str, canonical: dict[int, str]) -> None:
    assert {r.address: r.name for r in build_profile(model).registers} == canonical


# The registers every XGO has at the same address with the same meaning (profiles/_common.py), as
# the documents state them: encoding, bytes, unit, and each setting's codes ("0x00 normal
# control mode, 0x01 loop action", "0x01 enter the calibration mode, 0x00 exit", "0x01 enters
# the update mode", "0x00 off, 0x01 self-stabilising"); the firmware is "a 10-byte string", the
# Bluetooth name up to 20, the IMU angles float32 (0x62..0x64) and int16 (0x66..0x68) degrees.
_SHARED: dict[str, tuple[Encoding, int, str | None, dict[str, int]]] = {
    "battery": (Encoding.U8, 1, "%", {}),
    "show_mode": (Encoding.ENUM, 1, None, {"normal": 0, "loop": 1}),
    "calibration": (Encoding.ENUM, 1, None, {"exit": 0, "enter": 1}),
    "firmware_update": (Encoding.ENUM, 1, None, {"off": 0, "update": 1}),
    "firmware": (Encoding.ASCII, 10, None, {}),
    "bt_name": (Encoding.ASCII, 20, None, {}),
    "imu_mode": (Encoding.ENUM, 1, None, {"off": 0, "stabilise": 1}),
    **{f"imu_{axis}": (Encoding.FLOAT32, 4, "deg", {}) for axis in ("roll", "pitch", "yaw")},
    "imu_block": (Encoding.BLOCK, 24, None, {}),
    **{f"imu_{axis}_i16": (Encoding.INT16, 2, "deg", {}) for axis in ("roll", "pitch", "yaw")},
}


@pytest.mark.parametrize("model", XGO_MODELS)
def test_the_registers_every_xgo_shares(model: str) -> None:
    profile = build_profile(model)
    for name, (encoding, size, unit, choices) in _SHARED.items():
        reg = profile.register(name)
        assert (reg.encoding, reg.size, reg.unit) == (encoding, size, unit), name
        assert dict(reg.choices) == choices, name
    # The IMU block decodes through the profile's IMU layout, 24 bytes either way.
    assert profile.imu is not None and profile.imu.size == 24


@pytest.mark.parametrize("model", XGO_MODELS)
def test_names_and_addresses_unique(model: str) -> None:
    profile = build_profile(model)
    names = [r.name for r in profile.registers]
    addresses = [r.address for r in profile.registers]
    assert len(set(names)) == len(names)
    assert len(set(addresses)) == len(addresses)


def test_unsafe_registers() -> None:
    dog_unsafe = {"firmware_update", "calibration", "servo_zero", "bt_name", "servo_unload"}
    for model in ("mini", "lite"):
        assert {r.name for r in build_profile(model).registers if r.unsafe} == dog_unsafe
    assert {r.name for r in build_profile("rider").registers if r.unsafe} == {
        "firmware_update",
        "calibration",
        "bt_name",
    }


def test_unsafe_registers_are_not_offered_in_lookup_errors() -> None:
    with pytest.raises(ProfileError) as err:
        MINI.register("nope")
    assert "vx" in str(err.value) and "firmware_update" not in str(err.value)


@pytest.mark.parametrize("model", XGO_MODELS)
def test_every_register_is_described_and_grouped(model: str) -> None:
    profile = build_profile(model)
    for reg in profile.registers:
        assert reg.description, reg.name
        assert reg.group in {
            "speed", "posture", "periodic", "leg", "servo", "arm", "gripper", "led", "setting",
            "action", "telemetry",
        }, reg.name  # fmt: skip
        if reg.encoding is Encoding.ENUM:
            assert reg.initial is not None and reg.initial[0] in reg.choices.values(), reg.name


@pytest.mark.parametrize("model", XGO_MODELS)
def test_trajectory_registers_have_limits(model: str) -> None:
    profile = build_profile(model)
    moving = {"speed", "posture", "leg", "servo", "arm", "gripper"}
    for reg in profile.registers:
        if reg.group in moving and reg.encoding is Encoding.U8:
            assert reg.linear and reg.limits is not None, reg.name
            lim = reg.limits
            assert 0 < lim.velocity < lim.acceleration < lim.jerk, reg.name
        elif reg.limits is not None:
            pytest.fail(f"{reg.name} ({reg.group}, {reg.encoding}) should not carry limits")


@pytest.mark.parametrize("model", XGO_MODELS)
def test_initial_bytes_are_in_range(model: str) -> None:
    profile = build_profile(model)
    for reg in profile.registers:
        assert reg.initial is not None and len(reg.initial) == reg.size, reg.name
        if reg.linear and reg.size == 1:
            value = reg.to_physical(reg.initial[0])
            if not (reg.encoding is Encoding.U8_PERIODIC and value == 0):
                reg.check(value)


# --- ranges (vendor changePara) -------------------------------------------------------------


@pytest.mark.parametrize(
    ("name", "mini", "lite"),
    [
        ("vx", (-25, 25), (-25, 25)),
        ("vy", (-18, 18), (-18, 18)),
        ("vyaw", (-100, 100), (-100, 100)),
        ("body_x", (-35, 35), (-25, 25)),
        ("body_y", (-19.5, 19.5), (-18, 18)),
        ("body_z", (75, 120), (60, 110)),
        ("roll", (-20, 20), (-20, 20)),
        ("pitch", (-22, 22), (-10, 10)),
        ("yaw", (-16, 16), (-12, 12)),
        ("leg3_x", (-35, 35), (-25, 25)),
        ("leg2_y", (-18, 18), (-18, 18)),
        ("leg4_z", (75, 115), (60, 110)),
        # MOTOR_LIMIT[(i - 1) % 3]: servo x1 -> [0], x2 -> [1], x3 -> [2]
        ("servo_11", (-73, 57), (-70, 50)),
        ("servo_32", (-66, 93), (-70, 90)),
        ("servo_43", (-31, 31), (-30, 30)),
        ("servo_52", (-85, 50), (-115, 70)),
        ("servo_53", (-75, 90), (-85, 100)),
        ("mark_time", (10, 35), (10, 25)),
        ("periodic_pitch", (1.5, 8), (1.5, 8)),
        ("periodic_z", (1.5, 8), (1.5, 8)),
        ("arm_x", (-80, 155), (-80, 155)),
        ("arm_z", (-95, 155), (-95, 155)),
        ("gripper", (0, 100), (0, 100)),
    ],
)
def test_dog_ranges(name: str, mini: tuple[float, float], lite: tuple[float, float]) -> None:
    for profile, expected in ((build_profile("mini"), mini), (build_profile("lite"), lite)):
        reg = profile.register(name)
        assert (reg.minimum, reg.maximum) == expected, f"{profile.model} {name}"


# Units of the dogs' linear registers: vx/vy as the vendor's stride, vyaw deg/s (both
# undocumented, see xgo_dog._SPEED_UNITS), body and feet in mm, angles in deg, periods in s,
# mark time as a step height in mm, the arm's end point in mm.
_DOG_UNITS = {
    "vx": "mm/step", "vy": "mm/step", "vyaw": "deg/s", "body_x": "mm", "body_y": "mm",
    "body_z": "mm", "roll": "deg", "pitch": "deg", "yaw": "deg", "mark_time": "mm",
    **{f"periodic_{a}": "s" for a in ("roll", "pitch", "yaw", "x", "y", "z")},
    **{f"leg{leg}_{a}": "mm" for leg in range(1, 5) for a in "xyz"},
    **{f"servo_{leg}{j}": "deg" for leg in range(1, 5) for j in range(1, 4)},
    "servo_52": "deg", "servo_53": "deg", "arm_x": "mm", "arm_z": "mm", "gripper": "%",
}  # fmt: skip


@pytest.mark.parametrize("model", ["mini", "lite"])
def test_dog_linear_registers_units_groups_and_bytes(model: str) -> None:
    profile = build_profile(model)
    linear = {r.name: r for r in profile.registers if r.linear}
    assert {name: r.unit for name, r in linear.items()} == _DOG_UNITS
    for reg in linear.values():
        lo, hi = reg.minimum, reg.maximum
        assert lo is not None and hi is not None
        if reg.group == "periodic" or reg.name == "mark_time":
            # 0x00 is off; 0x01..0xFF span the range (the vendor's period/step encoding).
            assert reg.encoding is Encoding.U8_PERIODIC and reg.initial == b"\x00", reg.name
            assert (reg.to_byte(0), reg.to_byte(lo), reg.to_byte(hi)) == (0, 1, 255), reg.name
            continue
        assert reg.encoding is Encoding.U8 and reg.initial == b"\x80", reg.name
        assert (reg.to_byte(lo), reg.to_byte(hi)) == (0x00, 0xFF), reg.name
        if lo == -hi:  # symmetric: 0 is the documented neutral 0x80, each half scales apart
            assert (reg.to_byte(0), reg.to_byte(hi / 2), reg.to_byte(lo / 2)) == (
                0x80, 0x80 + 64, 0x40), reg.name
        else:  # servo joints, arm, gripper: plainly linear across the range
            mid = (lo + hi) / 2
            assert reg.to_byte(mid) == 128, reg.name
            if lo < 0 < hi:
                assert reg.to_byte(0) == round(-lo / (hi - lo) * 255), reg.name
    groups = {r.group for r in linear.values()}
    assert groups == {"speed", "posture", "periodic", "leg", "servo", "arm", "gripper"}
    assert [r.name for r in linear.values() if r.group == "speed"] == [
        "vx", "vy", "vyaw", "mark_time"]  # fmt: skip
    assert {r.name for r in linear.values() if r.group == "posture"} == {
        "body_x", "body_y", "body_z", "roll", "pitch", "yaw"}  # fmt: skip
    assert {r.name for r in linear.values() if r.group == "arm"} == {"arm_x", "arm_z"}
    assert {r.name for r in linear.values() if r.group == "servo"} == {
        f"servo_{s}" for s in (*SERVO_IDS, 52, 53)}  # fmt: skip
    assert {r.name for r in linear.values() if r.group == "leg"} == {
        f"leg{leg}_{a}" for leg in range(1, 5) for a in "xyz"}  # fmt: skip


@pytest.mark.parametrize("model", XGO_MODELS)
def test_registers_in_address_order_and_the_family(model: str) -> None:
    profile = build_profile(model)
    addresses = [r.address for r in profile.registers]
    assert addresses == sorted(addresses)
    assert profile.family == "xgo" and profile.model == model
    assert profile.firmware_default[0] == model[0].upper()
    # What `xgo-show info` titles it, and the firmware it is recognised by (the vendor's
    # auto-detection: "MW..." and "W..." firmware is driven as a Mini).
    titles = {"mini": "XGO-Mini", "lite": "XGO-Lite", "rider": "XGO-Rider"}
    prefixes = {"mini": ("M", "MW", "W"), "lite": ("L",), "rider": ("R",)}
    assert (profile.title, profile.firmware_prefixes) == (titles[model], prefixes[model])


def test_each_servo_register_says_which_leg_and_joint() -> None:
    # Servo ids are 10 * leg + joint (the document's numbering): the description names both.
    mini = build_profile("mini")
    joints = {1: "lower", 2: "middle", 3: "upper"}
    for sid in SERVO_IDS:
        text = mini.register(f"servo_{sid}").description
        assert text.startswith(f"servo {sid} angle: {LEG_NAMES[sid // 10]} leg, "), text
        assert joints[sid % 10] in text, text


def test_vendor_range_tables_agree_with_the_vendor_library() -> None:
    from xgolib import xgolib_dog

    for version, ranges in (("xgomini", MINI_RANGES), ("xgolite", LITE_RANGES)):
        xgolib_dog.changePara(version)
        p = xgolib_dog.XGOparam
        t, a, leg, m = (
            p["TRANSLATION_LIMIT"],
            p["ATTITUDE_LIMIT"],
            p["LEG_LIMIT"],
            p["MOTOR_LIMIT"],
        )
        assert ranges["body_x"] == (-t[0], t[0]) and ranges["body_y"] == (-t[1], t[1])
        assert ranges["body_z"] == tuple(t[2])
        assert (ranges["roll"][1], ranges["pitch"][1], ranges["yaw"][1]) == tuple(a)
        assert ranges["leg_x"][1] == leg[0] and ranges["leg_y"][1] == leg[1]
        assert ranges["leg_z"] == tuple(leg[2])
        assert [ranges[f"servo_x{j}"] for j in (1, 2, 3)] == [tuple(x) for x in m[:3]]
        assert (ranges["servo_52"], ranges["servo_53"]) == (tuple(m[4]), tuple(m[5]))
        assert ranges["periodic"] == tuple(p["PERIOD_LIMIT"][0])
        assert ranges["mark_time"] == tuple(p["MARK_TIME_LIMIT"])
        assert ranges["vx"][1] == p["VX_LIMIT"] and ranges["vy"][1] == p["VY_LIMIT"]
        assert ranges["vyaw"][1] == p["VYAW_LIMIT"]
        assert (ranges["arm_x"], ranges["arm_z"]) == (tuple(p["ARM_LIMIT"][0]),
                                                      tuple(p["ARM_LIMIT"][1]))  # fmt: skip


def test_rider_ranges() -> None:
    expected = {
        "vx": (-1.5, 1.5, "m/s"),
        "vyaw": (-360, 360, "deg/s"),
        "body_z": (60, 120, "mm"),
        "roll": (-17, 17, "deg"),
        "periodic_roll": (1, 2, "s"),
        "periodic_z": (1, 2, "s"),
    }
    rider = build_profile("rider")
    for name, (lo, hi, unit) in expected.items():
        reg = rider.register(name)
        assert (reg.minimum, reg.maximum, reg.unit) == (lo, hi, unit), name


# --- layout ---------------------------------------------------------------------------------


def test_walk_examples() -> None:
    def names(profile: Profile, address: int, n: int) -> list[str]:
        return [r.name for r in profile.walk(address, n)]

    assert names(MINI, 0x33, 6) == ["body_x", "body_y", "body_z", "roll", "pitch", "yaw"]
    assert names(RIDER, 0x69, 6) == ["led1", "led2"]
    assert names(MINI, 0x62, 12) == ["imu_roll", "imu_pitch", "imu_yaw"]
    assert names(RIDER, 0x62, 12) == ["imu_roll", "imu_pitch", "imu_yaw"]
    assert names(MINI, 0x07, 10) == ["firmware"]
    assert names(LITE, 0x65, 24) == ["imu_block"]
    assert names(MINI, 0x66, 6) == ["imu_roll_i16", "imu_pitch_i16", "imu_yaw_i16"]
    # the document's example read: 12 servos from 0x50; the vendor's read_motor reads 15
    assert names(MINI, 0x50, 12) == [f"servo_{leg}{j}" for leg in range(1, 5) for j in (1, 2, 3)]
    assert names(MINI, 0x50, 15)[-3:] == ["servo_speed", "servo_52", "servo_53"]
    assert names(LITE, 0x40, 12)[::3] == ["leg1_x", "leg2_x", "leg3_x", "leg4_x"]
    with pytest.raises(ProfileError):
        RIDER.walk(0x69, 4)  # led2 would be cut short
    with pytest.raises(ProfileError):
        MINI.walk(0x3F, 1)  # nothing documented there


def test_safe_stop_brings_xgos_to_rest() -> None:
    mini, rider = build_profile("mini"), build_profile("rider")
    for profile in (mini, build_profile("lite"), rider):
        assert profile.safe_stop
        for name, value in profile.safe_stop:
            reg = profile.register(name)
            assert reg.access.writable and not reg.unsafe
            byte = reg.to_byte(value)
            assert byte == (0x80 if reg.group == "speed" and reg.name != "mark_time" else 0x00)
    mini_stop = {name for name, _ in mini.safe_stop}
    assert {"vx", "vy", "vyaw", "mark_time"} <= mini_stop
    assert {r.name for r in mini.registers if r.group == "periodic"} <= mini_stop
    assert {r.name for r in rider.registers if r.group in ("speed", "periodic")} == {
        name for name, _ in rider.safe_stop
    }
    # At rest: no speed, no periodic motion (0.0 in each register's unit, not a small value
    # that rounds to the same byte).
    assert all(value == 0.0 for _, value in rider.safe_stop)


def test_default_posture_registers_exist_and_are_posture() -> None:
    mini, rider = build_profile("mini"), build_profile("rider")
    assert mini.default_posture == ("body_x", "body_y", "body_z", "roll", "pitch", "yaw")
    assert rider.default_posture == ("body_z", "roll")
    for profile in (mini, build_profile("lite"), rider):
        for name in profile.default_posture:
            assert profile.register(name).group == "posture"


def test_links_and_write_types() -> None:
    mini, lite, rider, xarm = map(build_profile, ("mini", "lite", "rider", "xarm"))
    for profile in (mini, lite, rider):
        # The 1 ms the documents ask for, and the margin for delivery jitter on top of it.
        assert (profile.link.baud, profile.link.gap) == (115200, 0.0012)
    assert (mini.write_type, lite.write_type, rider.write_type) == (0x00, 0x00, 0x01)
    assert xarm.link.baud == 9600
    assert xarm.family == "xarm" and not xarm.registers
    assert xarm.xarm_servos == (1, 2, 3, 4, 5, 6)
    assert xarm.capabilities == frozenset({"servos", "gripper"})


def test_capabilities() -> None:
    rider = build_profile("rider")
    for dog in (build_profile("mini"), build_profile("lite")):
        assert {"legs", "lateral", "arm", "gripper", "actions", "periodic", "imu"} <= (
            dog.capabilities
        )
        assert not dog.supports("led")
    assert rider.supports("led") and rider.supports("actions") and rider.supports("imu")
    assert rider.capabilities == frozenset({"wheels", "led", "actions", "periodic", "posture",
                                             "imu"})


@pytest.mark.parametrize("model", XGO_MODELS)
def test_firmware_register_reports_the_profiles_own_model(model: str) -> None:
    profile = build_profile(model)
    raw = profile.register("firmware").initial
    assert raw is not None and len(raw) == 10
    text = raw.rstrip(b"\0").decode("ascii")
    assert text == profile.firmware_default
    assert model_from_firmware(text) == profile.model
    assert profile.register("firmware").encode_value(text) == raw


# --- actions --------------------------------------------------------------------------------


def test_the_dogs_actions_and_their_durations_match_the_document() -> None:
    documented = dog_actions()
    assert len(documented) == 27  # 1..24 without 5, 128..130, 255
    for profile in (build_profile("mini"), build_profile("lite")):
        by_id = {a.id: a for a in profile.actions}
        assert set(by_id) == set(documented) | {5}
        for action_id, (_name, seconds) in documented.items():
            assert by_id[action_id].duration == seconds, action_id
        # 5 is not in the English table; the vendor's ActionTime gives it 4 s
        assert by_id[5].duration == 4.0


def test_dog_action_names() -> None:
    names = [a.name for a in MINI.actions]
    assert len(set(names)) == len(names)
    assert all(n.isidentifier() and n == n.lower() for n in names)
    assert MINI.action(1).name == "get_down" and MINI.action("stand_up").id == 2
    assert (MINI.action(13).name, MINI.action(15).name) == ("wave", "wave_2")
    assert MINI.action(255).name == "reset"


def test_dog_action_durations_match_the_vendor_library() -> None:
    from xgolib import xgolib_dog

    xgolib_dog.changePara("xgomini")
    assert {a.id: a.duration for a in MINI.actions} == {
        k: float(v) for k, v in xgolib_dog.XGOparam["ActionTime"].items()
    }


def test_rider_actions() -> None:
    rider = build_profile("rider")
    assert [a.id for a in rider.actions] == [*rider_action_ids(), 255]
    assert [a.id for a in rider.actions] == [*rider_action_ids(RIDER_ZH_DOC), 255]
    assert [a.name for a in rider.actions] == [
        "swinging",
        "ups_and_downs",
        "forward_and_backward",
        "four_sided_serpentine",
        "lift_and_rotate",
        "circular_shake",
        "reset",
    ]
    assert all(a.duration is None for a in rider.actions)


# The Rider's own registers (the shared ones: _SHARED) as its document states them: access,
# encoding, bytes, and each setting's codes (0x02 "0x00 falling state, 0x01 normal", 0x06
# "0x01 setting", 0x08 feedback on, 0x0A "0x00 off, 0x01 on"). 0x36 roll is not in the Rider
# table (the brief and the vendor library use it) and is written like the other postures.
_RIDER_OWN: dict[str, tuple[Access, Encoding, int, dict[str, int]]] = {
    "status": (Access.READ, Encoding.ENUM, 1, {"fallen": 0, "normal": 1}),
    "set_origin": (Access.WRITE, Encoding.ENUM, 1, {"idle": 0, "set": 1}),
    "auto_feedback": (Access.WRITE, Encoding.ENUM, 1, {"off": 0, "on": 1}),
    "steering_hold": (Access.WRITE, Encoding.ENUM, 1, {"off": 0, "on": 1}),
    "vx": (Access.WRITE, Encoding.U8, 1, {}),
    "vyaw": (Access.WRITE, Encoding.U8, 1, {}),
    "body_z": (Access.WRITE, Encoding.U8, 1, {}),
    "roll": (Access.WRITE, Encoding.U8, 1, {}),
    "periodic_roll": (Access.WRITE, Encoding.U8_PERIODIC, 1, {}),
    "action": (Access.WRITE, Encoding.U8, 1, {}),
    **{f"led{n}": (Access.WRITE, Encoding.RGB, 3, {}) for n in range(1, 5)},
    "periodic_z": (Access.WRITE, Encoding.U8_PERIODIC, 1, {}),
}


def test_the_riders_own_registers() -> None:
    rider = build_profile("rider")
    for name, (access, encoding, size, choices) in _RIDER_OWN.items():
        reg = rider.register(name)
        assert (reg.access, reg.encoding, reg.size, dict(reg.choices)) == (
            access, encoding, size, choices), name
    # Each LED register says which LED it colours.
    for n in range(1, 5):
        assert rider.register(f"led{n}").description.startswith(f"LED {n} colour"), n


# The Rider's default trajectory limits (our choice, not a vendor fact: a full-scale change
# within about a second): what a move without its own limits gets, per second^n.
_RIDER_LIMITS = {
    "vx": (1.5, 6.0, 40.0),
    "vyaw": (360.0, 1800.0, 15000.0),
    "body_z": (60.0, 300.0, 2000.0),
    "roll": (40.0, 200.0, 1500.0),
}


def test_rider_trajectory_limits() -> None:
    rider = build_profile("rider")
    for name, expected in _RIDER_LIMITS.items():
        lim = rider.register(name).limits
        assert lim is not None, name
        assert (lim.velocity, lim.acceleration, lim.jerk) == expected, name
    assert {r.name for r in rider.registers if r.limits is not None} == set(_RIDER_LIMITS)


def test_unknown_action_lists_valid_ones() -> None:
    with pytest.raises(ProfileError, match="swinging"):
        RIDER.action("moonwalk")
    with pytest.raises(ProfileError, match="24 naughty"):
        MINI.action(99)
