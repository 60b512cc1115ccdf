"""The frequency observer (GObs) at its defaults: how soon it sees a fault, how rarely it
cries wolf on a healthy topic that arrives in clumps, and what one message costs.

Run:  .venv/bin/python bench/gobs_timing.py [--minutes M]

Each topic is the compiler's observer (δ = 1/rate, ±10 %, ω = 10·δ, θ = 5) with racc's
defaults, fed as the observer host feeds it (an advance every 0.1 s).  Printed:

- detection latency, from the fault to the not_ok verdict: the publisher stops, halves its
  rate, or publishes five times as often (messages received 0-2 ms late, with header stamps
  and without);
- false not_ok verdicts on a healthy publisher whose messages a receiver takes in clumps
  after gaps of up to 0.27 s and 0.35 s (receive times only, as for a topic without a
  header), over M minutes per rate and seed;
- the time one message takes through the observer (receive times, then stamps).
"""

from __future__ import annotations

import argparse
import random
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from rac.logic import Atom
from rac.observe import Message, Verdict, build
from rac.passes.observers import ObserverSpec

RATES = (100.0, 50.0, 10.0, 1.0)
Trace = list[tuple[float, float | None]]


def gobs(rate: float):  # type: ignore[no-untyped-def]
    delta = 1.0 / rate
    params = (
        ("topic", "/x"),
        ("delta", delta),
        ("dev", 1.0 / (0.9 * rate) - delta),
        ("ws", 10 * delta),
        ("mismatch_th", 5),
    )
    return build(ObserverSpec("GObs", "x", params, (Atom("ok", ("x",)),)))


def run(obs, trace: Trace, end: float) -> list[Verdict]:  # type: ignore[no-untyped-def]
    out: list[Verdict] = []
    tick = 0.1
    for t, stamp in trace:
        while tick <= t:
            out += obs.advance(tick)
            tick = round(tick + 0.1, 9)
        out += obs.feed(Message(t, "/x", {}, stamp))
    while tick <= end:
        out += obs.advance(tick)
        tick = round(tick + 0.1, 9)
    return out


def faulty(rate: float, fault: str, at: float, stamps: bool, rng: random.Random) -> Trace:
    delta, t, out = 1.0 / rate, 0.0, []
    while t < 2 * at:
        if fault == "stop" and t >= at:
            break
        step = delta * (2.0 if fault == "half" else 0.2) if t >= at else delta
        out.append((t + rng.uniform(0.0, 0.002), 1.7e9 + t if stamps else None))
        t += step
    return sorted(out)


def clumped(rate: float, seconds: float, max_gap: float, rng: random.Random) -> Trace:
    published = [k / rate for k in range(int(seconds * rate))]
    out: Trace = []
    wake, i = 0.0, 0
    while i < len(published):
        wake += rng.uniform(0.0, max_gap)
        while i < len(published) and published[i] <= wake:
            out.append((wake, None))
            i += 1
    return out


def latencies() -> None:
    print("detection latency (s after the fault; with stamps / receive times only):")
    at = 60.0
    for fault in ("stop", "half", "5x"):
        cells = []
        for rate in RATES:
            pair = []
            for stamps in (True, False):
                out = run(gobs(rate), faulty(rate, fault, at, stamps, random.Random(1)), 3 * at)
                first = next((v.t for v in out if not v.positive and v.t >= at), None)
                pair.append("-" if first is None else f"{first - at:.2f}")
            cells.append(f"{rate:g} Hz {pair[0]}/{pair[1]}")
        print(f"  {fault:>4}: " + ", ".join(cells))


def false_alarms(minutes: float) -> None:
    seconds = 60.0 * minutes
    for max_gap in (0.27, 0.35):
        total, verdicts = 0, 0
        for rate in (100.0, 60.0, 30.0, 10.0):
            for seed in range(4):
                trace = clumped(rate, seconds, max_gap, random.Random(seed))
                out = run(gobs(rate), trace, trace[-1][0])
                verdicts += sum(1 for v in out if not v.positive)
                total += 1
        print(
            f"clumps after gaps up to {max_gap} s: {verdicts} false not_ok in {total} topics x "
            f"{minutes:g} min (100, 60, 30, 10 Hz; 4 seeds)"
        )


def cost() -> None:
    for stamps in (False, True):
        obs = gobs(100.0)
        messages = [
            Message(k / 100.0, "/x", {}, 1.7e9 + k / 100.0 if stamps else None)
            for k in range(200_000)
        ]
        start = time.perf_counter()
        for m in messages:
            obs.feed(m)
        per = (time.perf_counter() - start) / len(messages)
        print(f"cost per message ({'stamps' if stamps else 'receive times'}): {per * 1e6:.2f} us")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--minutes", type=float, default=10.0, help="healthy time per topic (default 10)"
    )
    args = parser.parse_args()
    latencies()
    false_alarms(args.minutes)
    cost()


if __name__ == "__main__":
    main()
