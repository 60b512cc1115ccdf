"""What replay and evaluate load: a model with observers, and runs with their inputs."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from rac.diagnosis.theory import Theory, theory_of
from rac.errors import Diagnostic, RacError
from rac.load.faults import load_truth
from rac.load.files import is_file
from rac.observe.bank import ObserverBank
from rac.passes.observers import ObserverSpec
from rac.pipeline import Compiled
from rac.replay.sources import Needs, RunInputs, load_run, properties_beside, shifted
from rac.synth.truth import GroundTruth, truth_path


@dataclass(frozen=True, slots=True)
class Replayable:
    """A compiled model as replay needs it: its observers and its diagnosis theory."""

    name: str
    specs: tuple[ObserverSpec, ...]
    theory: Theory


def replayable(compiled: Compiled, name: str | None = None) -> Replayable:
    theory = theory_of(compiled)
    return Replayable(name or compiled.model.name.value, compiled.observers, theory)


def needs_of(models: Sequence[Replayable]) -> Needs:
    """The union of what the models' observers read from a recording."""
    fields: dict[str, set[str]] = {}
    nodes: set[str] = set()
    diagnostics = False
    board = False
    for m in models:
        bank = ObserverBank(m.specs)
        board = board or bank.needs_board
        for topic, wanted in bank.topic_fields().items():
            fields.setdefault(topic, set()).update(wanted)
        nodes.update(bank.nodes)
        nodes.update(n for n, _ in bank.properties)
        diagnostics = diagnostics or bool(bank.devices)
    return Needs({t: frozenset(f) for t, f in fields.items()}, frozenset(nodes), diagnostics, board)


def properties_for(runs: Sequence[str], given: Sequence[str]) -> list[str | None]:
    """One properties CSV per run: as given (in order), else the one beside the run if any."""
    if given and len(given) != len(runs):
        message = (
            f"{len(given)} --properties for {len(runs)} runs: give one per run, in the runs' "
            "order, or none (then RUN.properties.csv beside each run is used when it exists)"
        )
        raise RacError([Diagnostic("RAC051", message)])
    if given:
        return list(given)
    out: list[str | None] = []
    for run in runs:
        beside = properties_beside(run)
        out.append(str(beside) if is_file(beside) else None)
    return out


def load_runs(runs: Sequence[str], properties: Sequence[str | None], needs: Needs) -> RunInputs:
    """Several runs as one recording, back to back (as learning merges them)."""
    parts = [load_run(r, needs, p) for r, p in zip(runs, properties, strict=True)]
    if len(parts) == 1:
        return parts[0]
    events = []
    offset = 0.0
    for part in parts:
        events.extend(shifted(part.events, offset))
        offset += part.duration
    return RunInputs(
        path=", ".join(p.path for p in parts),
        start=parts[0].start,
        duration=offset,
        events=tuple(events),
        messages=sum(p.messages for p in parts),
        notes=tuple(n for p in parts for n in p.notes),
        recorded=sum(p.recorded for p in parts) if all(p.recorded for p in parts) else 0,
        topics=max((p.topics for p in parts), default=0),
    )


def truth_for(
    runs: Sequence[str], explicit: str | None, notes: list[str] | None = None
) -> GroundTruth | None:
    """The injected faults: the file given, else RUN.faults.yaml beside a single RUN.  With
    ``notes``, a faults file found beside the run that cannot be used is a note there and
    no ground truth (the replay goes on); without, its RAC085/RAC086 error."""
    if explicit is not None:
        return load_truth(explicit)
    if len(runs) == 1:
        path = truth_path(Path(runs[0]))
        if is_file(path):
            try:
                return load_truth(path)
            except RacError as err:
                if notes is None:
                    raise
                first = err.diagnostics[0]
                notes.append(
                    f"{path} is not a usable faults file ({first.code}: {first.message}); "
                    "replaying without ground truth"
                )
    return None
