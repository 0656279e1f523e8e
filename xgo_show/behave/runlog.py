"""A behaviour's run log: the runtime's records plus one ``"rule"`` record per decision.

Each :class:`~xgo_show.behave.engine.BehaviourNote` becomes ``{"kind": "rule", "rule": NAME,
"what": fired|skipped|queued|refused|action|cut|published, "text": ..., "t": clock time}``,
flushed at once for firings (what led to a fault is on disk even if the process then dies).
"""

from __future__ import annotations

from xgo_show.behave.engine import BehaviourNote
from xgo_show.runtime.events import Event, EventBus, Subscription
from xgo_show.runtime.runlog import RunLog

__all__ = ["attach_behaviour_log"]


def attach_behaviour_log(log: RunLog, bus: EventBus) -> tuple[Subscription, Subscription]:
    """Write every event on ``bus`` to ``log`` from now on, rule decisions included."""

    def on_note(event: Event) -> None:
        if isinstance(event, BehaviourNote):
            log.write("rule", flush=event.kind == "fired", rule=event.rule, what=event.kind,
                      text=event.text, t=round(event.t, 6))

    return log.attach(bus), bus.subscribe(on_note, BehaviourNote)
