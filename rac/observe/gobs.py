"""GObs, the general observer (Algorithm 1 with the errata's |μ − δ| ≤ σ): ok(topic).

Parameters: ``topic``; ``delta`` δ, the expected interval (s); ``dev`` σ, the allowed
deviation of the mean interval (default δ/9, the compiler's ±10 % rate band); ``ws`` ω, the
window (default 10·δ, Equation 5.3 with c = 10); ``mismatch_th`` θ (default 5).

Decisions where the text leaves room:

- **The window** is centred on O_mid and holds the occurrences within [O_mid − ω/2,
  O_mid + ω/2] (Definition 5.4).  An occurrence beyond it triggers one check of the mean
  interval μ of the window (lines 9-21), then the window slides (lines 22-23): O_mid moves to
  the next occurrence and every occurrence now before O_mid − ω/2 leaves (the text pops one,
  which with its start at O_1 would keep only the right half of the window).  The
  occurrence that triggered the check is then tried again against the slid window, so none
  is lost; a healthy topic gets one check per occurrence.
- A window with fewer than two occurrences has no interval: that check is a violation.
- **The bound** |μ − δ| ≤ σ is taken with a slack of :data:`RESOLUTION_S` (1 ns, the
  resolution of ROS time stamps): σ comes to the observer rounded to twelve digits and μ
  from float time stamps, so a topic at exactly the slow edge of its band (the compiler's
  σ = 1/(RATE − TOL) − 1/RATE) would otherwise read as a violation by rounding alone.
- **A topic that stops** produces no occurrence, hence no check at all in the text.  Time
  (``advance`` or the next ``feed``) counts the silence: with E the end O_mid + ω/2 of the
  window when the last occurrence came, one violation is counted at each instant
  E + (k + ½)·δ, k = 1, 2, … that passes without an occurrence (half an interval of
  grace, so a jittery healthy topic never trips it).  A stopped topic with θ = 5 thus reads
  not ok at E + 6.5·δ; each such verdict carries the instant it was counted at.  When an
  occurrence comes after a counted silence, the stale window is dropped and a new one
  starts at that occurrence (as line 2 does), so stale intervals never count as good ones.
- Nothing is reported before the first check, so a topic that never publishes gets no
  verdict.
"""

from __future__ import annotations

import math
from collections import deque

from rac.observe.base import Latch, Mismatch, Needs
from rac.observe.events import Event, Message, Verdict
from rac.observe.params import Params
from rac.passes.observers import DEFAULT_MISMATCH_THRESHOLD, ObserverSpec

RESOLUTION_S = 1e-9  # deviations of the mean interval below this are not measurable


class GObs:
    def __init__(self, spec: ObserverSpec) -> None:
        p = Params(spec)
        self.spec = spec
        self.topic = p.text("topic")
        self.delta = p.positive("delta")
        self.dev = p.positive("dev", self.delta / 9)
        self.ws = p.positive("ws", 10 * self.delta)
        self.needs = Needs(topics=((self.topic, ()),))
        self._half = self.ws / 2
        self._mismatch = Mismatch(p.count("mismatch_th", DEFAULT_MISMATCH_THRESHOLD))
        self._latch = Latch(p.atom())
        # The window: ``_left`` ends with O_mid, ``_right`` holds the occurrences after it.
        self._left: deque[float] = deque()
        self._right: deque[float] = deque()
        self._end = math.nan  # E: the window's end when the last occurrence came
        self._silent = 0  # violations counted for the current silence

    def feed(self, event: Event) -> list[Verdict]:
        if not isinstance(event, Message) or event.topic != self.topic:
            return []
        out = self._count_silence(event.t)
        t = event.t
        if not self._left or self._silent:
            # The first occurrence (line 2), or the first after a counted silence.
            self._left.clear()
            self._right.clear()
            self._left.append(t)
        else:
            placed = False
            while not placed and t > self._left[-1] + self._half:
                self._check(t, out)
                placed = self._slide(t)
            if not placed:
                self._right.append(t)
        self._silent = 0
        self._end = self._left[-1] + self._half
        return out

    def advance(self, t: float) -> list[Verdict]:
        return self._count_silence(t)

    def _check(self, t: float, out: list[Verdict]) -> None:
        n = len(self._left) + len(self._right)
        last = self._right[-1] if self._right else self._left[-1]
        # μ = mean(ΔW) (Equation 5.2): the intervals telescope to (last − first)/(n − 1).
        mu = (last - self._left[0]) / (n - 1) if n >= 2 else math.inf
        good = abs(mu - self.delta) <= self.dev + RESOLUTION_S
        self._latch.report(t, self._mismatch.check(good), out)

    def _slide(self, t: float) -> bool:
        """O_mid becomes the next occurrence, ``t`` itself when the window has none after
        O_mid (then True: ``t`` is in the window)."""
        placed = not self._right
        self._left.append(t if placed else self._right.popleft())
        low = self._left[-1] - self._half
        while self._left[0] < low:
            self._left.popleft()
        return placed

    def _count_silence(self, t: float) -> list[Verdict]:
        out: list[Verdict] = []
        if not self._left:
            return out
        # Violations due by t: instants E + (k + ½)δ ≤ t, k ≥ 1.
        due = math.floor((t - self._end) / self.delta - 0.5)
        while self._silent < due:
            self._silent += 1
            instant = self._end + (self._silent + 0.5) * self.delta
            self._latch.report(instant, self._mismatch.check(False), out)
            if self._mismatch.count >= self._mismatch.cap:
                self._silent = max(self._silent, due)  # nothing more can change
        return out
