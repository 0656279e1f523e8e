"""Pre-flight: check every robot before anything moves.

For each performer: its port opens; then its robot family checks the robot (reads only,
:meth:`RobotFamily.preflight <xgo_show.families.RobotFamily.preflight>`): it answers, it is the
performer's model (an XGO robot's firmware string names it), its battery is above the show's
floor (the xArm, which reports volts, against the floor mapped onto its 6.0..8.4 V range). The
result is a table; a show starts only when every row passes (``force`` overrides the robot
checks with a warning, never a port that does not open). Low-latency mode is asked for on every
port (USB serial adapters otherwise hold bytes for up to 16 ms); the report also says what
real-time scheduling the writer threads get (:mod:`xgo_show.runtime.realtime`).
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TextIO

from xgo_show.compiler.schedule import PerformerSchedule, Schedule
from xgo_show.errors import PreflightError, XgoShowError
from xgo_show.families import get_family
from xgo_show.profiles import get_profile
from xgo_show.runtime.clock import Clock, MonotonicClock
from xgo_show.runtime.fanout import each
from xgo_show.transports.base import Transport

__all__ = [
    "PreflightError",
    "PreflightReport",
    "PreflightRow",
    "countdown",
    "open_ports",
    "preflight",
]

Opener = Callable[..., Transport]


@dataclass
class PreflightRow:
    """The checks of one performer."""

    performer: str
    model: str
    port: str
    opened: bool = False
    firmware: str = ""
    detected: str | None = None
    battery: float | None = None  # percent (XGO)
    voltage: float | None = None  # volts (xArm, which reports its supply in millivolts)
    low_latency: bool = False
    problems: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.opened and not self.problems


@dataclass
class PreflightReport:
    """Every performer's checks, plus what was granted for timing."""

    rows: list[PreflightRow]
    battery_floor: float
    realtime: str = "not requested"

    @property
    def ok(self) -> bool:
        return all(r.ok for r in self.rows)

    @property
    def ports_ok(self) -> bool:
        return all(r.opened for r in self.rows)

    def as_record(self) -> dict[str, object]:
        """The report as plain data (the run log's ``preflight`` event, a relay's reply)."""
        return {
            "ok": self.ok,
            "realtime": self.realtime,
            "rows": [
                {
                    "performer": r.performer,
                    "port": r.port,
                    "firmware": r.firmware,
                    "battery": r.battery,
                    "voltage": r.voltage,
                    "low_latency": r.low_latency,
                    "problems": r.problems,
                }
                for r in self.rows
            ],
        }

    def table(self) -> str:
        """A plain-text table of the results (one line per performer)."""
        head = ("performer", "model", "port", "firmware", "battery", "latency", "result")
        lines = [head]
        for r in self.rows:
            if r.voltage is not None:
                battery = f"{r.voltage:.2f} V"
            else:
                battery = "-" if r.battery is None else f"{r.battery:.0f}%"
            firmware = r.firmware or "-"
            if r.detected and r.detected != r.model:
                firmware += f" ({r.detected})"
            result = "ok" if r.ok else "FAIL: " + "; ".join(r.problems)
            if r.notes:
                result += " (" + "; ".join(r.notes) + ")"
            latency = "low" if r.low_latency else "default"
            lines.append((r.performer, r.model, r.port, firmware, battery, latency, result))
        widths = [max(len(row[i]) for row in lines) for i in range(len(head) - 1)]
        out = []
        for row in lines:
            cells = [c.ljust(w) for c, w in zip(row, widths, strict=False)]
            out.append("  ".join([*cells, row[-1]]).rstrip())
        floor = f"battery floor {self.battery_floor:g}%"
        families = dict.fromkeys(get_family(get_profile(r.model)) for r in self.rows)
        notes = [n for f in families if (n := f.battery_floor_note(self.battery_floor))]
        if notes:
            floor += f" ({'; '.join(notes)})"
        out.append(f"{floor}; real-time scheduling: {self.realtime}")
        out.append("(firmware: as reported, with the model it implies if another; battery: "
                   "charge, an xArm's supply in V;")
        out.append(" latency: the serial adapter's low-latency mode; result: ok, or every "
                   "check that failed)")
        return "\n".join(out)


def open_ports(
    schedule: Schedule, urls: Mapping[str, str], *, opener: Opener | None = None
) -> tuple[dict[str, Transport], dict[str, str]]:
    """Open every performer's port at its link's baud rate, the ports concurrently.

    Returns (open transports, errors by performer). Nothing is written. Should an opener raise
    anything but a located error (or Ctrl-C come), every port that did open is closed first.
    """
    if opener is None:
        from xgo_show.transports import open_transport

        opener = open_transport
    chosen = opener

    def open_one(perf: PerformerSchedule) -> tuple[str, Transport | str]:
        url = urls.get(perf.name)
        if url is None:
            return perf.name, "no port given (map it with --map NAME=PORT or in the show file)"
        try:
            transport = chosen(url, baudrate=perf.link.baud)
            transport.open()
        except XgoShowError as exc:
            return perf.name, str(exc)
        return perf.name, transport

    def close(outcome: tuple[str, Transport | str]) -> None:
        if not isinstance(outcome[1], str):
            outcome[1].close()

    outcomes = each(open_one, schedule.performers, undo=close, name="xgo-show open")
    transports = {n: o for n, o in outcomes if not isinstance(o, str)}
    errors = {n: o for n, o in outcomes if isinstance(o, str)}
    return transports, errors


def preflight(
    schedule: Schedule,
    transports: Mapping[str, Transport],
    *,
    urls: Mapping[str, str] | None = None,
    open_errors: Mapping[str, str] | None = None,
    battery_floor: float | None = None,
    timeout: float = 0.5,
    low_latency: bool = True,
) -> PreflightReport:
    """Check each robot on its open transport (reads only: nothing moves), the robots
    concurrently (each check mostly waits for its robot's answers)."""
    floor = schedule.battery_floor if battery_floor is None else battery_floor
    rows: list[PreflightRow] = []
    for perf in schedule.performers:
        port = (urls or {}).get(perf.name) or perf.port or "-"
        row = PreflightRow(perf.name, perf.model, port)
        rows.append(row)
        transport = transports.get(perf.name)
        if transport is None:
            row.problems.append((open_errors or {}).get(perf.name, "port not open"))
            continue
        row.opened = True

    def check(row: PreflightRow) -> None:
        transport = transports[row.performer]
        if low_latency:
            row.low_latency = transport.set_low_latency()
        _check_robot(row, transport, floor, timeout)

    each(check, [row for row in rows if row.opened], name="xgo-show pre-flight")
    return PreflightReport(rows, floor)


def _check_robot(row: PreflightRow, transport: Transport, floor: float, timeout: float) -> None:
    profile = get_profile(row.model)
    get_family(profile).preflight(row, transport, profile, floor, timeout)


def countdown(seconds: float, *, out: TextIO | None = None, clock: Clock | None = None) -> None:
    """Print a countdown of whole seconds, then return (0 = no countdown)."""
    if seconds <= 0:
        return
    clock = clock or MonotonicClock()
    stream = out or sys.stdout
    start = clock.now()
    left = seconds
    while left > 0:
        print(f"starting in {left:g} s", file=stream, flush=True)
        step = min(1.0, left)
        clock.sleep_until(start + (seconds - left) + step)
        left = round(left - step, 6)
