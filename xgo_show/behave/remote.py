"""Triggers for a running behaviour from any Zenoh client; its decisions as Zenoh events.

The keys and payloads are those of ``xgo-show serve`` (docs/zenoh-api.md,
:mod:`xgo_show.control.keys`, :func:`~xgo_show.control.protocol.parse_request`), so any client
of the show-control API, ``xgo-show trigger`` among them, fires a behaviour's triggers too:

- ``NS/trigger/NAME``, put (fire and forget) or get (answered): fires trigger ``NAME``. The
  answer is ``{"trigger": NAME, "accepted": true}`` when a rule of the behaviour waits for it
  (whether it then runs is the rule's: its conditions, its mode), else an error reply
  ``unknown_trigger`` listing the behaviour's triggers; a malformed payload is
  ``bad_request``. Each one is also published as a ``trigger`` event.
- ``NS/event/rule``: every decision of the engine, ``{"event": "rule", "rule": NAME, "what":
  fired|skipped|queued|refused|action|cut|published, "text": ...}`` (plus ``v`` and ``time``
  as every event of the API).

Zenoh calls the handlers on its own threads; :meth:`BehaviourRunner.trigger` only queues, and
events go out from the publisher's thread, so neither side waits for the other.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from xgo_show.behave.engine import BehaviourNote
from xgo_show.behave.ports import BehaviourRunner
from xgo_show.control.keys import trigger_key
from xgo_show.control.protocol import (
    TriggerRequest,
    error_payload,
    ok_payload,
    parse_request,
)
from xgo_show.control.publisher import EventPublisher
from xgo_show.errors import ControlError
from xgo_show.runtime.events import Event

if TYPE_CHECKING:
    import zenoh

__all__ = ["BehaviourService"]


class BehaviourService:
    """Serves ``runner``'s triggers on ``session`` under ``namespace`` (see the module doc)
    and publishes its decisions; :meth:`close` ends both."""

    def __init__(
        self, session: zenoh.Session, namespace: str, runner: BehaviourRunner,
        triggers: Sequence[str],
    ) -> None:
        import zenoh

        self._zenoh = zenoh
        self.session = session
        self.ns = namespace
        self.runner = runner
        self.triggers = tuple(triggers)
        self.received = 0
        self.publisher = EventPublisher(namespace, self._put, clock=runner.clock)
        self._notes = runner.events.subscribe(self._on_note, BehaviourNote)
        self._decls: list[Any] = [
            session.declare_queryable(trigger_key(namespace), self._on_query),
            session.declare_subscriber(trigger_key(namespace), self._on_put),
        ]

    def _fire(self, name: str, request: TriggerRequest) -> dict[str, Any]:
        self.received += 1
        source = {"source": request.source} if request.source is not None else {}
        if name not in self.triggers:
            known = ", ".join(self.triggers) or "none"
            self.publisher.publish("trigger", trigger=name, accepted=False, **source)
            raise ControlError(f"trigger {name!r} refused: no rule of the behaviour waits for "
                               f"it (its triggers: {known})", code="unknown_trigger")
        self.runner.trigger(name)
        self.publisher.publish("trigger", trigger=name, accepted=True, **source)
        return {"trigger": name, "accepted": True}

    def _on_put(self, sample: Any) -> None:
        name = str(sample.key_expr).rsplit("/", 1)[-1]
        try:
            request = parse_request("trigger", bytes(sample.payload.to_bytes()))
            self._fire(name, request)  # type: ignore[arg-type]
        except ControlError as exc:  # nobody to answer: said in a warning event
            self.publisher.publish("warning", message=str(exc))

    def _on_query(self, query: Any) -> None:
        name = str(query.key_expr).rsplit("/", 1)[-1]
        payload = query.payload
        try:
            request = parse_request("trigger", None if payload is None else
                                    bytes(payload.to_bytes()))
            fields = self._fire(name, request)  # type: ignore[arg-type]
        except ControlError as exc:
            query.reply_err(error_payload("trigger", exc.code, str(exc)))
        else:
            query.reply(query.key_expr, ok_payload("trigger", **fields))
        finally:
            query.drop()

    def _on_note(self, event: Event) -> None:
        if isinstance(event, BehaviourNote):
            self.publisher.publish("rule", rule=event.rule, what=event.kind, text=event.text)

    def _put(self, key: str, payload: dict[str, Any]) -> None:
        self.session.put(key, json.dumps(payload, separators=(",", ":")).encode(),
                         congestion_control=self._zenoh.CongestionControl.DROP)

    def close(self) -> None:
        """Stop taking triggers, send the events queued, stop publishing."""
        for decl in self._decls:
            decl.undeclare()
        self._notes.close()
        self.publisher.close()
