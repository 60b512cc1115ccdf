"""What a path a user named is, so that a command given the wrong kind of input (a directory
for a model, a model for a recording, a recording for a model, a model for the directory
``racc compile`` wrote) says what it was given, what it takes, and what to pass instead.

:func:`kind_of` looks at a path the way ``file(1)`` does: a directory by the files in it,
a file by its first bytes and its name.  :func:`check_kind` raises the reader's own error
code for a path that is certainly not what the reader takes; a path it cannot tell (a text
file of no known kind, a missing one) is left to the reader, whose errors say more.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from rac.errors import Diagnostic, RacError

HEAD_BYTES = 4096  # what is read of a file to tell its kind


@dataclass(frozen=True, slots=True)
class Kind:
    key: str  # a stable name: "ram", "ros1-bag", "compiled", ...
    what: str  # as a user reads it: "a ROS 1 bag (a recording)"


MISSING = Kind("missing", "no such file or directory")
TEXT = Kind("text", "a text file")

_KINDS = {
    k.key: k
    for k in (
        Kind("ram", "a .ram model"),
        Kind("json", "a ram/1 .json model"),
        Kind("other-json", "a JSON file"),
        Kind("model-yaml", "a model server file (model.yaml)"),
        Kind("observers-yaml", "an observers.yaml (what racc compile writes beside model.yaml)"),
        Kind("tug", "a tug_diagnosis configuration"),
        Kind("faults", "a faults file (the ground truth racc synth writes)"),
        Kind("graph", "a computation graph (what racc record writes beside a recording)"),
        Kind("ros2-metadata", "the metadata.yaml of a ROS 2 bag"),
        Kind("yaml", "a YAML file"),
        Kind("launch", "a launch file"),
        Kind("csv", "a CSV file"),
        Kind("ros1-bag", "a ROS 1 bag (a recording)"),
        Kind("ros2-bag", "a ROS 2 bag directory (a recording)"),
        Kind("ros2-storage", "the storage file of a ROS 2 bag (.db3 or .mcap)"),
        Kind("compiled", "the directory racc compile wrote"),
        Kind("demo", "the directory racc demo wrote"),
        Kind("directory", "a directory"),
        Kind("binary", "a binary file"),
    )
}

# A .ram text: comments, then `robot NAME`.
_RAM_HEADER = re.compile(r"\A(?:\s|#[^\n]*\n?)*robot[ \t]+[A-Za-z_]")
_YAML_KEY = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*):", re.MULTILINE)


def kind_of(path: str | Path) -> Kind:
    """What ``path`` is: a directory by its files, a file by its first bytes and name."""
    p = Path(path)
    try:
        if p.is_dir():
            return _directory(p)
        if not p.exists():
            return MISSING
        if not p.is_file():  # a device or a pipe: reading would block or never end
            return TEXT
        with p.open("rb") as handle:
            head = handle.read(HEAD_BYTES)
    except OSError:
        return MISSING  # the reader says why it cannot be read
    return _file(p, head)


def _directory(p: Path) -> Kind:
    def has(name: str) -> bool:
        return (p / name).is_file()

    if has("metadata.yaml"):
        return _KINDS["ros2-bag"]
    if has("model.yaml") or has("observers.launch") or has("observers.launch.xml"):
        return _KINDS["compiled"]
    if has("robot.launch") or has("robot.launch.xml"):
        return _KINDS["demo"]
    return _KINDS["directory"]


def _file(p: Path, head: bytes) -> Kind:
    if head.startswith(b"#ROSBAG"):
        return _KINDS["ros1-bag"]
    if head.startswith((b"\x89MCAP", b"SQLite format 3\x00")):
        return _KINDS["ros2-storage"]
    if b"\x00" in head:
        return _KINDS["binary"]
    text = head.decode("utf-8", errors="replace").removeprefix("\ufeff")
    if "\ufffd" in text[:-4]:  # not UTF-8 well before where the head was cut
        return _KINDS["binary"]
    name = p.name.lower()
    if name.endswith(".ram"):
        return _KINDS["ram"]
    if name.endswith(".json"):
        return _KINDS["json" if '"ram/1"' in text else "other-json"]
    if name.endswith((".yaml", ".yml")):
        return _yaml(text)
    if name.endswith(".csv"):
        return _KINDS["csv"]
    if "<launch" in text:
        return _KINDS["launch"]
    if _RAM_HEADER.match(text):
        return _KINDS["ram"]
    if text.lstrip().startswith("{") and '"ram/1"' in text:
        return _KINDS["json"]
    return TEXT


def _yaml(text: str) -> Kind:
    keys = set(_YAML_KEY.findall(text))
    if "rosbag2_bagfile_information" in keys:
        return _KINDS["ros2-metadata"]
    if keys & {"ab", "nab", "rules", "neg_prefix"}:
        return _KINDS["model-yaml"]
    if "observers" in keys:
        return _KINDS["observers-yaml"]
    if "faults" in keys:
        return _KINDS["faults"]
    if "nodes" in keys and ("pub_topic" in text or "sub_topic" in text):
        return _KINDS["tug"]
    if "nodes" in keys or "topics" in keys:
        return _KINDS["graph"]
    return _KINDS["yaml"]


@dataclass(frozen=True, slots=True)
class Expected:
    """What one input of a command takes: ``what`` as a user reads it, the kinds that are
    right (and those that cannot be told, left to the reader), and for each wrong kind what
    to pass instead (``{path}`` is the path given)."""

    what: str
    accepts: frozenset[str]
    instead: Mapping[str, str] = field(default_factory=dict)
    otherwise: str = ""


_UNTOLD = frozenset({"missing", "text"})  # the reader's own errors say more
# YAML files told apart by their keys; a loose guess ("graph": 'nodes' or 'topics') is
# left to the reader, the sure ones (racc's own outputs, a bag's metadata) are not.
_YAML = frozenset({"yaml", "graph", "tug", "faults"})

MODEL = Expected(
    "a model (a .ram or a ram/1 .json)",
    frozenset({"ram", "json", "other-json", "yaml", "graph", "model-yaml"}),
    {
        "compiled": "give the .ram (or .json) it was compiled from",
        "demo": "give the .ram (or .json) the demo was made from",
        "ros1-bag": "a recording goes after the model: racc replay MODEL RUN, racc learn RUN",
        "ros2-bag": "a recording goes after the model: racc replay MODEL RUN, racc learn RUN",
        "tug": "racc import tug {path} -o robot.ram makes a model of it",
    },
    "give a .ram or ram/1 .json model, e.g. models/tedusar.ram",
)
THEORY = Expected(
    "a model (a .ram, a ram/1 .json or a model.yaml)",
    frozenset({"ram", "json", "other-json", "yaml", "graph", "model-yaml"}),
    {
        "compiled": "give {path}/model.yaml, or the .ram it was compiled from",
        "observers-yaml": "give the model.yaml beside it, or the .ram it was compiled from",
        "ros1-bag": "a recording is replayed against a model: racc replay MODEL RUN",
        "ros2-bag": "a recording is replayed against a model: racc replay MODEL RUN",
        "tug": "racc import tug {path} -o robot.ram makes a model of it",
    },
    "give a .ram, a ram/1 .json or the model.yaml racc compile wrote",
)
RECORDING = Expected(
    "a recording (a ROS 1 .bag file or a ROS 2 bag directory)",
    frozenset({"ros1-bag", "ros2-bag"}),
    {
        "ram": "the model goes first (racc replay MODEL RUN; racc learn RUN --base MODEL)",
        "json": "the model goes first (racc replay MODEL RUN; racc learn RUN --base MODEL)",
        "ros2-storage": "give the bag's directory, the one holding metadata.yaml: {parent}",
        "ros2-metadata": "give the bag's directory, the one holding it: {parent}",
        "compiled": "give a recording: racc record or racc synth makes one",
        "binary": "a ROS 1 bag starts with '#ROSBAG V2.0' and this file does not; give a ROS 1 "
        ".bag file or a ROS 2 bag directory",
    },
    "give a ROS 1 .bag file or a ROS 2 bag directory (racc record and racc synth make them)",
)
COMPILED = Expected(
    "the directory racc compile wrote (or the launch file in it)",
    frozenset({"compiled", "launch", "directory"}),  # a directory: "no such launch file"
    {
        "ram": "compile it first: racc compile {path} -o build/{stem}, then racc run build/{stem}",
        "json": "compile it first: racc compile {path} -o build/{stem}, then racc run build/{stem}",
        "model-yaml": "give the directory it is in: racc run {parent}",
        "observers-yaml": "give the directory it is in: racc run {parent}",
        "demo": "the demo's robot.launch goes to --robot-launch: racc run DIR --robot-launch "
        "{path}/robot.launch",
    },
    "give the directory racc compile wrote: racc compile MODEL -o DIR, then racc run DIR",
)
ROBOT_LAUNCH = Expected(
    "the robot's own launch file",
    _YAML | {"launch"},  # a YAML launch file is the reader's to refuse
    {
        "demo": "give {path}/robot.launch (ROS 2: {path}/robot.launch.xml)",
        "compiled": "that is racc's own runtime; give the launch file that starts the robot",
    },
    "give the launch file that starts the robot's nodes (racc demo writes one: DIR/robot.launch)",
)
OBSERVERS = Expected(
    "an observers.yaml (what racc compile writes)",
    _YAML | {"observers-yaml"},
    {
        "compiled": "give {path}/observers.yaml",
        "ram": "compile it first (racc compile {path} -o DIR), then give DIR/observers.yaml",
        "json": "compile it first (racc compile {path} -o DIR), then give DIR/observers.yaml",
        "model-yaml": "give the observers.yaml beside it: {parent}/observers.yaml",
    },
    "give the observers.yaml racc compile wrote",
)
TUG = Expected(
    "a tug_diagnosis configuration (YAML with 'nodes' and 'observations')",
    _YAML,
    {
        "ram": "{path} is a model already: racc check {path}",
        "json": "{path} is a model already: racc export --ram {path}",
    },
    "give the tug_diagnosis configuration (YAML)",
)
RAM_FILE = Expected(
    "a .ram file",
    frozenset({"ram"}),
    {
        "compiled": "format the .ram it was compiled from",
        "json": "racc export --ram {path} -o NAME.ram writes its .ram",
    },
    "give .ram files",
)


PROPERTIES = Expected(
    "a properties CSV (time, node, cpu, mem)",
    frozenset({"csv"}),
    {"ros1-bag": "give the CSV racc record wrote beside it: {beside}.properties.csv"},
    "give the RUN.properties.csv racc record or racc synth wrote beside the recording",
)
GRAPH = Expected(
    "a computation graph (YAML)",
    _YAML,
    {"ros1-bag": "give the graph racc record wrote beside it: {beside}.graph.yaml"},
    "give the RUN.graph.yaml racc record wrote beside the recording",
)
FAULTS = Expected(
    "a faults file (YAML with 'faults')",
    _YAML,
    {"ros1-bag": "give the faults file racc synth wrote beside it: {beside}.faults.yaml"},
    "give the RUN.faults.yaml racc synth wrote beside the recording",
)
COSTS = Expected(
    "a costs file (YAML: observer kinds or names to costs)",
    _YAML,
    {},
    "give a YAML map such as 'GObs: 1'",
)
OBSERVATIONS = Expected(
    "an observations file (one literal per line)",
    frozenset(),
    {
        "ram": "observations are literals such as 'not ok(pose)': the model is MODEL",
        "model-yaml": "observations are literals such as 'not ok(pose)': the model is MODEL",
    },
    "give a text file with one literal per line, such as 'not ok(pose)'",
)


def check_kind(path: str | Path, expected: Expected, code: str) -> None:
    """``code`` (the reader's own) when ``path`` is certainly not what ``expected`` takes."""
    kind = kind_of(path)
    if kind.key in expected.accepts or kind.key in _UNTOLD:
        return
    p = Path(path)
    hint = expected.instead.get(kind.key, expected.otherwise)
    beside = p.with_suffix("") if p.suffix else p
    hint = hint.format(path=path, parent=p.parent, stem=p.stem or "robot", beside=beside)
    message = f"{path}: is {kind.what}, not {expected.what}"
    raise RacError([Diagnostic(code, message, hint=hint or None)])
