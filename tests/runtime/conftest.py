"""Shared helpers for runtime tests: hand-made schedules and simulators on real ptys."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest

from xgo_show.compiler.schedule import PerformerSchedule, Schedule, ScheduledFrame
from xgo_show.compiler.state import frame_labels
from xgo_show.diagnostics import Origin
from xgo_show.profiles import get_profile
from xgo_show.sim import PtyServer, create_robot
from xgo_show.transports import open_transport
from xgo_show.transports.base import Transport
from xgo_show.wire.xgo import write_frame

PerformerFactory = Callable[..., PerformerSchedule]


def make_performer(
    name: str,
    model: str = "mini",
    *,
    count: int = 10,
    spacing: float = 0.02,
    start: float = 0.0,
    register: str = "body_z",
    first_byte: int = 0x60,
    end: float | None = None,
) -> PerformerSchedule:
    """``count`` one-byte writes to ``register`` (distinct values), ``spacing`` s apart."""
    profile = get_profile(model)
    reg = profile.register(register)
    wtype = profile.write_type
    frames = tuple(
        ScheduledFrame(
            start + i * spacing,
            write_frame(reg.address, bytes(((first_byte + i) % 256,)), write_type=wtype),
            Origin("show.yaml", 1 + i, 1, f"cue{i // 4}"),
            labels=frame_labels(profile),
        )
        for i in range(count)
    )
    last = frames[-1].t if frames else 0.0
    return PerformerSchedule(
        name, model, profile.link, frames, end=end if end is not None else last + spacing
    )


def walking_performer(name: str, model: str = "mini", *, seconds: float = 1.5) -> PerformerSchedule:
    """Sets vx forward at once, then keeps changing body_z every 50 ms for ``seconds``."""
    profile = get_profile(model)
    vx = profile.register("vx")
    body_z = profile.register("body_z")
    forward = vx.encode_value(vx.maximum or 1.0)
    frames = [
        ScheduledFrame(
            0.0,
            write_frame(vx.address, forward, write_type=profile.write_type),
            Origin("show.yaml", 1, 1, "walk"),
            labels=frame_labels(profile),
        )
    ]
    n = int(seconds / 0.05)
    for i in range(1, n):
        frames.append(
            ScheduledFrame(
                i * 0.05,
                write_frame(body_z.address, bytes((0x70 + i % 16,)), write_type=profile.write_type),
                Origin("show.yaml", 2, 1, "sway"),
                labels=frame_labels(profile),
            )
        )
    return PerformerSchedule(name, model, profile.link, tuple(frames), end=seconds)


def make_schedule(*performers: PerformerSchedule, on_failure: str = "halt_all") -> Schedule:
    return Schedule("test", "show.yaml", tuple(performers), 20.0, on_failure=on_failure)


class Rig:
    """Simulators on real ptys and open pyserial transports to them, closed on exit."""

    def __init__(self) -> None:
        self.servers: dict[str, PtyServer] = {}
        self.transports: dict[str, Transport] = {}

    def add(self, name: str, model: str, **robot_options: object) -> PtyServer:
        server = PtyServer(create_robot(model, **robot_options)).start()
        self.servers[name] = server
        transport = open_transport(server.path, baudrate=get_profile(model).link.baud)
        transport.open()
        self.transports[name] = transport
        return server

    def for_schedule(self, schedule: Schedule) -> Rig:
        for perf in schedule.performers:
            self.add(perf.name, perf.model)
        return self

    def close(self) -> None:
        for t in self.transports.values():
            t.close()
        for s in self.servers.values():
            s.close()


@pytest.fixture
def rig() -> Iterator[Rig]:
    r = Rig()
    try:
        yield r
    finally:
        r.close()


# With --import-mode=importlib test modules cannot import this file: hand out the builders.
@pytest.fixture
def perf() -> PerformerFactory:
    return make_performer


@pytest.fixture
def walking() -> PerformerFactory:
    return walking_performer


@pytest.fixture
def sched() -> Callable[..., Schedule]:
    return make_schedule
