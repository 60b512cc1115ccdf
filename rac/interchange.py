"""The JSON interchange ``ram/1`` (docs/spec.md): read and write.

A field reference is a string, ``"/pose.yaw"``, or ``"I(/pose.twist.twist.angular.z)"`` for
an integrated side, exactly as the ``.ram`` text writes it.
"""

from __future__ import annotations

import json
from typing import Any

from rac.errors import Diagnostic, RacError
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


class _Reader:
    """Checks the document's shape as it lowers it, collecting every problem."""

    def __init__(self, path: str) -> None:
        self.path = path
        self.problems: list[Diagnostic] = []

    def fail(self, where: str, message: str) -> None:
        self.problems.append(Diagnostic("RAC005", f"{where}: {message}"))

    def obj(self, value: Any, kind: str, where: str) -> dict[str, Any]:
        if not isinstance(value, dict):
            self.fail(where, f"expected an object for {kind}")
            return {}
        required, optional = _KEYS[kind]
        for key in sorted(required - value.keys()):
            self.fail(where, f"missing key '{key}'")
        for key in sorted(value.keys() - required - optional):
            self.fail(where, f"unknown key '{key}'")
        return value

    def typed(self, value: Any, types: type | tuple[type, ...], what: str, where: str) -> Any:
        if isinstance(value, bool) and bool not in (
            types if isinstance(types, tuple) else (types,)
        ):
            self.fail(where, f"expected {what}")
            return None
        if not isinstance(value, types):
            self.fail(where, f"expected {what}")
            return None
        return value

    def names(self, value: Any, where: str) -> tuple[Name, ...]:
        if value is None:
            return ()
        items = self.typed(value, list, "a list of names", where) or []
        out = []
        for i, item in enumerate(items):
            if self.typed(item, str, "a name (string)", f"{where}[{i}]") is not None:
                out.append(Name(item))
        return tuple(out)

    def number(self, value: Any, where: str) -> float | None:
        if value is None:
            return None
        got = self.typed(value, (int, float), "a number", where)
        if got is not None and self.in_range(got, where):
            return float(got)
        return None

    def integer(self, value: Any, where: str) -> int | None:
        if value is None:
            return None
        got = self.typed(value, int, "a whole number", where)
        if got is not None and self.in_range(got, where):
            return int(got)
        return None

    def in_range(self, value: float | int, where: str) -> bool:
        """RAC007 for NaN, infinities and huge numbers (before float() overflows on them)."""
        problem = f"a number of {value.digits:,} digits" if isinstance(value, _LongNumber) else None
        problem = problem or number_problem(value)
        if problem is not None:
            self.problems.append(Diagnostic("RAC007", f"{where}: {problem}"))
        return problem is None

    def model(self, doc: Any) -> Model:
        d = self.obj(doc, "model", "document")
        if d.get("format", FORMAT) != FORMAT:
            self.fail("format", f'expected "{FORMAT}", got {d.get("format")!r}')
        name = self.typed(d.get("name", ""), str, "a string", "name") or ""
        lists = {k: self.typed(d.get(k) or [], list, "a list", k) or [] for k in _KEYS["model"][1]}
        return Model(
            name=Name(name),
            hardware=tuple(
                self.hardware(h, f"hardware[{i}]") for i, h in enumerate(lists["hardware"])
            ),
            topics=tuple(self.topic(t, f"topics[{i}]") for i, t in enumerate(lists["topics"])),
            nodes=tuple(self.node(n, f"nodes[{i}]") for i, n in enumerate(lists["nodes"])),
            related=tuple(self.related(r, f"related[{i}]") for i, r in enumerate(lists["related"])),
            intervals=tuple(
                self.interval(v, f"intervals[{i}]") for i, v in enumerate(lists["intervals"])
            ),
            path=self.path,
        )

    def hardware(self, value: Any, where: str) -> Hardware:
        h = self.obj(value, "hardware", where)
        switchable = h.get("switchable", False)
        if self.typed(switchable, bool, "true or false", f"{where}.switchable") is None:
            switchable = False
        return Hardware(
            Name(self.typed(h.get("name", ""), str, "a string", f"{where}.name") or ""),
            switchable=switchable,
            channel=self.integer(h.get("channel"), f"{where}.channel"),
        )

    def topic(self, value: Any, where: str) -> Topic:
        t = self.obj(value, "topic", where)
        msg_type = t.get("type")
        if msg_type is not None:
            msg_type = self.typed(msg_type, str, "a string", f"{where}.type")
        mismatch = self.integer(t.get("mismatch_threshold"), f"{where}.mismatch_threshold")
        return Topic(
            Name(self.typed(t.get("name", ""), str, "a string", f"{where}.name") or ""),
            msg_type=msg_type or None,
            fields=self.names(t.get("fields"), f"{where}.fields"),
            rate_hz=self.number(t.get("rate_hz"), f"{where}.rate_hz"),
            rate_tolerance_hz=self.number(t.get("rate_tolerance_hz"), f"{where}.rate_tolerance_hz"),
            window_s=self.number(t.get("window_s"), f"{where}.window_s"),
            mismatch_threshold=mismatch,
        )

    def node(self, value: Any, where: str) -> Node:
        n = self.obj(value, "node", where)
        pubs = self.typed(n.get("publishes") or [], list, "a list", f"{where}.publishes") or []
        limits = self.obj(n.get("limits") or {}, "limits", f"{where}.limits")
        mem = self.number(limits.get("mem"), f"{where}.limits.mem")
        return Node(
            Name(self.typed(n.get("name", ""), str, "a string", f"{where}.name") or ""),
            drives=self.names(n.get("drives"), f"{where}.drives"),
            subscribes=self.names(n.get("subscribes"), f"{where}.subscribes"),
            publishes=tuple(
                self.publication(p, f"{where}.publishes[{i}]") for i, p in enumerate(pubs)
            ),
            limits=Limits(
                cpu=self.number(limits.get("cpu"), f"{where}.limits.cpu"),
                mem=round(mem) if mem is not None else None,
            ),
            diagnostics=self.names(n.get("diagnostics"), f"{where}.diagnostics"),
        )

    def publication(self, value: Any, where: str) -> Publication:
        p = self.obj(value, "publication", where)
        topic = self.typed(p.get("topic", ""), str, "a string", f"{where}.topic") or ""
        return Publication(Name(topic), self.names(p.get("affected_by"), f"{where}.affected_by"))

    def field_ref(self, value: Any, where: str) -> FieldRef:
        text = self.typed(value, str, "a field reference 'TOPIC.FIELD'", where) or ""
        ref = FieldRef.parse(text)
        if text and ("." not in text or ref.text != text or "(" in ref.path or ")" in ref.path):
            self.fail(where, f"'{text}' is not TOPIC.FIELD or I(TOPIC.FIELD)")
        return ref

    def related(self, value: Any, where: str) -> Related:
        pair = self.typed(value, list, "a pair of field references", where) or []
        if len(pair) != 2:
            self.fail(where, "expected exactly two field references")
            pair = [*pair, "", ""][:2]
        return Related(
            self.field_ref(pair[0], f"{where}[0]"), self.field_ref(pair[1], f"{where}[1]")
        )

    def interval(self, value: Any, where: str) -> Interval:
        v = self.obj(value, "interval", where)
        return Interval(
            self.field_ref(v.get("a", ""), f"{where}.a"),
            self.field_ref(v.get("b", ""), f"{where}.b"),
            self.number(v.get("max_diff", 0.0), f"{where}.max_diff") or 0.0,
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
    """Read a ``ram/1`` document; every shape problem is reported at once (RAC005)."""
    from rac.errors import Span

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
        problems = [Diagnostic(p.code, f"{path}: {p.message}") for p in reader.problems]
        raise RacError(problems, text)
    return model
