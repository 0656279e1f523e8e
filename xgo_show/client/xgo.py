"""Request/response client for XGO robots (Mini, Lite, Rider) over any transport.

Writes are fire-and-forget frames (the robot never answers them). A read sends one read frame
and waits for the reply frame at the same address, skipping whatever else arrives meanwhile:
the Rider's 50 Hz automatic feedback frames, stale replies and line noise. A missing reply
raises :class:`~xgo_show.errors.TransportTimeout`; bytes that never make a valid reply raise
:class:`~xgo_show.errors.ProtocolError`, each with one line a user can act on.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from xgo_show.client.base import DEFAULT_TIMEOUT, ClientBase
from xgo_show.errors import ProfileError
from xgo_show.profiles import Action, Profile, Register, model_from_firmware
from xgo_show.transports.base import Transport
from xgo_show.wire.xgo import XgoDecoder, XgoFrame, read_frame, write_frame

__all__ = ["DEFAULT_TIMEOUT", "XgoClient"]


class XgoClient(ClientBase[XgoFrame]):
    """Read and write an XGO robot's registers by name through ``transport``.

    The transport must be open (``with open_transport(url) as link: XgoClient(link, profile)``);
    the client closes it when used as a context manager itself. ``clock`` is the time source
    for reply deadlines (inject a fake one together with a fake-clock ``sim:`` transport).

    Consecutive frames are spaced so that the link carries each one and then stays silent for
    the profile's ``link.gap`` (>= 1 ms for XGO) before the next, as the robot's parser needs:
    ``write`` returns when the bytes are queued, so two quick writes would otherwise run
    together on the wire.

    Not thread-safe: one thread talks through a client at a time (a reply read by another
    thread is lost to this one).
    """

    family = "xgo"
    protocol = "XGO"
    robots = "XGO robots"

    def __init__(
        self,
        transport: Transport,
        profile: Profile,
        *,
        timeout: float = DEFAULT_TIMEOUT,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        super().__init__(transport, profile, XgoDecoder(), timeout=timeout, clock=clock,
                         sleep=sleep)

    # ------------------------------------------------------------------ reads
    def read(
        self, register: str | int, count: int | None = None, *, timeout: float | None = None
    ) -> bytes:
        """Read ``count`` bytes starting at a register (by name or address).

        ``count`` defaults to the register's size (1 for an address with no register). Names
        are checked against the profile (unknown or write-only registers raise
        :class:`ProfileError`); addresses are sent as given.
        """
        address, default_count, label = self._resolve_read(register)
        count = default_count if count is None else count

        def match(frame: XgoFrame) -> bool | str:
            if not frame.is_reply or frame.address != address:
                return False  # feedback, stale replies: not ours
            if len(frame.data) != count:
                # Could be a Rider feedback block at the same address: keep waiting.
                return f"has {len(frame.data)} data bytes, expected {count}"
            return True

        reply = self._exchange.request(
            read_frame(address, count), match, label=f"a read of {label}", timeout=timeout
        )
        return reply.data

    def read_value(self, name: str, *, timeout: float | None = None) -> object:
        """Read register ``name`` and decode it (see :meth:`Register.decode_value`).

        E.g. ``"firmware"`` -> ``"M-1.4.1"``, ``"vx"`` -> ``0.0`` (mm/step), ``"imu_roll"`` ->
        degrees as float, ``"gait"`` -> ``"trot"``.
        """
        reg = self.profile.register(name)
        raw = self.read(name, reg.size, timeout=timeout)
        return reg.decode_value(raw)

    def firmware(self) -> str:
        """The firmware string (register ``firmware``, 0x07), e.g. ``"M-1.4.1"``."""
        return str(self.read_value("firmware"))

    def battery(self) -> int:
        """Battery level in percent (register ``battery``, 0x01)."""
        return self.read("battery")[0]

    def status(self) -> int:
        """The raw ``status`` byte (Mini/Lite working status; Rider 0 = fallen, 1 = normal)."""
        return self.read("status")[0]

    def identify(self) -> str | None:
        """The model the robot's firmware string names ("mini", "lite", "rider"), or None."""
        return model_from_firmware(self.firmware())

    # ------------------------------------------------------------------ writes
    def write(self, name: str, value: object, *, allow_unsafe: bool = False) -> None:
        """Write ``value`` to register ``name``, encoded by the profile.

        ``value`` is physical for linear registers (``write("vx", 12.5)``), a choice name or
        number for enums (``write("gait", "walk")``), ``(r, g, b)`` for LEDs. Out-of-range
        values raise :class:`~xgo_show.errors.ValueRangeError`. Registers marked unsafe
        (calibration, firmware update, rename, servo unload…) need ``allow_unsafe=True``.
        """
        reg = self.profile.register(name)
        if not reg.access.writable:
            raise ProfileError(f"{name} is read-only on the {self.model}")
        if reg.unsafe and not allow_unsafe:
            raise ProfileError(f"{name} is an unsafe register; pass allow_unsafe=True to write it")
        data = reg.encode_value(value)
        self._exchange.send(write_frame(reg.address, data, write_type=self.profile.write_type))

    def action(self, key: int | str) -> Action:
        """Start preset action ``key`` (number or name, e.g. ``"sit"``); returns the action."""
        act = self.profile.action(key)
        self.write("action", act.id)
        return act

    def __repr__(self) -> str:
        return f"<XgoClient {self.model} on {self.transport.url}>"

    # ------------------------------------------------------------------ helpers
    def _resolve_read(self, register: str | int) -> tuple[int, int, str]:
        if isinstance(register, str):
            reg: Register | None = self.profile.register(register)
            assert reg is not None
            if not reg.access.readable:
                raise ProfileError(f"{reg.name} is write-only on the {self.model}")
            return reg.address, reg.size, f"{reg.name} (0x{reg.address:02X})"
        reg = self.profile.register_at(register)
        if reg is None:
            return register, 1, f"0x{register:02X}"
        return register, reg.size, f"{reg.name} (0x{register:02X})"
