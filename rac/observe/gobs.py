"""GObs, the general observer (Algorithm 1 with the errata's |μ − δ| ≤ σ): ok(topic).

Parameters of the text: ``topic``; ``delta`` δ, the expected interval (s); ``dev`` σ, the
allowed deviation of the mean interval (default δ/9, the compiler's ±10 % rate band); ``ws``
ω, the window (default 10·δ, Equation 5.3 with c = 10); ``mismatch_th`` θ (default 5).

racc's own, all optional (``observers.yaml`` as the compiler writes it has none of them; the
defaults and the reasons for them are in docs/observers.md): ``min_window_s`` (2 s) and
``min_count`` N (10), the shortest window in seconds and in occurrences; ``hold_s`` (0.5 s),
how long a new verdict must stand before it is reported; ``silence_s`` (0.5 s), the
shortest silence counted; ``stamps`` (true), whether header stamps may time the topic;
``agree_s`` (10 s), over how long stamps must agree with arrivals.  With ``min_window_s: 0``,
``min_count: 0``, ``hold_s: 0``, ``silence_s: 0`` and ``stamps: false`` the observer is the
text's Algorithm 1 with the decisions below.

Decisions where the text leaves room:

- **The window** is centred on O_mid and holds the occurrences within [O_mid − W/2,
  O_mid + W/2] (Definition 5.4), W = max(ω, ``min_window_s``, N·δ).  An occurrence beyond
  it triggers one check (lines 9-21), then the window slides (lines 22-23): O_mid moves to
  the next occurrence until the new one falls in the window, and every occurrence before
  O_mid − W/2 leaves (the text pops one, which with its start at O_1 would keep only the
  right half of the window).  One occurrence makes at most one check: the text's loop
  would check it again after each one-step slide, giving a single late occurrence the
  weight of the whole gap before it; silence is counted on its own (below).
- **The mean interval** μ runs from the window's first occurrence to the one that closes
  it: μ = (O_i − O_first)/n over the n occurrences of the window (the text's mean of ΔW
  leaves O_i out).  Counting the closing occurrence keeps a bursty topic's mean right: when
  messages come in clumps, the check comes with the first message of a clump, and a mean
  over the window alone would end with a whole clump but without the gap after it, which
  makes a healthy topic read about one clump too fast in every check.
- **The occurrence's time**: receive time, or the publisher's header stamp while stamps
  are trusted (:class:`StampTrust`: present, increasing but for a bag's loop, and running
  at the rate of the arrivals over ``agree_s``), and only in a window whose stamps span the
  time its arrivals span, give or take the window (one wild stamp, from 1970 or an hour
  ahead, times its windows by arrival).  The window is placed by receive time either way;
  only μ is taken from the stamps, so a receiver that was late and got the messages in a
  clump still sees the publisher's cadence.
- **The bound** |μ − δ| ≤ σ is taken with a slack of :data:`RESOLUTION_S` (1 ns, the
  resolution of ROS time stamps; :data:`STAMP_RESOLUTION_S` for stamps carried as float
  seconds since 1970): σ comes to the observer rounded to twelve digits and μ from float
  time stamps, so a topic at exactly the slow edge of its band (the compiler's
  σ = 1/(RATE − TOL) − 1/RATE) would otherwise read as a violation by rounding alone.
- **A topic that stops** produces no occurrence, hence no check at all in the text.  Time
  (``advance`` or the next ``feed``), on receive time always, counts the silence: with E
  the end O_mid + W/2 of the window when the last occurrence came, one violation is counted
  at each instant E + G + (k − 1)·δ, k = 1, 2, … that passes without an occurrence, where
  G = max(1.5·δ, ``silence_s``) (with ``silence_s`` 0 the instants are E + (k + ½)·δ).
  Each such verdict carries the instant it was counted at.  When an occurrence comes after
  a silence that has turned the verdict negative, the stale window is dropped and a new
  one starts at that occurrence (as line 2 does), so stale intervals never count as good
  ones.  On a topic whose grace G is ``silence_s`` (faster than 1/(1.5·``silence_s``), 3 Hz
  at the default), an occurrence that comes before the silence's not_ok was due (G + θ·δ
  + ``hold_s``) takes the silence's violations back, and the window goes on with the gap in
  it: a delivery that paused for a fraction of a second and resumed is judged by the mean,
  as a burst.  A slower topic's silence is counted in intervals and stands (an irregular
  topic's long gap is what its frequency observer is for).
- **Hysteresis**: the θ rule gives a candidate verdict; it is reported only after it has
  stood for ``hold_s`` (:class:`rac.observe.base.Hold`).  At one check per message, θ
  alone is 50 ms at 100 Hz.
- **Starvation** (:meth:`GObs.starved`): while the process that times the messages is
  starved, and for one window W after, violations (of the mean and of silence) are not
  counted and no negative verdict is reported; silence is timed from the end.
- Nothing is reported before the first check, so a topic that never publishes gets no
  verdict.
"""

from __future__ import annotations

import math
from collections import deque
from typing import ClassVar, NamedTuple

from rac.observe.base import Hold, Mismatch, Needs
from rac.observe.events import Event, Message, Verdict
from rac.observe.params import Params
from rac.passes.observers import DEFAULT_MISMATCH_THRESHOLD, ObserverSpec

RESOLUTION_S = 1e-9  # deviations of the mean interval below this are not measurable
# A stamp of today carried as float seconds since 1970 is exact to about 0.24 µs.
STAMP_RESOLUTION_S = 1e-6
DEFAULT_MIN_WINDOW_S = 2.0
DEFAULT_MIN_COUNT = 10
DEFAULT_HOLD_S = 0.5
DEFAULT_SILENCE_S = 0.5
DEFAULT_AGREE_S = 10.0
AGREE_BLOCKS = 2  # the agreement history, in blocks of agree_s / AGREE_BLOCKS


class Occurrence(NamedTuple):
    t: float  # receive time
    stamp: float | None  # the publisher's header stamp
    k: int  # how many occurrences came before it
    seq: int | None = None  # the header's sequence number (ROS 1), where it counts


# Made once per message: tuple.__new__ skips the Python-level __new__ of a NamedTuple.
_occurrence = tuple.__new__


def _sent(first: Occurrence, closing: Occurrence, received: int) -> int:
    """How many intervals the publisher's header says it sent between ``first`` and
    ``closing``, of which ``received`` arrived: its sequence numbers' difference, while
    they count every message (ROS 1's ``header.seq``) and at least half arrived; else
    ``received``.  A message lost on the way (a relay's queue overflowing under load) is
    then no slower publisher; a stop still is (silence is timed on arrivals), and so is a
    stream that lost more than half."""
    if first.seq is None or closing.seq is None:
        return received
    sent = closing.seq - first.seq
    return sent if received <= sent <= 2 * received else received


class StampTrust:
    """Whether a topic's header stamps time it: every stamp present and later than the one
    before, and the stamps' clock running at the rate of the receiver's over ``agree_s``.

    The rate test compares the lower envelope of the offsets (receive time − stamp): the
    least offset of each of the last :data:`AGREE_BLOCKS` blocks of ``agree_s`` /
    AGREE_BLOCKS.  A receiver's delays only raise an offset, so a late block does not move
    its minimum unless every message in it was late; a stamp clock that runs at another
    rate (a bag played at another speed, stamps copied from an input) moves the envelope
    steadily, and trust ends once it has drifted by more than ``tolerance`` (a fraction)
    over the history.  A missing stamp ends trust at once.  A stamp that is not later than
    the one before is a jump back: a bag played with ``--loop`` starting over keeps the
    trust it had (the history starts again from it, and the observer takes the mean over
    the occurrences after the jump only), a second jump within ``agree_s`` (two publishers
    on one topic) ends it.
    """

    __slots__ = ("_blocks", "_last", "agree_s", "block_s", "jump", "tolerance", "trusted")

    def __init__(self, agree_s: float, tolerance: float) -> None:
        self.agree_s = agree_s
        self.block_s = agree_s / AGREE_BLOCKS
        self.tolerance = tolerance
        self.trusted = False
        self.jump: tuple[float, int] | None = None  # (receive time, k) of the last jump back
        self._last: float | None = None
        self._blocks: deque[list[float]] = deque()  # [first receive time, least offset]

    def add(self, now: Occurrence, measure: bool) -> None:
        """One occurrence; ``measure`` False while its receive time is in doubt (starved)."""
        t, stamp = now.t, now.stamp
        if stamp is None or (self._last is not None and stamp <= self._last):
            if stamp is None or (self.jump is not None and t - self.jump[0] < self.agree_s):
                self.trusted = False
            if stamp is not None:
                self.jump = (t, now.k)
            self._last = stamp
            self._blocks.clear()
            return
        self._last = stamp
        if not measure:
            return
        offset = t - stamp
        blocks = self._blocks
        if blocks and t - blocks[-1][0] < self.block_s:
            if offset < blocks[-1][1]:
                blocks[-1][1] = offset
            return
        blocks.append([t, offset])  # a new block: judge the complete ones
        if len(blocks) > AGREE_BLOCKS + 1:
            blocks.popleft()
        if len(blocks) == AGREE_BLOCKS + 1:
            (first, low), (last, high) = blocks[0], blocks[-2]
            self.trusted = abs(high - low) <= self.tolerance * (last - first)


class GObs:
    timed: ClassVar[bool] = True  # silence, windows and hysteresis run on time alone

    def __init__(self, spec: ObserverSpec) -> None:
        p = Params(spec)
        self.spec = spec
        self.topic = p.text("topic")
        self.delta = p.positive("delta")
        self.dev = p.positive("dev", self.delta / 9)
        self.ws = p.positive("ws", 10 * self.delta)
        self.min_window_s = p.non_negative("min_window_s", DEFAULT_MIN_WINDOW_S)
        self.min_count = p.count("min_count", DEFAULT_MIN_COUNT)
        self.hold_s = p.non_negative("hold_s", DEFAULT_HOLD_S)
        self.silence_s = p.non_negative("silence_s", DEFAULT_SILENCE_S)
        self.stamps = p.flag("stamps", True)
        self.window = max(self.ws, self.min_window_s, self.min_count * self.delta)
        agree_s = max(p.positive("agree_s", DEFAULT_AGREE_S), 2 * self.window)
        self.needs = Needs(topics=((self.topic, ()),))
        self._half = self.window / 2
        self._grace = max(1.5 * self.delta, self.silence_s)
        # A topic whose silence is timed in seconds rather than intervals (faster than
        # 3 Hz at silence_s 0.5 s) has its short silences taken back (module docstring).
        self._pauses = self.silence_s > 1.5 * self.delta
        self._mismatch = Mismatch(p.count("mismatch_th", DEFAULT_MISMATCH_THRESHOLD))
        self._hold = Hold(p.atom(), self.hold_s)
        # Stamps and receive times may disagree by half the band before the stamps lose.
        self._trust = StampTrust(agree_s, 0.5 * self.dev / self.delta)
        # The window: ``_left`` ends with O_mid, ``_right`` holds the occurrences after it.
        self._left: deque[Occurrence] = deque()
        self._right: deque[Occurrence] = deque()
        self._end = math.nan  # E: the window's end when the last occurrence came
        self._silent = 0  # violations counted for the current silence
        self._stale = False  # a silence was counted since the last occurrence
        self._count_before_silence = 0  # the θ counter when the silence began to count
        self._k = 0  # occurrences so far
        self._starved = False
        self._settled = -math.inf  # timing is trusted again from here on

    @property
    def stamped(self) -> bool:
        """Whether the topic is timed by its header stamps now."""
        return self._trust.trusted

    def feed(self, event: Event) -> list[Verdict]:
        if not isinstance(event, Message) or event.topic != self.topic:
            return []
        return self.occur(event.t, event.stamp, event.seq)

    def occur(self, t: float, stamp: float | None, seq: int | None = None) -> list[Verdict]:
        """One occurrence of the topic received at ``t`` with header stamp ``stamp`` and
        sequence number ``seq`` (None: none): what :meth:`feed` does with a
        :class:`Message`, without one (a transport that reads many messages at once feeds
        them so: ObserverBank.feed_messages)."""
        # Silence counts only from G past the window's end (_count_silence, inlined for
        # the usual case: a message well within its time, at every message of a topic).
        if self._silent or (self._left and t - self._end - self._grace >= 0):
            out = self._count_silence(t)
        else:
            out = []
        now = _occurrence(
            Occurrence,
            (t, stamp if self.stamps else None, self._k, seq if self.stamps else None),
        )
        self._k += 1
        self._trust.add(now, not (self._starved or t < self._settled))
        if self._pauses and self._stale and self._hold.positive:
            # The silence ended before its not_ok was due (the hold): a pause in delivery,
            # not a stop.  Its violations go, and the window goes on with the gap, so that
            # the messages that waited are judged with it, as a burst.
            self._mismatch.count = self._count_before_silence
            self._hold.since = None
            self._stale = False
        if not self._left or self._stale:
            # The first occurrence (line 2), or the first after a counted silence.
            self._left.clear()
            self._right.clear()
            self._left.append(now)
        elif now.t > self._left[-1].t + self._half:
            self._check(now, out)
            self._slide(now)
        else:
            self._right.append(now)
        self._silent = 0
        self._stale = False
        self._end = self._left[-1].t + self._half
        return out

    def advance(self, t: float) -> list[Verdict]:
        if self._at_rest():
            return []
        out = self._count_silence(t)
        self._settle(t, out)
        return out

    def _at_rest(self) -> bool:
        """A silence counted to the cap, not_ok reported and nothing pending: until an input,
        time alone changes nothing (_count_silence would only move its count on, which the
        next one catches up on in one step).  A recording with a stamp days off is days of
        such steps."""
        mismatch = self._mismatch
        return (
            self._stale
            and not self._starved
            and mismatch.count >= mismatch.cap
            and self._hold.positive is False
            and self._hold.since is None
        )

    def starved(self, t: float, starved: bool) -> list[Verdict]:
        if starved == self._starved:
            return []
        out: list[Verdict] = []
        if not starved:
            self._settled = t + self.window
            if self._left:
                self._end = max(self._end, t)  # silence is timed from here
            self._silent = 0
        self._starved = starved
        self._settle(t, out)
        return out

    def _in_doubt(self, t: float) -> bool:
        """Whether receive times up to ``t`` may be late: starved, or arrivals timed while
        starved are still in the window."""
        return self._starved or t < self._settled

    def _may_fall(self, t: float) -> bool:
        """Whether a negative verdict may stand: not while starved; while late arrivals are
        still in the window, only for a silence counted after the starvation."""
        return not self._starved and (t >= self._settled or self._stale)

    def _settle(self, t: float, out: list[Verdict]) -> None:
        """Time has passed: a pending verdict whose hold is over is reported."""
        if self._hold.positive is not None:
            positive = self._mismatch.count <= self._mismatch.theta
            self._hold.update(t, positive, out, self._may_fall(t))

    def _check(self, closing: Occurrence, out: list[Verdict]) -> None:
        first = self._left[0]
        n = len(self._left) + len(self._right)
        stamped = self._stamped_mean(closing)
        if stamped is not None:
            mu, slack = stamped, STAMP_RESOLUTION_S
        else:
            mu, slack = (closing.t - first.t) / _sent(first, closing, n), RESOLUTION_S
        good = abs(mu - self.delta) <= self.dev + slack
        if good or not self._in_doubt(closing.t):
            self._mismatch.check(good)
        positive = self._mismatch.count <= self._mismatch.theta
        self._hold.update(closing.t, positive, out, self._may_fall(closing.t))

    def _stamped_mean(self, closing: Occurrence) -> float | None:
        """μ from the stamps, when they are trusted and the window has enough of them after
        the last jump back (None: take receive times)."""
        if not self._trust.trusted or closing.stamp is None:
            return None
        first, n = self._left[0], len(self._left) + len(self._right)
        jump = self._trust.jump
        if jump is not None and first.k < jump[1]:  # the window holds the jump
            after = [o for o in (*self._left, *self._right) if o.k >= jump[1]]
            if len(after) < max(2, self.min_count):
                return None
            first, n = after[0], len(after)
        if first.stamp is None:
            return None
        span = closing.stamp - first.stamp
        # A stamp far from its neighbours (a clock from 1970, an hour off, a glitch) says
        # nothing about the cadence: stamps that disagree with the arrivals by more than a
        # window time this window by arrival instead.
        if abs(span - (closing.t - first.t)) > max(self.window, 1.0):
            return None
        return span / _sent(first, closing, n)

    def _slide(self, closing: Occurrence) -> None:
        """O_mid moves on, one occurrence at a time, until ``closing`` falls in the window
        (it becomes O_mid itself when the window has no occurrence after O_mid)."""
        left, right = self._left, self._right
        while right and closing.t > left[-1].t + self._half:
            left.append(right.popleft())
        if closing.t > left[-1].t + self._half:
            left.append(closing)
        else:
            right.append(closing)
        low = left[-1].t - self._half
        while left[0].t < low:
            left.popleft()

    def _count_silence(self, t: float) -> list[Verdict]:
        out: list[Verdict] = []
        if not self._left or self._starved:
            return out
        # Violations due by t: instants E + G + (k − 1)·δ ≤ t, k ≥ 1.
        due = math.floor((t - self._end - self._grace) / self.delta) + 1
        while self._silent < due:
            instant = self._end + self._grace + self._silent * self.delta
            if not self._stale:
                self._count_before_silence = self._mismatch.count
            self._silent += 1
            self._stale = True
            positive = self._mismatch.check(False)
            self._hold.update(instant, positive, out, self._may_fall(instant))
            if self._mismatch.count >= self._mismatch.cap and self._hold.positive is False:
                self._silent = max(self._silent, due)  # nothing more can change
        if self._silent:
            self._settle(t, out)
        return out
