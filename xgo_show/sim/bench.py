"""A bench of simulated robots: one per performer, each on its own real pseudo-terminal.

:class:`SimBench` is what ``dry-run`` and ``run --sim`` play a show on: any serial client (ours
over pyserial, the vendor's) talks to the robots through real ttys. After the show,
:meth:`SimBench.summaries` says what each robot received and ended up doing, as typed
:class:`SimSummary` values (:func:`format_summaries` prints them; ``dataclasses.asdict`` makes
them plain data for a log).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from xgo_show.closing import Closing
from xgo_show.compiler.schedule import Schedule
from xgo_show.profiles import get_profile
from xgo_show.sim import create_robot
from xgo_show.sim.pty_server import PtyServer

__all__ = ["RejectedFrame", "SimBench", "SimSummary", "format_summaries", "summarize"]


@dataclass(frozen=True)
class RejectedFrame:
    """A frame the simulated robot refused, and why."""

    hex: str
    reason: str


@dataclass(frozen=True)
class SimSummary:
    """What one simulated robot received and did during a show."""

    model: str
    changed: dict[str, Any]  # writable registers (xArm: servo_N positions) that changed
    raw: dict[str, Any]  # the raw register bytes of those
    actions: list[Any]  # preset action ids run, in order
    # for people: "wave (action 13)", "... cut after 1.20 of 7.00 s by ..."
    action_names: list[str]
    frames_received: int
    frames_rejected: int
    rejected: list[RejectedFrame] = field(default_factory=list)
    battery: float | None = None  # percent (XGO) or millivolts (xArm)
    stops: int = 0
    fallen: bool | None = None


class SimBench(Closing):
    """One simulated robot per named performer, each served on its own real pseudo-terminal.

    ``robot_options`` go to every robot (:func:`~xgo_show.sim.create_robot`). A context
    manager: leaving it closes every server.
    """

    def __init__(self, schedule: Schedule, names: Sequence[str], **robot_options: Any) -> None:
        self.servers: dict[str, PtyServer] = {}
        self.initial: dict[str, dict[str, Any]] = {}
        models = {p.name: p.model for p in schedule.performers}
        try:
            for name in names:
                robot = create_robot(models[name], **robot_options)
                self.initial[name] = robot.snapshot()
                self.servers[name] = PtyServer(robot).start()
        except BaseException:
            self.close()
            raise

    @property
    def urls(self) -> dict[str, str]:
        """Each performer's pty path, to give to ``run --map`` or a :class:`Launch`."""
        return {name: s.path for name, s in self.servers.items()}

    def settle(self, timeout: float = 1.0) -> bool:
        """Wait until every robot has taken in every byte written to it so far."""
        return all(server.settle(timeout) for server in self.servers.values())

    def summaries(self) -> dict[str, SimSummary]:
        """What each robot ended up doing (call :meth:`settle` first after a show)."""
        out = {}
        for name, server in self.servers.items():
            snap = server.snapshot()
            with server.lock:
                rejected = [
                    RejectedFrame(f.data.hex(), f.reason)
                    for f in server.robot.received
                    if not f.accepted
                ]
            out[name] = summarize(snap, self.initial[name], rejected)
        return out

    def close(self) -> None:
        for server in self.servers.values():
            server.close()




def summarize(
    snap: dict[str, Any], initial: dict[str, Any], rejected: Sequence[RejectedFrame] = ()
) -> SimSummary:
    """Final writable registers that differ from the start, actions, frames, rejections."""
    profile = get_profile(snap["model"])
    writable = {r.name for r in profile.registers if r.access.writable and not r.unsafe}
    changed = {
        name: value
        for name, value in snap.get("registers", {}).items()
        if name in writable and initial.get("registers", {}).get(name) != value
    }
    # xArm: servo positions instead of registers.
    for servo, state in snap.get("servos", {}).items():
        before = initial.get("servos", {}).get(servo, {}).get("position")
        if state.get("position") != before:
            changed[f"servo_{servo}"] = state.get("position")
    return SimSummary(
        model=snap["model"],
        changed=changed,
        raw={name: snap.get("raw", {}).get(name) for name in changed},
        actions=[a.get("id") for a in snap.get("actions", [])],
        action_names=[_action_text(a) for a in snap.get("actions", [])],
        frames_received=int(snap.get("frames_received") or 0),
        frames_rejected=int(snap.get("frames_rejected") or 0),
        rejected=list(rejected),
        battery=snap.get("battery", snap.get("battery_mv")),
        stops=len(snap.get("stops", [])),
        fallen=snap.get("fallen"),
    )


def format_summaries(summaries: dict[str, SimSummary], *, fast: bool = False) -> str:
    """The dry-run's closing lines: what each simulated robot received and ended up doing."""
    lines = ["simulated robots at the end:"]
    for name, s in summaries.items():
        changed = ", ".join(f"{k}={_short(v)}" for k, v in s.changed.items()) or "none"
        actions = ", ".join(s.action_names) or "none"
        lines.append(
            f"  {name} ({s.model}): {s.frames_received} frames received, "
            f"{s.frames_rejected} rejected; actions run: {actions}"
        )
        lines.append(f"    registers changed: {changed}")
        for r in s.rejected:
            lines.append(f"    rejected {r.hex}: {r.reason}")
    if fast and any("cut after" in a for s in summaries.values() for a in s.action_names):
        lines.append("  (--fast sends frames without waiting, so the simulators see preset actions "
                     "cut short; run without --fast to see them run their course)")
    return "\n".join(lines)


def _action_text(action: dict[str, Any]) -> str:
    # "wave (action 13)": the number is the action's id, not a count of runs.
    text = f"{action.get('name') or 'action'} (action {action.get('id')})"
    cut, start = action.get("interrupted_at"), action.get("start")
    if cut is not None and start is not None:
        text += f" cut after {cut - start:.2f} of {action.get('duration', 0.0):.2f} s"
        if action.get("interrupted_by"):
            text += f" by {action['interrupted_by']}"
    return text


def _short(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)
