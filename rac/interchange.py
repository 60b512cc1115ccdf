"""The JSON interchange ``ram/1`` (docs/spec.md): read and write.

A field reference is a string, ``"/pose.yaw"``, or ``"I(/pose.twist.twist.angular.z)"`` for
an integrated side, exactly as the ``.ram`` text writes it.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from json.decoder import scanstring  # type: ignore[attr-defined]
from typing import Any

from rac.errors import Diagnostic, RacError, Span, did_you_mean
from rac.ir import (
    FieldRef,
    Hardware,
    Interval,
    Limits,
    Model,
    Name,
    Node,
    Publication,
    Related,
    Topic,
)
from rac.limits import (
    MAX_DEPTH,
    MAX_DOCUMENT_BYTES,
    MAX_NUMBER_CHARS,
    depth_exceeds,
    number_problem,
)

FORMAT = "ram/1"

_KEYS: dict[str, tuple[set[str], set[str]]] = {
    # object kind: (required keys, optional keys)
    "model": ({"format", "name"}, {"hardware", "topics", "nodes", "related", "intervals"}),
    "hardware": ({"name"}, {"switchable", "channel"}),
    "topic": (
        {"name"},
        {"type", "fields", "rate_hz", "rate_tolerance_hz", "window_s", "mismatch_threshold"},
    ),
    "node": ({"name"}, {"drives", "subscribes", "publishes", "limits", "diagnostics"}),
    "publication": ({"topic"}, {"affected_by"}),
    "limits": (set(), {"cpu", "mem"}),
    "interval": ({"a", "b", "max_diff"}, set()),
}


def model_to_json(model: Model) -> dict[str, Any]:
    """The ``ram/1`` document of a model; optional keys are left out when empty."""
    return {
        "format": FORMAT,
        "name": model.name.value,
        "hardware": [_hardware(h) for h in model.hardware],
        "topics": [_topic(t) for t in model.topics],
        "nodes": [_node(n) for n in model.nodes],
        "related": [[r.a.text, r.b.text] for r in model.related],
        "intervals": [
            {"a": i.a.text, "b": i.b.text, "max_diff": i.max_diff} for i in model.intervals
        ],
    }


def dumps(model: Model) -> str:
    return json.dumps(model_to_json(model), indent=2, ensure_ascii=False) + "\n"


def _hardware(h: Hardware) -> dict[str, Any]:
    out: dict[str, Any] = {"name": h.name.value, "switchable": h.switchable}
    if h.channel is not None:
        out["channel"] = h.channel
    return out


def _topic(t: Topic) -> dict[str, Any]:
    out: dict[str, Any] = {"name": t.name.value}
    if t.msg_type is not None:
        out["type"] = t.msg_type
    out["fields"] = [f.value for f in t.fields]
    optional = {
        "rate_hz": t.rate_hz,
        "rate_tolerance_hz": t.rate_tolerance_hz,
        "window_s": t.window_s,
        "mismatch_threshold": t.mismatch_threshold,
    }
    out.update({k: v for k, v in optional.items() if v is not None})
    return out


def _node(n: Node) -> dict[str, Any]:
    out: dict[str, Any] = {
        "name": n.name.value,
        "drives": [h.value for h in n.drives],
        "subscribes": [t.value for t in n.subscribes],
        "publishes": [
            {"topic": p.topic.value, "affected_by": [a.value for a in p.affected_by]}
            for p in n.publishes
        ],
    }
    limits = {k: v for k, v in (("cpu", n.limits.cpu), ("mem", n.limits.mem)) if v is not None}
    if limits:
        out["limits"] = limits
    out["diagnostics"] = [d.value for d in n.diagnostics]
    return out


# A JSON path: the keys and list indices from the document down to a value.
JsonPath = tuple[str | int, ...]


def _where(path: JsonPath) -> str:
    """The path as messages write it: ``nodes[0].publishes[1].topic``, ``document`` for the root."""
    text = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in path).lstrip(".")
    return text or "document"


@dataclass(frozen=True, slots=True)
class _Problem:
    """A diagnostic before it is located: ``path`` names the value, or the key when ``on_key``."""

    code: str
    message: str
    path: JsonPath
    on_key: bool = False
    hint: str | None = None


class _Reader:
    """Checks the document's shape as it lowers it, collecting every problem."""

    def __init__(self, path: str) -> None:
        self.path = path
        self.problems: list[_Problem] = []

    def fail(self, where: JsonPath, message: str) -> None:
        self.problems.append(_Problem("RAC005", f"{_where(where)}: {message}", where))

    def obj(self, value: Any, kind: str, where: JsonPath) -> dict[str, Any]:
        if not isinstance(value, dict):
            self.fail(where, f"expected an object for {kind}")
            return {}
        required, optional = _KEYS[kind]
        for key in sorted(required - value.keys()):
            self.fail(where, f"missing key '{key}'")
        for key in sorted(value.keys() - required - optional):
            message = f"{_where(where)}: unknown key '{key}'"
            hint = did_you_mean(key, required | optional)
            self.problems.append(_Problem("RAC005", message, (*where, key), True, hint))
        return value

    def typed(self, value: Any, types: type | tuple[type, ...], what: str, where: JsonPath) -> Any:
        if isinstance(value, bool) and bool not in (
            types if isinstance(types, tuple) else (types,)
        ):
            self.fail(where, f"expected {what}")
            return None
        if not isinstance(value, types):
            self.fail(where, f"expected {what}")
            return None
        return value

    def names(self, value: Any, where: JsonPath) -> tuple[Name, ...]:
        if value is None:
            return ()
        items = self.typed(value, list, "a list of names", where) or []
        out = []
        for i, item in enumerate(items):
            if self.typed(item, str, "a name (string)", (*where, i)) is not None:
                out.append(Name(item))
        return tuple(out)

    def number(self, value: Any, where: JsonPath) -> float | None:
        if value is None:
            return None
        got = self.typed(value, (int, float), "a number", where)
        if got is not None and self.in_range(got, where):
            return float(got)
        return None

    def integer(self, value: Any, where: JsonPath) -> int | None:
        if value is None:
            return None
        got = self.typed(value, int, "a whole number", where)
        if got is not None and self.in_range(got, where):
            return int(got)
        return None

    def in_range(self, value: float | int, where: JsonPath) -> bool:
        """RAC007 for NaN, infinities and huge numbers (before float() overflows on them)."""
        problem = f"a number of {value.digits:,} digits" if isinstance(value, _LongNumber) else None
        problem = problem or number_problem(value)
        if problem is not None:
            self.problems.append(_Problem("RAC007", f"{_where(where)}: {problem}", where))
        return problem is None

    def model(self, doc: Any) -> Model:
        d = self.obj(doc, "model", ())
        if d.get("format", FORMAT) != FORMAT:
            self.fail(("format",), f'expected "{FORMAT}", got {d.get("format")!r}')
        name = self.typed(d.get("name", ""), str, "a string", ("name",)) or ""
        lists = {
            k: self.typed(d.get(k) or [], list, "a list", (k,)) or [] for k in _KEYS["model"][1]
        }
        return Model(
            name=Name(name),
            hardware=tuple(
                self.hardware(h, ("hardware", i)) for i, h in enumerate(lists["hardware"])
            ),
            topics=tuple(self.topic(t, ("topics", i)) for i, t in enumerate(lists["topics"])),
            nodes=tuple(self.node(n, ("nodes", i)) for i, n in enumerate(lists["nodes"])),
            related=tuple(self.related(r, ("related", i)) for i, r in enumerate(lists["related"])),
            intervals=tuple(
                self.interval(v, ("intervals", i)) for i, v in enumerate(lists["intervals"])
            ),
            path=self.path,
        )

    def hardware(self, value: Any, where: JsonPath) -> Hardware:
        h = self.obj(value, "hardware", where)
        switchable = h.get("switchable", False)
        if self.typed(switchable, bool, "true or false", (*where, "switchable")) is None:
            switchable = False
        return Hardware(
            Name(self.typed(h.get("name", ""), str, "a string", (*where, "name")) or ""),
            switchable=switchable,
            channel=self.integer(h.get("channel"), (*where, "channel")),
        )

    def topic(self, value: Any, where: JsonPath) -> Topic:
        t = self.obj(value, "topic", where)
        msg_type = t.get("type")
        if msg_type is not None:
            msg_type = self.typed(msg_type, str, "a string", (*where, "type"))
        mismatch = self.integer(t.get("mismatch_threshold"), (*where, "mismatch_threshold"))
        return Topic(
            Name(self.typed(t.get("name", ""), str, "a string", (*where, "name")) or ""),
            msg_type=msg_type or None,
            fields=self.names(t.get("fields"), (*where, "fields")),
            rate_hz=self.number(t.get("rate_hz"), (*where, "rate_hz")),
            rate_tolerance_hz=self.number(
                t.get("rate_tolerance_hz"), (*where, "rate_tolerance_hz")
            ),
            window_s=self.number(t.get("window_s"), (*where, "window_s")),
            mismatch_threshold=mismatch,
        )

    def node(self, value: Any, where: JsonPath) -> Node:
        n = self.obj(value, "node", where)
        pubs = self.typed(n.get("publishes") or [], list, "a list", (*where, "publishes")) or []
        limits = self.obj(n.get("limits") or {}, "limits", (*where, "limits"))
        mem = self.number(limits.get("mem"), (*where, "limits", "mem"))
        return Node(
            Name(self.typed(n.get("name", ""), str, "a string", (*where, "name")) or ""),
            drives=self.names(n.get("drives"), (*where, "drives")),
            subscribes=self.names(n.get("subscribes"), (*where, "subscribes")),
            publishes=tuple(
                self.publication(p, (*where, "publishes", i)) for i, p in enumerate(pubs)
            ),
            limits=Limits(
                cpu=self.number(limits.get("cpu"), (*where, "limits", "cpu")),
                mem=round(mem) if mem is not None else None,
            ),
            diagnostics=self.names(n.get("diagnostics"), (*where, "diagnostics")),
        )

    def publication(self, value: Any, where: JsonPath) -> Publication:
        p = self.obj(value, "publication", where)
        topic = self.typed(p.get("topic", ""), str, "a string", (*where, "topic")) or ""
        return Publication(Name(topic), self.names(p.get("affected_by"), (*where, "affected_by")))

    def field_ref(self, value: Any, where: JsonPath) -> FieldRef:
        text = self.typed(value, str, "a field reference 'TOPIC.FIELD'", where) or ""
        ref = FieldRef.parse(text)
        if text and ("." not in text or ref.text != text or "(" in ref.path or ")" in ref.path):
            self.fail(where, f"'{text}' is not TOPIC.FIELD or I(TOPIC.FIELD)")
        return ref

    def related(self, value: Any, where: JsonPath) -> Related:
        pair = self.typed(value, list, "a pair of field references", where) or []
        if len(pair) != 2:
            self.fail(where, "expected exactly two field references")
            pair = [*pair, "", ""][:2]
        return Related(self.field_ref(pair[0], (*where, 0)), self.field_ref(pair[1], (*where, 1)))

    def interval(self, value: Any, where: JsonPath) -> Interval:
        v = self.obj(value, "interval", where)
        return Interval(
            self.field_ref(v.get("a", ""), (*where, "a")),
            self.field_ref(v.get("b", ""), (*where, "b")),
            self.number(v.get("max_diff", 0.0), (*where, "max_diff")) or 0.0,
        )


class _LongNumber(int):
    """An integer written with too many digits to convert (and far out of range anyway)."""

    digits: int


def _parse_int(text: str) -> int:
    if len(text) <= MAX_NUMBER_CHARS:
        return int(text)
    long = _LongNumber(0)
    long.digits = len(text.lstrip("-"))
    return long


def parse_json(text: str, path: str = "<json>") -> Model:
    """Read a ``ram/1`` document; every shape problem is reported at once, located (RAC005)."""
    if len(text) > MAX_DOCUMENT_BYTES:
        message = f"the document is {len(text):,} characters long (at most {MAX_DOCUMENT_BYTES:,})"
        raise RacError([Diagnostic("RAC009", message, Span(path, 1, 1, 1, 2))])
    too_deep = False
    try:
        doc = json.loads(text, parse_int=_parse_int)
    except json.JSONDecodeError as err:
        span = Span(path, err.lineno, err.colno, err.lineno, err.colno + 1)
        raise RacError([Diagnostic("RAC005", f"invalid JSON: {err.msg}", span)], text) from None
    except RecursionError:
        too_deep = True  # far deeper than MAX_DEPTH: the decoder ran out of stack
    if too_deep or depth_exceeds(doc):
        message = f"lists and objects nest more than {MAX_DEPTH} deep"
        raise RacError([Diagnostic("RAC009", message, Span(path, 1, 1, 1, 2))])
    reader = _Reader(path)
    model = reader.model(doc)
    if reader.problems:
        raise RacError(_located(reader.problems, text, path), text)
    return model


def _located(problems: list[_Problem], text: str, path: str) -> list[Diagnostic]:
    """The problems as diagnostics with spans, in file order.

    Only a document with problems pays for this second, slower read of the text; a valid one
    stays on the C decoder alone.
    """
    found = _Locator(text, {p.path for p in problems}).spans
    offsets = []
    for problem in problems:
        at = problem.path
        while at not in found:  # a value the reader defaulted: point at its parent instead
            at = at[:-1]
        value_start, value_end, key_start, key_end = found[at]
        if problem.on_key and at == problem.path and key_start >= 0:
            offsets.append((key_start, key_end))
        else:
            offsets.append((value_start, value_end))
    places = _line_columns(text, sorted({o for pair in offsets for o in pair}))
    located = []
    for problem, (start, end) in zip(problems, offsets, strict=True):
        span = Span(path, *places[start], *places[end])
        located.append((start, Diagnostic(problem.code, problem.message, span, hint=problem.hint)))
    located.sort(key=lambda pair: pair[0])  # stable: problems at one place keep their order
    return [diagnostic for _, diagnostic in located]


def _line_columns(text: str, offsets: list[int]) -> dict[int, tuple[int, int]]:
    """1-based (line, column) of each offset, given in ascending order, in one pass."""
    places = {}
    line, line_start, counted_to = 1, 0, 0
    for offset in offsets:
        newlines = text.count("\n", counted_to, offset)
        if newlines:
            line += newlines
            line_start = text.rfind("\n", counted_to, offset) + 1
        counted_to = offset
        places[offset] = (line, offset - line_start + 1)
    return places


_SPACE = re.compile(r"[ \t\n\r]*")


class _Locator:
    """Where the values on some JSON paths are in a text the C decoder has accepted.

    ``spans`` maps each wanted path, and every path above one, to its value's start and end
    offsets and its key's (-1, -1 for a list item or the document).  Containers on the way to
    a wanted path are walked here; everything else is skipped by the C scanner.  A duplicated
    key keeps its last occurrence, the one the decoder kept.
    """

    def __init__(self, text: str, wanted: set[JsonPath]) -> None:
        self.text = text
        self.wanted = {p[:n] for p in wanted for n in range(len(p) + 1)}
        self.above = {p[:n] for p in wanted for n in range(len(p))}
        self.skip = json.JSONDecoder(parse_int=lambda _: 0).raw_decode
        self.spans: dict[JsonPath, tuple[int, int, int, int]] = {}
        self.value(self.space(0), (), -1, -1)

    def space(self, at: int) -> int:
        return _SPACE.match(self.text, at).end()  # type: ignore[union-attr]

    def value(self, at: int, path: JsonPath, key_start: int, key_end: int) -> int:
        opening = self.text[at]
        if path in self.above and opening == "{":
            end = self.object(at, path)
        elif path in self.above and opening == "[":
            end = self.array(at, path)
        else:
            end = self.skip(self.text, at)[1]
        if path in self.wanted:
            self.spans[path] = (at, end, key_start, key_end)
        return end

    def object(self, at: int, path: JsonPath) -> int:
        at = self.space(at + 1)
        while self.text[at] != "}":
            key, key_end = scanstring(self.text, at + 1)
            colon = self.space(key_end)
            end = self.value(self.space(colon + 1), (*path, key), at, key_end)
            at = self.space(end)
            if self.text[at] == ",":
                at = self.space(at + 1)
        return at + 1

    def array(self, at: int, path: JsonPath) -> int:
        at = self.space(at + 1)
        index = 0
        while self.text[at] != "]":
            at = self.space(self.value(at, (*path, index), -1, -1))
            if self.text[at] == ",":
                at = self.space(at + 1)
            index += 1
        return at + 1
