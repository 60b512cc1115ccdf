"""Benchmark of the observer core: a ten-minute run of a model through an ObserverBank.

Run:  .venv/bin/python bench/observe.py [MODEL.ram] [--minutes M]

Every topic of the model publishes at its rate (its GObs δ; 20 Hz for a topic without one)
with ±5 % jitter, with a value for every field some observer reads; every node gets a
liveness and a cpu/mem sample at 10 Hz.  The bank is advanced before each event, as a replay
does.  Printed: events, verdicts, wall time, and the time per event.
"""

from __future__ import annotations

import argparse
import math
import random
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from rac.load.files import load_model
from rac.observe import Event, Message, NodeSample, ObserverBank, PropertySample
from rac.observe.gobs import GObs
from rac.pipeline import compile_model

ROOT = Path(__file__).resolve().parent.parent


def stream(bank: ObserverBank, seconds: float, seed: int = 1) -> list[Event]:
    rng = random.Random(seed)
    rates = {o.topic: o.delta for o in bank.observers if isinstance(o, GObs)}
    events: list[Event] = []
    for topic, fields in bank.topic_fields().items():
        delta = rates.get(topic, 0.05)
        t = 0.0
        while t < seconds:
            events.append(Message(t, topic, {f: math.sin(0.2 * t + len(f)) for f in fields}))
            t += delta * rng.uniform(0.95, 1.05)
    for k in range(int(seconds * 10)):
        events += [NodeSample(k / 10, n, True) for n in sorted(bank.nodes)]
        events += [PropertySample(k / 10, n, p, 1.0) for n, p in sorted(bank.properties)]
    events.sort(key=lambda e: e.t)
    return events


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", nargs="?", default=str(ROOT / "models" / "tedusar.ram"))
    parser.add_argument("--minutes", type=float, default=10.0)
    args = parser.parse_args()
    bank = ObserverBank(compile_model(load_model(args.model)).observers)
    events = stream(bank, args.minutes * 60)
    start = time.perf_counter()
    verdicts = 0
    for event in events:
        verdicts += len(bank.advance(event.t)) + len(bank.feed(event))
    elapsed = time.perf_counter() - start
    print(f"model {Path(args.model).name}: {len(bank.observers)} observers, {args.minutes} min")
    print(f"events {len(events)}  verdicts {verdicts}")
    print(f"wall {elapsed:.2f} s  ({1e6 * elapsed / len(events):.1f} µs per event)")


if __name__ == "__main__":
    main()
