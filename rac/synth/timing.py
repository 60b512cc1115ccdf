"""When each topic of a synthetic recording is published.

Regular topics tick at their rate with Gaussian jitter on each tick (drivers of hardware
are steadier than software nodes); event-driven topics are a Poisson process, or follow
the events of an event-driven input they are computed from (``publishes T from I``).
A ``crash`` stops a node's topics, a ``freq`` fault publishes a topic five times as often.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rac.ir import Model, Topic
from rac.learn.fields import FloatArray
from rac.synth.faults import FREQ_FACTOR, Fault

DRIVER_JITTER = 0.01  # σ of a tick as a fraction of the period: Δ̄/σ ≈ 70
SOFTWARE_JITTER = 0.1  # Δ̄/σ ≈ 7
EVENT_RATE_HZ = {"sensor_msgs/Joy": 5.0, "nav_msgs/OccupancyGrid": 0.5}
DEFAULT_EVENT_RATE_HZ = 2.0
REACTION_S = 0.002  # a node reacting to an input event publishes this much later


def _ticks(
    rate: float, start: float, end: float, jitter: float, rng: np.random.Generator
) -> FloatArray:
    period = 1.0 / rate
    ticks = np.arange(start + period * float(rng.uniform(0, 1)), end, period)
    noise = np.clip(rng.normal(0.0, jitter * period, ticks.size), -0.45 * period, 0.45 * period)
    out: FloatArray = ticks + noise
    return out


def _poisson(rate: float, end: float, rng: np.random.Generator) -> FloatArray:
    gaps = rng.exponential(1.0 / rate, int(end * rate * 1.5) + 10)
    times = np.cumsum(gaps)
    out: FloatArray = times[times < end]
    return out


def publication_times(
    model: Model, duration: float, faults: Sequence[Fault], rng: np.random.Generator
) -> dict[str, FloatArray]:
    """Topic -> sorted publication times in [0, duration) for every published topic."""
    publishers = model.publishers()
    nodes = model.node_by_name()
    topics = model.topic_by_name()
    out: dict[str, FloatArray] = {}

    def schedule(topic: Topic, visiting: frozenset[str]) -> FloatArray:
        name = topic.name.value
        if name in out:
            return out[name]
        node = nodes[publishers[name][0]]
        if topic.rate_hz is not None:
            jitter = DRIVER_JITTER if node.drives else SOFTWARE_JITTER
            times = _regular(topic.rate_hz, name, duration, jitter, faults, rng)
        else:
            inputs = next(p.affected_by for p in node.publishes if p.topic.value == name)
            events = [
                i.value
                for i in inputs
                if i.value in publishers
                and i.value not in visiting
                and topics[i.value].rate_hz is None
            ]
            if events:
                parts = [schedule(topics[e], visiting | {name}) for e in events]
                times = np.unique(np.concatenate(parts)) + REACTION_S
                times = times[times < duration]
            else:
                rate = EVENT_RATE_HZ.get(topic.msg_type or "", DEFAULT_EVENT_RATE_HZ)
                times = _poisson(rate, duration, rng)
        for f in faults:
            # A crash stops the node's topics; a trip the topics of its device's driver.
            stops = f.kind == "crash" and node.name.value == f.target
            stops |= f.kind == "trip" and f.target in {d.value for d in node.drives}
            if stops:
                times = times[(times < f.start) | (times >= f.end)]
        out[name] = np.sort(times)
        return out[name]

    for topic in model.topics:
        if topic.name.value in publishers:
            schedule(topic, frozenset())
    return out


def _regular(
    rate: float,
    name: str,
    duration: float,
    jitter: float,
    faults: Sequence[Fault],
    rng: np.random.Generator,
) -> FloatArray:
    times = _ticks(rate, 0.0, duration, jitter, rng)
    for f in faults:
        if f.kind == "freq" and f.target == name:
            extra = _ticks(rate * (FREQ_FACTOR - 1), f.start, min(f.end, duration), jitter, rng)
            times = np.concatenate([times, extra])
    return times
