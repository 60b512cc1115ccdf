"""Held-out validation of learned relations and rate bands (beyond chapter 9).

A learned model must hold on the next recording, not only on the one it was learned from.
The training set is cut into blocks (its runs when there are several, else equal time
blocks of its one run), and every learned value is checked on blocks it was not fitted on
(k-fold over the blocks):

- **Relations.**  Each block's trends are computed from that block alone (the slope limits
  b+ and b− too, as a running observer has only what it has seen).  For fold i, the learning
  rule (ratio > Q and beating chance by the minimum lift) is applied to the other blocks,
  pooled; block i is held out.  The pair must be selected in at least half of the folds,
  and pooled over its held-out blocks its agreement must exceed chance significantly: a
  one-sided z test of the match ratio
  against the chance level with the *effective* number of checks (trend symbols come in
  runs, so successive checks are not independent: the count is the number of symbol runs
  of the less active signal), and Holm's step-down correction over every admissible pair
  the search tried.  The agreement must also be above chance in every held-out block.
- **Invariance.**  A relation whose agreement falls below chance (by the minimum lift) in
  one heading quadrant (of any yaw signal in the recording) while it is above chance
  overall depends on where the robot is, and is rejected.  A *drifting* signal (fewer than
  :data:`DRIFT_RUNS` trend runs in a block: GPS latitude, altitude, a running sum) is
  paired only when one held-out block supports the pair on its own (p < the significance
  level, uncorrected).
- **Rates.**  For fold i, the mean interval is fitted on the other blocks and the windowed
  mean intervals of block i (the frequency observer's window) are compared with it.  The
  learned deviation is the largest of σ, :data:`RATE_MARGIN` times the largest held-out
  deviation, :data:`RATE_FLOOR` of the mean interval, and what :data:`LOST_MESSAGES`
  messages missing from the observer's window do to its mean (:func:`lost_messages`): a
  topic with few messages per window moves by a whole message at a time.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rac.learn.correlate import Correlation, pair_matches
from rac.learn.recording import Recording, TopicData
from rac.learn.trends import CONSTANT, DECREASING, INCREASING, Signal, TopicTrends, topic_trends

DRIFT_RUNS = 6  # a signal with fewer trend runs than this in a block drifts
RATE_MARGIN = 2.0  # the band covers twice the largest held-out deviation ...
RATE_FLOOR = 0.05  # ... and at least 5 % of the mean interval
LOST_MESSAGES = 2  # ... and two messages missing from the observer's window
MIN_RANGE_SHARE = 0.1  # a heading quadrant is judged when it holds this share of the checks
MIN_RANGE_CHECKS = 200  # ... and at least this many checks
MIN_BLOCK_S = 2.0  # blocks shorter than this hold too few trends to validate on


@dataclass(frozen=True, slots=True)
class Block:
    segment: int  # the run it belongs to
    start: float  # seconds on the merged time line
    end: float


@dataclass(frozen=True, slots=True)
class PairEvidence:
    """One pair's statistics on one block (its trends computed from the block alone)."""

    matches: int
    checks: int
    chance: float
    runs: int  # the effective number of independent checks under chance (see z_test)
    slow_runs: int  # the trend runs of the less active side (a drifting side has few)

    @property
    def lift(self) -> float:
        return self.matches / self.checks - self.chance if self.checks else 0.0


@dataclass(frozen=True, slots=True)
class HeldOut:
    """The held-out verdict on one learned relation."""

    ratio: float  # pooled over the held-out blocks
    chance: float
    z: float
    p: float  # one-sided, uncorrected
    blocks: int  # blocks it was held out on
    min_lift: float  # the lowest held-out block's ratio - chance
    threshold: float = math.nan  # Holm's threshold for its p (set after correction)
    why_not: str = ""  # empty when kept

    @property
    def kept(self) -> bool:
        return not self.why_not

    def comment(self) -> str:
        text = (
            f"held out on {self.blocks} blocks: {self.ratio:.2f} vs chance {self.chance:.2f}, "
            f"lowest block +{self.min_lift:.2f}, z {self.z:.1f}, p {self.p:.2g}"
        )
        if math.isfinite(self.threshold):
            text += f" (Holm threshold {self.threshold:.2g})"
        return text


def blocks(recording: Recording, count: int) -> tuple[Block, ...]:
    """The runs when there are several, else ``count`` equal time blocks of the one run
    (fewer when the run is too short for blocks of :data:`MIN_BLOCK_S`)."""
    spans: list[tuple[int, float, float]] = []
    for segment in range(len(recording.runs)):
        times = [t.times[t.segments == segment] for t in recording.topics]
        times = [t for t in times if t.size]
        if times:
            spans.append(
                (segment, min(float(t[0]) for t in times), max(float(t[-1]) for t in times))
            )
    if len(spans) > 1:
        return tuple(Block(s, a, b + 1e-9) for s, a, b in spans)
    if not spans or count < 2:
        return ()
    segment, start, end = spans[0]
    count = min(count, int((end - start) // MIN_BLOCK_S))
    if count < 2:
        return ()
    edges = np.linspace(start, end + 1e-9, count + 1)
    return tuple(Block(segment, float(a), float(b)) for a, b in itertools.pairwise(edges.tolist()))


def block_topic(data: TopicData, block: Block) -> TopicData:
    keep = (data.segments == block.segment) & (data.times >= block.start) & (data.times < block.end)
    return TopicData(
        data.name,
        data.msg_type,
        data.publishers,
        data.times[keep],
        data.segments[keep],
        data.fields,
        data.values[:, keep],
    )


def _runs(codes: np.ndarray) -> np.ndarray:
    """Per row, how many runs of equal symbols it holds."""
    out: np.ndarray = np.zeros(codes.shape[0], dtype=np.int64)
    if codes.shape[1]:
        out += 1 + np.count_nonzero(np.diff(codes, axis=1), axis=1)
    return out


def _frequencies(t: TopicTrends) -> np.ndarray:
    return np.stack([(t.codes == s).mean(axis=1) for s in (DECREASING, CONSTANT, INCREASING)], 1)


def block_evidence(
    recording: Recording,
    chosen: Sequence[Block],
    pairs: Sequence[tuple[Signal, Signal]],
    occurrences: int,
    integrate: bool,
) -> list[list[PairEvidence | None]]:
    """Per block, per pair: its statistics on that block (None: a side has no trend there)."""
    topics = {t.name: t for t in recording.topics}
    wanted = sorted({s.topic for p in pairs for s in p})
    out: list[list[PairEvidence | None]] = []
    for block in chosen:
        trends: dict[str, TopicTrends] = {}
        for name in wanted:
            found = topic_trends(block_topic(topics[name], block), occurrences, integrate)
            if found is not None:
                trends[name] = found
        rows = {n: {s: i for i, s in enumerate(t.signals)} for n, t in trends.items()}
        runs = {n: _runs(t.codes) for n, t in trends.items()}
        freqs = {n: _frequencies(t) for n, t in trends.items()}
        cache: dict[tuple[str, str], tuple[np.ndarray, int]] = {}
        evidence: list[PairEvidence | None] = []
        for a, b in pairs:
            if a.topic not in trends or b.topic not in trends:
                evidence.append(None)
                continue
            ra, rb = rows[a.topic].get(a), rows[b.topic].get(b)
            if ra is None or rb is None:
                evidence.append(None)
                continue
            key = (a.topic, b.topic)
            if key not in cache:
                with np.errstate(divide="ignore", invalid="ignore"):  # messages with one stamp
                    cache[key] = pair_matches(trends[a.topic], trends[b.topic])
            m, checks = cache[key]
            if checks == 0:
                evidence.append(None)
                continue
            chance = float(freqs[a.topic][ra] @ freqs[b.topic][rb])
            ends = sorted((int(runs[a.topic][ra]), int(runs[b.topic][rb])))
            evidence.append(
                PairEvidence(int(m[ra, rb]), checks, chance, min(ends[1], checks), ends[0])
            )
        out.append(evidence)
    return out


def z_test(parts: Sequence[PairEvidence], slow: bool = False) -> tuple[float, float, float, float]:
    """Pooled ratio, pooled chance, z and one-sided p of agreement above chance.

    Successive checks are not independent: a trend symbol holds for a run of samples.
    Under chance (two independent signals) the match indicator decorrelates as fast as the
    more active side changes, so the effective number of checks is that side's number of
    trend runs.  ``slow`` counts the less active side's runs instead (the drifting rule).
    """
    checks = sum(e.checks for e in parts)
    if checks == 0:
        return 0.0, 0.0, 0.0, 1.0
    ratio = sum(e.matches for e in parts) / checks
    chance = sum(e.chance * e.checks for e in parts) / checks
    effective = max(1, sum(e.slow_runs if slow else e.runs for e in parts))
    spread = math.sqrt(max(chance * (1 - chance), 1e-12) / effective)
    z = (ratio - chance) / spread
    return ratio, chance, z, 0.5 * math.erfc(z / math.sqrt(2))


def holm(p_values: Sequence[float], family: int, alpha: float) -> list[tuple[bool, float]]:
    """Holm's step-down correction: per p, (rejected, its threshold), with ``family`` tests
    in all (the untested ones count as p = 1, so they come last)."""
    family = max(family, len(p_values))
    order = sorted(range(len(p_values)), key=lambda i: p_values[i])
    out: list[tuple[bool, float]] = [(False, math.nan)] * len(p_values)
    still = True
    for rank, i in enumerate(order):
        threshold = alpha / (family - rank)
        still = still and p_values[i] <= threshold
        out[i] = (still, threshold)
    return out


def _passes_fit(parts: Sequence[PairEvidence], q: float, min_lift: float) -> bool:
    checks = sum(e.checks for e in parts)
    if checks == 0:
        return False
    ratio = sum(e.matches for e in parts) / checks
    chance = sum(e.chance * e.checks for e in parts) / checks
    return ratio > q and ratio >= chance + min_lift


def held_out(
    evidence: Sequence[Sequence[PairEvidence | None]],
    pair: int,
    q: float,
    min_lift: float,
    significance: float,
) -> HeldOut:
    """k-fold over the blocks for one pair: its held-out statistics (before Holm)."""
    per_block = [row[pair] for row in evidence]
    fitted = 0
    for i in range(len(per_block)):
        others = [e for j, e in enumerate(per_block) if j != i and e is not None]
        fitted += _passes_fit(others, q, min_lift)
    held = [e for e in per_block if e is not None]
    if not held:
        return HeldOut(0.0, 0.0, 0.0, 1.0, 0, 0.0, why_not="no block has trends of both sides")
    ratio, chance, z, p = z_test(held)
    lowest = min(e.lift for e in held) if len(held) == len(per_block) else -1.0
    result = HeldOut(ratio, chance, z, p, len(held), lowest)
    if 2 * fitted < len(per_block):
        return _rejected(
            result, f"the other blocks select it in {fitted} of {len(per_block)} folds"
        )
    if lowest <= 0:
        return _rejected(result, "a held-out block agreed no better than chance")
    drifting = any(e.slow_runs < DRIFT_RUNS for e in held)
    if drifting and not any(z_test([e], slow=True)[3] < significance for e in held):
        return _rejected(result, "a side drifts and no held-out block supports it alone")
    return result


def _rejected(result: HeldOut, why: str) -> HeldOut:
    return HeldOut(
        result.ratio, result.chance, result.z, result.p, result.blocks, result.min_lift, why_not=why
    )


def with_holm(results: Sequence[HeldOut], family: int, alpha: float) -> list[HeldOut]:
    """The results with Holm's correction over ``family`` tested pairs applied."""
    corrected = holm([r.p for r in results], family, alpha)
    out = []
    for r, (rejected, threshold) in zip(results, corrected, strict=True):
        why = r.why_not
        if not why and not rejected:
            why = f"p {r.p:.2g} is above Holm's threshold {threshold:.2g} ({family} pairs tried)"
        out.append(
            HeldOut(r.ratio, r.chance, r.z, r.p, r.blocks, r.min_lift, threshold, why_not=why)
        )
    return out


# -- invariance over the operating range ----------------------------------------------------


def heading_quadrants(recording: Recording) -> list[tuple[str, TopicData, int]]:
    """Every yaw signal of the recording: (its name, its topic, its row)."""
    out = []
    for t in recording.topics:
        if "yaw" in t.fields:
            out.append((f"{t.name}.yaw", t, t.fields.index("yaw")))
    return out


def _quadrant(times: np.ndarray, topic: TopicData, row: int) -> np.ndarray:
    yaw = np.interp(times, topic.times, topic.values[row])
    out: np.ndarray = np.floor(np.mod(yaw, 2 * np.pi) / (np.pi / 2)).astype(np.int64).clip(0, 3)
    return out


def range_dependence(
    correlation: Correlation,
    trends: dict[str, TopicTrends],
    ranges: Sequence[tuple[str, TopicData, int]],
    min_lift: float,
) -> str:
    """Why the pair's agreement depends on the heading ("" when it does not): in a
    well-visited quadrant of some yaw signal it agrees less than chance by ``min_lift``
    (its agreement changes sign)."""
    from rac.learn.correlate import interpolate

    x, y = trends[correlation.a.topic], trends[correlation.b.topic]
    rx, ry = x.signals.index(correlation.a), y.signals.index(correlation.b)
    # Both directions, as the learning counts them: each side's own symbols against the
    # other's interpolated at its times.
    sides = []
    for own, other, r_own, r_other in ((x, y, rx, ry), (y, x, ry, rx)):
        with np.errstate(divide="ignore", invalid="ignore"):  # messages with one stamp
            codes, _ = interpolate(own.times, _one_row(other, r_other))
        sides.append((own.times, own.codes[r_own], codes[0]))
    total = sum(int((o < 3).sum()) for _, _, o in sides)
    for name, topic, row in ranges:
        counts = np.zeros(4)
        matched = np.zeros(4)
        own_freq = np.zeros((4, 3))
        other_freq = np.zeros((4, 3))
        for times, mine, theirs in sides:
            inside = theirs < 3
            quadrant = _quadrant(times[inside], topic, row)
            a, b = mine[inside], theirs[inside]
            np.add.at(counts, quadrant, 1)
            np.add.at(matched, quadrant, (a == b).astype(np.float64))
            for s in (DECREASING, CONSTANT, INCREASING):
                np.add.at(own_freq[:, s], quadrant, (a == s).astype(np.float64))
                np.add.at(other_freq[:, s], quadrant, (b == s).astype(np.float64))
        for k in range(4):
            n = counts[k]
            if n < max(MIN_RANGE_CHECKS, MIN_RANGE_SHARE * total):
                continue
            chance = float((own_freq[k] / n) @ (other_freq[k] / n))
            lift = matched[k] / n - chance
            if lift < -min_lift:
                lo = 90 * k
                return (
                    f"its agreement falls below chance ({lift:+.2f}) where {name} is in "
                    f"[{lo}°, {lo + 90}°)"
                )
    return ""


def _one_row(t: TopicTrends, row: int) -> TopicTrends:
    return TopicTrends(t.topic, t.times, (t.signals[row],), t.codes[row : row + 1], t.window_s)


# -- rates ----------------------------------------------------------------------------------


def observer_window(mean: float, ws: float | None) -> float:
    """The window the frequency observer takes its mean over, for a topic with this mean
    interval (``ws``: the model's window, else Equation 5.3's 10 intervals)."""
    from rac.observe.gobs import DEFAULT_MIN_COUNT, DEFAULT_MIN_WINDOW_S

    return max(ws if ws is not None else 10 * mean, DEFAULT_MIN_WINDOW_S, DEFAULT_MIN_COUNT * mean)


def lost_messages(mean: float, window: float) -> float:
    """How far the observer's windowed mean interval moves when :data:`LOST_MESSAGES` of
    the n = window/mean intervals in its window are missing: mean·k/(n − k).  A publisher
    that a loaded machine stalls for longer than it catches up on loses a message or two
    (the demo robot's 10 Hz /pose: 20 intervals in the 2 s window, so one lost message is
    5 %), however regular the training recording was."""
    n = window / mean
    return mean * LOST_MESSAGES / max(n - LOST_MESSAGES, 1.0)


def windowed_intervals(times: np.ndarray, window: float) -> np.ndarray:
    """The mean interval of the occurrences within ±window/2 of each occurrence (the
    frequency observer's check), where the window lies inside ``times``' span."""
    if times.size < 3:
        return np.empty(0)
    half = window / 2
    inside = (times - half >= times[0]) & (times + half <= times[-1])
    lo = np.searchsorted(times, times - half, side="left")
    hi = np.searchsorted(times, times + half, side="right") - 1
    ok = inside & (hi > lo)
    out: np.ndarray = (times[hi[ok]] - times[lo[ok]]) / (hi[ok] - lo[ok])
    return out


@dataclass(frozen=True, slots=True)
class RateHoldout:
    deviation: float  # the largest held-out |windowed mean interval - fitted mean|, s
    blocks: int


def rate_holdout(data: TopicData, chosen: Sequence[Block], window: float) -> RateHoldout | None:
    """k-fold over the blocks: the fitted mean interval of the other blocks against the
    windowed mean intervals of the held-out one."""
    parts = [block_topic(data, b) for b in chosen]
    deltas = [p.intervals() for p in parts]
    worst = 0.0
    used = 0
    for i, part in enumerate(parts):
        fit = np.concatenate([d for j, d in enumerate(deltas) if j != i] or [np.empty(0)])
        held = windowed_intervals(part.times, window)
        if fit.size < 3 or held.size == 0:
            continue
        worst = max(worst, float(np.max(np.abs(held - fit.mean()))))
        used += 1
    return RateHoldout(worst, used) if used else None
