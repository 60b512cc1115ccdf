"""The diagnosis node's logic (§6.3, §6.4): Algorithm 10's collection, then minimal diagnoses.

Observations are merged into Θ as they come (:class:`rac.observe.ObservationSet`); on each
tick the engine diagnoses Θ again if it or the model changed since the last tick.  A
transport ticks at its publication rate, and sooner when Θ changes (:attr:`pending`), so
that a new fault does not wait for the next period.  The model
can be replaced at run time (§6.3's model server permits changes): Θ is kept and the next
tick diagnoses it against the new theory.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace

from rac.diagnosis import DiagnosisResult, Theory, diagnose
from rac.diagnosis.theory import known_atoms
from rac.errors import RacError
from rac.logic import NEG_PREFIX, Atom
from rac.observe import ObservationSet, Verdict
from rac.runtime.hosts import HOST_LOST_S, HostWatch, lost_line
from rac.runtime.status import (
    ERROR,
    OK,
    WARN,
    Row,
    diagnosis_rows,
    row_atom,
    row_unknown,
    row_verdict,
    summary_row,
)

MIN_GAP_S = 0.2  # between diagnoses triggered by changed observations
# Observations read this long after they were sent: the engine has fallen behind (its queue
# of arrays grows); it says so rather than diagnose the past in silence.
BEHIND_S = 1.0
# /diagnosis is published at least this often, whatever the rate: it is the engine's
# heartbeat, by which the repairer and the observer hosts know the diagnosis is live.
HEARTBEAT_S = 1.0


@dataclass(frozen=True, slots=True)
class Tick:
    result: DiagnosisResult
    rows: tuple[Row, ...]  # for /diagnosis
    summary: Row  # for /diagnostics
    changed: bool  # the diagnoses differ from the last tick's
    hosts: tuple[Row, ...] = ()  # for /diagnostics: each observer host heard or lost


class Diagnoser:
    def __init__(self, theory: Theory, robot: str, node: str, max_card: int | None = None) -> None:
        self.robot, self.node, self.max_card = robot, node, max_card
        self.observations = ObservationSet()
        self.unknown: set[Atom] = set()  # atoms the model does not know (reported once)
        self._dirty = True
        self._last: DiagnosisResult | None = None
        self.load(theory)

    def load(self, theory: Theory) -> None:
        self.theory = theory
        self._known = known_atoms(theory)
        self._dirty = True

    def observe(self, verdict: Verdict) -> bool:
        """Θ ⊕ θ; True when Θ changed.  Atoms the model does not know are set aside."""
        atom = verdict.atom
        plain = Atom(atom.predicate.removeprefix(NEG_PREFIX), atom.args)
        if plain not in self._known and atom not in self._known:
            self.unknown.add(plain)
            return False
        changed = self.observations.add(verdict)
        self._dirty |= changed
        return changed

    def forget(self, atom: Atom) -> bool:
        """Θ without ``atom``'s literal (its observer withdrew it); True when Θ changed."""
        changed = self.observations.discard(atom)
        self._dirty |= changed
        return changed

    @property
    def pending(self) -> bool:
        """Θ or the model changed since the last tick."""
        return self._dirty

    def tick(self) -> Tick:
        result = self._last
        if result is None or self._dirty:
            result = diagnose(self.theory, self.observations.literals(), self.max_card)
            self._dirty = False
        changed = self._last is None or result.diagnoses != self._last.diagnoses
        self._last = result
        return Tick(
            result,
            diagnosis_rows(result, self.robot),
            summary_row(self.node, self.robot, result, len(self.observations)),
            changed,
        )


def diagnosis_line(t: float, result: DiagnosisResult) -> str:
    if result.consistent:
        return f"t={t:.3f} diagnosis none (no fault)"
    if not result.diagnoses:
        return f"t={t:.3f} diagnosis impossible (the observations contradict the model)"
    shown = " | ".join("{" + ",".join(d) + "}" for d in result.diagnoses)
    return f"t={t:.3f} diagnosis {shown}"


def reload_refusal(target: str, folder: str | None) -> str | None:
    """Why a model at ``target`` may not be loaded on request (None: it may): only a
    regular file inside ``folder``, symbolic links resolved, never one outside it."""
    if folder is None:
        return "reloading another model on request is off (--reload-dir none)"
    real, root = os.path.realpath(target), os.path.realpath(folder)
    if os.path.commonpath([real, root]) != root:
        return f"{target} is outside the model directory {root} fixed at start"
    if not os.path.isfile(real):
        return f"{target} is not a file"
    return None


def _stamp(path: str) -> tuple[float, int] | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_mtime, st.st_size


class EngineLoop:
    """The diagnosis node's schedule, transport-free: observation arrays in (any thread),
    reload requests in, and on :meth:`step` the tick to publish when one is due (at
    ``rate_hz``, or ``MIN_GAP_S`` after Θ changed).  The model is reloaded when its file
    changes or on request; a model that does not load is reported and the old one kept.
    ``log(level, text)`` receives every decision."""

    def __init__(
        self,
        path: str,
        load: Callable[[str], Theory],
        robot: str,
        node: str,
        log: Callable[[int, str], None],
        *,
        rate_hz: float = 1.0,
        max_card: int | None = None,
        host_lost_s: float = HOST_LOST_S,
        reload_dir: str | None = None,
    ) -> None:
        self.load, self.log = load, log
        self.diagnoser = Diagnoser(load(path), robot, node, max_card)
        self.period = min(1.0 / rate_hz, HEARTBEAT_S)
        self.path, self.stamp, self.request = path, _stamp(path), ""
        # Models are reloaded only from here (None: never on request): a message on the
        # reload topic cannot make the engine read a model from anywhere else.
        self.reload_dir = reload_dir
        self.hosts = HostWatch(host_lost_s)
        self._lock = threading.Lock()
        self._last = float("-inf")
        self._lag = 0.0  # the oldest observations read since the last tick (s after sent)
        self._least: dict[str, float] = {}  # host -> the least delay its arrays have shown
        self.behind: float | None = None  # since when the engine has been behind
        self.diagnosis_s = 0.0  # how long the last diagnosis took

    def observation_rows(
        self, rows: Iterable[Row], t: float, sent: tuple[str, float] | None = None
    ) -> None:
        """An ``/observations`` array received at ``t``; ``sent``: who sealed it and when,
        on its own clock (a host's clock may be off by seconds: its lag is counted from
        the least delay it has shown)."""
        with self._lock:
            if sent is not None:
                sender, at = sent
                delay = t - at
                least = min(self._least.get(sender, delay), delay)
                self._least[sender] = least
                self._lag = max(self._lag, delay - least)
            rows = list(rows)
            self._heard(rows, t)
            for row in rows:
                withdrawn = row_unknown(row)
                if withdrawn is not None:
                    self.diagnoser.forget(withdrawn)
                    continue
                verdict = row_verdict(row, t)
                if verdict is not None:
                    self.diagnoser.observe(verdict)

    def _heard(self, rows: list[Row], t: float) -> None:
        by_host: dict[str, list[Atom]] = {}
        for row in rows:
            host = row.value("host")
            if host:
                atom = row_unknown(row) or row_atom(row)
                by_host.setdefault(host, []).extend([atom] if atom is not None else [])
        for host, atoms in by_host.items():
            if self.hosts.heard_from(host, atoms, t):
                self.log(WARN, f"t={t:.3f} observer host {host} back")

    def _lose_silent_hosts(self, now: float) -> None:
        for host, atoms in self.hosts.newly_lost(now):
            for atom in atoms:
                self.diagnoser.forget(atom)
            silent = now - self.hosts.heard[host]
            self.log(ERROR, lost_line(now, host, atoms, silent))

    def request_reload(self, target: str) -> str | None:
        """Reload the model from ``target`` (empty: the same file) at the next step; the
        reason it is refused, if it is (the engine's model directory is fixed at start)."""
        target = target.strip()
        if target and os.path.realpath(target) != os.path.realpath(self.path):
            why = reload_refusal(target, self.reload_dir)
            if why is not None:
                return why
        with self._lock:
            self.request = target or self.path
        return None

    def step(self, now: float) -> Tick | None:
        with self._lock:
            pending = self.diagnoser.pending
            request, self.request = self.request, ""
        since = now - self._last
        if not (since >= self.period or (pending and since >= MIN_GAP_S)) and not request:
            return None
        self._last = now
        if request:
            self._reload(request, now)
        elif _stamp(self.path) != self.stamp:
            self._reload(self.path, now)
        with self._lock:
            self._lose_silent_hosts(now)
            began = time.perf_counter()
            tick = self.diagnoser.tick()
            self.diagnosis_s = time.perf_counter() - began
            lag, self._lag = self._lag, 0.0
            tick = replace(
                tick,
                hosts=(*self.hosts.rows(self.diagnoser.node, now), self._pace(now, lag)),
            )
        if tick.changed:
            self.log(OK, diagnosis_line(now, tick.result))
        return tick

    def _pace(self, now: float, lag: float) -> Row:
        """Whether the engine keeps up (``NODE: pace`` on /diagnostics); falling behind and
        catching up again are logged."""
        name = f"{self.diagnoser.node}: pace"
        values = (("lag_s", f"{lag:.2f}"), ("diagnosis_s", f"{self.diagnosis_s:.3f}"))
        if lag > BEHIND_S:
            if self.behind is None:
                self.behind = now
                self.log(
                    ERROR,
                    f"t={now:.3f} engine behind: observations read {lag:.1f} s after they "
                    f"were sent (the last diagnosis took {self.diagnosis_s:.2f} s); its "
                    "diagnoses are that late",
                )
            return Row(name, WARN, f"behind: observations read {lag:.1f} s late", "", values)
        if self.behind is not None:
            self.log(WARN, f"t={now:.3f} engine caught up, after {now - self.behind:.1f} s behind")
            self.behind = None
        return Row(name, OK, f"keeping up (observations {lag:.2f} s old)", "", values)

    def _reload(self, target: str, now: float) -> None:
        try:
            theory = self.load(target)
        except RacError as err:
            self.log(
                ERROR,
                f"racc engine: model {target} not reloaded, keeping the old one:\n" + err.render(),
            )
            return
        with self._lock:
            self.diagnoser.load(theory)
            self.path, self.stamp = target, _stamp(target)
        self.log(
            OK,
            f"t={now:.3f} model reloaded from {target} ({len(theory.clauses)} clauses, "
            f"{len(theory.components)} components)",
        )
