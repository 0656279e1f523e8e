"""Read schedules back: decode frames, replay register state, catch up mid-show.

- :func:`describe_frame` turns one scheduled frame back into register names and physical values
  (transcripts, plots, progress). The compiler labels every frame with :func:`format_fields`
  of it, so a label always says what the bytes say.
- :func:`state_at` replays a performer's writes up to a time: the bytes each register would hold.
- :func:`frames_to_reach` builds the few frames that bring a robot from its initial values to
  such a state (to start or resume a show in the middle).

Each asks the performer's robot family (:mod:`xgo_show.families`); the XGO family's answers
are here (``describe_xgo_frame``, ``xgo_state_at``, ``xgo_frames_to_reach``), the xArm's in
:mod:`xgo_show.compiler.xarm`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

from xgo_show.compiler.layout import ACTION_REGISTER, Layout
from xgo_show.compiler.schedule import PerformerSchedule, ScheduledFrame, frame_data
from xgo_show.errors import ProtocolError
from xgo_show.families import get_family
from xgo_show.profiles.model import Link, Profile, Register
from xgo_show.profiles.registry import get_profile
from xgo_show.wire.xgo import MAX_DATA, MIN_LENGTH, decode_one, write_frame

__all__ = [
    "FrameLabels",
    "describe_frame",
    "describe_xgo_frame",
    "format_fields",
    "format_value",
    "frame_label",
    "frame_labels",
    "frames_to_reach",
    "reach_frame",
    "state_at",
    "xgo_frames_to_reach",
    "xgo_state_at",
]

_LAYOUTS: dict[str, Layout] = {}


def layout_of(profile: Profile) -> Layout:
    """A cached :class:`Layout` per model (profiles are immutable tables)."""
    cached = _LAYOUTS.get(profile.model)
    if cached is None or cached.profile is not profile:
        cached = Layout(profile)
        _LAYOUTS[profile.model] = cached
    return cached


def _fields(layout: Layout, address: int, data: bytes) -> list[tuple[Register, bytes]]:
    regs = layout.walk(address, len(data))
    if regs is None:
        raise ProtocolError(
            f"{len(data)} bytes at 0x{address:02X} do not match the {layout.profile.model} "
            "register layout"
        )
    out: list[tuple[Register, bytes]] = []
    offset = 0
    for reg in regs:
        out.append((reg, data[offset : offset + reg.size]))
        offset += reg.size
    return out


def _xgo_write(data: bytes) -> tuple[int, bytes]:
    used, frame = decode_one(data)
    if frame is None or used != len(data) or not frame.is_write:
        raise ProtocolError(f"not a single XGO write frame: {data.hex(' ')}")
    return frame.address, frame.data


def describe_frame(profile: Profile, data: bytes) -> list[tuple[str, object]]:
    """Decode a scheduled frame's wire bytes into (register name, physical value) pairs.

    XGO: one pair per field the write covers, in address order. xArm ServoMove: ``("time_ms",
    n)`` then ``("servo_<id>", position)`` per servo. Raises :class:`ProtocolError` for bytes
    that are not such a frame.
    """
    return get_family(profile).describe_frame(profile, data)


def describe_xgo_frame(profile: Profile, data: bytes) -> list[tuple[str, object]]:
    """One (register, physical value) pair per field an XGO write frame covers, in order."""
    address, payload = _xgo_write(data)
    fields = _fields(layout_of(profile), address, payload)
    return [(reg.name, reg.decode_value(raw)) for reg, raw in fields]


def format_value(profile: Profile, name: str, value: object) -> str:
    """One value as a transcript shows it: 1 decimal and the unit, colours as #RRGGBB."""
    if isinstance(value, float):
        unit = ""
        reg = layout_of(profile).by_name.get(name)
        if reg is not None and reg.unit:
            unit = reg.unit
        text = f"{value:.1f}"
        return ("0.0" if text == "-0.0" else text) + unit
    if isinstance(value, tuple):
        return "#" + "".join(f"{int(c):02X}" for c in value)
    if isinstance(value, bytes):
        return value.hex()
    if name == ACTION_REGISTER and isinstance(value, int):
        for act in profile.actions:
            if act.id == value:
                return f"{value}({act.name})"
    return str(value)


def format_fields(profile: Profile, fields: Sequence[tuple[str, object]]) -> str:
    """``name=value`` pairs joined by spaces, e.g. ``body_z=98.0mm pitch=5.0deg``."""
    return " ".join(f"{name}={format_value(profile, name, value)}" for name, value in fields)


def frame_label(profile: Profile, data: bytes) -> str:
    """A frame's label: ``format_fields(profile, describe_frame(profile, data))``."""
    return format_fields(profile, describe_frame(profile, data))


def field_label(profile: Profile, address: int, raw: bytes) -> str:
    """``name=value`` of one field: the piece :func:`format_fields` builds labels of."""
    reg = layout_of(profile).by_address[address]
    return f"{reg.name}={format_value(profile, reg.name, reg.decode_value(raw))}"


class FrameLabels:
    """``frame bytes -> label`` for one XGO profile: :func:`frame_label`, faster.

    The XGO family's labeller (what :attr:`ScheduledFrame.label` is derived with, through
    :func:`frame_labels`). An XGO write frame is cut into its fields by the cached layout walk
    and each distinct field's ``name=value`` text is made once (compiled frames are well
    formed; anything else goes through :func:`describe_frame`, which checks).
    """

    def __init__(self, profile: Profile) -> None:
        self.profile = profile
        self._walks: dict[tuple[int, int], tuple[tuple[int, int, int], ...]] = {}
        # Field texts by (address, bytes); a one-byte field's key is the int address << 8 | byte
        # (no slice, no tuple: most fields are one byte).
        self._texts: dict[object, str] = {}

    def __call__(self, data: bytes) -> str:
        profile = self.profile
        if len(data) < MIN_LENGTH or data[2] != len(data):
            return frame_label(profile, data)
        address, payload = data[4], data[5:-3]
        walk = self._walks.get((address, len(payload)))
        if walk is None:
            regs = layout_of(profile).walk(address, len(payload))
            if regs is None:  # not a layout the compiler makes: let describe_frame say why
                return frame_label(profile, data)
            offsets, at = [], 0
            for reg in regs:
                offsets.append((reg.address, at, at + reg.size))
                at += reg.size
            walk = self._walks[(address, len(payload))] = tuple(offsets)
        texts = self._texts
        parts = []
        for reg_address, begin, end in walk:
            key = (reg_address << 8 | payload[begin] if end - begin == 1
                   else (reg_address, payload[begin:end]))
            text = texts.get(key)
            if text is None:
                text = texts[key] = field_label(profile, reg_address, payload[begin:end])
            parts.append(text)
        return " ".join(parts)


class _Labels:
    """A family's labeller that never raises: a label is read while a show runs, and a schedule
    file may hold any frame its family accepts. Bytes it cannot read are labelled with why."""

    def __init__(self, profile: Profile) -> None:
        self.profile = profile
        self._label = get_family(profile).frame_labels(profile)

    def __call__(self, data: bytes) -> str:
        try:
            return self._label(data)
        except ProtocolError as exc:
            return f"({exc})"


_LABELS: dict[str, _Labels] = {}


def frame_labels(profile: Profile) -> Callable[[bytes], str]:
    """``frame bytes -> label`` for ``profile``'s frames, one per profile (frames share it)."""
    cached = _LABELS.get(profile.model)
    if cached is None or cached.profile is not profile:
        cached = _LABELS[profile.model] = _Labels(profile)
    return cached


def state_at(performer: PerformerSchedule, t: float) -> dict[str, bytes]:
    """The bytes each register holds at show time ``t`` after replaying the writes up to ``t``.

    Only registers the schedule wrote appear. The ``action`` entry is present only while a
    preset action started by the schedule is still running at ``t`` (a finished action is not
    state to restore). For the xArm: ``servo_<id>`` -> 2-byte little-endian target position of
    the last move started at or before ``t``.
    """
    profile = get_profile(performer.model)
    return get_family(profile).state_at(profile, performer.frames, t)


def xgo_state_at(
    profile: Profile, frames: Sequence[ScheduledFrame], t: float
) -> dict[str, bytes]:
    """:func:`state_at` of an XGO performer: register name -> bytes."""
    state: dict[str, bytes] = {}
    action_until: float | None = None
    for frame in frames:
        if frame.t > t:
            break
        address, payload = _xgo_write(frame.data)
        for reg, raw in _fields(layout_of(profile), address, payload):
            state[reg.name] = bytes(raw)
            if reg.name == ACTION_REGISTER:
                action_until = frame.t + frame.duration
    if ACTION_REGISTER in state and (action_until is None or t >= action_until):
        del state[ACTION_REGISTER]
    return state


def frames_to_reach(
    profile: Profile, state: Mapping[str, bytes], *, move_time: float = 1.0
) -> list[ScheduledFrame]:
    """The fewest write frames that bring a robot at its initial values to ``state``.

    Registers already at their initial value are skipped; consecutive registers share a frame
    (gaps are bridged with the initial bytes, which a robot at its initial values holds). A
    running action is started last, once the rest is in place. xArm: one ServoMove taking
    ``move_time`` seconds. Frames carry ``t = 0`` and a label; pace them like any other.
    """
    return get_family(profile).frames_to_reach(profile, state, move_time=move_time)


def xgo_frames_to_reach(profile: Profile, state: Mapping[str, bytes]) -> list[ScheduledFrame]:
    """:func:`frames_to_reach` for an XGO robot: register writes, a running action last."""
    layout = layout_of(profile)
    wanted: dict[int, bytes] = {}
    action: bytes | None = None
    for name in sorted(state, key=lambda n: layout.register(n).address):
        reg = layout.register(name)
        raw = bytes(state[name])
        if name == ACTION_REGISTER:
            action = raw
            continue
        if not reg.access.writable or reg.unsafe or raw == reg.initial:
            continue
        wanted[reg.address] = raw
    frames: list[ScheduledFrame] = []
    for address, data in _runs(layout, wanted):
        wire = write_frame(address, data, write_type=profile.write_type)
        frames.append(reach_frame(profile, wire))
    if action is not None and ACTION_REGISTER in layout.by_name:
        reg = layout.by_name[ACTION_REGISTER]
        wire = write_frame(reg.address, action, write_type=profile.write_type)
        frames.append(reach_frame(profile, wire))
    return frames


def reach_frame(profile: Profile, wire: bytes, duration: float = 0.0) -> ScheduledFrame:
    """A frame of :func:`frames_to_reach`: at ``t = 0``, labelled from its bytes."""
    return ScheduledFrame(0.0, wire, None, duration, frame_labels(profile))


def _runs(layout: Layout, wanted: Mapping[int, bytes]) -> list[tuple[int, bytes]]:
    """Consecutive fields, bridging gaps with initial bytes where that is shorter on the wire.

    With every robot link we know, a frame costs 8 bytes of overhead plus the silence between
    frames, so bridging pays while the gap is shorter than 8 bytes (the gap's silence is a bonus).
    """
    runs: list[tuple[int, bytearray]] = []
    last: int | None = None
    for address in sorted(wanted):
        if last is not None and runs:
            bridge = _initial_bridge(layout, last, address)
            _, buf = runs[-1]
            if (
                bridge is not None
                and len(bridge) < MIN_LENGTH
                and len(buf) + len(bridge) + len(wanted[address]) <= MAX_DATA
            ):
                buf += bridge + wanted[address]
                last = address
                continue
        runs.append((address, bytearray(wanted[address])))
        last = address
    return [(a, bytes(b)) for a, b in runs]


def _initial_bridge(layout: Layout, last: int, nxt: int) -> bytes | None:
    out = bytearray()
    for addr in range(last + 1, nxt):
        reg = layout.by_address.get(addr)
        if reg is None or not layout.can_fill(reg) or reg.initial is None:
            return None
        out += reg.initial
    return bytes(out)


def link_use(link: Link, frames: Sequence[ScheduledFrame], duration: float) -> float:
    """Fraction of ``duration`` the link spends carrying ``frames`` (wire time only)."""
    if duration <= 0:
        return 0.0
    return sum(map(link.wire_time, map(len, frame_data(frames)))) / duration
