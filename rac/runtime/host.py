"""The observer host: every observer of a model in one process (one ObserverBank).

It keeps the current verdict of every atom, so that a transport can publish the whole
observation set (one status per literal) whenever a verdict changes and again
periodically for late subscribers, and logs each change with its time.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable, Mapping

from rac.logic import Atom
from rac.observe import Event, Message, ObserverBank, Verdict
from rac.passes.observers import ObserverSpec
from rac.runtime.status import Row, literal_row


class ObserverHost:
    """Thread-safe: a transport may feed it from several callback threads."""

    def __init__(
        self, specs: Iterable[ObserverSpec], clock: Callable[[], float] | None = None
    ) -> None:
        self.specs = tuple(specs)
        self.bank = ObserverBank(self.specs)
        # Seconds since the host started: small numbers keep the observers' running sums
        # (regressions over time) accurate, which epoch seconds (~1.8e9) would not.
        start = time.monotonic()
        self.clock = clock or (lambda: time.monotonic() - start)
        self.owner: dict[Atom, str] = {a: s.name for s in self.specs for a in s.atoms}
        self.current: dict[Atom, Verdict] = {}
        self.changes: list[Verdict] = []  # since the last ``take_changes``
        self.errors: list[str] = []  # observers that failed on an event, for the log
        self._lock = threading.Lock()
        self._last_t = float("-inf")

    @property
    def atoms(self) -> tuple[Atom, ...]:
        return tuple(self.owner)

    def _now(self) -> float:
        # Every stream must see non-decreasing times, whatever thread delivers the event.
        self._last_t = max(self._last_t, self.clock())
        return self._last_t

    def message(self, topic: str, values: Mapping[str, float]) -> None:
        with self._lock:
            self._feed(Message(self._now(), topic, values))

    def feed(self, events: Iterable[Event]) -> None:
        """Events of their own streams (node samples, statuses, channels), already timed."""
        with self._lock:
            for e in events:
                self._feed(e)

    def advance(self) -> None:
        with self._lock:
            self._keep(self.bank.advance(self._now()))

    def _feed(self, event: Event) -> None:
        try:
            self._keep(self.bank.feed(event))
        except (ArithmeticError, ValueError) as err:  # one bad event must not stop the host
            self.errors.append(f"{type(event).__name__} at t={event.t:.3f}: {err}")

    def _keep(self, verdicts: list[Verdict]) -> None:
        for v in verdicts:
            self.current[v.atom] = v
            self.changes.append(v)

    def take_changes(self) -> list[Verdict]:
        with self._lock:
            out, self.changes = self.changes, []
            return out

    def take_errors(self) -> list[str]:
        with self._lock:
            out, self.errors = self.errors, []
            return out

    def rows(self) -> tuple[Row, ...]:
        """One status per current literal, sorted by atom."""
        with self._lock:
            verdicts = sorted(self.current.values(), key=lambda v: v.atom)
        return tuple(literal_row(v, self.owner.get(v.atom, "")) for v in verdicts)

    def all_ok(self) -> bool:
        """Every atom reported, and positively."""
        with self._lock:
            return len(self.current) == len(self.owner) and all(
                v.positive for v in self.current.values()
            )


def change_line(v: Verdict, observer: str) -> str:
    """A log line for one verdict change, greppable: ``t=… observation not_ok(pose) …``."""
    return f"t={v.t:.3f} observation {v} (by {observer})"
