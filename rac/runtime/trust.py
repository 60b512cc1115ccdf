"""racc's own messages carry a seal: proof that a racc process of this robot sent them, now.

Anyone on a ROS graph can publish on any topic: ROS 1 has no authentication at all, and
ROS 2 has it only inside an SROS2 enclave.  racc's nodes steer each other through topics
(observations, diagnoses, repair requests, confirmations, board switching), so each such
message is sealed by its sender and checked by its receiver, as Kubernetes admits only
authenticated requests:

- the **key** is a secret of the robot's user (a file only that user can read,
  :mod:`rac.load.secret`), the same for every racc process of the robot;
- the **seal** is ``racc-seal/1 ROLE SENDER T NONCE MAC``: the sender's role (``observer``,
  ``engine``, ``repairer``, ``board_client``, ``operator``), its name, its wall-clock time,
  a random nonce, and an HMAC-SHA256 with the key over all of them, the message's
  *purpose* (its topic, ``/observations``, or for a node's private topic a word,
  ``confirm``, ``agent:arm``: one message cannot stand for another) and its body (the
  rows, the text);
- a **gate** admits a sealed message when its MAC is right, its role is one the purpose
  accepts, its time is within ``max_age_s`` of the receiver's clock and (but on a latched
  topic, whose last message reaches late subscribers) not before the receiver started, and
  it is later than the last one admitted from that sender for that purpose (a replay is
  never later).

What a gate refuses is counted and reported once per sender and reason
(:class:`Refusals`), never acted on.  The seal travels in ``header.frame_id`` of a
``DiagnosticArray`` and after the body of a ``String`` or a ``KeyValue``'s value, on a
line of its own, so that ``rostopic echo`` still shows the body first.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import secrets
import threading
import time
from collections.abc import Callable, Collection, Iterable
from dataclasses import dataclass

from rac.passes.observers import BOARD_TOPIC
from rac.runtime.status import DIAGNOSIS, OBSERVATIONS, WARN, Row

SEAL = "racc-seal/1"
MAX_AGE_S = 10.0  # how far a sealed message's time may be from the receiver's clock
KEY_BYTES = 32

# The roles racc's processes seal as, and the purposes each may seal.
OBSERVER, ENGINE, REPAIRER, BOARD_CLIENT, OPERATOR = (
    "observer",
    "engine",
    "repairer",
    "board_client",
    "operator",
)
# The purposes a message is sealed for: the topic of the shared ones, a word for the
# private ones (a node's ~confirm resolves to another name in each namespace).
BOARD_SWITCH = "/board_switch"
CONFIRM = "confirm"
RELOAD = "reload"
AGENT = "agent:"  # + the machine's name
ROLES_OF = {
    OBSERVATIONS: frozenset({OBSERVER}),
    DIAGNOSIS: frozenset({ENGINE}),
    CONFIRM: frozenset({OPERATOR}),
    BOARD_SWITCH: frozenset({REPAIRER}),
    BOARD_TOPIC: frozenset({BOARD_CLIENT}),
    RELOAD: frozenset({OPERATOR, REPAIRER}),
}


def roles_of(purpose: str) -> frozenset[str]:
    """The roles whose seal a gate of ``purpose`` accepts."""
    if purpose.startswith(AGENT):
        return frozenset({REPAIRER})
    return ROLES_OF.get(purpose, frozenset())


def rows_body(rows: Iterable[Row]) -> bytes:
    """The bytes a seal covers for an array of statuses (the same on every ROS)."""
    return json.dumps(
        [[r.name, r.level, r.message, r.hardware_id, [list(kv) for kv in r.values]] for r in rows],
        ensure_ascii=False,
        separators=(",", ":"),
    ).encode()


def text_body(text: str) -> bytes:
    return text.encode()


@dataclass(frozen=True, slots=True)
class Seal:
    role: str
    sender: str
    t: float
    nonce: str
    mac: str

    def __str__(self) -> str:
        return f"{SEAL} {self.role} {self.sender} {self.t:.6f} {self.nonce} {self.mac}"


def parse_seal(text: str) -> Seal | None:
    parts = text.strip().split(" ")
    if len(parts) != 6 or parts[0] != SEAL:
        return None
    try:
        t = float(parts[3])
    except ValueError:
        return None
    return Seal(parts[1], parts[2], t, parts[4], parts[5])


def _mac(key: bytes, purpose: str, role: str, sender: str, t: str, nonce: str, body: bytes) -> str:
    head = "\n".join((SEAL, purpose, role, sender, t, nonce)).encode()
    return hmac.new(key, head + b"\n" + body, hashlib.sha256).hexdigest()


class Sealer:
    """What a racc process seals its messages with: the key, its role and its name."""

    def __init__(
        self, key: bytes, role: str, sender: str, clock: Callable[[], float] = time.time
    ) -> None:
        self.key, self.role, self.sender, self.clock = key, role, sender, clock

    def seal(self, purpose: str, body: bytes) -> Seal:
        t = f"{self.clock():.6f}"
        nonce = secrets.token_hex(8)
        mac = _mac(self.key, purpose, self.role, self.sender, t, nonce, body)
        return Seal(self.role, self.sender, float(t), nonce, mac)

    def seal_text(self, purpose: str, text: str) -> str:
        """``text`` with its seal on a line of its own after it."""
        return f"{text}\n{self.seal(purpose, text_body(text))}"


@dataclass(frozen=True, slots=True)
class Admitted:
    sender: str
    role: str
    t: float


@dataclass(frozen=True, slots=True)
class Refused:
    sender: str  # the claimed sender ("" when the message had no seal)
    reason: str  # "unsealed", "bad seal", "not a racc repairer", "stale", "replayed", ...

    def __str__(self) -> str:
        return f"{self.reason} ({self.sender or 'no sender'})"


def split_text(text: str) -> tuple[str, str]:
    """A sealed text's (body, seal line); an unsealed one has no seal line ("")."""
    body, sep, last = text.rpartition("\n")
    if sep and last.startswith(SEAL + " "):
        return body, last
    return text, ""


class Gate:
    """Admits the sealed messages of one purpose (module docstring); not thread-safe (a
    transport calls it from the callback that received the message)."""

    def __init__(
        self,
        key: bytes,
        purpose: str,
        *,
        senders: Collection[str] = (),
        max_age_s: float = MAX_AGE_S,
        clock: Callable[[], float] = time.time,
        latched: bool = False,
    ) -> None:
        self.key, self.purpose = key, purpose
        # A latched topic's last message reaches a receiver that starts later: one sealed
        # before the receiver started is no replay there (its age is still bounded).
        self.latched = latched
        self.roles = roles_of(purpose)
        self.senders = frozenset(s.strip("/") for s in senders)  # empty: any of the roles
        self.max_age_s = max_age_s
        self.clock = clock
        self.started = clock()
        self._last: dict[str, float] = {}

    def admit(self, seal_text: str, body: bytes) -> Admitted | Refused:
        seal = parse_seal(seal_text) if seal_text else None
        if seal is None:
            return Refused("", "unsealed")
        want = _mac(
            self.key, self.purpose, seal.role, seal.sender, f"{seal.t:.6f}", seal.nonce, body
        )
        if not hmac.compare_digest(want, seal.mac):
            return Refused(seal.sender, "bad seal (another key, or altered)")
        if seal.role not in self.roles:
            allowed = " or ".join(sorted(self.roles)) or "nobody"
            return Refused(seal.sender, f"sealed by a racc {seal.role}; only a {allowed} may")
        if self.senders and seal.sender.strip("/") not in self.senders:
            return Refused(seal.sender, "not one of the senders this launch names")
        now = self.clock()
        if abs(now - seal.t) > self.max_age_s:
            return Refused(seal.sender, f"stale: sent {now - seal.t:+.1f} s from now")
        if seal.t < self.started and not self.latched:
            return Refused(seal.sender, "replayed: sent before this node started")
        last = self._last.get(seal.sender)
        if last is not None and seal.t <= last:
            return Refused(seal.sender, "replayed: not later than the last one admitted")
        self._last[seal.sender] = seal.t
        return Admitted(seal.sender, seal.role, seal.t)

    def admit_text(self, text: str) -> tuple[str, Admitted | Refused]:
        """A sealed text: its body and what the gate says of it."""
        body, seal = split_text(text)
        return body, self.admit(seal, text_body(body))


@dataclass(slots=True)
class _Count:
    first: float
    last: float
    count: int


class Refusals:
    """What this node refused and ignored, by (source, topic, reason): each new one is
    logged once (:meth:`note` says so), and all are a status on ``/diagnostics``."""

    def __init__(self, node: str, clock: Callable[[], float] = time.time) -> None:
        self.node, self.clock = node, clock
        self._seen: dict[tuple[str, str, str], _Count] = {}

    def note(self, source: str, topic: str, reason: str) -> bool:
        """Count one; True the first time this source, topic and reason came together."""
        now = self.clock()
        key = (source, topic, reason)
        seen = self._seen.get(key)
        if seen is None:
            self._seen[key] = _Count(now, now, 1)
            return True
        seen.last, seen.count = now, seen.count + 1
        return False

    def __bool__(self) -> bool:
        return bool(self._seen)

    def row(self) -> Row:
        """``NODE: ignored``: OK while nothing was refused, WARN once something was."""
        name = f"{self.node}: ignored"
        if not self._seen:
            return Row(name, 0, "nothing ignored: every message came from where it should")
        parts = [
            f"{source or 'unknown'} on {topic}: {reason} ({c.count}x, last t={c.last:.1f})"
            for (source, topic, reason), c in sorted(self._seen.items())
        ]
        shown = "; ".join(parts[:5]) + (f"; +{len(parts) - 5} more" if len(parts) > 5 else "")
        values = tuple(
            (f"{source or 'unknown'} {topic}", f"{reason}: {c.count}")
            for (source, topic, reason), c in sorted(self._seen.items())
        )
        return Row(name, WARN, f"ignored {shown}", "", values[:50])


def refused_line(t: float, node: str, topic: str, refused: Refused | str, source: str = "") -> str:
    """The log line of a first refusal: ``t=… ignored /observations from X: bad seal …``."""
    who = source or (refused.sender if isinstance(refused, Refused) else "") or "an unknown sender"
    why = refused.reason if isinstance(refused, Refused) else refused
    return f"t={t:.3f} {node} ignored {topic} from {who}: {why}; reported once, never acted on"


class Trust:
    """One racc node's seal and gates: what it sends is sealed with its role and name, what
    it receives from racc passes a gate, and what a gate (or a transport's own check of
    publishers) refuses is logged once and counted in :attr:`refusals`.  Thread-safe."""

    def __init__(
        self,
        key: bytes,
        role: str,
        node: str,
        log: Callable[[int, str], None],
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.key, self.role, self.node = key, role, node
        self.sealer = Sealer(key, role, node, clock)
        self.refusals = Refusals(node, clock)
        self.log, self.clock = log, clock
        self._lock = threading.Lock()
        # topic -> who sealed the last rows admitted on it, and when (the sender's clock):
        # how far behind a receiver reads them (rac.runtime.diagnoser's lag)
        self.sent: dict[str, tuple[str, float]] = {}

    def gate(self, purpose: str, senders: Collection[str] = (), latched: bool = False) -> Gate:
        return Gate(self.key, purpose, senders=senders, clock=self.clock, latched=latched)

    def seal_rows(self, purpose: str, rows: Iterable[Row]) -> str:
        return str(self.sealer.seal(purpose, rows_body(rows)))

    def seal_text(self, purpose: str, text: str) -> str:
        return self.sealer.seal_text(purpose, text)

    def seal_kv(self, purpose: str, key: str, value: str) -> str:
        """A ``KeyValue``'s value with its seal on a line of its own; the seal covers the
        key too (a device or an action cannot be swapped under it)."""
        seal = self.sealer.seal(purpose, text_body(f"{key}={value}"))
        return f"{value}\n{seal}"

    def check_kv(self, topic: str, gate: Gate, key: str, value: str) -> tuple[str, str] | None:
        """The value of a sealed ``KeyValue`` and its sender, or None when it is refused."""
        body, seal = split_text(value)
        with self._lock:
            verdict = gate.admit(seal, text_body(f"{key}={body}"))
        if isinstance(verdict, Refused):
            self.refuse(verdict.sender, topic, verdict.reason)
            return None
        return body, verdict.sender

    def check_rows(self, topic: str, gate: Gate, seal_text: str, rows: Iterable[Row]) -> bool:
        """Whether the rows a message carries may be acted on."""
        with self._lock:
            verdict = gate.admit(seal_text, rows_body(rows))
        if isinstance(verdict, Refused):
            self.refuse(verdict.sender, topic, verdict.reason)
            return False
        self.sent[topic] = (verdict.sender, verdict.t)
        return True

    def check_text(self, topic: str, gate: Gate, text: str) -> tuple[str, str] | None:
        """The body of a sealed text and its sender, or None when it is refused."""
        with self._lock:
            body, verdict = gate.admit_text(text)
        if isinstance(verdict, Refused):
            self.refuse(verdict.sender, topic, verdict.reason)
            return None
        return body, verdict.sender

    def refuse(self, source: str, topic: str, reason: str) -> None:
        """Count a refused message; log the first of its kind."""
        with self._lock:
            first = self.refusals.note(source, topic, reason)
        if first:
            self.log(WARN, refused_line(self.clock(), self.node, topic, reason, source))

    def row(self) -> Row:
        with self._lock:
            return self.refusals.row()


def confirm_body(plan: str, run: str = "") -> str:
    """The text of an operator's confirmation of advised plan ``plan`` of repairer run
    ``run`` (sealed by ``racc confirm``)."""
    return json.dumps({"plan": plan, "run": run}, separators=(",", ":"))


def read_confirm(body: str) -> tuple[str, str]:
    """(plan, run) of a confirmation; a bare id (``3``) names no run."""
    try:
        data = json.loads(body)
    except ValueError:
        return body.strip(), ""
    if isinstance(data, dict):
        return str(data.get("plan", "")).strip(), str(data.get("run", "")).strip()
    return str(data).strip(), ""


# -- what a transport hands its subscriptions (one check for every ROS and message kind) ---


def guard_rows(
    trust: Trust | None, topic: str, gate: Gate | None, callback: Callable[[list[Row]], None]
) -> Callable[[list[Row], str], None]:
    """``receive(rows, seal)`` for a status-array subscription: ``callback`` with the rows
    a gate admits (with no gate or no trust, every array)."""

    def receive(rows: list[Row], seal: str) -> None:
        if trust is None or gate is None or trust.check_rows(topic, gate, seal, rows):
            callback(rows)

    return receive


def guard_text(
    trust: Trust | None, topic: str, gate: Gate | None, callback: Callable[[str, str], None]
) -> Callable[[str], None]:
    """``receive(text)`` for a ``String`` subscription: ``callback(body, sender)`` with what a
    gate admits (with no gate or no trust, every text, sender "")."""

    def receive(text: str) -> None:
        if trust is None or gate is None:
            callback(text, "")
            return
        admitted = trust.check_text(topic, gate, text)
        if admitted is not None:
            callback(*admitted)

    return receive


def guard_kv(
    trust: Trust | None, topic: str, gate: Gate | None, callback: Callable[[str, str], None]
) -> Callable[[str, str], None]:
    """``receive(key, value)`` for a ``KeyValue`` subscription: ``callback(key, value)``
    with what a gate admits, the value without its seal (with no gate or no trust, all)."""

    def receive(key: str, value: str) -> None:
        if trust is None or gate is None:
            callback(key, value)
            return
        admitted = trust.check_kv(topic, gate, key, value)
        if admitted is not None:
            callback(key, admitted[0])

    return receive
