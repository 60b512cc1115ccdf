"""GObs at its defaults on a live robot's timing: bursty arrivals, a starved receiver, header
stamps (also years old, also out of order), hysteresis, and starvation.

Every trace is a publisher at a regular cadence (its header stamps) and a receiver that gets
the messages later, perhaps in clumps (the receive times).  The observer is the compiler's:
δ = 1/rate, σ for ±10 %, ω = 10·δ, θ = 5; racc's own parameters at their defaults.
"""

from __future__ import annotations

import itertools
import math
import random

import pytest

from rac.logic import Atom
from rac.observe import Message, Verdict, build
from rac.observe.base import Hold
from rac.observe.gobs import DEFAULT_HOLD_S, DEFAULT_SILENCE_S, GObs
from rac.passes.observers import ObserverSpec

OK = Atom("ok", ("x",))
NOW = 1.78e9  # a stamp of today
Trace = list[tuple[float, float | None]]  # (receive time, stamp)


def gobs(rate: float, **extra: float) -> GObs:
    delta = 1.0 / rate
    params: tuple[tuple[str, str | int | float], ...] = (
        ("topic", "/x"),
        ("delta", delta),
        ("dev", 1.0 / (0.9 * rate) - delta),
        ("ws", 10 * delta),
        ("mismatch_th", 5),
        *extra.items(),
    )
    obs = build(ObserverSpec("GObs", "x_gobs", params, (OK,)))
    assert isinstance(obs, GObs)
    return obs


def run(obs: GObs, trace: Trace, until: float | None = None) -> list[Verdict]:
    """Feed the trace in receive order with an advance every 0.1 s, as the host does."""
    out: list[Verdict] = []
    tick = 0.1
    for t, stamp in trace:
        while tick <= t:
            out += obs.advance(tick)
            tick = round(tick + 0.1, 9)
        out += obs.feed(Message(t, "/x", {}, stamp))
    end = trace[-1][0] if until is None else until
    while tick <= end:
        out += obs.advance(tick)
        tick = round(tick + 0.1, 9)
    return out


def texts(verdicts: list[Verdict]) -> list[str]:
    return [str(v) for v in verdicts]


def regular(rate: float, start: float, end: float, stamp0: float = NOW) -> Trace:
    """A healthy publisher received at once (receive time = stamp − stamp0)."""
    n = round((end - start) * rate)
    return [(start + k / rate, stamp0 + start + k / rate) for k in range(n)]


def clumped(trace: Trace, max_gap: float, seed: int, start: float = 0.0) -> Trace:
    """The same messages, received in clumps: the receiver wakes after gaps drawn from
    [0, max_gap] and takes every message published by then."""
    rng = random.Random(seed)
    out: Trace = []
    wake, i = start, 0
    while i < len(trace):
        wake += rng.uniform(0.0, max_gap)
        while i < len(trace) and trace[i][0] <= wake:
            out.append((wake, trace[i][1]))
            i += 1
    return [m for m in trace if m[0] < start] + out


def lagged(trace: Trace, amplitude: float, period: float, start: float) -> Trace:
    """The same messages from ``start`` on, received late by a lag that swings between 0
    and ``amplitude`` every ``period`` seconds (a receiver that falls behind under load
    and catches up): no gap is long, but receive times run slow, then fast."""
    out: Trace = []
    for t, stamp in trace:
        phase = 2 * math.pi * max(t - start, 0.0) / period
        out.append((t + amplitude * (1 - math.cos(phase)) / 2, stamp))
    return out


def without_stamps(trace: Trace) -> Trace:
    return [(t, None) for t, _ in trace]


def first_not_ok(verdicts: list[Verdict]) -> float:
    return next(v.t for v in verdicts if not v.positive)


# -- bursty arrivals --------------------------------------------------------------------


@pytest.mark.parametrize("rate", [100.0, 60.0, 30.0])
def test_bursty_topic_with_gaps_up_to_027_s_and_a_healthy_mean_reads_ok(rate: float) -> None:
    # No stamps at all (a /tf): receive times only.  The receiver takes the messages in
    # clumps after gaps of up to 0.27 s, ten minutes long.
    trace = without_stamps(clumped(regular(rate, 0.0, 600.0), 0.27, seed=int(rate)))
    assert max(b[0] - a[0] for a, b in itertools.pairwise(trace)) > 0.25
    assert texts(run(gobs(rate), trace)) == ["ok(x)"]


def test_the_texts_observer_reads_the_same_bursts_not_ok() -> None:
    # The same trace through Algorithm 1 as printed (a 0.1 s window, no hold, silence after
    # 1.5 intervals): the reason for the defaults above.
    trace = without_stamps(clumped(regular(100.0, 0.0, 60.0), 0.27, seed=100))
    text = {"min_window_s": 0.0, "min_count": 0, "hold_s": 0.0, "silence_s": 0.0}
    assert "not_ok(x)" in texts(run(gobs(100.0, **text), trace))


def test_stamps_time_a_topic_that_a_starved_receiver_gets_late() -> None:
    # Ten healthy seconds, then for a minute the receiver falls behind by up to 0.45 s and
    # catches up again, every 4 s: on receive times that reads not ok; the regular header
    # stamps keep it ok.
    trace = lagged(regular(100.0, 0.0, 70.0), 0.45, 4.0, start=10.0)
    obs = gobs(100.0)
    assert texts(run(obs, trace)) == ["ok(x)"]
    assert obs.stamped
    assert "not_ok(x)" in texts(run(gobs(100.0), without_stamps(trace)))


# -- real faults still show -------------------------------------------------------------


@pytest.mark.parametrize("stamps", [True, False])
def test_a_real_rate_drop_reads_not_ok_within_one_and_a_half_seconds(stamps: bool) -> None:
    # At 30 s the publisher halves its rate; stamps and arrivals agree.
    trace = regular(100.0, 0.0, 30.0) + regular(50.0, 30.0, 60.0)
    trace = trace if stamps else without_stamps(trace)
    out = run(gobs(100.0), trace)
    assert texts(out) == ["ok(x)", "not_ok(x)"]
    assert 30.0 < first_not_ok(out) <= 31.5  # 1.02 s (docs/observers.md)


def test_a_stopped_topic_reads_not_ok_on_receive_time_despite_stamps() -> None:
    obs = gobs(100.0)
    out = run(obs, regular(100.0, 0.0, 30.0), until=40.0)
    assert obs.stamped
    assert texts(out) == ["ok(x)", "not_ok(x)"]
    # The last message at 29.99: silence counts from E (about one interval later) after
    # silence_s, θ + 1 violations one interval apart, then the hold.
    bound = 29.99 + 0.01 + DEFAULT_SILENCE_S + 6 * 0.01 + DEFAULT_HOLD_S
    assert first_not_ok(out) == pytest.approx(bound, abs=0.02)


def test_a_topic_that_comes_back_reads_ok_again() -> None:
    trace = regular(100.0, 0.0, 30.0) + regular(100.0, 35.0, 60.0)
    assert texts(run(gobs(100.0), trace)) == ["ok(x)", "not_ok(x)", "ok(x)"]


# -- stamps -----------------------------------------------------------------------------


def test_stamps_years_old_time_the_topic() -> None:
    # rosbag play keeps the recording's stamps: 2011 here, received today on the host's
    # clock, which starts at zero.  Only differences count.
    trace = lagged(regular(50.0, 0.0, 60.0, stamp0=1.3e9), 0.45, 4.0, start=10.0)
    obs = gobs(50.0)
    assert texts(run(obs, trace)) == ["ok(x)"]
    assert obs.stamped


def test_stamps_that_go_back_are_not_trusted() -> None:
    # Two publishers on one topic (or a bag that loops): stamps out of order.  The topic is
    # timed by receive time, and a starved receiver's clumps show.
    trace = regular(100.0, 0.0, 70.0)
    trace = [(t, s - (0.5 if k % 2 else 0.0)) for k, (t, s) in enumerate(trace) if s is not None]
    obs = gobs(100.0)
    assert texts(run(obs, trace)) == ["ok(x)"]
    assert not obs.stamped
    assert "not_ok(x)" in texts(run(gobs(100.0), lagged(trace, 0.45, 4.0, start=10.0)))


def test_a_stamp_of_zero_or_none_ends_trust_at_once() -> None:
    obs = gobs(100.0)
    run(obs, regular(100.0, 0.0, 20.0))
    assert obs.stamped
    obs.feed(Message(20.0, "/x", {}, None))
    assert not obs.stamped


def test_stamps_of_a_clock_at_another_rate_are_not_trusted() -> None:
    # A bag played at 0.8 times its speed: the stamps say 100 Hz, the wire carries 80 Hz.
    trace: list[tuple[float, float | None]] = [(k / 80.0, NOW + k / 100.0) for k in range(80 * 60)]
    obs = gobs(100.0)
    assert texts(run(obs, trace)) == ["ok(x)", "not_ok(x)"]  # the θ rule's first is ok
    assert not obs.stamped


def test_stamps_can_be_switched_off() -> None:
    trace = lagged(regular(100.0, 0.0, 70.0), 0.45, 4.0, start=10.0)
    obs = gobs(100.0, stamps=0)
    assert "not_ok(x)" in texts(run(obs, trace))
    assert not obs.stamped


# -- hysteresis -------------------------------------------------------------------------


def edge_trace() -> Trace:
    """100 Hz that alternates every 0.3 s between 5 % and 15 % slow: the mean of a 0.1 s
    window wanders across the slow edge of the ±10 % band and back."""
    out: Trace = []
    t = 0.0
    while t < 60.0:
        slow = 1.15 if int(t / 0.3) % 2 else 1.05
        t += 0.01 * slow
        out.append((t, None))
    return out


def test_hysteresis_keeps_a_topic_at_the_band_edge_from_flapping() -> None:
    # The window of the text (ω = 0.1 s), so that its mean follows the alternation.
    flapping = run(gobs(100.0, min_window_s=0.0, hold_s=0.0), edge_trace())
    assert len(flapping) > 20  # the θ rule alone: one check per message, 50 ms at 100 Hz
    held = run(gobs(100.0, min_window_s=0.0), edge_trace())
    assert len(held) <= 2


def test_hold_reports_a_change_only_after_it_stood() -> None:
    hold = Hold(OK, 0.5)
    out: list[Verdict] = []
    hold.update(0.0, True, out)  # the first verdict at once
    hold.update(1.0, False, out)
    hold.update(1.4, True, out)  # back before 1.5: nothing
    hold.update(2.0, False, out)
    hold.update(2.3, False, out)
    hold.update(2.6, False, out)  # stood since 2.0: reported at 2.5
    assert [(v.t, str(v)) for v in out] == [(0.0, "ok(x)"), (2.5, "not_ok(x)")]


# -- starvation -------------------------------------------------------------------------


def test_starvation_holds_silence_and_times_it_from_the_end() -> None:
    obs = gobs(100.0)
    out = run(obs, regular(100.0, 0.0, 30.0))
    assert obs.starved(30.0, True) == []
    out += obs.advance(33.0)  # silent for 3 s, but starved: no violation
    assert texts(out) == ["ok(x)"]
    out += obs.starved(33.0, False)
    out += obs.advance(33.5)
    assert texts(out) == ["ok(x)"]
    out += obs.advance(35.0)
    assert texts(out) == ["ok(x)", "not_ok(x)"]
    assert out[-1].t == pytest.approx(33.0 + DEFAULT_SILENCE_S + 5 * 0.01 + DEFAULT_HOLD_S)


def test_starvation_holds_rate_violations_until_late_arrivals_have_left_the_window() -> None:
    # No stamps: while starved, a clump looks like a burst and the gap before it like a
    # slow rate.  Nothing of it counts, nor in the window after.
    trace = regular(100.0, 0.0, 20.0) + [(21.0, None)] * 100 + regular(100.0, 21.01, 40.0)
    trace = without_stamps(trace)
    obs = gobs(100.0)
    out = run(obs, [m for m in trace if m[0] < 20.0])
    out += obs.starved(20.05, True)
    out += run(obs, [m for m in trace if 20.0 <= m[0] <= 21.0])
    out += obs.starved(21.0, False)
    out += run(obs, [m for m in trace if m[0] > 21.0])
    assert texts(out) == ["ok(x)"]
    # Unheld, the same trace reads not ok.
    assert "not_ok(x)" in texts(run(gobs(100.0), trace))


def test_starvation_does_not_stop_a_recovery() -> None:
    obs = gobs(100.0)
    out = run(obs, regular(100.0, 0.0, 10.0), until=12.0)
    assert texts(out) == ["ok(x)", "not_ok(x)"]
    obs.starved(12.0, True)
    out += run(obs, regular(100.0, 12.0, 20.0))
    assert texts(out) == ["ok(x)", "not_ok(x)", "ok(x)"]


def paused(trace: Trace, at: float, pause: float) -> Trace:
    """The same messages; those published in [at, at + pause) are received at at + pause."""
    return [(max(t, at + pause) if at <= t < at + pause else t, s) for t, s in trace]


def test_a_delivery_that_pauses_for_less_than_silence_and_hold_is_not_a_stop() -> None:
    # 0.9 s without a message, then the ones that waited: the silence's violations are
    # taken back when the messages come before its not_ok was due (0.5 + 0.06 + 0.5 s).
    trace = paused(regular(100.0, 0.0, 40.0), 20.0, 0.9)
    obs = gobs(100.0)
    assert texts(run(obs, trace)) == ["ok(x)"]
    # Longer than that, it is a stop (and the topic comes back).
    assert texts(run(gobs(100.0), paused(regular(100.0, 0.0, 40.0), 20.0, 1.5))) == [
        "ok(x)",
        "not_ok(x)",
        "ok(x)",
    ]


def test_a_bag_that_loops_keeps_its_stamps_trusted() -> None:
    # rosbag play --loop of a 16 s recording: the stamps jump back by 16 s at every seam,
    # where the player pauses for 0.9 s and then catches up.
    trace: Trace = []
    for loop in range(4):
        part = regular(100.0, 16.0 * loop, 16.0 * (loop + 1), stamp0=1.3e9 - 16.0 * loop)
        trace += paused(part, 16.0 * loop, 0.9 if loop else 0.0)
    obs = gobs(100.0)
    assert texts(run(obs, trace)) == ["ok(x)"]
    assert obs.stamped


class _NeverResting(GObs):
    """GObs without its rest: every advance() does the whole count, as before it had one."""

    def _at_rest(self) -> bool:
        return False


@pytest.mark.parametrize("seed", range(6))
def test_a_frequency_observer_at_rest_says_what_one_counting_every_step_says(seed: int) -> None:
    """Counted to the end of a silence, the observer rests until its next message or a
    change of starvation (replay of a recording stretched to days by a damaged stamp).
    On bursts, stops of seconds to minutes, starvation and returns, every verdict and its
    time is that of an observer that counts at every step."""
    rng = random.Random(seed)
    resting, counting = gobs(10.0), gobs(10.0)
    counting.__class__ = _NeverResting
    trace: Trace = []
    t = 0.0
    for _ in range(8):
        burst = clumped(regular(10.0, t, t + rng.uniform(2.0, 15.0)), 0.2, rng.randrange(99), t)
        trace += burst
        t = burst[-1][0] + rng.choice([0.3, 1.0, 4.0, 30.0, 200.0])
    starving = {round(rng.uniform(0, t), 1): rng.random() < 0.5 for _ in range(10)}
    verdicts: dict[str, list[str]] = {}
    for name, obs in (("resting", resting), ("counting", counting)):
        out: list[Verdict] = []
        tick, events = 0.1, iter(trace)
        pending = next(events, None)
        while tick <= t + 5.0:
            if tick in starving:
                out += obs.starved(tick, starving[tick])
            while pending is not None and pending[0] <= tick:
                out += obs.feed(Message(pending[0], "/x", {}, pending[1]))
                pending = next(events, None)
            out += obs.advance(tick)
            tick = round(tick + 0.1, 9)
        verdicts[name] = [f"{v.t:.3f} {v}" for v in out]
    assert verdicts["resting"] == verdicts["counting"]
    assert any("not_ok" in v for v in verdicts["resting"])  # the stops were noticed
    assert any(" ok" in v for v in verdicts["resting"][1:])  # and the returns


def _lossy(seqs: bool, keep: float, seconds: float = 30.0) -> list[str]:
    """A 100 Hz publisher with stamps and sequence numbers, received in clumps of 20 every
    0.2 s, of which each clump loses its last (1 - keep) share (a relay's queue)."""
    from rac.observe import Message, build
    from rac.passes.observers import ObserverSpec

    spec = ObserverSpec(
        "GObs",
        "x_gobs",
        (("topic", "/x"), ("delta", 0.01), ("dev", 1 / 90 - 0.01), ("mismatch_th", 5)),
        (Atom("ok", ("x",)),),
    )
    obs = build(spec)
    out = []
    for clump in range(int(seconds / 0.2)):
        t = clump * 0.2 + 0.2
        for k in range(int(20 * keep)):
            n = clump * 20 + k
            message = Message(t, "/x", {}, 1000.0 + n * 0.01, n if seqs else None)
            out += [str(v) for v in obs.feed(message)]
        out += [str(v) for v in obs.advance(t)]
    return out


def test_messages_lost_on_the_way_are_no_slower_publisher_where_it_counts_them() -> None:
    """ROS 1's header.seq counts every message its publisher sent: a relay chain under
    load that loses a tenth of them in bursts reads 90 Hz by arrivals, the publisher's
    100 Hz by its sequence numbers.  Losing more than half is a fault either way."""
    assert "not_ok(x)" in _lossy(seqs=False, keep=0.85)
    assert _lossy(seqs=True, keep=0.85) == ["ok(x)"]
    assert "not_ok(x)" in _lossy(seqs=True, keep=0.4)
