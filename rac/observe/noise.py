"""Where a signal rests: the noise band of its trend slopes, measured where it does not move.

A robot that stands still still has signals that move a little: an IMU's heading wanders
with magnetometer noise, a gyro's rate with its bias.  A trend observer that reads that
wander as a trend fails every relation of a robot at rest.  The slopes |β| of a signal that
rests part of the time and moves part of the time fall into two clusters on a logarithmic
scale: the wander (0.01 rad/s) and the motion (0.5 rad/s), with a valley between them.
:func:`rest_band` finds that valley; slopes below it are the signal at rest.  A signal that
never rests (or never moves) has no valley, and then no band: its slopes are judged by
their significance alone (:func:`noise_band`); and until its history can tell (or is
20 s old), a relation observer counts no mismatch in which it moves beside a side at rest
(:func:`settled`): unknown is better than a false "not matched".

Pure Python (the observer core does not load NumPy); the learner calls the same function.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

BIN = 0.1  # decades per histogram bin, at least
MIN_COUNT = 20  # slopes needed before a band is measured
MIN_SIDE = 0.1  # each cluster holds at least this share of the slopes
MIN_SEPARATION = 0.5  # decades between the two clusters' peaks
VALLEY_DEPTH = 0.5  # the valley holds at most this share of the lower peak


def rest_band(magnitudes: Iterable[float]) -> float:
    """The slope below which the signal rests: the deepest valley between a cluster of its
    small slopes and a cluster of its large ones (log scale, :data:`BIN` wide bins smoothed
    over three); 0.0 when there is none."""
    values = sorted(m for m in magnitudes if m > 0 and math.isfinite(m))
    if len(values) < MIN_COUNT:
        return 0.0
    lo = math.log10(values[int(0.005 * len(values))])
    hi = math.log10(values[min(int(0.995 * len(values)), len(values) - 1)])
    if hi - lo < MIN_SEPARATION:
        return 0.0
    # Bins wide enough that counting noise does not carve valleys into a few slopes.
    width = max(BIN, 1.0 * (hi - lo) / math.sqrt(len(values)))
    bins = int((hi - lo) / width) + 1
    counts = [0.0] * bins
    for v in values:
        k = min(max(int((math.log10(v) - lo) / width), 0), bins - 1)
        counts[k] += 1
    smooth = [
        (counts[max(k - 1, 0)] + 2 * counts[k] + counts[min(k + 1, bins - 1)]) / 4
        for k in range(bins)
    ]
    total = len(values)
    # The highest bin at or before each bin, and at or after it.
    upto, after = [0] * bins, [bins - 1] * bins
    for k in range(1, bins):
        upto[k] = k if smooth[k] > smooth[upto[k - 1]] else upto[k - 1]
    for k in range(bins - 2, -1, -1):
        after[k] = k if smooth[k] >= smooth[after[k + 1]] else after[k + 1]
    best: tuple[float, int] | None = None  # (valley / lower peak, valley bin)
    seen: set[tuple[int, int]] = set()
    left_mass = 0.0
    for split in range(1, bins):
        left_mass += counts[split - 1]
        if left_mass < MIN_SIDE * total or total - left_mass < MIN_SIDE * total:
            continue
        left, right = upto[split - 1], after[split]
        if (left, right) in seen or (right - left) * width < MIN_SEPARATION:
            continue
        seen.add((left, right))
        valley = min(range(left, right + 1), key=lambda k: smooth[k])
        lower = min(smooth[left], smooth[right])
        depth = smooth[valley] / max(lower, 1e-12)
        # The valley must be deeper than the counting noise of the lower peak.
        significant = lower - smooth[valley] >= 2 * math.sqrt(max(lower, 1.0))
        if significant and depth <= VALLEY_DEPTH and (best is None or depth < best[0]):
            best = (depth, valley)
    if best is None:
        return 0.0
    return float(10 ** (lo + (best[1] + 0.5) * width))


NOISE_CAP = 0.25  # the band is at most this fraction of the signal's fast slopes (and a
# slope within twice the band is admitted as constant: half of the fast slope at most)
YOUNG_K = 4.0  # a young history's band: this many times its median slope (at most the cap)


MATURE = 40  # |β| entries (20 s at ω = 1 s) after which a history is taken as it is


def _resting_exactly(magnitudes: Sequence[float]) -> bool:
    """A signal that is exactly flat at rest (odometry's heading while the wheels stand)
    and also moves: a share of slopes exactly 0 and a share that are not."""
    flat = sum(1 for m in magnitudes if m == 0)
    n = len(magnitudes)
    return n >= MIN_COUNT and flat >= MIN_SIDE * n and n - flat >= MIN_SIDE * n


def settled(magnitudes: Sequence[float]) -> bool:
    """Whether a history (sorted |β|) can tell the signal's noise from its motion: it shows
    the valley between them, or slopes exactly 0 beside others, or it is :data:`MATURE`."""
    if len(magnitudes) >= MATURE:
        return True
    return _resting_exactly(magnitudes) or rest_band(magnitudes) > 0


def noise_band(magnitudes: Sequence[float], fast: float) -> float:
    """The noise band of a signal from its history of |β| (sorted) and its fast slope
    (the :data:`~rac.observe.qobs.FLOOR_QUANTILE` quantile): the valley where there is one,
    at most :data:`NOISE_CAP` of the fast slope; nothing for a signal exactly flat at rest.
    Without either, a young history (a robot that has only stood, or only moved, since the
    observer started) cannot tell noise from motion: the band is :data:`YOUNG_K` times the
    median slope, at most the cap; a :data:`MATURE` one has none (the signal never rests,
    or never moves: its slopes are judged by their significance)."""
    found = rest_band(magnitudes)
    if found > 0:
        return min(found, NOISE_CAP * fast)
    if not magnitudes or _resting_exactly(magnitudes) or len(magnitudes) >= MATURE:
        return 0.0
    median = magnitudes[len(magnitudes) // 2]
    return min(YOUNG_K * median, NOISE_CAP * fast)
