"""Learned rates as model topics: the rate to the digits its band justifies, the band, and
the evidence comment (:mod:`rac.learn.frequency` has the statistics)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace

from rac.ir import Topic
from rac.learn.frequency import (
    LOST_MESSAGES,
    RATE_FLOOR,
    RATE_MARGIN,
    RateStats,
    TopicRates,
    lost_messages,
    on_demand,
    rate_stats,
)
from rac.learn.options import LearnOptions

# Topics the robot's nodes and racc's own runtime both publish on: the diagnosis engine and
# the repair engine publish their status on /diagnostics, which a recording made without
# racc does not hold, so a rate learned there reads "too fast" once racc runs.
SHARED_WITH_RACC = frozenset({"/diagnostics"})


def _sig(value: float, digits: int) -> float:
    return float(f"{value:.{digits}g}")


def _ms(seconds: float) -> str:
    return f"{seconds * 1e3:.4g} ms"


def rounded_rate(rate: float, tolerance: float) -> tuple[float, float]:
    """The rate to the digits its tolerance justifies (a tenth of the tolerance's leading
    digit: 9.99997 ± 0.144 Hz is 10 Hz), the tolerance widened by what the rounding moved."""
    if not (math.isfinite(tolerance) and tolerance > 0):
        return _sig(rate, 6), _sig(tolerance, 3)
    step = 10.0 ** (math.floor(math.log10(tolerance)) - 1)
    rounded = _sig(round(rate / step) * step, 6) or _sig(rate, 6)  # never a rate of zero
    widened = tolerance + abs(rate - rounded)
    scale = 10.0 ** (math.floor(math.log10(widened)) - 2)
    return rounded, _sig(math.ceil(widened / scale - 1e-9) * scale, 3)


def rate_comment(s: RateStats, alpha: float) -> str:
    verdict = f"> α {alpha:g}: regular" if s.regular else f"<= α {alpha:g}: irregular"
    clock = "header stamps" if s.stamped else "receive times"
    gaps = f", {s.gaps} gaps ({s.gap_s:.3g} s in all)" if s.gaps else ", no gaps"
    return (
        f"learned from {s.samples} intervals ({clock}{gaps}): interval {_ms(s.mean)} (median "
        f"of the windowed mean; median {_ms(s.median)}), robust σ {_ms(s.stddev)}, "
        f"interval/σ {s.ratio:.3g} {verdict}"
    )


def band(stats: RateStats, window: float) -> tuple[float, str]:
    """The learned rate tolerance: its slow edge lies the largest of σ, the held-out
    deviation with its margin, the floor and two lost messages beyond δ; and its comment."""
    floor = RATE_FLOOR * stats.mean
    lost = lost_messages(stats.mean, window)
    deviation = max(stats.stddev, floor, lost)
    text = (
        f"band: the largest of σ, {RATE_FLOOR:.0%} of the interval ({_ms(floor)}), "
        f"{LOST_MESSAGES} messages lost from the {window:.3g} s window ({_ms(lost)})"
    )
    if stats.held_deviation is not None:
        deviation = max(deviation, RATE_MARGIN * stats.held_deviation)
        text += (
            f" and {RATE_MARGIN:g} × the largest held-out deviation of the windowed "
            f"mean interval ({_ms(stats.held_deviation)} over {stats.held_blocks} blocks)"
        )
    return stats.rate_hz - 1.0 / (stats.mean + deviation), f"{text}: ±{_ms(deviation)}"


def _without_rate(topic: Topic, comments: Sequence[str]) -> Topic:
    return replace(
        topic,
        rate_hz=None,
        rate_tolerance_hz=None,
        window_s=None,
        mismatch_threshold=None,
        comments=tuple(comments),
    )


def learned_topic(
    topic: Topic, stats: RateStats | None, alpha: float, rate_band: tuple[float, str] | None
) -> Topic:
    """``topic`` with the learned rate and tolerance (or none) and the evidence comment."""
    if stats is None:
        note = "too few messages in the recording to learn a rate"
        return replace(topic, comments=(*topic.comments, note))
    comments = (*topic.comments, rate_comment(stats, alpha))
    if stats.regular and rate_band is not None:
        comments = (*comments, rate_band[1])
    if not stats.regular:
        return _without_rate(topic, comments)
    tolerance_hz = rate_band[0] if rate_band is not None else stats.tolerance_hz
    rate, tolerance = rounded_rate(stats.rate_hz, tolerance_hz)
    tolerance = min(tolerance, rate * 0.999)
    window = topic.window_s if topic.rate_hz is not None else None
    mismatch = topic.mismatch_threshold if topic.rate_hz is not None else None
    return replace(
        topic,
        rate_hz=rate,
        rate_tolerance_hz=tolerance,
        window_s=window,
        mismatch_threshold=mismatch,
        comments=comments,
    )


def learn_rates(
    topics: Sequence[Topic],
    timing: Mapping[str, TopicRates],
    published: set[str],
    options: LearnOptions,
    notes: list[str],
    undeclared: list[str],
) -> tuple[list[Topic], list[RateStats]]:
    """Frequency observers (Algorithm 15, lines 5-10) on the declared topics."""
    rates: list[RateStats] = []
    learned_topics: list[Topic] = []
    for topic in topics:
        name = topic.name.value
        timed = timing.get(name)
        if timed is None:
            if topic.rate_hz is not None or topic.fields:
                notes.append(f"topic {name} is not in the recording: kept as it was")
            learned_topics.append(topic)
            continue
        stats = rate_stats(timed, options.alpha)
        if stats is not None:
            rates.append(stats)
        if name in SHARED_WITH_RACC:
            why = (
                f"no rate learned: racc's own nodes publish on {name} too, so on "
                "the robot with racc running its rate is not the recorded one"
            )
            notes.append(f"topic {name}: {why}")
            learned_topics.append(replace(topic, comments=(*topic.comments, why)))
            continue
        rate_band = band(stats, timed.window) if stats is not None and stats.regular else None
        learned = learned_topic(topic, stats, options.alpha, rate_band)
        if learned.rate_hz is not None and name not in published:
            # Only a published topic can be declared regular: ok(t) needs a clause.
            undeclared.append(
                f"{name} @ {learned.rate_hz:g} Hz +- "
                f"{learned.rate_tolerance_hz:g} Hz (no publisher known, so not declared)"
            )
            learned = replace(
                learned,
                rate_hz=None,
                rate_tolerance_hz=None,
                window_s=None,
                mismatch_threshold=None,
            )
        looks = on_demand(name, topic.msg_type)
        if learned.rate_hz is not None and looks is not None:
            why = (
                f"the rate is learned, but {name} looks published on demand ({looks}): its "
                "frequency observer reports a fault whenever the publisher is not asked to "
                "publish; keep the rate only if it publishes all the time"
            )
            notes.append(f"topic {name}: {why}")
            learned = replace(learned, comments=(*learned.comments, why))
        learned_topics.append(learned)
    return learned_topics, rates
