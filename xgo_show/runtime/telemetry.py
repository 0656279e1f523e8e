"""Telemetry polled in the link's spare capacity: battery, status, attitude.

The poller is pure bookkeeping (no I/O, no threads): the executor's writer asks it which read
request is due and sends it only where the next scheduled frame is far enough away; the
executor's reader feeds it whatever bytes arrive. What is read and how replies are parsed is the
robot family's (:meth:`RobotFamily.telemetry_items <xgo_show.families.RobotFamily.telemetry_items>`
and ``telemetry_values``): an XGO robot's registers through the one XGO codec, laid out with
:meth:`Profile.walk`; the xArm's battery voltage (``battery_v``, volts), whose request keeps
room for its reply (:attr:`TelemetryItem.reply_bytes`). Frames nobody asked for (a Rider's
auto-feedback, line noise) are counted and ignored.

Items named in ``watch`` are read on their own, faster cadence, each every ``watch[name]``
seconds, ahead of the rotation (a behaviour reacting to a fall reads the status register every
20 ms instead of once per 3-item cycle); the rest rotate, one every ``interval``.

Faults: what a reading shows by itself (:meth:`RobotFamily.telemetry_fault
<xgo_show.families.RobotFamily.telemetry_fault>`: a Rider reporting status 0x00, fallen), or a
battery below the floor (:meth:`~xgo_show.families.RobotFamily.battery_low`) on two readings in
a row (one low reading under a load spike is not a flat battery).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from xgo_show.families import get_family
from xgo_show.families.values import TelemetryItem
from xgo_show.profiles.model import Profile

__all__ = ["TelemetryItem", "TelemetryPoller", "TelemetrySample"]


@dataclass(frozen=True)
class TelemetrySample:
    """One value read back: register name, value, monotonic time it arrived."""

    name: str
    value: float
    t: float


class TelemetryPoller:
    """Decides which read request is due and turns replies into samples and faults."""

    def __init__(
        self,
        profile: Profile,
        *,
        interval: float = 0.25,
        battery_floor: float | None = None,
        low_readings: int = 2,
        detect_falls: bool = True,
        watch: Mapping[str, float] | None = None,
    ) -> None:
        self.profile = profile
        #: a fallen status is a fault (a show); False leaves it to a listener (a behaviour)
        self.detect_falls = detect_falls
        self.interval = interval
        self.battery_floor = battery_floor
        self.low_readings = low_readings
        self._family = get_family(profile)
        self.items = self._family.telemetry_items(profile)
        watch = watch or {}
        #: item name -> its own period (items this model has); the rest rotate
        self.watch = {i.name: watch[i.name] for i in self.items if i.name in watch}
        self._rotation = tuple(i for i in self.items if i.name not in self.watch)
        self._watched = tuple(i for i in self.items if i.name in self.watch)
        self._watch_due = {name: float("-inf") for name in self.watch}
        self._pending: TelemetryItem | None = None
        self.last: dict[str, float] = {}
        self.samples = 0
        self.unsolicited = 0
        self.fault: str | None = None
        self._next = 0
        self._due = float("-inf")
        self._low = 0
        self._decoder = self._family.decoder()
        self._by_address = {item.address: item for item in self.items}

    @property
    def enabled(self) -> bool:
        return bool(self.items)

    @property
    def next_due(self) -> float:
        """Monotonic time the next request is due (``-inf``: now)."""
        rotation = self._due if self._rotation else float("inf")
        return min([rotation, *self._watch_due.values()])

    def due(self, now: float) -> TelemetryItem | None:
        """The request to send now, if one is due (a watched item first)."""
        item: TelemetryItem | None = None
        if self._watched:
            first = min(self._watched, key=lambda i: self._watch_due[i.name])
            if self._watch_due[first.name] <= now:
                item = first
        if item is None and self._rotation and now >= self._due:
            item = self._rotation[self._next]
        self._pending = item
        return item

    def sent(self, now: float) -> None:
        """The request :meth:`due` returned went out at ``now``: schedule its next read."""
        item, self._pending = self._pending, None
        if item is not None and item.name in self.watch:
            self._watch_due[item.name] = now + self.watch[item.name]
        elif self._rotation:
            self._next = (self._next + 1) % len(self._rotation)
            self._due = now + self.interval

    def feed(self, chunk: bytes, now: float) -> list[TelemetrySample]:
        """Parse received bytes; return the samples they complete and update ``fault``."""
        out: list[TelemetrySample] = []
        values_of = self._family.telemetry_values
        for frame in self._decoder.feed(chunk):
            values = values_of(self._by_address, frame)
            if values is None:
                self.unsolicited += 1
                continue
            for name, value in values:
                self.last[name] = value
                out.append(TelemetrySample(name, value, now))
                self._check(name, value)
        self.samples += len(out)
        return out

    def _check(self, name: str, value: float) -> None:
        if self.fault is not None:
            return
        fault = self._family.telemetry_fault(self.profile, name, value)
        if fault is not None and self.detect_falls:
            self.fault = fault
            return
        if self.battery_floor is None:
            return
        low = self._family.battery_low(name, value, self.battery_floor)
        if low is None:
            return
        below, text = low
        self._low = self._low + 1 if below else 0
        if self._low >= self.low_readings:
            self.fault = text
