"""A trigger script played against the director (control/script.py's ScriptPlayer), in this
process, over a runner whose performers only record what they are told: which trigger fires
when, what each firing reports, and when a wait the script skips times out. Virtual time first
(each decision carries its time), then real time on a clock the test sets."""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest

from xgo_show.choreo.sections import Section, Wait
from xgo_show.control.script import Fired, ScriptCue, ScriptPlayer, TriggerScript
from xgo_show.runtime.events import ShowEnded

from .directing import PAUSED, RUNNING, T0, RunningClock, SetClock, Show


def cues(*items: tuple[str, str, float]) -> TriggerScript:
    return TriggerScript(triggers=[ScriptCue(trigger=name, **{kind: t})  # type: ignore[arg-type]
                                   for name, kind, t in items])


class Played:
    """A show, its director and a script player saying what it does into ``said``."""

    def __init__(self, script: TriggerScript, *, virtual: bool = True,
                 sections: tuple[Section, ...] | None = None) -> None:
        self.show = Show(virtual=virtual) if sections is None else Show(virtual=virtual,
                                                                       sections=sections)
        self.said: list[str] = []
        self.player = ScriptPlayer(script, self.show.director, say=self.said.append)

    def close(self) -> None:
        self.player.close()
        self.show.close()

    def fired(self) -> list[tuple[str, float, str]]:
        return [(f.trigger, round(f.t, 6), f.result) for f in self.player.fired]


@pytest.fixture
def play() -> Iterator[list[Played]]:
    made: list[Played] = []
    yield made
    for p in made:
        p.close()


def start(p: Played, offset: float = 0.0) -> None:
    s = p.show
    s.start(offset)
    s.state(RUNNING, T0, offset)


def hold(p: Played, t: float, show_time: float) -> None:
    p.show.state(PAUSED, T0 + t, show_time)


# --- virtual time ----------------------------------------------------------------------------

def test_an_after_entry_fires_that_long_after_the_show_holds(play: list[Played]) -> None:
    p = Played(cues(("go", "after", 0.5)))
    play.append(p)
    start(p)
    hold(p, 1.0, 1.0)
    assert p.fired() == [("go", 1.5, "released section 'b'")]
    assert p.said == ["trigger 'go' at 1.500 s: released section 'b'"]
    assert p.show.p().calls[-1] == ("resume", T0 + 1.5)
    assert p.player.fired[0] == Fired("go", pytest.approx(1.5), "released section 'b'")


def test_an_at_entry_due_before_its_wait_is_kept_for_it(play: list[Played]) -> None:
    p = Played(cues(("go", "at", 0.25)))
    play.append(p)
    start(p)  # fired as the show starts playing: 0.25 s is before b's hold at 1 s
    assert p.fired() == [("go", 0.25, "kept for section 'b'")]
    p.show.state(RUNNING, T0, 0.0)
    assert ("pause", T0 + 1.0) not in p.show.p().calls  # it plays through b


def test_an_at_entry_due_at_the_hold_releases_it(play: list[Played]) -> None:
    p = Played(cues(("go", "at", 1.0)))
    play.append(p)
    start(p)
    assert p.fired() == []  # not before the hold
    hold(p, 1.0, 1.0)
    assert p.fired() == [("go", 1.0, "released section 'b'")]


def test_an_at_entry_due_while_the_show_holds_releases_it_then(play: list[Played]) -> None:
    p = Played(cues(("go", "at", 1.25)))
    play.append(p)
    start(p)
    hold(p, 1.0, 1.0)
    assert p.fired() == [("go", 1.25, "released section 'b'")]
    assert p.show.p().calls[-1] == ("resume", T0 + 1.25)


def test_entries_fire_in_order_each_after_the_one_before(play: list[Played]) -> None:
    # go 0.5 s into b's hold; encore 0.25 s after that, although the show holds at c
    # (at 2 s of show, 2.5 s of clock) only after it: then at once (0.25 s after go is past).
    p = Played(cues(("go", "after", 0.5), ("encore", "after", 0.25)))
    play.append(p)
    start(p)
    hold(p, 1.0, 1.0)
    p.show.state(RUNNING, T0 + 1.5, 1.0)
    hold(p, 2.5, 2.0)
    assert p.fired() == [("go", 1.5, "released section 'b'"),
                         ("encore", 2.75, "released section 'c'")]


def test_a_second_entry_for_a_wait_already_holding_counts_from_the_one_before(
    play: list[Played],
) -> None:
    # 'bow' refused at b (nobody waits for it there), then 'go' 0.5 s after that refusal.
    p = Played(cues(("bow", "at", 1.25), ("go", "after", 0.5)))
    play.append(p)
    start(p)
    hold(p, 1.0, 1.0)
    assert p.fired() == [
        ("bow", 1.25, "trigger 'bow' refused: the show waits for 'go' (section 'b')"),
        ("go", 1.75, "released section 'b'"),
    ]


def test_a_wait_the_script_skips_times_out_and_the_entry_waits_for_its_own(
    play: list[Played],
) -> None:
    # c waits for 'encore' at most 0.5 s, then goes to e (4 s), which waits for 'go' at most
    # 1 s: the script's 'go' is for a hold of its own trigger, so c times out.
    p = Played(cues(("go", "after", 0.5), ("go", "after", 0.25)))
    play.append(p)
    start(p)
    hold(p, 1.0, 1.0)
    p.show.state(RUNNING, T0 + 1.5, 1.0)
    hold(p, 2.5, 2.0)
    assert p.show.p().calls[-2:] == [("seek", 4.0, T0 + 3.0), ("resume", T0 + 3.0)]
    assert len(p.fired()) == 1
    p.show.state(RUNNING, T0 + 3.0, 4.0)
    hold(p, 3.0, 4.0)
    assert p.fired()[1] == ("go", 3.25, "released section 'e'")


def test_an_entry_due_after_the_timeout_lets_the_wait_time_out_first(play: list[Played]
                                                                     ) -> None:
    p = Played(cues(("go", "after", 0.5), ("encore", "after", 0.75)))
    play.append(p)
    start(p)
    hold(p, 1.0, 1.0)
    p.show.state(RUNNING, T0 + 1.5, 1.0)
    hold(p, 2.5, 2.0)
    # encore would come 0.75 s into a wait of at most 0.5 s: the wait times out at 3.0.
    assert p.show.p().calls[-2:] == [("seek", 4.0, T0 + 3.0), ("resume", T0 + 3.0)]
    assert len(p.fired()) == 1
    assert p.player.cues == [ScriptCue(trigger="encore", after=0.75)]


def test_an_at_entry_due_exactly_at_the_timeout_fires_before_it(play: list[Played]) -> None:
    p = Played(cues(("go", "after", 0.5), ("encore", "at", 3.0)))
    play.append(p)
    start(p)
    hold(p, 1.0, 1.0)
    p.show.state(RUNNING, T0 + 1.5, 1.0)
    hold(p, 2.5, 2.0)  # c's timeout runs out at 3.0: the entry due then still releases it
    assert p.fired()[-1] == ("encore", 3.0, "released section 'c'")


def test_a_wait_without_timeout_and_no_entry_for_it_ends_the_show(play: list[Played]
                                                                   ) -> None:
    p = Played(cues(("encore", "after", 0.0)))
    play.append(p)
    start(p)
    hold(p, 1.0, 1.0)
    assert p.show.runner.calls == [
        ("stop", "no trigger 'go' came for section 'b', which waits without a timeout")]
    assert p.fired() == []


def test_at_entries_due_before_the_next_wait_fire_after_a_release(play: list[Played]
                                                                   ) -> None:
    # After b is released at 1.5, 'bow' (due 1.75, before c's hold at 2.5) is refused then,
    # as it would be in real time, and 'encore' (due 2.0) is kept for c.
    p = Played(cues(("go", "after", 0.5), ("bow", "at", 1.75), ("encore", "at", 2.0)))
    play.append(p)
    start(p)
    hold(p, 1.0, 1.0)
    assert p.fired() == [
        ("go", 1.5, "released section 'b'"),
        ("bow", 1.75, "trigger 'bow' refused: the show will wait for 'encore' (section 'c')"),
        ("encore", 2.0, "kept for section 'c'"),
    ]


def test_no_at_entry_fires_early_when_no_wait_is_ahead(play: list[Played]) -> None:
    p = Played(cues(("go", "at", 0.5)), sections=(Section("a", 0.0), Section("b", 5.0)))
    play.append(p)
    start(p)
    assert p.fired() == []


def test_a_show_started_mid_way_counts_entries_from_its_start(play: list[Played]) -> None:
    p = Played(cues(("encore", "after", 0.25)))
    play.append(p)
    start(p, offset=1.5)  # from 1.5 s of show: c at 2 s holds 0.5 s after the start
    hold(p, 0.5, 2.0)
    assert p.fired() == [("encore", 0.75, "released section 'c'")]
    assert p.said == ["trigger 'encore' at 0.750 s: released section 'c'"]


# --- real time -------------------------------------------------------------------------------

def set_time(p: Played, t: float) -> None:
    """Move the set clock to T0 + ``t`` and wake the player's thread to see it."""
    clock = p.show.clock
    assert isinstance(clock, SetClock)
    clock.t = T0 + t
    with p.player._cond:
        p.player._cond.notify_all()


def until(predicate: object, timeout: float = 5.0) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():  # type: ignore[operator]
        assert time.monotonic() < deadline, "not in time"
        time.sleep(0.002)


def test_real_time_fires_at_entries_on_the_clock(play: list[Played]) -> None:
    p = Played(cues(("go", "at", 0.5)), virtual=False)
    play.append(p)
    assert p.player._thread is not None
    time.sleep(0.02)
    assert p.fired() == []  # no show yet
    p.show.start()
    set_time(p, 0.49)
    time.sleep(0.05)
    assert p.fired() == []
    set_time(p, 0.5)
    until(lambda: p.fired() == [("go", 0.5, "kept for section 'b'")])


def test_real_time_fires_an_after_entry_after_the_hold(play: list[Played]) -> None:
    p = Played(cues(("bow", "after", 0.5), ("go", "after", 0.25)), virtual=False,
               sections=(Section("a", 0.0), Section("b", 1.0, Wait("go")),
                         Section("c", 2.0, Wait("bow"))))
    play.append(p)
    p.show.start()
    set_time(p, 0.95)
    p.show.state(RUNNING, T0, 0.0)
    set_time(p, 1.0)
    hold(p, 1.0, 1.0)  # a hold for go: the entry waits for one for bow, this one is dropped
    set_time(p, 1.6)
    time.sleep(0.05)
    assert p.fired() == []
    p.show.director.trigger("go")  # the operator, not the script
    p.show.state(RUNNING, T0 + 1.6, 1.0)
    set_time(p, 2.55)  # the director arms c's wait its margin before it
    with p.show.director._cond:
        p.show.director._cond.notify_all()
    until(lambda: p.show.p().calls[-1] == ("pause", T0 + 2.6))
    set_time(p, 2.6)
    hold(p, 2.6, 2.0)  # holds at c for bow
    set_time(p, 3.09)
    time.sleep(0.05)
    assert p.fired() == []
    set_time(p, 3.1)
    until(lambda: p.fired() == [("bow", 3.1, "released section 'c'")])
    assert p.player.cues == [ScriptCue(trigger="go", after=0.25)]


def test_real_time_stops_when_the_show_ends_or_the_player_closes(play: list[Played]) -> None:
    p = Played(cues(("go", "at", 5.0)), virtual=False)
    play.append(p)
    thread = p.player._thread
    assert thread is not None
    p.show.start()
    p.show.publish(ShowEnded(T0 + 1, True, "completed"))
    thread.join(2.0)
    assert not thread.is_alive()
    set_time(p, 6.0)
    assert p.fired() == []
    q = Played(cues(("go", "at", 5.0)), virtual=False)
    play.append(q)
    q.player.close()
    assert q.player._thread is not None and not q.player._thread.is_alive()


# --- more of the same, with a clock that runs and a show that starts later ------------------

def test_entries_count_from_the_shows_start_not_from_when_it_was_announced(
    play: list[Played],
) -> None:
    # The show is announced at T0 to start 0.5 s later (the lead): 'at' counts from its start.
    p = Played(cues(("go", "at", 0.25)))
    play.append(p)
    p.show.start(at=T0 + 0.5)
    assert p.fired() == [("go", 0.25, "kept for section 'b'")]
    assert p.player.fired[0].t == pytest.approx(0.25)
    assert p.show.waits()[-1][-1] == T0 + 0.75  # fired at 0.25 s of the show


def test_real_time_the_player_wakes_by_itself_when_an_entry_is_due(play: list[Played]) -> None:
    clock = RunningClock()
    show = Show(virtual=False, clock=clock)
    said: list[str] = []
    player = ScriptPlayer(cues(("go", "at", 0.2)), show.director, say=said.append)
    try:
        show.start()
        deadline = time.monotonic() + 5
        while not player.fired:
            assert time.monotonic() < deadline, "the entry never fired"
            time.sleep(0.002)
        assert player.fired[0].t >= 0.2
        assert player.fired[0].result == "kept for section 'b'"
    finally:
        player.close()
        show.close()


def test_real_time_entries_after_a_firing_count_from_it(play: list[Played]) -> None:
    sections = (Section("a", 0.0), Section("b", 1.0, Wait("go")),
                Section("c", 2.0, Wait("bow")), Section("d", 3.0, Wait("go")))
    p = Played(cues(("go", "after", 0.25), ("bow", "after", 0.25)), virtual=False,
               sections=sections)
    play.append(p)
    p.show.start()
    set_time(p, 0.95)
    p.show.state(RUNNING, T0, 0.0)  # armed for b
    set_time(p, 1.0)
    hold(p, 1.0, 1.0)
    set_time(p, 1.25)
    until(lambda: len(p.fired()) == 1)
    p.show.state(RUNNING, T0 + 1.25, 1.0)
    set_time(p, 2.2)
    with p.show.director._cond:
        p.show.director._cond.notify_all()
    until(lambda: p.show.p().calls[-1] == ("pause", T0 + 2.25))
    set_time(p, 2.25)
    hold(p, 2.25, 2.0)  # holds at c for bow: 0.25 s after that
    set_time(p, 2.5)
    until(lambda: len(p.fired()) == 2)
    assert p.fired() == [("go", 1.25, "released section 'b'"), ("bow", 2.5, "released section 'c'")]


def test_the_player_thread_is_a_named_daemon(play: list[Played]) -> None:
    p = Played(cues(("go", "at", 5.0)), virtual=False)
    play.append(p)
    thread = p.player._thread
    assert thread is not None and (thread.name, thread.daemon) == ("xgo-show triggers", True)
    assert Played(cues(("go", "at", 5.0))).player._thread is None  # virtual time: none
