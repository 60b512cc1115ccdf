"""Learned observers checked against the runs they were learned from.

A model learned from fault-free runs must find those runs fault-free.  After learning, the
training runs are replayed through the learned model's frequency (GObs) and binary
qualitative (BiQObs) observers, exactly as ``racc replay`` runs them; a relation whose
observer reads "not matched", or a rate whose observer reads "not ok", anywhere in a
training run is a false alarm waiting to happen and is dropped (with a comment saying
why).  Each run is replayed on its own, so no observer sees the seam between two runs.
"""

from __future__ import annotations

from dataclasses import dataclass

from rac.ir import Model
from rac.learn.recording import Recording, message_stream
from rac.observe.bank import ObserverBank
from rac.pipeline import compile_model

CHECKED = ("GObs", "BiQObs")


@dataclass(frozen=True, slots=True)
class Failure:
    kind: str  # GObs or BiQObs
    index: int  # the topic's position in model.topics, or the relation's in model.related
    run: str  # the training run it failed on
    at: float  # seconds from that run's start


def failures(model: Model, recording: Recording) -> tuple[Failure, ...]:
    """The GObs and BiQObs of ``model`` that report a fault on a run of ``recording``."""
    specs = [s for s in compile_model(model).observers if s.kind in CHECKED]
    if not specs:
        return ()
    where = _positions(model)
    found: dict[tuple[str, int], Failure] = {}
    for segment, run in enumerate(recording.runs):
        origin = min(
            (float(t.times[t.segments == segment][0]) for t in recording.topics
             if (t.segments == segment).any()),
            default=0.0,
        )  # fmt: skip
        bank = ObserverBank(specs)
        for message in message_stream(recording.topics, origin, segment):
            for verdict in bank.feed(message):
                key = where[str(verdict.atom)]
                if not verdict.positive and key not in found:
                    found[key] = Failure(key[0], key[1], run.path, verdict.t)
    return tuple(sorted(found.values(), key=lambda f: (f.kind, f.index)))


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
