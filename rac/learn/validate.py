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

from dataclasses import dataclass, replace

from rac.ir import Model
from rac.learn.recording import Recording, message_stream
from rac.learn.summary import Mapper, serial
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


def failures(model: Model, recording: Recording, mapper: Mapper = serial) -> tuple[Failure, ...]:
    """The GObs and BiQObs of ``model`` that report a fault on a run of ``recording``;
    the runs are replayed through ``mapper`` (in parallel, when it spreads them)."""
    specs = [s for s in compile_model(model).observers if s.kind in CHECKED]
    where = _positions(model)
    # A grid of models learned from one recording shares most observers: each spec (its
    # kind and parameters) is replayed once, and its outcome remembered.
    memo = _MEMO.setdefault(id(recording), (recording, {}))
    if memo[0] is not recording:
        memo = _MEMO[id(recording)] = (recording, {})
    known = memo[1]
    todo = [s for s in specs if (s.kind, s.params) not in known]
    for spec, outcome in zip(todo, _replay(todo, recording, mapper), strict=True):
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


def _replay(
    specs: list[ObserverSpec], recording: Recording, mapper: Mapper
) -> list[Outcome | None]:
    """Per spec, the run and time of its first fault (or near fault) on the recording:
    each run replayed on its own, the first run's failure first."""
    if not specs:
        return []

    def one(segment: int) -> object:
        return _replay_run(specs, recording, segment)

    failed: dict[int, Outcome] = {}
    for found in mapper(one, list(range(len(recording.runs)))):
        assert isinstance(found, dict)
        for i, outcome in found.items():
            failed.setdefault(i, outcome)
    return [failed.get(i) for i in range(len(specs))]


def _replay_run(
    specs: list[ObserverSpec], recording: Recording, segment: int
) -> dict[int, Outcome]:
    """Per spec that fails on run ``segment``, when it first does."""
    failed: dict[int, Outcome] = {}
    run = recording.runs[segment]
    # Each observer on its own, dropped once it has failed: most false relations fail
    # early, and the rest of the run need not be replayed for them.
    readers: dict[str, list[tuple[int, Observer]]] = {}
    for i, obs in enumerate(build_all(specs)):
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
    return failed


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


def without_false_alarms(
    model: Model, recording: Recording, notes: list[str], mapper: Mapper = serial
) -> Model:
    """Drop the learned rates and relations whose observers report a fault on the
    fault-free training runs themselves (:mod:`rac.learn.validate`)."""
    failed = failures(model, recording, mapper)
    if not failed:
        return model
    topics = list(model.topics)
    dropped: list[str] = []
    bad_relations = set()
    for f in failed:
        where = f"{f.run} at {f.at:.1f} s"
        if f.kind == "GObs":
            t = topics[f.index]
            why = f"rate {t.rate_hz:g} Hz dropped: its frequency observer read not ok on {where}"
            topics[f.index] = replace(
                t,
                rate_hz=None,
                rate_tolerance_hz=None,
                window_s=None,
                mismatch_threshold=None,
                comments=(*t.comments, why),
            )
            dropped.append(f"{t.name.value} @ {t.rate_hz:g} Hz")
        else:
            r = model.related[f.index]
            bad_relations.add(f.index)
            dropped.append(f"{r.a.text} ~ {r.b.text}")
    related = tuple(r for i, r in enumerate(model.related) if i not in bad_relations)
    trailing = [
        f"dropped: relate {model.related[f.index].a.text} ~ {model.related[f.index].b.text} "
        f"(its observer {'came near' if f.near else 'read'} not matched on {f.run} at "
        f"{f.at:.1f} s)"
        for f in failed
        if f.kind == "BiQObs"
    ]
    notes.append(
        "observers that report a fault on the training runs themselves, dropped: "
        + "; ".join(dropped)
    )
    return replace(
        model,
        topics=tuple(topics),
        related=related,
        trailing_comments=(*model.trailing_comments, *trailing),
    )
