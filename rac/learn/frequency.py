"""Frequency observers (Algorithm 15, lines 5-10): which topics are regular, at what rate,
and within what band, from statistics that survive dropouts and bursts.

Algorithm 15 takes the mean and σ of the intervals Δ.  One dropout of a second in a minute
of a 50 Hz IMU moves σ as much as all the jitter of the rest (an AR.Drone IMU with 24 gaps
over 0.1 s in 92 s read mean/σ 0.93, "irregular"), and a driver whose messages arrive in
bursts has a median interval that is not its rate.  So:

- **The clock.**  A topic whose messages carry header stamps that are present, increasing and
  run at the rate of the receive times (within :data:`STAMP_AGREEMENT`) is timed by its
  stamps, the publisher's own cadence, as its frequency observer times it on the robot
  (docs/observers.md); any other topic by its receive times.
- **The interval** δ is the median of the frequency observer's own measurement, the mean
  interval over its window W around each message: bursts average out in it and a rare
  dropout does not move a median.  The rate is 1/δ.
- **Gaps are gaps.**  An interval longer than :data:`GAP_FACTOR` times δ is a gap: counted
  (how many, how long in all) and left out of the spread.
- **Regular** when δ/s > α, with s = 1.4826 times the median absolute deviation of the
  intervals from δ, gaps left out (the robust σ: Algorithm 15's mean/σ when the intervals
  are normal; messages that arrive in bursts have a large one).
- **The band** (the observer's deviation d): the largest of s, :data:`RATE_FLOOR` of δ, what
  :data:`LOST_MESSAGES` messages missing from the window do to its mean, and
  :data:`RATE_MARGIN` times the largest deviation of the windowed mean interval from δ on
  blocks δ was not fitted on (windows with gaps included: the observer sees them).

Every statistic is a histogram or an extreme per block, so the statistics of separate
recordings merge (:meth:`TopicRates.merged`) without the recordings.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rac.learn.fields import FloatArray
from rac.learn.recording import TopicData

GAP_FACTOR = 4.0  # an interval this many times the median is a gap
STAMP_AGREEMENT = 0.02  # stamps and receive times may differ in rate by this share
MAD_SIGMA = 1.4826  # MAD × this is σ for normal intervals
RATE_MARGIN = 2.0  # the band covers twice the largest held-out deviation ...
RATE_FLOOR = 0.05  # ... and at least 5 % of the interval
LOST_MESSAGES = 2  # ... and two messages missing from the observer's window
BINS_PER_DECADE = 2000  # interval histograms: 0.12 % wide bins


@dataclass(frozen=True, slots=True)
class Histogram:
    """Counts of positive numbers in logarithmic bins (:data:`BINS_PER_DECADE`), with the
    sum of the numbers in each bin: a quantile is the mean of its bin (exact when the
    numbers of a bin are one), and histograms merge by adding."""

    bins: tuple[tuple[int, int, float], ...] = ()  # (bin, count, sum), sorted by bin

    @staticmethod
    def of(values: FloatArray) -> Histogram:
        # Two messages received at one instant are an interval of (at most) a nanosecond,
        # the resolution of ROS time: counted, not dropped.
        finite = values[np.isfinite(values)]
        positive = np.maximum(finite, 1e-9)
        if not positive.size:
            return Histogram()
        index = np.floor(np.log10(positive) * BINS_PER_DECADE).astype(np.int64)
        keys, inverse, counts = np.unique(index, return_inverse=True, return_counts=True)
        sums = np.bincount(inverse, weights=positive)
        return Histogram(tuple(zip(keys.tolist(), counts.tolist(), sums.tolist(), strict=True)))

    def __add__(self, other: Histogram) -> Histogram:
        merged: dict[int, tuple[int, float]] = {k: (c, t) for k, c, t in self.bins}
        for k, c, t in other.bins:
            c0, t0 = merged.get(k, (0, 0.0))
            merged[k] = (c0 + c, t0 + t)
        return Histogram(tuple((k, c, t) for k, (c, t) in sorted(merged.items())))

    @property
    def count(self) -> int:
        return sum(c for _, c, _ in self.bins)

    def _centres(self) -> tuple[FloatArray, FloatArray]:
        counts = np.array([c for _, c, _ in self.bins], dtype=np.float64)
        means = np.array([t for _, _, t in self.bins], dtype=np.float64) / counts
        return means, counts

    def quantile(self, q: float) -> float:
        if not self.bins:
            return math.nan
        centres, counts = self._centres()
        return _weighted_quantile(centres, counts, q)

    def spread(self, centre: float, below: float) -> float:
        """1.4826 × the median absolute deviation from ``centre`` of the values up to
        ``below`` (the robust σ of the intervals that are not gaps)."""
        if not self.bins:
            return math.nan
        centres, counts = self._centres()
        keep = centres <= below
        if not keep.any():
            return math.nan
        deviation = np.abs(centres[keep] - centre)
        return MAD_SIGMA * _weighted_quantile(deviation, counts[keep], 0.5)


def _weighted_quantile(values: FloatArray, weights: FloatArray, q: float) -> float:
    order = np.argsort(values)
    v, w = values[order], weights[order]
    cumulative = np.cumsum(w)
    return float(v[min(int(np.searchsorted(cumulative, q * cumulative[-1])), v.size - 1)])


@dataclass(frozen=True, slots=True)
class BlockRates:
    """One topic's timing on one block of a recording."""

    intervals: Histogram  # Δ
    windowed: Histogram  # the observer's windowed mean interval at each message
    lowest: float  # the smallest and largest windowed mean interval (nan: none)
    highest: float
    gaps: int
    gap_s: float


@dataclass(frozen=True, slots=True)
class TopicRates:
    """One topic's timing statistics, per block, mergeable across recordings."""

    topic: str
    stamped: bool  # timed by header stamps (else by receive times)
    window: float  # the observer's window W the windowed means were taken over
    blocks: tuple[BlockRates, ...]

    def merged(self, other: TopicRates) -> TopicRates:
        """Both recordings' blocks; timed by stamps only when both were."""
        return TopicRates(
            self.topic, self.stamped and other.stamped, self.window, self.blocks + other.blocks
        )


@dataclass(frozen=True, slots=True)
class RateStats:
    """What the learner decides from a topic's timing."""

    topic: str
    samples: int  # intervals measured
    mean: float  # δ: the median windowed mean interval, s
    stddev: float  # s: the robust σ of the intervals that are not gaps, s
    regular: bool  # median(Δ)/s > α
    median: float = math.nan  # median(Δ)
    gaps: int = 0
    gap_s: float = 0.0
    stamped: bool = False
    held_deviation: float | None = None  # the largest held-out deviation of the windowed mean
    held_blocks: int = 0

    @property
    def ratio(self) -> float:
        return self.mean / self.stddev if self.stddev > 0 else math.inf

    @property
    def rate_hz(self) -> float:
        return 1.0 / self.mean

    @property
    def tolerance_hz(self) -> float:
        """The rate band whose slower edge is one σ longer than δ."""
        return self.rate_hz - 1.0 / (self.mean + self.stddev)


def clock(topic: TopicData) -> tuple[FloatArray, bool]:
    """The times a topic's cadence is judged on: its header stamps when they can be
    trusted (present, increasing within each run, at the rate of the receive times), else
    its receive times; and whether they are stamps."""
    stamps = topic.stamps
    if stamps is None or topic.count < 3 or not np.all(np.isfinite(stamps) & (stamps > 0)):
        return topic.times, False
    same_run = topic.segments[1:] == topic.segments[:-1]
    d_stamp, d_recv = np.diff(stamps)[same_run], np.diff(topic.times)[same_run]
    if d_stamp.size < 2 or np.any(d_stamp <= 0):
        return topic.times, False
    span_stamp, span_recv = float(d_stamp.sum()), float(d_recv.sum())
    if not span_recv > 0 or abs(span_stamp / span_recv - 1) > STAMP_AGREEMENT:
        return topic.times, False
    # On the receive clock's origin, so that blocks and windows cut alike.
    shifted = np.empty_like(stamps)
    for segment in np.unique(topic.segments).tolist():
        rows = topic.segments == segment
        shifted[rows] = stamps[rows] - stamps[rows][0] + topic.times[rows][0]
    return shifted, True


def windowed_intervals(times: FloatArray, window: float) -> FloatArray:
    """The mean interval of the occurrences within ±window/2 of each occurrence (the
    frequency observer's check), where the window lies inside ``times``' span."""
    if times.size < 3:
        return np.empty(0)
    half = window / 2
    inside = (times - half >= times[0]) & (times + half <= times[-1])
    lo = np.searchsorted(times, times - half, side="left")
    hi = np.searchsorted(times, times + half, side="right") - 1
    ok = inside & (hi > lo)
    out: FloatArray = (times[hi[ok]] - times[lo[ok]]) / (hi[ok] - lo[ok])
    return out


def block_rates(times: FloatArray, window: float) -> BlockRates:
    """The timing of one block's messages (one run's, in order)."""
    deltas = np.diff(times)
    means = windowed_intervals(times, window)
    # The topic's interval here: its windowed mean's median (bursts average out in it).
    typical = float(np.median(means)) if means.size else math.nan
    if not math.isfinite(typical):
        typical = float(np.median(deltas)) if deltas.size else math.nan
    gap = deltas > GAP_FACTOR * typical if math.isfinite(typical) else np.zeros(0, dtype=bool)
    return BlockRates(
        Histogram.of(deltas),
        Histogram.of(means),
        float(means.min()) if means.size else math.nan,
        float(means.max()) if means.size else math.nan,
        int(gap.sum()),
        float(deltas[gap].sum()),
    )


def observer_window(mean: float, ws: float | None) -> float:
    """The window the frequency observer takes its mean over, for a topic with this mean
    interval (``ws``: the model's window, else Equation 5.3's 10 intervals)."""
    from rac.observe.gobs import DEFAULT_MIN_COUNT, DEFAULT_MIN_WINDOW_S

    return max(ws if ws is not None else 10 * mean, DEFAULT_MIN_WINDOW_S, DEFAULT_MIN_COUNT * mean)


def topic_rates(
    topic: TopicData, blocks: Sequence[tuple[int, float, float]], ws: float | None
) -> TopicRates | None:
    """A topic's timing on each block (segment, start, end); None with fewer than three
    intervals in all."""
    times, stamped = clock(topic)
    deltas = topic.intervals()
    if deltas.size < 3:
        return None
    window = observer_window(float(np.median(deltas)), ws)
    out = []
    for segment, start, end in blocks:
        rows = (topic.segments == segment) & (topic.times >= start) & (topic.times < end)
        out.append(block_rates(times[rows], window))
    return TopicRates(topic.name, stamped, window, tuple(out))


def rate_stats(rates: TopicRates, alpha: float) -> RateStats | None:
    """The learner's reading of a topic's timing (None: fewer than three intervals)."""
    intervals = sum((b.intervals for b in rates.blocks), Histogram())
    windowed = sum((b.windowed for b in rates.blocks), Histogram())
    if intervals.count < 3:
        return None
    median = intervals.quantile(0.5)
    delta = windowed.quantile(0.5) if windowed.count else median
    # The spread around the topic's interval δ (around the median of the intervals, a
    # topic whose messages come in bursts would have none: most of them 0 apart).
    spread = intervals.spread(delta, GAP_FACTOR * delta)
    regular = spread == 0 or delta / spread > alpha
    held = _held_out(rates.blocks)
    return RateStats(
        rates.topic,
        intervals.count,
        delta,
        spread,
        regular,
        median,
        sum(b.gaps for b in rates.blocks),
        sum(b.gap_s for b in rates.blocks),
        rates.stamped,
        held[0] if held else None,
        held[1] if held else 0,
    )


def _held_out(blocks: Sequence[BlockRates]) -> tuple[float, int] | None:
    """k-fold over the blocks: δ fitted on the other blocks against the windowed mean
    intervals of the held-out one; the largest deviation and the blocks used."""
    if len(blocks) < 2:
        return None
    worst, used = 0.0, 0
    for i, block in enumerate(blocks):
        others = sum((b.windowed for j, b in enumerate(blocks) if j != i), Histogram())
        if others.count < 3 or not math.isfinite(block.lowest):
            continue
        fitted = others.quantile(0.5)
        worst = max(worst, abs(block.lowest - fitted), abs(block.highest - fitted))
        used += 1
    return (worst, used) if used else None


def lost_messages(mean: float, window: float) -> float:
    """How far the observer's windowed mean interval moves when :data:`LOST_MESSAGES` of
    the n = window/mean intervals in its window are missing: mean·k/(n − k).  A publisher
    that a loaded machine stalls for longer than it catches up on loses a message or two
    (the demo robot's 10 Hz /pose: 20 intervals in the 2 s window, so one lost message is
    5 %), however regular the training recording was."""
    n = window / mean
    return mean * LOST_MESSAGES / max(n - LOST_MESSAGES, 1.0)


# Message types published when someone or something asks, not at a steady rate (docs/
# language.md, "topic": a joystick, velocity commands, a map updated when the robot moves,
# goals and plans), and the last segments of topic names that say the same.
ON_DEMAND_TYPES = {
    "sensor_msgs/Joy": "a joystick",
    "geometry_msgs/Twist": "velocity commands",
    "geometry_msgs/TwistStamped": "velocity commands",
    "nav_msgs/OccupancyGrid": "a map, updated when the robot moves",
    "nav_msgs/Path": "a plan, made when a goal is given",
    "geometry_msgs/PoseStamped": "a pose, such as a goal",
    "geometry_msgs/PoseWithCovarianceStamped": "a pose, such as an initial pose",
    "move_base_msgs/MoveBaseActionGoal": "goals",
    "actionlib_msgs/GoalID": "goal cancellations",
    "std_msgs/Empty": "events without data",
}
ON_DEMAND_NAMES = {
    "cmd_vel": "velocity commands",
    "joy": "a joystick",
    "goal": "goals",
    "initialpose": "an initial pose",
    "map": "a map, updated when the robot moves",
    "plan": "a plan, made when a goal is given",
    "cancel": "goal cancellations",
}


def on_demand(name: str, msg_type: str | None) -> str | None:
    """Why a topic looks published on demand (by its type or its name), or None.

    A rate learned from such a topic holds while its publisher is asked to publish (the
    demo robot publishes every topic without a rate at 2 Hz; move_base publishes velocity
    commands while it drives): its frequency observer would report a fault whenever it
    is not."""
    last = name.rstrip("/").rsplit("/", 1)[-1]
    if msg_type in ON_DEMAND_TYPES:
        return f"{msg_type}: {ON_DEMAND_TYPES[msg_type]}"
    if last in ON_DEMAND_NAMES:
        return f"named {last}: {ON_DEMAND_NAMES[last]}"
    return None
