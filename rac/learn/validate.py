"""Learned observers checked against the runs they were learned from.

A model learned from fault-free runs must find those runs fault-free.  After learning, the
training runs are replayed through the learned model's frequency (GObs) and binary
qualitative (BiQObs) observers, exactly as ``racc replay`` runs them; a relation whose
observer reads "not matched", or a rate whose observer reads "not ok", anywhere in a
training run is a false alarm waiting to happen and is dropped (with a comment saying
why).  So is a relation whose observer came near "not matched": its mismatch count (the θ
rule) rose above half of θ, so that a next recording, which the learner never saw, needs
little more to make it flip.  Each run is replayed on its own, so no observer sees the seam
between two runs.
"""

from __future__ import annotations

from dataclasses import dataclass

from rac.ir import Model
from rac.learn.recording import Recording, message_stream
from rac.observe.base import Observer
from rac.observe.biqobs import BiQObs
from rac.observe.build import build_all
from rac.observe.events import Message
from rac.passes.observers import ObserverSpec
from rac.pipeline import compile_model

CHECKED = ("GObs", "BiQObs")


@dataclass(frozen=True, slots=True)
class Failure:
    kind: str  # GObs or BiQObs
    index: int  # the topic's position in model.topics, or the relation's in model.related
    run: str  # the training run it failed on
    at: float  # seconds from that run's start
    near: bool = False  # it came near a fault (a BiQObs's count above θ/2), not to one


def failures(model: Model, recording: Recording) -> tuple[Failure, ...]:
    """The GObs and BiQObs of ``model`` that report a fault on a run of ``recording``."""
    specs = [s for s in compile_model(model).observers if s.kind in CHECKED]
    where = _positions(model)
    # A grid of models learned from one recording shares most observers: each spec (its
    # kind and parameters) is replayed once, and its outcome remembered.
    memo = _MEMO.setdefault(id(recording), (recording, {}))
    if memo[0] is not recording:
        memo = _MEMO[id(recording)] = (recording, {})
    known = memo[1]
    todo = [s for s in specs if (s.kind, s.params) not in known]
    for spec, outcome in zip(todo, _replay(todo, recording), strict=True):
        known[(spec.kind, spec.params)] = outcome
    found = []
    for spec in specs:
        outcome = known[(spec.kind, spec.params)]
        if outcome is not None:
            kind, index = where[str(spec.atoms[0])]
            found.append(Failure(kind, index, outcome[0], outcome[1], outcome[2]))
    return tuple(sorted(found, key=lambda f: (f.kind, f.index)))


Outcome = tuple[str, float, bool]  # run, time, only near a fault
_MEMO: dict[int, tuple[Recording, dict[tuple[str, object], Outcome | None]]] = {}


def _near(obs: Observer) -> bool:
    """A relation observer whose θ counter stands above half of θ: near "not matched"."""
    counter = getattr(obs, "_mismatch", None) if isinstance(obs, BiQObs) else None
    return counter is not None and 2 * counter.count > counter.theta


def _replay(specs: list[ObserverSpec], recording: Recording) -> list[Outcome | None]:
    """Per spec, the run and time of its first fault (or near fault) on the recording."""
    failed: dict[int, Outcome] = {}
    for segment, run in enumerate(recording.runs):
        # Each observer on its own, dropped once it has failed: most false relations fail
        # early, and the rest of the run need not be replayed for them.
        readers: dict[str, list[tuple[int, Observer]]] = {}
        for i, obs in enumerate(build_all(specs)):
            if i not in failed:
                for topic, _ in obs.needs.topics:
                    readers.setdefault(topic, []).append((i, obs))
        for message in _stream(recording, segment, frozenset(readers)):
            for i, obs in readers.get(message.topic, ()):
                if i in failed:
                    continue
                if any(not v.positive for v in obs.feed(message)):
                    failed[i] = (run.path, message.t, False)
                elif _near(obs):
                    failed[i] = (run.path, message.t, True)
    return [failed.get(i) for i in range(len(specs))]


def _positions(model: Model) -> dict[str, tuple[str, int]]:
    """The atom an observer reports -> (its kind, the topic's or relation's position)."""
    compiled = compile_model(model)
    out: dict[str, tuple[str, int]] = {}
    regular = [i for i, t in enumerate(model.topics) if t.regular]
    gobs = [s for s in compiled.observers if s.kind == "GObs"]
    for i, spec in zip(regular, gobs, strict=True):
        out[str(spec.atoms[0])] = ("GObs", i)
    biq = [s for s in compiled.observers if s.kind == "BiQObs"]
    for i, spec in enumerate(biq):
        out[str(spec.atoms[0])] = ("BiQObs", i)
    return out


# Learning a grid of models checks each against the same recording: build its message
# streams once.  Keyed by the recording's identity, which the cache keeps alive.
_STREAMS: dict[tuple[int, int], tuple[Recording, frozenset[str], list[Message]]] = {}


def _stream(recording: Recording, segment: int, topics: frozenset[str]) -> list[Message]:
    """Run ``segment``'s messages on ``topics``, times from its first message."""
    hit = _STREAMS.get((id(recording), segment))
    if hit is not None and hit[0] is recording and topics <= hit[1]:
        return [m for m in hit[2] if m.topic in topics]
    mine = [t for t in recording.topics if (t.segments == segment).any()]
    origin = min((float(t.times[t.segments == segment][0]) for t in mine), default=0.0)
    every = frozenset(t.name for t in mine)
    messages = message_stream(mine, origin, segment)
    if len(_STREAMS) >= 4:
        _STREAMS.pop(next(iter(_STREAMS)))
    _STREAMS[(id(recording), segment)] = (recording, every, messages)
    return [m for m in messages if m.topic in topics]


def prepare(recording: Recording) -> None:
    """Build the message streams of every run now (before forking workers that share them)."""
    every = frozenset(t.name for t in recording.topics)
    for segment in range(len(recording.runs)):
        _stream(recording, segment, every)
