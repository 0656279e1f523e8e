"""The test hooks' environment variables and injectors (net/testhooks.py), word for word: what
each variable may say, the defaults of what it leaves out, the environment read when none is
given, and every refusal."""

from __future__ import annotations

import os
import time

import pytest

from xgo_show.net.testhooks import (
    CLOCK_ENV,
    DELAY_ENV,
    TRACE_ENV,
    DelayInjector,
    SkewedClock,
    clock_from_env,
    delay_from_env,
    trace_from_env,
)
from xgo_show.runtime.clock import FakeClock, MonotonicClock


def test_the_variables_names() -> None:
    assert (CLOCK_ENV, DELAY_ENV, TRACE_ENV) == (
        "XGO_SHOW_TEST_CLOCK", "XGO_SHOW_TEST_SYNC_DELAY", "XGO_SHOW_TEST_TRACE")


def test_the_process_environment_is_read_when_none_is_given(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv(CLOCK_ENV, "offset=2")
    monkeypatch.setenv(DELAY_ENV, "mean=0.004")
    monkeypatch.setenv(TRACE_ENV, "1")
    clock = clock_from_env(base=FakeClock(10.0))
    assert isinstance(clock, SkewedClock) and clock.now() == 12.0
    assert isinstance(clock_from_env(), SkewedClock)
    delay = delay_from_env()
    assert delay is not None and delay.mean == 0.004
    assert trace_from_env() is True
    for name in (CLOCK_ENV, DELAY_ENV, TRACE_ENV):
        monkeypatch.delenv(name)
    assert isinstance(clock_from_env(), MonotonicClock)
    assert delay_from_env() is None and trace_from_env() is False
    assert os.environ.get(CLOCK_ENV) is None


def test_blank_variables_mean_nothing_asked() -> None:
    base = FakeClock(10.0)
    assert clock_from_env({CLOCK_ENV: "  "}, base) is base
    assert delay_from_env({DELAY_ENV: " "}) is None


@pytest.mark.parametrize(("text", "offset", "ppm"), [
    ("offset=3", 3.0, 0.0), ("ppm=50", 0.0, 50.0), (" ppm = 50 , offset = -1 ", -1.0, 50.0),
])
def test_the_clock_variable_leaves_out_what_is_zero(text: str, offset: float, ppm: float) -> None:
    clock = clock_from_env({CLOCK_ENV: text}, FakeClock(10.0))
    assert isinstance(clock, SkewedClock) and (clock.offset, clock.ppm) == (offset, ppm)


def test_the_delay_variable_leaves_out_what_is_zero_and_reads_the_seed_whole() -> None:
    inj = delay_from_env({DELAY_ENV: "mean=0.003"})
    assert inj is not None and (inj.mean, inj.jitter, inj.seed) == (0.003, 0.0, None)
    inj = delay_from_env({DELAY_ENV: "jitter=0, seed=7.0"})
    assert inj is not None and (inj.mean, inj.jitter, inj.seed) == (0.0, 0.0, 7)
    assert isinstance(inj.seed, int)


@pytest.mark.parametrize(("text", "on"), [
    ("1", True), ("yes", True), (" 1 ", True), ("", False), ("0", False), (" 0 ", False),
])
def test_the_trace_variable_is_on_unless_blank_or_0(text: str, on: bool) -> None:
    assert trace_from_env({TRACE_ENV: text}) is on
    assert trace_from_env({}) is False


@pytest.mark.parametrize(("env", "says"), [
    ({CLOCK_ENV: "12.5"}, "XGO_SHOW_TEST_CLOCK='12.5': expected offset=N, ppm=N"),
    ({CLOCK_ENV: "offset=1,drift=2"},
     "XGO_SHOW_TEST_CLOCK='offset=1,drift=2': expected offset=N, ppm=N"),
    ({CLOCK_ENV: "offset=soon"}, "XGO_SHOW_TEST_CLOCK='offset=soon': offset is not a number"),
    ({DELAY_ENV: "mean"}, "XGO_SHOW_TEST_SYNC_DELAY='mean': expected mean=N, jitter=N, seed=N"),
    ({DELAY_ENV: "seed=x"}, "XGO_SHOW_TEST_SYNC_DELAY='seed=x': seed is not a number"),
])
def test_a_variable_it_cannot_read_is_one_line_naming_it(env: dict[str, str], says: str) -> None:
    with pytest.raises(ValueError) as info:
        if CLOCK_ENV in env:
            clock_from_env(env, FakeClock())
        else:
            delay_from_env(env)
    assert str(info.value) == says


@pytest.mark.parametrize(("mean", "jitter"), [(-0.001, 0.0), (0.001, -0.0005), (0.001, 0.002)])
def test_an_injected_delay_needs_jitter_within_the_mean(mean: float, jitter: float) -> None:
    with pytest.raises(ValueError) as info:
        DelayInjector(mean, jitter)
    assert str(info.value) == "an injected delay needs 0 <= jitter <= mean"


def test_edges_of_an_injected_delay_are_allowed_and_draws_stay_within() -> None:
    assert DelayInjector(0.0).draw() == 0.0
    edge = DelayInjector(0.002, 0.002, seed=1)
    draws = [edge.draw() for _ in range(200)]
    assert all(0.0 <= d <= 0.004 for d in draws) and min(draws) < 0.001 < 0.003 < max(draws)


def test_waiting_an_injected_delay_sleeps_it_and_says_how_long() -> None:
    inj = DelayInjector(0.02)
    start = time.monotonic()
    assert inj.wait() == 0.02
    assert time.monotonic() - start >= 0.02


@pytest.mark.parametrize("ppm", [10_000.0, -10_000.0])
def test_a_skewed_clock_refuses_a_rate_error_of_1_percent(ppm: float) -> None:
    with pytest.raises(ValueError) as info:
        SkewedClock(FakeClock(), ppm=ppm)
    assert str(info.value) == "a test clock's rate error must be under 10,000 ppm"
    assert SkewedClock(FakeClock(), ppm=9_999.0).ppm == 9_999.0


def test_a_skewed_clock_defaults_to_none_and_sleeps_on_its_base() -> None:
    base = FakeClock(100.0)
    clock = SkewedClock(base)
    assert (clock.offset, clock.ppm, clock.now()) == (0.0, 0.0, 100.0)
    skewed = SkewedClock(base, offset=5.0, ppm=1000.0)  # 0.1 % fast
    assert skewed.sleep_until(115.01)  # 10.01 s of its own time from 105: 10 s of the base's
    assert base.waits == [pytest.approx(110.0, abs=1e-9)]
    import threading

    stop = threading.Event()
    stop.set()
    assert not skewed.sleep_until(200.0, stop)


def test_a_value_with_a_second_equals_sign_is_not_a_number() -> None:
    # The key is what comes before the first "=": "offset=1=2" names offset, with "1=2".
    with pytest.raises(ValueError) as info:
        clock_from_env({CLOCK_ENV: "offset=1=2"}, FakeClock())
    assert str(info.value) == "XGO_SHOW_TEST_CLOCK='offset=1=2': offset is not a number"
