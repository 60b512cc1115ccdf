"""``racc fmt``: the canonical text of a model, comments kept, idempotent.

The formatter prints the IR, so its output is what the parser reads back; it
is also how ``racc learn`` writes the models it learns.
"""

from __future__ import annotations

from collections.abc import Iterable

from rac.ir import Hardware, Interval, Limits, Machine, Model, Node, Related, Topic

INDENT = "  "
_MEM_UNITS = (("GB", 1000**3), ("MB", 1000**2), ("kB", 1000))


def format_number(value: float) -> str:
    """Shortest text that reads back to the same float: 10.0 -> 10, 0.05 -> 0.05."""
    if value == int(value) and abs(value) < 1e15:
        return str(int(value))
    return repr(value)


def format_mem(value: int) -> str:
    for unit, size in _MEM_UNITS:
        if value % size == 0:
            return f"{value // size} {unit}"
    return f"{value} B"


def format_limits(limits: Limits) -> str:
    """``cpu 15 %, mem 64 MB`` (empty when the node declares none)."""
    parts = []
    if limits.cpu is not None:
        parts.append(f"cpu {format_number(limits.cpu)} %")
    if limits.mem is not None:
        parts.append(f"mem {format_mem(limits.mem)}")
    return ", ".join(parts)


def _comments(comments: Iterable[str], indent: str = "") -> list[str]:
    return [f"{indent}#{c}" if c.startswith(" ") or not c else f"{indent}# {c}" for c in comments]


def _machine(m: Machine) -> list[str]:
    line = f"machine {m.name.value}"
    if m.address is not None:
        line += f" address {m.address}"
    return [line]


def _hardware(h: Hardware) -> list[str]:
    line = f"hardware {h.name.value}"
    if h.switchable:
        line += " switchable"
    if h.channel is not None:
        line += f" channel {h.channel}"
    return [line]


def _topic(t: Topic) -> list[str]:
    head = f"topic {t.name.value}"
    if t.msg_type:
        head += f" : {t.msg_type}"
    rate = ""
    if t.rate_hz is not None:
        rate = f" @ {format_number(t.rate_hz)} Hz"
        if t.rate_tolerance_hz is not None:
            rate += f" +- {format_number(t.rate_tolerance_hz)} Hz"
        if t.window_s is not None:
            rate += f" window {format_number(t.window_s)} s"
        if t.mismatch_threshold is not None:
            rate += f" mismatch {t.mismatch_threshold}"
    fields = [f.value for f in t.fields]
    one_line = f"{head} {{ {', '.join(fields)} }}{rate}" if fields else f"{head}{rate}"
    if len(one_line) <= 100 or not fields:
        return [one_line]
    return [f"{head} {{", *_fill(fields, 100), f"}}{rate}"]


def _fill(items: list[str], width: int) -> list[str]:
    """Comma-separated items on indented lines of at most ``width`` characters."""
    lines: list[str] = []
    current = ""
    for i, item in enumerate(items):
        piece = item + ("," if i < len(items) - 1 else "")
        if current and len(INDENT + current + " " + piece) > width:
            lines.append(INDENT + current)
            current = piece
        else:
            current = f"{current} {piece}" if current else piece
    lines.append(INDENT + current)
    return lines


def _node(n: Node) -> list[str]:
    head = f"node {n.name.value}"
    if n.drives:
        head += " drives " + ", ".join(h.value for h in n.drives)
    if n.machine is not None:
        head += f" on {n.machine.value}"
    if n.container is not None:
        head += f" in container {n.container.name.value} via {n.container.runtime}"
    notes: dict[str, list[str]] = {}
    for anchor, text in n.body_comments:
        notes.setdefault(anchor, []).append(text)
    body = _comments(n.inner_comments, INDENT)

    def statement(line: str, *anchors: str) -> None:
        for anchor in anchors:
            body.extend(_comments(notes.pop(anchor, ()), INDENT))
        body.append(line)

    if n.subscribes:
        statement(f"{INDENT}subscribes " + ", ".join(t.value for t in n.subscribes), "subscribes")
    # Publications keep their order (the JSON export's order): a run of outputs without
    # inputs shares one line, each output with inputs has its own.
    plain: list[str] = []
    for p in n.publishes:
        if not p.affected_by:
            plain.append(p.topic.value)
            continue
        if plain:
            statement(f"{INDENT}publishes " + ", ".join(plain), *(f"pub:{t}" for t in plain))
            plain = []
        inputs = ", ".join(a.value for a in p.affected_by)
        statement(f"{INDENT}publishes {p.topic.value} from {inputs}", f"pub:{p.topic.value}")
    if plain:
        statement(f"{INDENT}publishes " + ", ".join(plain), *(f"pub:{t}" for t in plain))
    limits = format_limits(n.limits)
    if limits:
        statement(f"{INDENT}limits {limits}", "limits")
    if n.diagnostics:
        statement(f"{INDENT}reports " + ", ".join(d.value for d in n.diagnostics), "reports")
    # Comments after the last statement, or above one the model no longer has.
    body.extend(_comments((t for a, t in n.body_comments if a in notes), INDENT))
    if not body:
        return [head + " {}"]
    return [head + " {", *body, "}"]


def _related(r: Related) -> list[str]:
    return [f"relate {r.a.text} ~ {r.b.text}"]


def _interval(i: Interval) -> list[str]:
    return [f"interval {i.a.text} ~ {i.b.text} within {format_number(i.max_diff)}"]


def format_model(model: Model) -> str:
    """The canonical ``.ram`` text: sections in a fixed order, declarations as written."""
    out = [*_comments(model.comments), f"robot {model.name.value}"]
    sections: list[list[tuple[tuple[str, ...], list[str]]]] = [
        [(m.comments, _machine(m)) for m in model.machines],
        [(h.comments, _hardware(h)) for h in model.hardware],
        [(t.comments, _topic(t)) for t in model.topics],
        [(n.comments, _node(n)) for n in model.nodes],
        [(r.comments, _related(r)) for r in model.related],
        [(i.comments, _interval(i)) for i in model.intervals],
    ]
    for section in sections:
        if not section:
            continue
        out.append("")
        for i, (comments, lines) in enumerate(section):
            # A commented or multi-line declaration gets air around it.
            if i and (comments or len(lines) > 1 or len(section[i - 1][1]) > 1):
                out.append("")
            out.extend(_comments(comments))
            out.extend(lines)
    if model.trailing_comments:
        out.append("")
        out.extend(_comments(model.trailing_comments))
    return "\n".join(out) + "\n"
