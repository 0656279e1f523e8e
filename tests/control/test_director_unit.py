"""The director's decisions (control/director.py), in this process, one event at a time: a fake
runner whose performers only record what they are told, and a clock the test sets. What a wait
asks of each performer and when, what a trigger, a timeout, a pause, a resume and a seek do,
and every refusal's words. test_director.py plays the same on simulators in real time."""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest

from xgo_show.choreo.sections import Section, Wait
from xgo_show.control.director import (
    ControlError,
    Director,
    TriggerOutcome,
    TriggerRefused,
    WaitReleased,
    WaitStarted,
)
from xgo_show.runtime.events import ShowEnded, ShowPaused, ShowResumed, StateChanged
from xgo_show.runtime.executor import ExecutorState

from .directing import PAUSED, RUNNING, SECTIONS, T0, RunningClock, Show, us


@pytest.fixture
def show() -> Iterator[Show]:
    s = Show()
    yield s
    s.close()


def hold_at_b(s: Show) -> None:
    """The show started at T0, rex runs, is asked to hold at b (1 s) and holds there."""
    s.start()
    s.state(RUNNING, T0, 0.0)
    assert s.p().calls == [("pause", T0 + 1.0)]
    s.state(PAUSED, T0 + 1.0, 1.0)


# --- queries ---------------------------------------------------------------------------------

def test_before_the_show_nothing_waits_and_commands_are_refused(show: Show) -> None:
    d = show.director
    assert d.phase == "idle" and d.virtual
    assert d.waiting_for is None and d.wait_ahead is None and d.hold_ahead() is None
    assert d.section_now(2.5) == SECTIONS[2] and d.section_now(-1) is None
    for command in (lambda: d.pause(), lambda: d.seek(1.0)):
        with pytest.raises(ControlError) as info:
            command()
        assert str(info.value).endswith(": no show is running")
    with pytest.raises(ControlError, match=r"^cannot pause: no show is running$"):
        d.pause()
    with pytest.raises(ControlError, match=r"^cannot seek: no show is running$"):
        d.seek(1.0)
    with pytest.raises(ControlError, match=r"^the show is not paused \(it is idle\)$"):
        d.resume()


def test_a_started_show_heads_for_its_first_wait(show: Show) -> None:
    show.start()
    d = show.director
    assert d.phase == "playing"
    assert d.wait_ahead == SECTIONS[1] and d.waiting_for is None
    assert d.hold_ahead() == T0 + 1.0


def test_a_show_started_mid_way_heads_for_the_next_wait(show: Show) -> None:
    show.start(offset=2.5)  # from 2.5 s of show: c's wait is behind, d's ahead
    assert show.director.wait_ahead == SECTIONS[3]
    assert show.director.hold_ahead() == pytest.approx(T0 + 0.5)
    show.state(RUNNING, T0, 2.5)
    assert show.p().calls == [("pause", us(T0 + 0.5))]


def test_a_show_started_at_a_wait_holds_there_at_once(show: Show) -> None:
    show.start(offset=1.0)
    assert show.director.wait_ahead == SECTIONS[1]
    show.state(RUNNING, T0, 1.0)
    assert show.p().calls == [("pause", T0)]


def test_a_show_without_waits_asks_nothing(show: Show) -> None:
    s = Show(sections=(Section("a", 0.0), Section("b", 2.0)))
    try:
        s.start()
        s.state(RUNNING, T0, 0.0)
        assert s.p().calls == [] and s.director.wait_ahead is None
        with pytest.raises(ControlError, match="the show waits for no trigger from here on"):
            s.director.trigger("go")
    finally:
        s.close()


# --- holding and triggers --------------------------------------------------------------------

def test_a_held_wait_is_released_by_its_trigger_for_every_performer() -> None:
    s = Show(names=("rex", "ivy"))
    try:
        s.start()
        s.state(RUNNING, T0, 0.0, "rex")
        s.state(RUNNING, T0, 0.0, "ivy")
        s.state(PAUSED, T0 + 1.0, 1.0, "rex")
        d = s.director
        assert d.phase == "waiting" and d.waiting_for == SECTIONS[1]
        assert d.hold_ahead() == T0 + 1.0
        s.state(PAUSED, T0 + 1.0, 1.0, "ivy")
        assert s.waits() == [("started", "b", "go", T0 + 1.0, 1.0, None)]  # once
        outcome = d.trigger("go")
        assert outcome == TriggerOutcome("go", "b", True)
        # Virtual time: at the instant the show held; both go on together.
        assert s.p("rex").calls[-1] == s.p("ivy").calls[-1] == ("resume", T0 + 1.0)
        assert s.waits()[-1] == ("released", "b", "go", "trigger", "b", T0 + 1.0)
        assert d.phase == "playing" and d.wait_ahead == SECTIONS[2]
        assert d.hold_ahead() == T0 + 2.0
    finally:
        s.close()


def test_a_trigger_fired_later_releases_the_show_later(show: Show) -> None:
    hold_at_b(show)
    show.director.trigger("go", at=T0 + 1.75)
    assert show.p().calls[-1] == ("resume", T0 + 1.75)
    assert show.waits()[-1] == ("released", "b", "go", "trigger", "b", T0 + 1.75)
    # The next wait comes as much later.
    assert show.director.hold_ahead() == T0 + 2.75
    show.state(RUNNING, T0 + 1.75, 1.0)
    assert show.p().calls[-1] == ("pause", T0 + 2.75)


def test_a_trigger_before_its_wait_is_kept_and_the_show_goes_through(show: Show) -> None:
    show.start()
    outcome = show.director.trigger("go", at=T0 + 0.5)
    assert outcome == TriggerOutcome("go", "b", False)
    assert show.waits() == [("released", "b", "go", "early", "b", T0 + 0.5)]
    show.state(RUNNING, T0, 0.0)
    # b's wait was released before rex gets there: it plays through to c.
    assert show.p().calls == [("pause", T0 + 2.0)]
    assert show.director.wait_ahead == SECTIONS[2]


def test_a_trigger_fired_before_the_hold_in_virtual_time_is_early(show: Show) -> None:
    show.start()
    show.state(RUNNING, T0, 0.0)
    show.state(PAUSED, T0 + 1.0, 1.0)
    # Fired at a time before the show held there: kept as early, the show goes on at the hold.
    outcome = show.director.trigger("go", at=T0 + 0.9)
    assert outcome.held is False
    assert show.waits()[-1] == ("released", "b", "go", "early", "b", T0 + 1.0)
    assert show.p().calls[-1] == ("resume", T0 + 1.0)


def test_refusals_say_what_the_show_waits_for(show: Show) -> None:
    d = show.director
    show.start()
    with pytest.raises(ControlError) as info:
        d.trigger("encore")
    assert str(info.value) == ("trigger 'encore' refused: the show will wait for 'go' "
                               "(section 'b')")
    with pytest.raises(ControlError) as info:
        d.trigger("nope")
    assert str(info.value) == ("trigger 'nope' refused: no section of this show waits for "
                               "'nope'; the show will wait for 'go' (section 'b')")
    show.state(RUNNING, T0, 0.0)
    show.state(PAUSED, T0 + 1.0, 1.0)
    with pytest.raises(ControlError, match=r"refused: the show waits for 'go' \(section 'b'\)$"):
        d.trigger("bow")
    d.trigger("go")
    with pytest.raises(ControlError) as info:
        d.trigger("go")
    assert str(info.value) == "trigger 'go' refused: 'go' was already given for section 'b'"
    assert [w for w in show.waits() if w[0] == "refused"] == [
        ("refused", "encore", "the show will wait for 'go' (section 'b')"),
        ("refused", "nope", "no section of this show waits for 'nope'; the show will wait "
         "for 'go' (section 'b')"),
        ("refused", "bow", "the show waits for 'go' (section 'b')"),
        ("refused", "go", "'go' was already given for section 'b'"),
    ]


def test_a_trigger_refused_at_a_time_is_stamped_with_it(show: Show) -> None:
    show.start()
    with pytest.raises(ControlError):
        show.director.trigger("encore", at=T0 + 0.25)
    refused = [e for e in show.seen if isinstance(e, TriggerRefused)]
    assert [e.t for e in refused] == [T0 + 0.25]
    with pytest.raises(ControlError):
        show.director.trigger("encore")  # no time given: now
    assert [e.t for e in show.seen if isinstance(e, TriggerRefused)][-1] == T0


def test_a_trigger_after_a_timeout_is_not_already_given(show: Show) -> None:
    hold_at_b(show)
    show.director.trigger("go")
    show.state(RUNNING, T0 + 1.0, 1.0)
    show.state(PAUSED, T0 + 2.0, 2.0)
    show.director.expire()  # c times out: 'encore' was never given
    with pytest.raises(ControlError) as info:
        show.director.trigger("encore")
    assert "already given" not in str(info.value)
    assert "the show will wait for 'go' (section 'e')" in str(info.value)


def test_no_trigger_when_the_show_is_over(show: Show) -> None:
    show.start()
    show.publish(ShowEnded(T0 + 5, True, "completed"))
    assert show.director.phase == "ended" and show.director.wait_ahead is None
    with pytest.raises(ControlError, match=r"^trigger 'go' refused: the show is over$"):
        show.director.trigger("go")
    with pytest.raises(ControlError, match=r"^cannot seek: the show is over$"):
        show.director.seek(1.0)
    with pytest.raises(ControlError, match=r"refused: no show is running$"):
        Show().director.trigger("go")


# --- timeouts --------------------------------------------------------------------------------

def to_c(s: Show) -> None:
    """Released at b at its hold; rex runs on and holds at c (2 s)."""
    hold_at_b(s)
    s.director.trigger("go")
    s.state(RUNNING, T0 + 1.0, 1.0)
    assert s.p().calls[-1] == ("pause", T0 + 2.0)
    s.state(PAUSED, T0 + 2.0, 2.0)
    assert s.director.waiting_for == SECTIONS[2]
    assert s.waits()[-1] == ("started", "c", "encore", T0 + 2.0, 2.0, 0.5)


def test_a_timeout_to_a_section_jumps_there_when_it_runs_out(show: Show) -> None:
    to_c(show)
    show.director.expire()
    assert show.p().calls[-2:] == [("seek", 4.0, T0 + 2.5), ("resume", T0 + 2.5)]
    assert show.waits()[-1] == ("released", "c", "encore", "timeout", "e", T0 + 2.5)
    # From e (4 s) at 102.5: e waits at once, for 'go' again.
    assert show.director.wait_ahead == SECTIONS[4]
    assert show.director.hold_ahead() == T0 + 2.5


def test_a_timeout_to_the_end_jumps_to_the_end(show: Show) -> None:
    show.start(offset=2.5)
    show.state(RUNNING, T0, 2.5)
    show.state(PAUSED, T0 + 0.5, 3.0)  # holds at d
    show.director.expire(at=T0 + 0.6)
    assert show.p().calls[-2:] == [("seek", 6.0, T0 + 0.6), ("resume", T0 + 0.6)]
    assert show.waits()[-1] == ("released", "d", "bow", "timeout", "end", T0 + 0.6)
    assert show.director.wait_ahead is None


def test_a_timeout_that_continues_plays_on(show: Show) -> None:
    show.start(offset=3.5)
    show.state(RUNNING, T0, 3.5)
    show.state(PAUSED, T0 + 0.5, 4.0)  # holds at e, which waits at most 1 s, then goes on
    show.director.expire()
    assert show.p().calls[-1] == ("resume", T0 + 1.5)
    assert show.waits()[-1] == ("released", "e", "go", "timeout", "e", T0 + 1.5)
    assert show.director.phase == "playing"


def test_expire_does_nothing_unless_the_show_holds(show: Show) -> None:
    show.director.expire()
    show.start()
    show.director.expire()
    assert show.waits() == [] and show.runner.calls == []


def test_a_wait_without_timeout_ends_the_show_when_expired(show: Show) -> None:
    hold_at_b(show)
    show.director.expire()
    assert show.runner.calls == [
        ("stop", "no trigger 'go' came for section 'b', which waits without a timeout")]
    assert show.director.phase == "waiting"


# --- the operator's commands -----------------------------------------------------------------

def test_no_operators_pause_while_a_wait_is_armed_or_held(show: Show) -> None:
    show.start()
    show.state(RUNNING, T0, 0.0)  # rex is asked to hold at b: a pause would come on top
    d = show.director
    d.pause()  # about to hold: nothing to do
    assert show.runner.calls == []
    show.state(PAUSED, T0 + 1.0, 1.0)
    d.pause()  # holding at a wait: nothing to pause
    assert show.runner.calls == []
    with pytest.raises(ControlError) as info:
        d.resume()
    assert str(info.value) == ("the show waits for trigger 'go' (section 'b'): fire it, or "
                               "seek")
    d.trigger("go")  # rex told to resume: its RUNNING is still to come
    with pytest.raises(ControlError, match="cannot pause yet"):
        d.pause()  # told to ask again, not dropped without a word
    assert show.runner.calls == []


def test_an_operators_pause_and_resume(show: Show) -> None:
    s = Show(sections=(Section("a", 0.0), Section("b", 5.0, Wait("go"))))
    try:
        s.start()
        s.state(RUNNING, T0, 0.0)  # 5 s from the wait: not armed
        assert s.p().calls == [("pause", T0 + 5.0)]  # virtual time: armed at once
    finally:
        s.close()
    r = Show(virtual=False, sections=(Section("a", 0.0), Section("b", 5.0, Wait("go"))))
    try:
        r.start()
        r.state(RUNNING, T0, 0.0)
        assert r.p().calls == []  # real time: armed only arm_margin before the wait
        r.director.pause(at=T0 + 1.0)
        assert r.runner.calls == [("pause", T0 + 1.0)]
        r.publish(ShowPaused(T0 + 1.0, 1.0))
        assert r.director.phase == "paused"
        r.director.pause()  # paused: the runner is asked again (it knows it is paused)
        r.director.resume(at=T0 + 2.0)
        assert r.runner.calls[-1] == ("resume", T0 + 2.0)
        r.publish(ShowResumed(T0 + 2.0, 1.0))
        assert r.director.phase == "playing"
        with pytest.raises(ControlError, match=r"not paused \(it is playing\)"):
            r.director.resume()
    finally:
        r.director.close()


def test_paused_and_resumed_only_change_a_playing_or_paused_show(show: Show) -> None:
    show.publish(ShowPaused(T0, 0.0))
    assert show.director.phase == "idle"
    show.publish(ShowResumed(T0, 0.0))
    assert show.director.phase == "idle"
    hold_at_b(show)
    show.publish(ShowPaused(T0 + 1.0, 1.0))
    show.publish(ShowResumed(T0 + 1.0, 1.0))
    assert show.director.phase == "waiting"


def test_a_seek_jumps_every_performer_and_starts_the_waits_again_from_there() -> None:
    s = Show(names=("rex", "ivy"))
    try:
        s.start()
        s.state(RUNNING, T0, 0.0, "rex")
        s.state(RUNNING, T0, 0.0, "ivy")
        s.state(PAUSED, T0 + 1.0, 1.0, "rex")
        s.state(PAUSED, T0 + 1.0, 1.0, "ivy")
        s.clock.advance(1.5)  # type: ignore[union-attr]
        s.director.seek(2.5)  # from the wait at b to 2.5 s: past c's wait, d's ahead
        for name in ("rex", "ivy"):
            assert s.p(name).calls[-2:] == [("seek", 2.5, T0 + 1.5), ("resume", T0 + 1.5)]
        assert s.waits()[-1] == ("released", "b", "go", "seek", "", T0 + 1.5)
        assert s.director.phase == "playing"
        assert s.director.wait_ahead == SECTIONS[3]
        assert s.director.hold_ahead() == T0 + 2.0
    finally:
        s.close()


def test_a_seek_outside_the_show_is_refused(show: Show) -> None:
    show.start()
    for t in (-0.5, 6.0, 7.0):
        with pytest.raises(ControlError) as info:
            show.director.seek(t)
        assert str(info.value) == f"seek to {t:g} s: outside the show (0 to 6 s)"
        assert info.value.code == "bad_request"  # a value out of range, as a start's
    show.director.seek(0.0)  # its first instant is inside
    show.director.seek(5.999)


def test_seek_section_goes_to_its_start_or_names_the_sections(show: Show) -> None:
    show.start()
    assert show.director.seek_section("d") == 3.0
    assert show.p().calls == [("seek", 3.0, T0)]  # playing: a seek alone, no resume
    with pytest.raises(ControlError) as info:
        show.director.seek_section("z")
    assert str(info.value) == "no section named 'z'; sections: a, b, c, d, e"
    s = Show(sections=())
    try:
        with pytest.raises(ControlError, match=r"^no section named 'a'; sections: none$"):
            s.director.seek_section("a")
    finally:
        s.close()


def test_a_seek_while_a_wait_is_armed_jumps_once_the_performer_holds(show: Show) -> None:
    show.start()
    show.state(RUNNING, T0, 0.0)  # asked to hold at b
    show.clock.advance(0.5)  # type: ignore[union-attr]
    show.director.seek(3.5)
    assert show.p().calls == [("pause", T0 + 1.0)]  # not a second command on top of it
    show.state(PAUSED, T0 + 1.0, 1.0)
    assert show.p().calls[1:] == [("seek", 3.5, T0 + 0.5), ("resume", T0 + 0.5)]
    assert show.waits() == []  # it never held there for the show
    assert show.director.wait_ahead == SECTIONS[4]


def test_a_seek_while_a_performer_is_moving_waits_until_it_runs(show: Show) -> None:
    hold_at_b(show)
    show.director.trigger("go")  # told to resume: its RUNNING is still to come
    assert show.p().calls[-1] == ("resume", T0 + 1.0)
    show.director.seek(0.5)
    assert show.p().calls[-1] == ("resume", T0 + 1.0)
    show.state(RUNNING, T0 + 1.0, 1.0)
    assert show.p().calls[-1] == ("seek", 0.5, T0)
    with pytest.raises(ControlError, match="cannot pause yet"):
        show.director.pause()  # the seek is on its way: no pause on top of it
    assert show.runner.calls == []
    show.state(RUNNING, T0 + 1.0, 0.5)
    assert show.p().calls[-1] == ("pause", T0 + 1.5)  # b's wait again, from 0.5 s


def test_a_paused_show_seeks_without_playing(show: Show) -> None:
    show.start()
    show.publish(ShowPaused(T0, 0.0))
    show.director.seek(2.5)
    assert show.p().calls == [("seek", 2.5, T0)]  # no resume: the operator resumes


def test_stop_goes_to_the_runner(show: Show) -> None:
    show.director.stop("operator")
    assert show.runner.calls == [("stop", "operator")]


def test_the_command_lead_delays_every_command() -> None:
    s = Show(lead=0.2)
    try:
        hold_at_b(s)
        s.director.trigger("go", at=T0 + 1.5)
        assert s.p().calls[-1] == ("resume", T0 + 1.7)
        assert s.director.hold_ahead() == pytest.approx(T0 + 2.7)
    finally:
        s.close()


def test_performers_that_are_done_are_left_alone(show: Show) -> None:
    s = Show(names=("rex", "ivy"))
    try:
        s.start()
        s.state(RUNNING, T0, 0.0, "rex")
        s.state(ExecutorState.FAILED, T0, 0.0, "ivy")
        s.state(RUNNING, T0, 0.0, "ivy")  # a stray report after it failed
        assert s.p("ivy").calls == []
        s.director.seek(2.5)
        assert s.p("ivy").calls == []
        s.publish(StateChanged(T0, "nobody", RUNNING, 0.0))  # not a performer of this show
    finally:
        s.close()


# --- real time: the director's own thread -----------------------------------------------------

def until(predicate: object, timeout: float = 5.0) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():  # type: ignore[operator]
        assert time.monotonic() < deadline, "not in time"
        time.sleep(0.002)


def test_real_time_arms_a_wait_its_margin_before_it() -> None:
    s = Show(virtual=False, arm_margin=0.25)
    try:
        s.start()
        s.state(RUNNING, T0, 0.0)
        assert s.p().calls == []
        assert s.director.virtual is False
        s.clock.t = T0 + 0.74  # type: ignore[union-attr]
        with s.director._cond:
            s.director._cond.notify_all()
        time.sleep(0.05)
        assert s.p().calls == []
        s.clock.t = T0 + 0.75  # type: ignore[union-attr]
        with s.director._cond:
            s.director._cond.notify_all()
        until(lambda: s.p().calls == [("pause", T0 + 1.0)])
    finally:
        s.close()


def test_real_time_takes_a_timeout_when_it_runs_out() -> None:
    s = Show(virtual=False, sections=(Section("a", 0.0), Section("b", 1.0, Wait("go", 0.5))))
    try:
        s.start()
        s.clock.t = T0 + 0.95  # type: ignore[union-attr]
        s.state(RUNNING, T0, 0.0)  # due within the margin: armed from the writer's event
        assert s.p().calls == [("pause", T0 + 1.0)]
        s.clock.t = T0 + 1.0  # type: ignore[union-attr]
        s.state(PAUSED, T0 + 1.0, 1.0)
        s.clock.t = T0 + 1.49  # type: ignore[union-attr]
        with s.director._cond:
            s.director._cond.notify_all()
        time.sleep(0.05)
        assert s.director.phase == "waiting"
        s.clock.t = T0 + 1.5  # type: ignore[union-attr]
        with s.director._cond:
            s.director._cond.notify_all()
        until(lambda: s.director.phase == "playing")
        assert s.p().calls[-1] == ("resume", T0 + 1.5)
        assert s.waits()[-1] == ("released", "b", "go", "timeout", "b", T0 + 1.5)
    finally:
        s.close()


def test_real_time_trigger_and_timeout_at_now_and_close_ends_the_thread() -> None:
    s = Show(virtual=False)
    s.start()
    s.clock.t = T0 + 0.95  # type: ignore[union-attr]
    s.state(RUNNING, T0, 0.0)
    s.clock.t = T0 + 1.0  # type: ignore[union-attr]
    s.state(PAUSED, T0 + 1.0, 1.0)
    s.clock.t = T0 + 1.3  # type: ignore[union-attr]
    assert s.director.trigger("go").held
    assert s.p().calls[-1] == ("resume", T0 + 1.3)  # now (plus no lead)
    thread = s.director._thread
    assert thread is not None and thread.is_alive()
    s.close()
    assert not thread.is_alive()


# --- the timeline each decision is taken on --------------------------------------------------

def test_the_hold_is_when_the_performer_held_not_when_it_was_due(show: Show) -> None:
    show.start()
    show.state(RUNNING, T0, 0.0)
    show.state(PAUSED, T0 + 1.2, 1.0)  # 0.2 s later than due (a busy writer)
    assert show.director.hold_ahead() == T0 + 1.2
    show.director.trigger("go", at=T0 + 1.1)  # fired before it held: kept, released then
    assert show.p().calls[-1] == ("resume", T0 + 1.2)
    # The next wait is as far after the hold as c is after b.
    assert show.director.hold_ahead() == pytest.approx(T0 + 2.2)


def test_a_trigger_given_early_twice_is_refused_the_second_time(show: Show) -> None:
    show.start()
    show.director.trigger("go")  # virtual time, before the hold, no time given: kept
    assert show.waits() == [("released", "b", "go", "early", "b", T0)]
    with pytest.raises(ControlError) as info:
        show.director.trigger("go")
    assert str(info.value) == "trigger 'go' refused: 'go' was already given for section 'b'"


def test_a_show_with_no_wait_left_refuses_triggers_saying_so(show: Show) -> None:
    show.start(offset=4.5)  # after e, the last wait
    with pytest.raises(ControlError) as info:
        show.director.trigger("go")
    assert str(info.value) == "trigger 'go' refused: the show waits for no trigger from here on"


def test_the_director_says_a_wait_started_before_it_is_released() -> None:
    # A listener that fires the trigger as the wait starts (a rehearsal): every listener
    # still sees the wait start first.
    s = Show()
    try:
        order: list[str] = []

        def fire(event: object) -> None:
            if isinstance(event, WaitStarted):
                s.director.trigger("go")

        s.runner.events.subscribe(fire, WaitStarted)
        s.runner.events.subscribe(lambda e: order.append(type(e).__name__), WaitStarted,
                                  WaitReleased)
        hold_at_b(s)
        assert order == ["WaitStarted", "WaitReleased"]
    finally:
        s.close()


def test_a_timeline_reported_a_little_late_is_kept_and_one_far_off_is_taken() -> None:
    s = Show(names=("rex", "ivy"))
    try:
        s.start(offset=0.5)  # b (1 s) is due at T0 + 0.5
        s.state(RUNNING, T0 + 0.33, 0.8, "rex")  # stamped 30 ms late (a relay's heartbeat)
        s.state(RUNNING, T0 + 0.5, 0.8, "ivy")  # really 0.2 s behind
        assert s.p("rex").calls == [("pause", T0 + 0.5)]
        assert s.p("ivy").calls == [("pause", T0 + 0.7)]
    finally:
        s.close()


def test_a_seek_at_a_time_to_come_is_sent_for_that_time(show: Show) -> None:
    show.start()
    show.director.seek(2.5, at=T0 + 0.4)
    assert show.p().calls == [("seek", 2.5, T0 + 0.4)]


def test_after_a_seek_the_next_command_waits_until_the_performer_runs(show: Show) -> None:
    show.start()
    show.director.seek(2.5)  # playing: a seek alone
    with pytest.raises(ControlError, match="cannot pause yet"):
        show.director.pause()  # one command at a time: not on top of the seek
    assert show.runner.calls == []
    show.state(RUNNING, T0, 2.5)  # it runs from 2.5 s: d's wait (3 s) is armed
    assert show.p().calls == [("seek", 2.5, T0), ("pause", T0 + 0.5)]


def test_a_seek_from_a_held_wait_plays_on_to_the_next_wait(show: Show) -> None:
    hold_at_b(show)
    show.director.seek(2.5)
    assert show.p().calls[-2:] == [("seek", 2.5, T0), ("resume", T0)]
    with pytest.raises(ControlError, match=r"^cannot pause yet: a release or a seek is still "
                       r"reaching the robots; pause again in a moment$") as moving:
        show.director.pause()  # moving: refused until it runs
    assert moving.value.code == "refused"
    assert show.runner.calls == []
    show.state(RUNNING, T0, 2.5)
    assert show.p().calls[-1] == ("pause", T0 + 0.5)  # held no more, armed again for d


def test_a_paused_show_takes_seek_after_seek_at_once() -> None:
    s = Show(virtual=False, sections=(Section("a", 0.0), Section("b", 5.0, Wait("go"))))
    try:
        s.start()
        s.state(RUNNING, T0, 0.0)
        s.publish(ShowPaused(T0, 0.0))
        s.director.seek(1.0)
        s.director.seek(2.0)  # paused: nothing is on its way, nothing to wait for
        assert s.p().calls == [("seek", 1.0, T0), ("seek", 2.0, T0)]
    finally:
        s.close()


def test_a_seek_applied_at_a_hold_goes_when_a_command_can_take_effect_then(show: Show
                                                                           ) -> None:
    show.start()
    show.state(RUNNING, T0, 0.0)  # asked to hold at b
    show.clock.advance(0.5)  # type: ignore[union-attr]
    show.director.seek(3.5)  # for T0 + 0.5, but rex holds only at T0 + 1.0
    show.clock.advance(0.5)  # type: ignore[union-attr]
    show.state(PAUSED, T0 + 1.0, 1.0)
    assert show.p().calls[1:] == [("seek", 3.5, T0 + 1.0), ("resume", T0 + 1.0)]


def test_a_performer_that_failed_first_does_not_keep_the_others_from_a_seek() -> None:
    s = Show(names=("rex", "ivy"))
    try:
        s.start()
        s.state(ExecutorState.FAILED, T0, 0.0, "rex")
        s.director.seek(2.5)
        assert s.p("rex").calls == [] and s.p("ivy").calls == [("seek", 2.5, T0)]
    finally:
        s.close()


def test_real_time_late_holders_and_the_command_lead() -> None:
    s = Show(virtual=False, names=("rex", "ivy"), lead=0.05)
    try:
        s.start()
        s.clock.t = T0 + 0.95  # type: ignore[union-attr]
        s.state(RUNNING, T0, 0.0, "rex")
        s.state(RUNNING, T0, 0.0, "ivy")
        s.clock.t = T0 + 1.0  # type: ignore[union-attr]
        s.state(PAUSED, T0 + 1.0, 1.0, "rex")
        s.clock.t = T0 + 1.3  # type: ignore[union-attr]
        assert s.director.trigger("go").held
        assert s.p("rex").calls[-1] == ("resume", T0 + 1.35)  # now plus the lead
        assert s.waits()[-1] == ("released", "b", "go", "trigger", "b", T0 + 1.3)
        s.clock.t = T0 + 1.5  # type: ignore[union-attr]
        s.state(PAUSED, T0 + 1.5, 1.0, "ivy")  # ivy holds after the release: goes at once
        assert s.p("ivy").calls[-1] == ("resume", T0 + 1.55)
    finally:
        s.close()


def test_real_time_expire_takes_the_timeout_now() -> None:
    s = Show(virtual=False, sections=(Section("a", 0.0), Section("b", 1.0, Wait("go", 5.0))))
    try:
        s.start()
        s.clock.t = T0 + 0.95  # type: ignore[union-attr]
        s.state(RUNNING, T0, 0.0)
        s.clock.t = T0 + 1.0  # type: ignore[union-attr]
        s.state(PAUSED, T0 + 1.0, 1.0)
        s.clock.t = T0 + 1.25  # type: ignore[union-attr]
        s.director.expire()
        assert s.p().calls[-1] == ("resume", T0 + 1.25)
        assert s.waits()[-1] == ("released", "b", "go", "timeout", "b", T0 + 1.25)
    finally:
        s.close()

def test_an_early_trigger_for_the_instant_the_show_gets_there_plays_through(show: Show
                                                                           ) -> None:
    show.start()
    show.director.trigger("go", at=T0 + 1.0)  # fired for the instant b starts
    show.state(RUNNING, T0, 0.0)
    assert show.p().calls == [("pause", T0 + 2.0)]  # no hold at b: on to c


def test_waits_released_early_one_after_another_are_all_played_through(show: Show) -> None:
    show.start()
    show.director.trigger("go", at=T0 + 0.1)
    show.director.trigger("encore", at=T0 + 0.2)
    show.state(RUNNING, T0, 0.0)
    assert show.p().calls == [("pause", T0 + 3.0)]  # b and c played through, d held


def test_the_last_wait_released_early_leaves_nothing_to_hold_at() -> None:
    s = Show(sections=(Section("a", 0.0), Section("b", 1.0, Wait("go"))))
    try:
        s.start()
        s.director.trigger("go", at=T0 + 0.5)
        s.state(RUNNING, T0, 0.0)
        assert s.p().calls == []
    finally:
        s.close()


def test_a_performer_still_running_while_another_holds_is_asked_to_hold_too() -> None:
    s = Show(names=("rex", "ivy"))
    try:
        s.start()
        s.state(RUNNING, T0, 0.0, "rex")
        s.state(PAUSED, T0 + 1.0, 1.0, "rex")
        assert s.director.phase == "waiting"
        s.state(RUNNING, T0 + 0.5, 0.4, "ivy")  # ivy says it runs only now, 0.1 s behind
        assert s.p("ivy").calls == [("pause", T0 + 1.1)]
    finally:
        s.close()


def test_the_same_instant_from_two_timelines_is_one_pause_time() -> None:
    s = Show(names=("rex", "ivy"))
    try:
        s.start()
        s.director.seek(0.1)  # both timelines start again from each one's RUNNING
        s.state(RUNNING, T0 + 0.01, 0.11, "rex")
        s.state(RUNNING, T0 + 0.02, 0.12, "ivy")  # the same timeline, other floats
        rex, ivy = s.p("rex").pauses[-1], s.p("ivy").pauses[-1]
        assert rex is not None and abs(rex - (T0 + 0.9)) < 1e-9
        assert rex != (T0 + 0.02) + (1.0 - 0.12)  # computed alone, ivy's would differ
        assert ivy == rex  # bit for bit: a relay sends one pause for both
    finally:
        s.close()


def test_an_armed_performer_the_show_ended_for_reports_its_hold_harmlessly(show: Show
                                                                         ) -> None:
    show.start()
    show.state(RUNNING, T0, 0.0)  # armed for b
    show.publish(ShowEnded(T0 + 0.5, False, "stopped"))
    show.state(PAUSED, T0 + 1.0, 1.0)  # its pause still took effect
    assert show.director.phase == "ended" and show.waits() == []


def test_real_time_a_writers_report_arms_the_wait_not_the_directors_thread() -> None:
    s = Show(virtual=False)
    try:
        s.start()
        s.clock.t = T0 + 0.95  # type: ignore[union-attr]
        with s.director._cond:  # the director's thread cannot run meanwhile
            s.state(RUNNING, T0, 0.0)  # reported late: b is due within the margin now
            assert s.p().calls == [("pause", T0 + 1.0)]
    finally:
        s.close()


def test_real_time_an_armed_performer_is_asked_once() -> None:
    s = Show(virtual=False)
    try:
        s.start()
        s.clock.t = T0 + 0.95  # type: ignore[union-attr]
        s.state(RUNNING, T0, 0.0)
        for _ in range(3):
            with s.director._cond:
                s.director._cond.notify_all()
            time.sleep(0.01)
        assert s.p().calls == [("pause", T0 + 1.0)]
    finally:
        s.close()


def test_real_time_an_operators_pause_leaves_the_directors_thread_running() -> None:
    s = Show(virtual=False, sections=(Section("a", 0.0), Section("b", 5.0, Wait("go"))))
    try:
        s.start()
        s.state(RUNNING, T0, 0.0)
        s.director.pause(at=T0 + 1.0)
        s.publish(ShowPaused(T0 + 1.0, 1.0))
        s.state(PAUSED, T0 + 1.0, 1.0)  # not a hold at a wait: the operator's
        with s.director._cond:
            s.director._cond.notify_all()
        time.sleep(0.05)
        thread = s.director._thread
        assert thread is not None and thread.is_alive()
        assert s.director.phase == "paused"
    finally:
        s.close()


def test_real_time_the_director_wakes_by_itself_to_arm_and_to_time_out() -> None:
    # A clock that runs: nothing pokes the director's thread, it wakes when something is due.
    s = Show(virtual=False, clock=RunningClock(), arm_margin=0.4,
             sections=(Section("a", 0.0), Section("b", 0.6, Wait("go", 0.3)),
                       Section("c", 1.2, Wait("encore"))))
    try:
        s.start()
        s.state(RUNNING, T0, 0.0)
        assert s.p().calls == []  # b is due in 0.6 s: armed 0.4 s before it
        deadline = time.monotonic() + 5
        while not s.p().calls:
            assert time.monotonic() < deadline, "never armed"
            time.sleep(0.002)
        assert T0 + 0.2 <= s.clock.now() < T0 + 0.6  # armed before b, not long before
        assert s.p().calls == [("pause", T0 + 0.6)]
        s.state(PAUSED, T0 + 0.6, 0.6)
        while s.director.phase == "waiting":
            assert time.monotonic() < deadline, "the timeout was never taken"
            time.sleep(0.002)
        released = s.clock.now()
        assert released >= T0 + 0.9  # after its 0.3 s
        s.state(RUNNING, released, 0.6)
        # The thread goes on after a timeout: c is armed in its turn, 0.4 s before it.
        while len(s.p().calls) < 3:
            assert time.monotonic() < deadline, "the next wait was never armed"
            time.sleep(0.002)
        assert s.p().calls[-1][0] == "pause"
    finally:
        s.close()


def test_a_release_before_a_seeking_performer_runs_sends_it_nothing_more(show: Show) -> None:
    hold_at_b(show)
    show.director.seek(2.5)  # from the hold: seek and resume, its RUNNING still to come
    calls = list(show.p().calls)
    show.director.trigger("bow", at=T0 + 0.1)  # d's wait released early meanwhile
    assert show.p().calls == calls  # one command at a time: nothing on top of the seek


def test_the_directors_thread_is_a_named_daemon() -> None:
    # Named for the thread-leak check; a daemon, so a director left open never keeps the
    # process alive at exit.
    s = Show(virtual=False)
    try:
        thread = s.director._thread
        assert thread is not None and (thread.name, thread.daemon) == ("xgo-show director", True)
    finally:
        s.close()


def test_by_default_a_wait_is_armed_a_tenth_of_a_second_before_it() -> None:
    s = Show(virtual=False)
    s.director.close()
    s.director = Director(s.runner, clock=s.clock)  # type: ignore[arg-type]
    try:
        assert s.director.arm_margin == 0.1
        s.start()
        s.clock.t = T0 + 0.89  # type: ignore[union-attr]
        s.state(RUNNING, T0, 0.0)
        assert s.p().calls == []
        s.clock.t = T0 + 0.9  # type: ignore[union-attr]
        s.state(RUNNING, T0, 0.0)
        assert s.p().calls == [("pause", T0 + 1.0)]
    finally:
        s.close()
