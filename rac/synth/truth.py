"""Ground truth for evaluating diagnoses (§10.2): which faults a recording holds, and when.

``racc synth`` writes ``RUN.faults.yaml`` beside every recording it makes; a user may
write one by hand for a real recording.  Times are seconds from the start of the
recording; a fault is active in ``[start, end)``.  ``culprits`` are the model's
components a correct diagnosis names::

    # Faults injected by racc synth into run.bag, seconds from the start of the recording.
    robot: pioneer
    duration: 600.0
    faults:
    - kind: slip
      target: /pose
      start: 60.0
      end: 75.0
      culprits: [p2os]

The file is composed (not just loaded) so that every problem names its line and column:
RAC085 for what is not such a file (YAML syntax, keys, types), RAC086 for values that do
not fit (times outside the recording, culprits the model lacks).  ``robot`` and
``duration`` may be left out: the model names the robot, and the recording knows its
duration (a fault without ``end`` then lasts to the recording's end: :meth:`GroundTruth.fitted`).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import yaml

from rac.errors import Diagnostic, RacError, Severity, Span, did_you_mean
from rac.ir import Model
from rac.limits import check_yaml_limits, yaml_error_diagnostic
from rac.synth.faults import FAULT_KINDS, Fault

SUFFIX = ".faults.yaml"
TOP_KEYS = ("robot", "duration", "faults")
FAULT_KEYS = ("kind", "target", "start", "end", "culprits")
_INT = "tag:yaml.org,2002:int"
_FLOAT = "tag:yaml.org,2002:float"
_STR = "tag:yaml.org,2002:str"
_NULL = "tag:yaml.org,2002:null"
# A name written bare in the flow list ``[a, b]`` and as a block value: ROS names and the like.
_BARE = re.compile(r"[A-Za-z_/~][A-Za-z0-9_/~.\-]*")


@dataclass(frozen=True, slots=True)
class InjectedFault:
    kind: str  # slip, crash, freq, cpu, mem from racc synth; any word in a hand-written file
    target: str  # the topic or node the fault was injected into
    start: float  # seconds from the start of the recording
    end: float  # exclusive; the recording's duration when the fault lasts to its end
    culprits: tuple[str, ...]  # sorted model components a correct diagnosis names
    span: Span | None = field(default=None, compare=False)

    def active(self, t: float) -> bool:
        return self.start <= t < self.end


@dataclass(frozen=True, slots=True)
class GroundTruth:
    robot: str  # "" when the file names none
    duration: float | None  # seconds; None when the file gives none (the recording's, then)
    faults: tuple[InjectedFault, ...]  # by start, end, kind, target
    span: Span | None = field(default=None, compare=False)
    source: str | None = field(default=None, compare=False, repr=False)  # the file's text

    def active(self, t: float) -> tuple[InjectedFault, ...]:
        return tuple(f for f in self.faults if f.active(t))

    def fitted(self, recording_s: float) -> GroundTruth:
        """With the recording's duration where the file gave none: the faults that last to
        the end (no ``end`` in the file) end with the recording."""
        if self.duration is not None:
            return self
        faults = tuple(
            f if f.end <= recording_s else replace(f, end=max(recording_s, f.start))
            for f in self.faults
        )
        return replace(self, duration=recording_s, faults=faults)


def beside(run: Path, suffix: str) -> Path:
    """``run.bag`` -> ``run<suffix>``; a ROS 2 bag directory ``run`` -> ``run<suffix>``."""
    stem = run.name[: -len(".bag")] if run.name.endswith(".bag") else run.name
    return run.with_name(stem + suffix)


def truth_path(run: Path) -> Path:
    """Where ``racc synth`` writes the faults file of the recording ``run``."""
    return beside(run, SUFFIX)


def culprits_of(kind: str, target: str, model: Model) -> tuple[str, ...]:
    """A node fault blames the node; a topic fault (slip, freq) the topic's publishers."""
    if FAULT_KINDS.get(kind) == "topic":
        return tuple(sorted(set(model.publishers().get(target, ()))))
    return (target,)


def _sort_key(f: InjectedFault) -> tuple[float, float, str, str]:
    return (f.start, f.end, f.kind, f.target)


def ground_truth(model: Model, duration: float, faults: Sequence[Fault]) -> GroundTruth:
    """The truth of a synthetic recording: each fault clipped to ``[0, duration)``."""
    out = [
        InjectedFault(
            f.kind, f.target, f.start, min(f.end, duration), culprits_of(f.kind, f.target, model)
        )
        for f in faults
    ]
    return GroundTruth(model.name.value, duration, tuple(sorted(out, key=_sort_key)))


# --- writing ---------------------------------------------------------------------------


def _text(value: str) -> str:
    """A string bare when YAML reads it back as that string, else double-quoted (JSON is)."""
    # safe_load: not a number, boolean, null, date or other implicit type.
    if _BARE.fullmatch(value) and yaml.safe_load(value) == value:
        return value
    return json.dumps(value)


def _number(value: float) -> str:
    """Microsecond precision, always with a dot (PyYAML reads ``1e-05`` as a string)."""
    text = f"{value:.6f}".rstrip("0")
    return text + "0" if text.endswith(".") else text


def dump_truth(truth: GroundTruth, run_name: str) -> str:
    """The file's text; ``run_name`` goes into its first (comment) line."""
    name = " ".join(run_name.splitlines())
    lines = [
        f"# Faults injected by racc synth into {name}, seconds from the start of the recording.",
        f"robot: {_text(truth.robot)}",
    ]
    if truth.duration is not None:
        lines.append(f"duration: {_number(truth.duration)}")
    if not truth.faults:
        lines.append("faults: []")
    else:
        lines.append("faults:")
    for f in truth.faults:
        culprits = ", ".join(_text(c) for c in f.culprits)
        lines += [
            f"- kind: {_text(f.kind)}",
            f"  target: {_text(f.target)}",
            f"  start: {_number(f.start)}",
            f"  end: {_number(f.end)}",
            f"  culprits: [{culprits}]",
        ]
    return "\n".join(lines) + "\n"


# --- reading ---------------------------------------------------------------------------


def _span(file: str, node: yaml.Node) -> Span:
    start, end = node.start_mark, node.end_mark
    return Span(file, start.line + 1, start.column + 1, end.line + 1, end.column + 1)


class _Reader:
    """Collects every problem of one file, each located at its YAML node."""

    def __init__(self, file: str) -> None:
        self.file = file
        self.errors: list[Diagnostic] = []

    def bad(self, node: yaml.Node, message: str, hint: str | None = None) -> None:
        self.errors.append(Diagnostic("RAC085", message, _span(self.file, node), hint=hint))

    def unfit(self, node: yaml.Node, message: str, hint: str | None = None) -> None:
        self.errors.append(Diagnostic("RAC086", message, _span(self.file, node), hint=hint))

    def mapping(
        self, node: yaml.Node, keys: tuple[str, ...], required: tuple[str, ...], what: str
    ) -> dict[str, yaml.Node] | None:
        if not isinstance(node, yaml.MappingNode):
            self.bad(node, f"{what} must be a mapping with keys {', '.join(keys)}")
            return None
        values: dict[str, yaml.Node] = {}
        for key_node, value_node in node.value:
            key = str(key_node.value)
            if key not in keys:
                self.bad(key_node, f"unknown key '{key}' in {what}", did_you_mean(key, keys))
            elif key in values:
                self.bad(key_node, f"key '{key}' given twice in {what}")
            else:
                values[key] = value_node
        missing = [k for k in required if k not in values]
        if missing:
            self.bad(node, f"{what} lacks {', '.join(repr(k) for k in missing)}")
            return None
        return values

    def name(self, node: yaml.Node, what: str) -> str | None:
        if isinstance(node, yaml.ScalarNode) and node.tag == _STR and str(node.value).strip():
            return str(node.value).strip()
        self.bad(node, f"{what} must be a name")
        return None

    def number(self, node: yaml.Node, what: str) -> float | None:
        if isinstance(node, yaml.ScalarNode) and node.tag in (_INT, _FLOAT):
            try:
                value = float(str(node.value).replace("_", ""))
            except ValueError:
                value = math.nan
            if math.isfinite(value):
                return value
        self.bad(node, f"{what} must be a number of seconds")
        return None

    def names(self, node: yaml.Node, what: str) -> tuple[str, ...] | None:
        items = node.value if isinstance(node, yaml.SequenceNode) else [node]
        if (isinstance(node, yaml.ScalarNode) and node.tag == _NULL) or not items:
            self.bad(node, f"{what} must name at least one component")
            return None
        out = [self.name(item, f"each of {what}") for item in items]
        if any(n is None for n in out):
            return None
        return tuple(sorted({n for n in out if n is not None}))


def _fault(reader: _Reader, node: yaml.Node, duration: float | None) -> InjectedFault | None:
    values = reader.mapping(node, FAULT_KEYS, ("kind", "target", "start", "culprits"), "a fault")
    if values is None:
        return None
    kind = reader.name(values["kind"], "'kind'")
    target = reader.name(values["target"], "'target'")
    start = reader.number(values["start"], "'start'")
    to_the_end = math.inf if duration is None else duration
    end = reader.number(values["end"], "'end'") if "end" in values else to_the_end
    culprits = reader.names(values["culprits"], "'culprits'")
    if kind is None or target is None or start is None or end is None or culprits is None:
        return None
    if start < 0:
        reader.unfit(values["start"], f"the fault starts before the recording ({start:g} s)")
        return None
    if end <= start:
        where = values.get("end", node)
        reader.unfit(where, f"the fault ends ({end:g} s) before it starts ({start:g} s)")
        return None
    if duration is not None and end > duration:
        where = values.get("end", values["start"])
        hint = "a fault lasting to the end of the recording ends at its duration"
        reader.unfit(where, f"the fault ends after the recording ({end:g} > {duration:g} s)", hint)
        return None
    return InjectedFault(kind, target, start, end, culprits, _span(reader.file, node))


def parse_truth(text: str, file: str) -> GroundTruth:
    """A faults file's truth; RacError (RAC085, RAC086) with every problem found."""
    check_yaml_limits(text, file)
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError as err:
        raise RacError([yaml_error_diagnostic(err, file, "RAC085")], text) from None
    hint = "see 'Ground truth' in docs/learning.md"
    if root is None:
        message = "an empty faults file: it needs at least 'faults' (and may give robot, duration)"
        raise RacError([Diagnostic("RAC085", message, Span(file, 1, 1, 1, 1), hint=hint)], text)
    reader = _Reader(file)
    values = reader.mapping(root, TOP_KEYS, ("faults",), "a faults file")
    if values is None:
        raise RacError(reader.errors, text)
    robot = reader.name(values["robot"], "'robot'") if "robot" in values else ""
    duration = reader.number(values["duration"], "'duration'") if "duration" in values else None
    if duration is not None and duration <= 0:
        reader.unfit(values["duration"], "'duration' must be above 0 s")
    faults_node = values["faults"]
    items: list[yaml.Node] = []
    if isinstance(faults_node, yaml.SequenceNode):
        items = list(faults_node.value)
    elif not (isinstance(faults_node, yaml.ScalarNode) and faults_node.tag == _NULL):
        reader.bad(faults_node, "'faults' must be a list (write 'faults: []' for none)")
    faults = [_fault(reader, item, duration) for item in items]
    if reader.errors or robot is None:
        raise RacError(reader.errors, text)
    found = sorted((f for f in faults if f is not None), key=_sort_key)
    return GroundTruth(robot, duration, tuple(found), _span(file, root), text)


def check_truth(
    truth: GroundTruth, models: Sequence[Model], robot: bool = True
) -> list[Diagnostic]:
    """RAC086 for every culprit that is a node or hardware of none of ``models``; with
    ``robot``, a RAC107 warning when none of them is the robot the file names (a learned
    model without a base is named after its recording, so its name says nothing)."""
    components = set().union(*(set(m.node_by_name()) | set(m.hardware_by_name()) for m in models))
    names = sorted({m.name.value for m in models})
    out = []
    where = f"'{names[0]}'" if len(names) == 1 else "any of the models"
    if robot and names and truth.robot and truth.robot not in names:
        message = f"the ground truth is for robot '{truth.robot}', not {where}"
        advice = "scores mean something only against the robot the recording was made on"
        out.append(Diagnostic("RAC107", message, truth.span, Severity.WARNING, advice))
    for f in truth.faults:
        for culprit in f.culprits:
            if culprit not in components:
                text = f"culprit '{culprit}' of the {f.kind} fault is not in {where}"
                hint = did_you_mean(culprit, components)
                out.append(Diagnostic("RAC086", text, f.span, hint=hint))
    return out
