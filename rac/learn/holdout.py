"""Held-out validation of learned relations (beyond chapter 9).

A learned model must hold on the next recording, not only on the one it was learned from.
Each run is cut into equal time blocks (:func:`splits`), and every candidate relation is
judged on blocks it was not fitted on (k-fold over the blocks of all runs):

- each block's trends are computed from the block alone (the noise bands too, as a running
  observer has only what it has seen);
- the learning rule (ratio > Q and beating chance by the minimum lift), pooled over all
  blocks, selects it; for fold i it must also select it on the other blocks pooled, in at
  least half of the folds;
- pooled over the blocks, each held out once, its agreement must be significantly above
  chance: z = Σ(match − chance·counted) / √(its variance under independence), the variance
  from the effective number of checks of these autocorrelated series
  (:mod:`rac.learn.correlate`), with Holm's step-down correction over the family it
  belongs to (:func:`holm`);
- it must agree better than chance on every block where it has at least
  :data:`MIN_BLOCK_EFFECTIVE` effective checks (a block where the robot stood still has
  none, and says nothing);
- it must do all this under two splits of the recordings (:data:`BLOCKS` and one block
  more), or it is unstable: its selection would change with where the recording is cut;
- its agreement must not fall below chance in a well-visited quadrant of any heading of
  the recording (a relation that holds heading north and flips heading south depends on
  where the robot is).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rac.learn.correlate import PairEvidence, Pooled, Quadrants, pooled
from rac.learn.recording import Recording, TopicData

MIN_BLOCK_S = 2.0  # blocks shorter than this hold too few trends to validate on
MIN_BLOCK_EFFECTIVE = 8.0  # a block with fewer effective checks does not judge alone
MIN_RANGE_SHARE = 0.1  # a heading quadrant is judged when it holds this share of the checks
MIN_RANGE_CHECKS = 200  # ... and at least this many checks


@dataclass(frozen=True, slots=True)
class Block:
    segment: int  # the run it belongs to
    start: float  # seconds on the merged time line
    end: float


def run_span(recording: Recording, segment: int) -> tuple[float, float] | None:
    """The first and last message time of one run on the merged time line."""
    times = [t.times[t.segments == segment] for t in recording.topics]
    times = [t for t in times if t.size]
    if not times:
        return None
    return min(float(t[0]) for t in times), max(float(t[-1]) for t in times)


def run_blocks(recording: Recording, segment: int, count: int) -> tuple[Block, ...]:
    """``count`` equal time blocks of one run (fewer when the run is too short for blocks of
    :data:`MIN_BLOCK_S`; one, the whole run, when it is shorter than two)."""
    span = run_span(recording, segment)
    if span is None:
        return ()
    start, end = span
    count = max(1, min(count, int((end - start) // MIN_BLOCK_S)))
    edges = np.linspace(start, end + 1e-9, count + 1)
    return tuple(Block(segment, float(a), float(b)) for a, b in itertools.pairwise(edges.tolist()))


def splits(recording: Recording, segment: int, count: int) -> tuple[tuple[Block, ...], ...]:
    """The two ways one run is cut: ``count`` blocks and ``count + 1`` (none: ``count`` 0)."""
    if count < 2:
        return ()
    return (run_blocks(recording, segment, count), run_blocks(recording, segment, count + 1))


def block_topic(data: TopicData, block: Block) -> TopicData:
    keep = (data.segments == block.segment) & (data.times >= block.start) & (data.times < block.end)
    return data.part(keep)


@dataclass(frozen=True, slots=True)
class HeldOut:
    """The held-out verdict on one candidate under one split."""

    pooled: Pooled  # over every block
    blocks: int  # blocks with evidence
    folds: int  # folds whose other blocks select it
    lowest: float  # the lowest lift of a block that judges alone (nan: none does)
    threshold: float = math.nan  # Holm's threshold for its p (after correction)
    why_not: str = ""  # empty when kept

    @property
    def kept(self) -> bool:
        return not self.why_not

    def comment(self) -> str:
        p = self.pooled
        text = (
            f"held out on {self.blocks} blocks: {p.ratio:.2f} vs chance {p.chance:.2f}, "
            f"{p.effective:.0f} effective of {p.checks} checks"
        )
        if math.isfinite(self.lowest):
            text += f", lowest block {self.lowest:+.2f}"
        text += f", z {p.z:.1f}, p {p.p:.2g}"
        if math.isfinite(self.threshold):
            text += f" (Holm threshold {self.threshold:.2g})"
        return text

    def rejected(self, why: str, threshold: float = math.nan) -> HeldOut:
        t = threshold if math.isfinite(threshold) else self.threshold
        return HeldOut(self.pooled, self.blocks, self.folds, self.lowest, t, why)


def passes_fit(parts: Sequence[PairEvidence], q: float, min_lift: float) -> bool:
    p = pooled(parts)
    return p.checks > 0 and p.ratio > q and p.ratio >= p.chance + min_lift


def held_out(evidence: Sequence[PairEvidence | None], q: float, min_lift: float) -> HeldOut:
    """k-fold over the blocks for one candidate: its held-out statistics (before Holm)."""
    present = [e for e in evidence if e is not None and e.checks > 0]
    result = HeldOut(pooled(present), len(present), 0, math.nan)
    if not present:
        return result.rejected("no block has a trend of both sides while one moves")
    if not passes_fit(present, q, min_lift):
        p = result.pooled
        return result.rejected(
            f"its ratio {p.ratio:.2f} is not above Q {q:g} by the lift over chance "
            f"{p.chance:.2f} + {min_lift:g}"
        )
    folds = sum(
        passes_fit([e for j, e in enumerate(present) if j != i], q, min_lift)
        for i in range(len(present))
    )
    judged = [e.lift for e in present if e.effective >= MIN_BLOCK_EFFECTIVE]
    lowest = min(judged) if judged else math.nan
    result = HeldOut(result.pooled, len(present), folds, lowest)
    if len(present) > 1 and 2 * folds < len(present):
        return result.rejected(f"the other blocks select it in {folds} of {len(present)} folds")
    if judged and lowest <= 0:
        return result.rejected("a held-out block agreed no better than chance")
    return result


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


def with_holm(results: Sequence[HeldOut], family: int, alpha: float) -> list[HeldOut]:
    """The results with Holm's correction over ``family`` tested candidates applied (the
    already rejected ones take part with their p: they were tried)."""
    corrected = holm([r.pooled.p for r in results], family, alpha)
    out = []
    for r, (significant, threshold) in zip(results, corrected, strict=True):
        if r.why_not or significant:
            out.append(HeldOut(r.pooled, r.blocks, r.folds, r.lowest, threshold, r.why_not))
            continue
        out.append(
            r.rejected(
                f"p {r.pooled.p:.2g} is above Holm's threshold {threshold:.2g} "
                f"({family} candidates in its family)",
                threshold,
            )
        )
    return out


def heading_dependence(quadrants: Quadrants | None, min_lift: float) -> str:
    """Why the pair's agreement depends on the heading ("" when it does not): in a
    well-visited quadrant of some heading it agrees less than chance by ``min_lift``."""
    if quadrants is None:
        return ""
    worst = quadrants.worst(MIN_RANGE_CHECKS, MIN_RANGE_SHARE)
    if worst is None or worst[0] >= -min_lift:
        return ""
    lift, name, q = worst
    return (
        f"its agreement falls below chance ({lift:+.2f}) where {name} is in "
        f"[{90 * q}°, {90 * q + 90}°)"
    )
