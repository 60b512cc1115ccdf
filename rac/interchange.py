"""The JSON interchange ``ram/1`` (docs/spec.md): read and write.

A field reference is a string, ``"/pose.yaw"``, or ``"I(/pose.twist.twist.angular.z)"`` for
an integrated side, exactly as the ``.ram`` text writes it.
"""

from __future__ import annotations

import json
import re
from bisect import bisect_right
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from json.decoder import scanstring  # type: ignore[attr-defined]
from typing import Any

from rac.errors import Diagnostic, RacError, Span, did_you_mean
from rac.ir import (
    CONTAINER_RUNTIMES,
    Container,
    FieldRef,
    Hardware,
    Interval,
    Limits,
    Machine,
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
from rac.perf import paused_gc

FORMAT = "ram/1"

_KEYS: dict[str, tuple[set[str], set[str]]] = {
    # object kind: (required keys, optional keys)
    "model": (
        {"format", "name"},
        {"machines", "hardware", "topics", "nodes", "related", "intervals"},
    ),
    "machine": ({"name"}, {"address"}),
    "container": ({"name", "runtime"}, set()),
    "hardware": ({"name"}, {"switchable", "channel"}),
    "topic": (
        {"name"},
        {"type", "fields", "rate_hz", "rate_tolerance_hz", "window_s", "mismatch_threshold"},
    ),
    "node": (
        {"name"},
        {"drives", "subscribes", "publishes", "limits", "diagnostics", "machine", "container"},
    ),
    "publication": ({"topic"}, {"affected_by"}),
    "limits": (set(), {"cpu", "mem"}),
    "interval": ({"a", "b", "max_diff"}, set()),
}


def model_to_json(model: Model) -> dict[str, Any]:
    """The ``ram/1`` document of a model; optional keys are left out when empty (a model
    without machines is written as before they existed)."""
    machines: dict[str, Any] = {}
    if model.machines:
        machines["machines"] = [_machine(m) for m in model.machines]
    return {
        "format": FORMAT,
        "name": model.name.value,
        **machines,
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


def _machine(m: Machine) -> dict[str, Any]:
    out: dict[str, Any] = {"name": m.name.value}
    if m.address is not None:
        out["address"] = m.address
    return out


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
    if n.machine is not None:
        out["machine"] = n.machine.value
    if n.container is not None:
        out["container"] = {"name": n.container.name.value, "runtime": n.container.runtime}
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


# Where a JSON path's value is in the text, for a model read again to locate its diagnostics.
SpanAt = Callable[[JsonPath], Span | None]


class _Reader:
    """Checks the document's shape as it lowers it, collecting every problem.

    With ``span_at`` (only when a model's diagnostics are being located) every name, field
    reference and declaration it builds carries the span of its JSON value; without it, the
    IR is span-less and the reader does no more work than lowering.
    """

    def __init__(self, path: str, span_at: SpanAt | None = None) -> None:
        self.path = path
        self.problems: list[_Problem] = []
        self.span_at = span_at
        self.keys = 0  # the keys of every object read, to tell a key given twice

    def at(self, where: JsonPath) -> Span | None:
        return None if self.span_at is None else self.span_at(where)

    def name(self, value: Any, where: JsonPath) -> Name:
        """The name at ``where`` (a string, or "" after a RAC005)."""
        if not isinstance(value, str):  # typed(), inlined: one call per name, as many as names
            self.fail(where, "expected a string")
            value = ""
        return Name(value, None if self.span_at is None else self.span_at(where))

    def fail(self, where: JsonPath, message: str) -> None:
        self.problems.append(_Problem("RAC005", f"{_where(where)}: {message}", where))

    def obj(self, value: Any, kind: str, where: JsonPath) -> dict[str, Any]:
        if not isinstance(value, dict):
            self.fail(where, f"expected an object for {kind}")
            return {}
        self.keys += len(value)
        for key in getattr(value, "given_twice", ()):
            message = f"{_where(where)}: key '{key}' given twice (only the last one would count)"
            self.problems.append(_Problem("RAC005", message, (*where, key), True))
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
        span_at = self.span_at
        for i, item in enumerate(items):
            if self.typed(item, str, "a name (string)", (*where, i)) is not None:
                out.append(Name(item, None if span_at is None else span_at((*where, i))))
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
        name = self.name(d.get("name", ""), ("name",))
        lists = {
            k: self.typed(d.get(k) or [], list, "a list", (k,)) or [] for k in _KEYS["model"][1]
        }
        return Model(
            name=name,
            hardware=tuple(
                self.hardware(h, ("hardware", i)) for i, h in enumerate(lists["hardware"])
            ),
            topics=tuple(self.topic(t, ("topics", i)) for i, t in enumerate(lists["topics"])),
            nodes=tuple(self.node(n, ("nodes", i)) for i, n in enumerate(lists["nodes"])),
            related=tuple(self.related(r, ("related", i)) for i, r in enumerate(lists["related"])),
            intervals=tuple(
                self.interval(v, ("intervals", i)) for i, v in enumerate(lists["intervals"])
            ),
            machines=tuple(
                self.machine(m, ("machines", i)) for i, m in enumerate(lists["machines"])
            ),
            path=self.path,
        )

    def machine(self, value: Any, where: JsonPath) -> Machine:
        m = self.obj(value, "machine", where)
        address = m.get("address")
        if address is not None:
            address = self.typed(address, str, "a string", (*where, "address"))
        return Machine(
            self.name(m.get("name", ""), (*where, "name")),
            address=address or None,
            span=self.at(where),
        )

    def container(self, value: Any, where: JsonPath) -> Container | None:
        if value is None:
            return None
        c = self.obj(value, "container", where)
        runtime = self.typed(c.get("runtime", ""), str, "a string", (*where, "runtime"))
        if runtime is not None and runtime not in CONTAINER_RUNTIMES:
            self.fail((*where, "runtime"), f"expected docker or podman, got {runtime!r}")
        return Container(self.name(c.get("name", ""), (*where, "name")), runtime or "")

    def hardware(self, value: Any, where: JsonPath) -> Hardware:
        h = self.obj(value, "hardware", where)
        switchable = h.get("switchable", False)
        if self.typed(switchable, bool, "true or false", (*where, "switchable")) is None:
            switchable = False
        return Hardware(
            self.name(h.get("name", ""), (*where, "name")),
            switchable=switchable,
            channel=self.integer(h.get("channel"), (*where, "channel")),
            span=self.at(where),
        )

    def topic(self, value: Any, where: JsonPath) -> Topic:
        t = self.obj(value, "topic", where)
        msg_type = t.get("type")
        if msg_type is not None:
            msg_type = self.typed(msg_type, str, "a string", (*where, "type"))
        mismatch = self.integer(t.get("mismatch_threshold"), (*where, "mismatch_threshold"))
        return Topic(
            self.name(t.get("name", ""), (*where, "name")),
            msg_type=msg_type or None,
            fields=self.names(t.get("fields"), (*where, "fields")),
            rate_hz=self.number(t.get("rate_hz"), (*where, "rate_hz")),
            rate_tolerance_hz=self.number(
                t.get("rate_tolerance_hz"), (*where, "rate_tolerance_hz")
            ),
            window_s=self.number(t.get("window_s"), (*where, "window_s")),
            mismatch_threshold=mismatch,
            span=self.at(where),
        )

    def node(self, value: Any, where: JsonPath) -> Node:
        n = self.obj(value, "node", where)
        pubs = self.typed(n.get("publishes") or [], list, "a list", (*where, "publishes")) or []
        limits = self.obj(n.get("limits") or {}, "limits", (*where, "limits"))
        mem = self.number(limits.get("mem"), (*where, "limits", "mem"))
        return Node(
            self.name(n.get("name", ""), (*where, "name")),
            drives=self.names(n.get("drives"), (*where, "drives")),
            subscribes=self.names(n.get("subscribes"), (*where, "subscribes")),
            publishes=tuple(
                self.publication(p, (*where, "publishes", i)) for i, p in enumerate(pubs)
            ),
            limits=Limits(
                cpu=self.number(limits.get("cpu"), (*where, "limits", "cpu")),
                mem=round(mem) if mem is not None else None,
                span=self.at((*where, "limits")),
            ),
            diagnostics=self.names(n.get("diagnostics"), (*where, "diagnostics")),
            machine=(
                self.name(n["machine"], (*where, "machine"))
                if n.get("machine") is not None
                else None
            ),
            container=self.container(n.get("container"), (*where, "container")),
            span=self.at(where),
        )

    def publication(self, value: Any, where: JsonPath) -> Publication:
        p = self.obj(value, "publication", where)
        topic = self.name(p.get("topic", ""), (*where, "topic"))
        return Publication(topic, self.names(p.get("affected_by"), (*where, "affected_by")))

    def field_ref(self, value: Any, where: JsonPath) -> FieldRef:
        text = self.typed(value, str, "a field reference 'TOPIC.FIELD'", where) or ""
        ref = FieldRef.parse(text, self.at(where))
        if text and ("." not in text or ref.text != text or "(" in ref.path or ")" in ref.path):
            self.fail(where, f"'{text}' is not TOPIC.FIELD or I(TOPIC.FIELD)")
        return ref

    def related(self, value: Any, where: JsonPath) -> Related:
        pair = self.typed(value, list, "a pair of field references", where) or []
        if len(pair) != 2:
            self.fail(where, "expected exactly two field references")
            pair = [*pair, "", ""][:2]
        return Related(
            self.field_ref(pair[0], (*where, 0)),
            self.field_ref(pair[1], (*where, 1)),
            span=self.at(where),
        )

    def interval(self, value: Any, where: JsonPath) -> Interval:
        v = self.obj(value, "interval", where)
        return Interval(
            self.field_ref(v.get("a", ""), (*where, "a")),
            self.field_ref(v.get("b", ""), (*where, "b")),
            self.number(v.get("max_diff", 0.0), (*where, "max_diff")) or 0.0,
            span=self.at(where),
        )


class _LongNumber(int):
    """An integer written with too many digits to convert (and far out of range anyway)."""

    digits: int


class _KeysGivenTwice(dict[str, Any]):
    """A JSON object in which a key occurs more than once, and those keys.  The decoder keeps
    the last value of such a key, silently losing the others (two ``"nodes"`` lists: the
    first robot half gone), so the reader reports them."""

    given_twice: tuple[str, ...] = ()


def _object(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """``object_pairs_hook``: a dict, or a :class:`_KeysGivenTwice` when a key repeats."""
    found = dict(pairs)
    if len(found) == len(pairs):
        return found
    twice = _KeysGivenTwice(found)
    keys = [key for key, _ in pairs]
    twice.given_twice = tuple(sorted({k for k in keys if keys.count(k) > 1}))
    return twice


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
    reader = _Reader(path)
    model = reader.model(_decoded(text, path, exact=False))
    if text.count(":") != reader.keys:
        # Each key of the text has one colon after it.  More colons than keys read: a colon
        # in a string, or a key given twice, whose first value the C decoder dropped without a
        # word.  Read again, telling every object with a repeated key (slower: a Python call
        # per object, paid by such documents only).
        reader = _Reader(path)
        model = reader.model(_decoded(text, path, exact=True))
    if reader.problems:
        raise RacError(_located(reader.problems, text, path), text)
    # The text rides along (as a .ram model's does) so that diagnostics found later can be
    # located by reading it again: see located_model.
    return replace(model, source=text)


def _decoded(text: str, path: str, *, exact: bool) -> Any:
    """The JSON document of ``text``; ``exact``: objects with a repeated key tell it."""
    hook = _object if exact else None
    too_deep = False
    try:
        doc = json.loads(text, parse_int=_parse_int, object_pairs_hook=hook)
    except json.JSONDecodeError as err:
        span = Span(path, err.lineno, err.colno, err.lineno, err.colno + 1)
        raise RacError([Diagnostic("RAC005", f"invalid JSON: {err.msg}", span)], text) from None
    except RecursionError:
        too_deep = True  # far deeper than MAX_DEPTH: the decoder ran out of stack
    if too_deep or depth_exceeds(doc):
        message = f"lists and objects nest more than {MAX_DEPTH} deep"
        raise RacError([Diagnostic("RAC009", message, Span(path, 1, 1, 1, 2))])
    return doc


def from_json(model: Model) -> bool:
    """Whether ``model`` was read from a ``ram/1`` text, which it carries without spans."""
    return (
        model.source is not None
        and model.name.span is None
        and _OPENING.match(model.source) is not None
    )


def located_model(model: Model) -> Model | None:
    """``model`` read again from its ``ram/1`` text, every name and declaration with a span.

    The slow, position-recording read (a walk of the whole text) that a model read from
    JSON pays only when one of its diagnostics is shown.  None when the model did not come
    from JSON, or no longer is what its text says (a model derived from a loaded one keeps
    the text it was read from).
    """
    if not from_json(model):
        return None
    assert model.source is not None
    text, path = model.source, model.path
    with paused_gc():  # hundreds of thousands of acyclic offsets and spans (rac.perf)
        doc = json.loads(text, parse_int=_parse_int)
        reader = _Reader(path, _SpanLookup(text, doc, path).at)
        located = reader.model(doc)
        if reader.problems or located != model:
            return None
        return replace(located, source=text)


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
    lines = _Lines(text, path)
    located = []
    for problem, (start, end) in zip(problems, offsets, strict=True):
        span = lines.span(start, end)
        located.append((start, Diagnostic(problem.code, problem.message, span, hint=problem.hint)))
    located.sort(key=lambda pair: pair[0])  # stable: problems at one place keep their order
    return [diagnostic for _, diagnostic in located]


class _Lines:
    """Offsets of a text as spans: its line starts, found once, searched by bisection."""

    def __init__(self, text: str, path: str) -> None:
        self.path = path
        self.starts = [0, *(m.end() for m in re.finditer("\n", text))]

    def span(self, start: int, end: int) -> Span:
        starts = self.starts
        line = bisect_right(starts, start)
        end_line = bisect_right(starts, end, line - 1)
        return Span(
            self.path, line, start - starts[line - 1] + 1, end_line, end - starts[end_line - 1] + 1
        )


class _SpanLookup:
    """The span of every string, list and object of a text the C decoder has accepted (as
    ``doc``), by JSON path."""

    def __init__(self, text: str, doc: Any, path: str) -> None:
        found = _in_order(text, doc)
        if found is None:  # a duplicated key: only a walk of the text knows which one counts
            found = {p: (s[0], s[1]) for p, s in _Locator(text, None).spans.items()}
        self.offsets = found
        self.lines = _Lines(text, path)

    def at(self, where: JsonPath) -> Span | None:
        found = self.offsets.get(where)
        return None if found is None else self.lines.span(*found)


# Outside its strings, a JSON text holds no quote; inside them, no bracket counts.
_TOKEN = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"|[\[\]{}]')


def _in_order(text: str, doc: Any) -> dict[JsonPath, tuple[int, int]] | None:
    """Each string's, list's and object's offsets, by pairing the decoded document, walked in
    file order, with the strings and brackets of the text found by one regular expression
    (several times faster than :class:`_Locator` walking every value).  None when the two
    do not pair up: a duplicated key, of which the decoder kept one."""
    tokens = _TOKEN.finditer(text)
    spans: dict[JsonPath, tuple[int, int]] = {}

    def walk(value: dict[str, Any] | list[Any], path: JsonPath) -> bool:
        """Pair a list or object (its opening bracket is next) and everything in it."""
        is_object = isinstance(value, dict)
        token = next(tokens, None)
        if token is None or text[token.start()] != ("{" if is_object else "["):
            return False
        start = token.start()
        pairs: Iterable[tuple[str | int, Any]]
        pairs = value.items() if isinstance(value, dict) else enumerate(value)
        for key, item in pairs:
            if is_object and next(tokens, None) is None:  # the key
                return False
            if isinstance(item, str):  # most values: paired here, not in a call
                token = next(tokens, None)
                if token is None or text[token.start()] != '"':
                    return False
                at = (*path, key)
                spans[at] = token.span()
            elif isinstance(item, dict | list) and not walk(item, (*path, key)):
                return False
        token = next(tokens, None)
        if token is None or text[token.start()] != ("}" if is_object else "]"):
            return False
        spans[path] = (start, token.end())
        return True

    if isinstance(doc, str):
        token = next(tokens, None)
        return None if token is None or next(tokens, None) else {(): token.span()}
    if not isinstance(doc, dict | list):
        return {}
    if not walk(doc, ()) or next(tokens, None) is not None:
        return None
    return spans


_SPACE = re.compile(r"[ \t\n\r]*")
_OPENING = re.compile(r"[ \t\n\r]*\{")


class _Locator:
    """Where the values on some JSON paths are in a text the C decoder has accepted.

    ``spans`` maps each wanted path, and every path above one, to its value's start and end
    offsets and its key's (-1, -1 for a list item or the document).  Containers on the way to
    a wanted path are walked here; everything else is skipped by the C scanner.  A duplicated
    key keeps its last occurrence, the one the decoder kept.  ``wanted=None`` wants every path:
    the whole document is walked.
    """

    def __init__(self, text: str, wanted: set[JsonPath] | None) -> None:
        self.text = text
        self.everything = wanted is None
        self.wanted = {p[:n] for p in wanted or () for n in range(len(p) + 1)}
        self.above = {p[:n] for p in wanted or () for n in range(len(p))}
        self.skip = json.JSONDecoder(parse_int=lambda _: 0).raw_decode
        self.spans: dict[JsonPath, tuple[int, int, int, int]] = {}
        self.value(self.space(0), (), -1, -1)

    def space(self, at: int) -> int:
        return _SPACE.match(self.text, at).end()  # type: ignore[union-attr]

    def value(self, at: int, path: JsonPath, key_start: int, key_end: int) -> int:
        opening = self.text[at]
        walk = self.everything or path in self.above
        if walk and opening == "{":
            end = self.object(at, path)
        elif walk and opening == "[":
            end = self.array(at, path)
        elif opening == '"':
            end = scanstring(self.text, at + 1)[1]
        else:
            end = self.skip(self.text, at)[1]
        if self.everything or path in self.wanted:
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
