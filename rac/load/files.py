"""Read a model file: ``.ram`` (the DSL) or ``.json`` (the ``ram/1`` interchange)."""

from __future__ import annotations

import os
import stat
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO

import yaml

from rac.errors import Diagnostic, RacError, Span
from rac.limits import MAX_INPUT_BYTES, safe_yaml, yaml_error_diagnostic
from rac.load.kinds import MODEL, OBSERVERS, check_kind, kind_of
from rac.logic import parse_atom
from rac.perf import paused_gc

if TYPE_CHECKING:  # the parsers and passes load on first use: `racc diagnose x.yaml` needs none
    from rac.ir import Model
    from rac.passes.observers import ObserverSpec, ParamValue, TopicSource


def read_text(path: str | Path, code: str = "RAC004") -> str:
    """A text file racc reads (a model, observations, a CSV...): UTF-8, a leading byte-order
    mark dropped, at most :data:`MAX_INPUT_BYTES`; ``code`` (RAC004 unless the caller has its
    own) when it cannot be read, with the line and column of a byte that is not UTF-8."""
    try:
        with Path(path).open("rb") as handle:
            data = _read_bounded(handle)
    except FileNotFoundError:
        raise RacError([Diagnostic(code, f"{path}: no such file")]) from None
    except IsADirectoryError:
        what = kind_of(path).what
        message = f"{path}: is a directory, not a file" + (
            f" ({what})" if what != "a directory" else ""
        )
        raise RacError([Diagnostic(code, message)]) from None
    except OSError as err:
        raise RacError([Diagnostic(code, f"{path}: cannot read: {err}")]) from None
    if len(data) > MAX_INPUT_BYTES:
        message = f"{path}: larger than {MAX_INPUT_BYTES // 2**20} MiB; is it the right file?"
        raise RacError([Diagnostic("RAC009", message)])
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        shown = data.decode("utf-8", errors="replace")  # the line, its bad byte as U+FFFD
        raise RacError([_not_utf8(str(path), data, err, code)], shown) from None
    # Editors on Windows start UTF-8 files with a byte-order mark: it is no part of the text.
    return text.removeprefix("\ufeff")


def _read_bounded(handle: BinaryIO) -> bytes:
    """The file's bytes, or one chunk past :data:`MAX_INPUT_BYTES` of them: enough to tell an
    oversized file (or /dev/zero, or a bag given as a model by mistake) without holding all
    of it.  A regular file is read in one call of its own size: ``read(limit + 1)`` would
    allocate the whole limit for every small file."""
    status = os.fstat(handle.fileno())
    if stat.S_ISREG(status.st_mode) and status.st_size <= MAX_INPUT_BYTES:
        return handle.read()  # a file growing meanwhile is checked below like any other
    chunks: list[bytes] = []
    held = 0
    while held <= MAX_INPUT_BYTES:
        chunk = handle.read(1 << 20)
        if not chunk:
            break
        chunks.append(chunk)
        held += len(chunk)
    return b"".join(chunks)


def is_file(path: Path) -> bool:
    """``path.is_file()``, False too where the name cannot be looked up at all (too long for
    the file system: ``is_file`` raises then), so that reading it reports the problem."""
    try:
        return path.is_file()
    except OSError:
        return False


def _not_utf8(path: str, data: bytes, err: UnicodeDecodeError, code: str) -> Diagnostic:
    """Where the first byte that is not UTF-8 is, as an editor counts lines and columns."""
    line_start = data.rfind(b"\n", 0, err.start) + 1
    line = data.count(b"\n", 0, err.start) + 1
    column = len(data[line_start : err.start].decode("utf-8", errors="replace")) + 1
    message = f"not UTF-8 text: byte 0x{data[err.start]:02x} ({err.reason})"
    return Diagnostic(
        code,
        message,
        Span(path, line, column, line, column + 1),
        hint="save the file as UTF-8",
    )


def load_model(path: str | Path) -> Model:
    """Parse (not validate) a model; the suffix picks the format."""
    from rac.interchange import parse_json
    from rac.parse import parse_ram

    check_kind(path, MODEL, "RAC004")
    if str(path).endswith((".yaml", ".yml")):
        # A model server file holds clauses only: without this, the .ram parser's
        # "unexpected 'ab'; expected 'robot'" would be all the user learns.
        raise RacError(
            [
                Diagnostic(
                    "RAC060",
                    f"{path}: a model server file (model.yaml) has only clauses, and this "
                    "command needs the architecture: give a .ram or a ram/1 .json model",
                    hint="diagnose, repair, scenario, simulate and analyze take a model.yaml",
                )
            ]
        )
    text = read_text(path)
    if str(path).endswith(".json"):
        return parse_json(text, str(path))
    return parse_ram(text, str(path))


def load_observers(path: str | Path) -> tuple[str, tuple[ObserverSpec, ...]]:
    """``observers.yaml`` (what ``racc compile`` writes): the robot's name and its observers
    (:func:`load_observer_file` also gives the observed topics' sources)."""
    loaded = load_observer_file(path)
    return loaded.robot, loaded.specs


@dataclass(frozen=True, slots=True)
class ObserverFile:
    robot: str
    specs: tuple[ObserverSpec, ...]
    # topic -> its type and publishers; None: the file has no 'topics' (an older racc)
    sources: Mapping[str, TopicSource] | None


@paused_gc()  # a large robot's observers are a million small objects, none cyclic (rac.perf)
def load_observer_file(path: str | Path) -> ObserverFile:
    """``observers.yaml`` (what ``racc compile`` writes): the robot's name, its observers,
    and the type and publishers of each topic they read.

    RAC056 when the file is not of that shape; an observer's parameters are checked later,
    when the observer core builds it (RAC050/RAC051).
    """
    check_kind(path, OBSERVERS, "RAC056")
    text = read_text(path)

    hint = "give the observers.yaml that 'racc compile' wrote"

    def bad(why: str) -> RacError:
        return RacError([Diagnostic("RAC056", f"{path}: {why}", hint=hint)])

    # racc's own layout is read whatever its size (a 50,000-node robot's is 33.8 MB);
    # any other text by the YAML path, within its limits (RAC009).  Imported here: its
    # regular expressions are compiled only by the commands that read observers.
    from rac.load.observers_yaml import racc_layout_document

    data = racc_layout_document(text)
    if data is None:
        try:
            data = safe_yaml(text, str(path))
        except yaml.YAMLError as err:
            diagnostic = yaml_error_diagnostic(err, str(path), "RAC056", hint=hint)
            raise RacError([diagnostic], text) from None
    if not isinstance(data, dict) or not isinstance(data.get("observers"), list):
        raise bad("expected a mapping with a list 'observers'")
    from rac.passes.observers import ObserverSpec

    specs: list[ObserverSpec] = []
    for i, entry in enumerate(data["observers"], 1):
        if not isinstance(entry, dict):
            raise bad(f"observer {i} is not a mapping")
        kind, name = entry.get("kind"), entry.get("name")
        params, reports = entry.get("params") or {}, entry.get("reports") or []
        if not isinstance(kind, str) or not isinstance(name, str):
            raise bad(f"observer {i} needs a 'kind' and a 'name'")
        if not isinstance(params, dict) or not isinstance(reports, list):
            raise bad(f"observer '{name}': 'params' must be a mapping, 'reports' a list")
        values: list[tuple[str, ParamValue]] = []
        for key, value in params.items():
            # Booleans are ints in Python: integral1/integral2 of a BiQObs are true/false.
            if not isinstance(value, str | int | float):
                raise bad(
                    f"observer '{name}': parameter '{key}' is not a number, a boolean or a string"
                )
            values.append((str(key), value))
        try:
            atoms = tuple(parse_atom(str(a)) for a in reports)
        except ValueError as err:
            raise bad(f"observer '{name}': {err}") from None
        specs.append(ObserverSpec(kind, name, tuple(values), atoms))
    robot = str(data.get("robot") or Path(path).resolve().parent.name)
    return ObserverFile(robot, tuple(specs), _sources(data.get("topics"), bad))


def _sources(entries: object, bad: Callable[[str], RacError]) -> dict[str, TopicSource] | None:
    if entries is None:
        return None
    if not isinstance(entries, list):
        raise bad("'topics' must be a list")
    from rac.passes.observers import TopicSource

    out: dict[str, TopicSource] = {}
    for i, entry in enumerate(entries, 1):
        if not isinstance(entry, dict) or not isinstance(entry.get("topic"), str):
            raise bad(f"topics entry {i} needs a 'topic'")
        kind, publishers = entry.get("type"), entry.get("publishers") or []
        subscribers = entry.get("subscribers") or []  # absent in an older racc's file
        if kind is not None and not isinstance(kind, str):
            raise bad(f"topic '{entry['topic']}': 'type' must be a string")
        for key, nodes in (("publishers", publishers), ("subscribers", subscribers)):
            if not isinstance(nodes, list) or not all(isinstance(n, str) for n in nodes):
                raise bad(f"topic '{entry['topic']}': '{key}' must be a list of node names")
        out[entry["topic"]] = TopicSource(
            entry["topic"], kind, tuple(publishers), tuple(subscribers)
        )
    return out
