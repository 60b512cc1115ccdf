"""GObs (Algorithm 1) on hand-computed traces: healthy, too fast, stopped, jittery.

The hand traces use δ = 0.25 s, σ = 0.05 s, ω = 1 s (half window 0.5 s) and θ = 2: all
binary fractions, so that the window's edges are exact.
"""

from __future__ import annotations

import random

import pytest

from rac.logic import Atom
from rac.observe import Message, Verdict, build
from rac.observe.base import Observer
from rac.passes.observers import ObserverSpec

OK = Atom("ok", ("x",))


# The text's Algorithm 1: no window floor, no hold, no silence floor, receive times only.
TEXT = (("min_window_s", 0.0), ("min_count", 0), ("hold_s", 0.0), ("silence_s", 0.0))


def gobs(delta: float = 0.25, dev: float = 0.05, ws: float = 1.0, theta: int = 2) -> Observer:
    params = (("topic", "/x"), ("delta", delta), ("dev", dev), ("ws", ws), ("mismatch_th", theta))
    return build(ObserverSpec("GObs", "x_gobs", params + TEXT + (("stamps", 0),), (OK,)))


def run(obs: Observer, times: list[float]) -> list[Verdict]:
    out = []
    for t in times:
        out += obs.feed(Message(t, "/x", {}))
    return out


def trace(verdicts: list[Verdict]) -> list[tuple[float, str]]:
    return [(v.t, str(v)) for v in verdicts]


def test_healthy_topic_reads_ok_once() -> None:
    obs = gobs()
    # O_1 = 0 is O_mid; 0.25 and 0.5 fall in [−0.5, 0.5].  0.75 falls beyond: the check sees
    # W = {0, 0.25, 0.5}, μ = 0.5/2 = 0.25 = δ: count 0, ok at 0.75.  Then O_mid = 0.25 and
    # 0.75 fits [−0.25, 0.75]; every later occurrence makes one good check.
    out = run(obs, [0.25 * k for k in range(40)])
    assert trace(out) == [(0.75, "ok(x)")]
    assert obs.needs.topics == (("/x", ()),)


def test_four_times_the_rate_reads_not_ok() -> None:
    obs = gobs()
    # Interval 0.0625: every check has μ = 0.0625, |μ − δ| = 0.1875 > σ.  The first check
    # comes with the first occurrence beyond 0.5, i.e. 0.5625 (count 1 <= θ: ok); 0.625
    # gives count 2 (ok); 0.6875 gives count 3 > θ: not ok.
    out = run(obs, [0.0625 * k for k in range(64)])
    assert trace(out) == [(0.5625, "ok(x)"), (0.6875, "not_ok(x)")]


def test_stopped_topic_reads_not_ok_and_recovers_in_a_fresh_window() -> None:
    obs = gobs()
    out = run(obs, [0.25 * k for k in range(6)])  # 0 .. 1.25, ok at 0.75
    # After 1.25: O_mid = 0.75, so the window ends at E = 1.25.  Silent violations are
    # counted at E + (k + ½)δ: 1.625, 1.875, 2.125 -> counts 1, 2, 3 > θ.
    out += obs.advance(2.0)  # counts 1, 2: no change
    assert trace(out) == [(0.75, "ok(x)")]
    out += obs.advance(2.2)
    assert trace(out)[-1] == (2.125, "not_ok(x)")
    # Resuming at 3.0: the instants up to 3.0 (k = 4, 5, 6) first count on, to the bound 5.
    # The stale window is dropped; a new one starts at 3.0 and its first check comes at
    # 3.75 (good: count 4), then 4.0 (3) and 4.25 (2 <= θ): ok again.
    out += run(obs, [3.0 + 0.25 * k for k in range(8)])
    assert trace(out)[2:] == [(4.25, "ok(x)")]


def test_topic_that_never_published_has_no_verdict() -> None:
    assert gobs().advance(100.0) == []


def test_five_times_the_rate_at_model_parameters() -> None:
    # /pose of the tedusar model: 10 Hz, δ = 0.1, σ = 1/9 − 0.1, ω = 1.0, θ = 5.
    obs = gobs(0.1, 0.0111111111111, 1.0, 5)
    out = run(obs, [0.02 * k for k in range(500)])
    assert [str(v) for v in out] == ["ok(x)", "not_ok(x)"]
    # The first check comes after ω/2; the sixth violation five occurrences later.
    assert out[1].t == pytest.approx(0.52 + 5 * 0.02)


def test_stopped_ten_hertz_topic_reads_not_ok_within_theta_plus_one_intervals() -> None:
    obs = gobs(0.1, 0.0111111111111, 1.0, 5)
    out = run(obs, [0.1 * k for k in range(100)])  # the last occurrence at 9.9
    for k in range(1, 30):
        out += obs.advance(9.9 + 0.05 * k)
    assert [str(v) for v in out] == ["ok(x)", "not_ok(x)"]
    # E ≈ 9.9 (the last occurrence ends the window); the sixth violation at E + 6.5·δ.
    assert out[1].t == pytest.approx(9.9 + 0.65)


@pytest.mark.parametrize("jitter", ["uniform", "normal", "timestamps"])
def test_jittery_healthy_topic_never_flaps(jitter: str) -> None:
    rng = random.Random(7)
    obs = gobs(0.1, 0.0111111111111, 1.0, 5)
    out: list[Verdict] = []
    t = 0.0
    for k in range(6000):  # ten minutes at 10 Hz
        if jitter == "timestamps":
            stamp = 0.1 * k + rng.gauss(0.0, 0.01)  # each stamp off by σ = 10 % of δ
        else:
            stamp = t
            step = rng.uniform(0.09, 0.11) if jitter == "uniform" else rng.gauss(0.1, 0.01)
            t += max(step, 0.001)
        out += obs.feed(Message(stamp, "/x", {}))
        out += obs.advance(stamp + 0.05)
    assert [str(v) for v in out] == ["ok(x)"]


def test_slow_topic_reads_not_ok() -> None:
    # A fifth of the rate: one occurrence per 0.5 s cannot fill a 1 s window around O_mid
    # with intervals of 0.1 s; the silence between occurrences counts as well.
    obs = gobs(0.1, 0.0111111111111, 1.0, 5)
    out = run(obs, [0.5 * k for k in range(40)])
    assert [str(v) for v in out] == ["ok(x)", "not_ok(x)"]
