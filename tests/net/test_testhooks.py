"""Test-only hooks read from the environment: a skewed relay clock and delayed sync replies."""

from __future__ import annotations

import pytest

from xgo_show.net.testhooks import (
    CLOCK_ENV,
    DELAY_ENV,
    DelayInjector,
    SkewedClock,
    clock_from_env,
    delay_from_env,
)
from xgo_show.runtime.clock import FakeClock, MonotonicClock


def test_no_variable_means_the_plain_clock_and_no_delay() -> None:
    assert isinstance(clock_from_env({}), MonotonicClock)
    assert delay_from_env({}) is None


def test_the_clock_variable_makes_a_skewed_clock() -> None:
    base = FakeClock(100.0)
    clock = clock_from_env({CLOCK_ENV: "offset=12.5, ppm=-80"}, base)
    assert isinstance(clock, SkewedClock)
    assert (clock.offset, clock.ppm) == (12.5, -80.0)
    assert clock.now() == pytest.approx(112.5)


def test_the_delay_variable_draws_reproducible_delays_within_the_jitter() -> None:
    inj = delay_from_env({DELAY_ENV: "mean=0.005,jitter=0.002,seed=3"})
    assert inj is not None
    draws = [inj.draw() for _ in range(500)]
    assert all(0.003 <= d <= 0.007 for d in draws)
    assert max(draws) - min(draws) > 0.003
    again = DelayInjector(0.005, 0.002, 3)
    assert [again.draw() for _ in range(500)] == draws


@pytest.mark.parametrize(
    ("env", "message"),
    [
        ({CLOCK_ENV: "12.5"}, "expected offset=N, ppm=N"),
        ({CLOCK_ENV: "offset=soon"}, "offset is not a number"),
        ({CLOCK_ENV: "ppm=20000"}, "under 10,000 ppm"),
        ({DELAY_ENV: "mean=0.001,jitter=0.002"}, "0 <= jitter <= mean"),
    ],
)
def test_bad_values_are_one_line_errors(env: dict[str, str], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        if CLOCK_ENV in env:
            clock_from_env(env, FakeClock())
        else:
            delay_from_env(env)
