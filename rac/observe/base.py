"""What every observer shares: the θ rule, reporting on change, and its inputs.

**The θ rule** (Algorithms 1, 2, 3, 5, 7 and 8, lines "mismatch"): one counter per observer,
decremented on a satisfied check while above zero, incremented on a violated one; the
verdict is negative while the counter exceeds θ.  The text calls it the number of
*consecutive* violations but never bounds it, so a node that was down for ten minutes would
need ten minutes of good samples before it read running again.  We bound it at 2θ + 1: a
fault still needs θ + 1 net violations to show, and a recovery needs θ + 1 net good checks to
clear, whatever the fault's length.  Any sequence that keeps the counter at or below 2θ + 1
gives the text's verdicts exactly.

**Reporting**: an observer returns a verdict only when it changes; the first one counts as a
change, and nothing is reported before the first check.  :class:`Hold` adds a pending time
(Prometheus' ``for:``): a new verdict is reported only once it has stood for a while.

**Starvation**: an observer that judges time (:class:`TimingObserver`) is told when the
process feeding it was starved of CPU, so that late deliveries do not read as faults.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Protocol, runtime_checkable

from rac.logic import Atom
from rac.observe.events import Event, Verdict
from rac.passes.observers import ObserverSpec


@dataclass(frozen=True, slots=True)
class Needs:
    """The inputs an observer reads, so that a bank can route events to it."""

    topics: tuple[tuple[str, tuple[str, ...]], ...] = ()  # (topic, fields it reads)
    nodes: tuple[str, ...] = ()  # liveness samples (NObs)
    properties: tuple[tuple[str, str], ...] = ()  # (node, cpu|mem) samples (PObs)
    devices: tuple[str, ...] = ()  # /diagnostics devices (DObs)
    channels: tuple[int, ...] = ()  # board channels (HObs)


class Observer(Protocol):
    spec: ObserverSpec
    needs: Needs
    # Whether time passing alone can change a verdict: False for the observers whose
    # advance() has nothing to do, which a bank then never calls (replay calls it every
    # 0.1 s of the recording, and a two-day recording is 1.8 million times).
    timed: ClassVar[bool]

    def feed(self, event: Event) -> list[Verdict]:
        """An input routed to this observer; the verdicts that changed."""
        ...

    def advance(self, t: float) -> list[Verdict]:
        """Time ``t`` has come with no input for this observer; the verdicts that changed."""
        ...


class Mismatch:
    """The θ rule's counter (see the module docstring)."""

    __slots__ = ("cap", "count", "theta")

    def __init__(self, theta: int) -> None:
        self.theta = theta
        self.cap = 2 * theta + 1
        self.count = 0

    def check(self, satisfied: bool) -> bool:
        """Count one check; True while the verdict is positive."""
        if satisfied:
            if self.count > 0:
                self.count -= 1
        elif self.count < self.cap:
            self.count += 1
        return self.count <= self.theta


@runtime_checkable
class TimingObserver(Protocol):
    """An observer whose checks depend on when inputs arrive (GObs)."""

    def starved(self, t: float, starved: bool) -> list[Verdict]:
        """From ``t`` on, the process that times the inputs is (or is no longer) starved:
        while it is, and until late arrivals have left the observer's window, timing
        violations are not counted and no new negative verdict is reported."""
        ...


class Latch:
    """Remembers the last verdict of one atom and reports only changes."""

    __slots__ = ("atom", "positive")

    def __init__(self, atom: Atom) -> None:
        self.atom = atom
        self.positive: bool | None = None

    def report(self, t: float, positive: bool, out: list[Verdict]) -> None:
        if positive is not self.positive:
            self.positive = positive
            out.append(Verdict(t, self.atom, positive))


class Hold:
    """A :class:`Latch` whose verdict changes only after the new one has stood for
    ``hold_s`` (hysteresis in time): a candidate that flips back before then is never
    reported.  The first verdict is reported at once.  A negative candidate that is not
    allowed to fall (``may_fall`` False: the observer's timing is in doubt) is not
    pending at all; its hold starts when it may fall again."""

    __slots__ = ("hold_s", "latch", "since")

    def __init__(self, atom: Atom, hold_s: float) -> None:
        self.latch = Latch(atom)
        self.hold_s = hold_s
        self.since: float | None = None  # when the pending candidate first stood

    @property
    def positive(self) -> bool | None:
        return self.latch.positive

    def update(self, t: float, positive: bool, out: list[Verdict], may_fall: bool = True) -> None:
        current = self.latch.positive
        if positive is current or (not positive and not may_fall):
            self.since = None
            return
        if current is None:
            self.latch.report(t, positive, out)
            return
        if self.since is None:
            self.since = t
        if t - self.since >= self.hold_s:
            self.latch.report(self.since + self.hold_s, positive, out)
            self.since = None


def plain_node(name: str) -> str:
    """A node name as the model writes it: no leading '/'."""
    return name.strip().lstrip("/")
