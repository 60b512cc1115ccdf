"""What replay and evaluate load: a model with observers, and runs with their inputs."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
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


# A fault may end this long after the recording's last message (``racc synth`` ends a fault
# that lasts to the end at the recording's duration, a period or so past its last message).
END_SLACK_S = 1.0


def truth_in_span(truth: GroundTruth, span_s: float, where: str) -> GroundTruth:
    """The ground truth of a replay that judges ``span_s`` seconds of ``where``: a fault
    that lasts to the end ends with the replay; a fault that starts, or ends, outside the
    replayed span is an error naming the span (RAC160), never clipped silently."""
    problems = []
    faults = []
    for f in truth.faults:
        ends_at = f.end if math.isfinite(f.end) else span_s
        if f.start >= span_s or ends_at > span_s + END_SLACK_S:
            what = f"fault {f.kind} {f.target} {f.start:g}-{f.end:g} s"
            edge = "starts" if f.start >= span_s else "ends"
            problems.append(
                Diagnostic(
                    "RAC160",
                    f"{what} {edge} outside the replayed span of {where}: 0-{span_s:.3f} s "
                    "(its last message)",
                    f.span,
                    hint="give times in seconds from the recording's first message, within "
                    "the recording; a fault that lasts to the end needs no end",
                )
            )
            continue
        faults.append(replace(f, end=min(ends_at, span_s)))
    if problems:
        raise RacError(problems, truth.source)
    return replace(truth, duration=span_s, faults=tuple(faults))
