"""Semantic validation of a RAM: every rule is a small function in ``RULES``.

Each rule reads the model and yields diagnostics; ``validate`` runs them all so
a user sees every problem of a file in one run.  Errors stop compilation,
warnings do not.
"""

from __future__ import annotations

import functools
import math
import re
from collections import defaultdict
from collections.abc import Callable, Iterable, Iterator, Sequence
from itertools import chain
from operator import attrgetter

from rac.errors import Diagnostic, Severity, Span, did_you_mean
from rac.ir import FieldRef, Model, Name
from rac.limits import MAX_NAME, NUMBER_MAX, name_problem, number_problem, shown_name
from rac.logic import integral_arg, mangle
from rac.passes.loops import find_loops, is_exact
from rac.passes.observers import gobs_timing

Rule = Callable[[Model], Iterable[Diagnostic]]

# ROS graph resource names (ROS 1 and 2): segments start with a letter.
_ROS_NAME = re.compile(r"/?[A-Za-z][A-Za-z0-9_]*(/[A-Za-z][A-Za-z0-9_]*)*")
# Names one a line, each a ROS name.
_ROS_NAMES = re.compile(rf"(?:{_ROS_NAME.pattern}\n)*")
_DEVICE_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_\-]*")


def _error(code: str, message: str, span: Span | None, hint: str | None = None) -> Diagnostic:
    return Diagnostic(code, message, span, hint=hint)


def _warning(code: str, message: str, span: Span | None, hint: str | None = None) -> Diagnostic:
    return Diagnostic(code, message, span, Severity.WARNING, hint)


def check_names(model: Model) -> Iterator[Diagnostic]:
    """Node and topic names are ROS names; hardware and the robot are identifiers."""
    ros_names = [*map(_NAME, model.nodes), *map(_NAME, model.topics)]
    # All valid (the usual case) in one regex call over the names one a line, rather than
    # one call per name; any doubt and each name is looked at.
    lines = "\n".join(map(_VALUE, ros_names)) + "\n" if ros_names else ""
    if lines.count("\n") != len(ros_names) or _ROS_NAMES.fullmatch(lines) is None:
        kinds = ["node"] * len(model.nodes) + ["topic"] * len(model.topics)
        for name, kind in zip(ros_names, kinds, strict=True):
            if not _ROS_NAME.fullmatch(name.value):
                hint = "a ROS name is segments of letters, digits and '_' separated by '/', "
                hint += "each starting with a letter; private '~' names must be written in full"
                yield _error("RAC028", f"invalid ROS {kind} name '{name.value}'", name.span, hint)
    for name, kind in [(model.name, "robot"), *((h.name, "hardware") for h in model.hardware)]:
        if not _DEVICE_NAME.fullmatch(name.value):
            hint = "use letters, digits, '_' and '-', starting with a letter or '_'"
            yield _error("RAC028", f"invalid {kind} name '{name.value}'", name.span, hint)
    yield from _check_name_sets(model)


def _check_name_sets(model: Model) -> Iterator[Diagnostic]:
    """Every name within its documented character set and length (RAC008).

    Node, topic, hardware and robot names are checked above (RAC028), and only for length
    here; fields, message types and reported devices have their own sets.  Each distinct
    name is checked once (a few field names recur thousands of times in a large model),
    and only when one is wrong are the names looked at one by one, in model order.
    """
    declared = [model.name, *map(_NAME, model.hardware), *map(_NAME, model.nodes)]
    declared += map(_NAME, model.topics)
    if max(map(len, map(_VALUE, declared))) > MAX_NAME:
        for name in declared:
            if len(name.value) > MAX_NAME:
                message = (
                    f"name {shown_name(name.value)} is too long (at most {MAX_NAME} characters)"
                )
                yield _error("RAC008", message, name.span)
    fields = list(chain.from_iterable(map(_FIELDS, model.topics)))
    devices = list(chain.from_iterable(map(_DIAGNOSTICS, model.nodes)))
    types = {t.msg_type for t in model.topics if t.msg_type is not None}
    distinct = [("field", set(map(_VALUE, fields))), ("device", set(map(_VALUE, devices)))]
    distinct.append(("message type", types))
    if all(name_problem(kind, value) is None for kind, values in distinct for value in values):
        return
    typed: list[tuple[str, str, Span | None]] = [
        *(("field", f.value, f.span) for f in fields),
        *(("device", d.value, d.span) for d in devices),
    ]
    typed.extend(
        ("message type", t.msg_type, t.span) for t in model.topics if t.msg_type is not None
    )
    for kind, value, span in typed:
        problem = name_problem(kind, value)
        if problem is not None:
            yield _error("RAC008", f"{kind} name {shown_name(value)} {problem}", span)


_NAME = attrgetter("name")
_VALUE = attrgetter("value")
_FIELDS = attrgetter("fields")
_DIAGNOSTICS = attrgetter("diagnostics")


def check_duplicates(model: Model) -> Iterator[Diagnostic]:
    """Names are declared once: components (nodes, hardware) share one namespace."""
    seen: dict[str, tuple[str, Name]] = {}
    for kind, name in [
        *(("hardware", h.name) for h in model.hardware),
        *(("node", n.name) for n in model.nodes),
    ]:
        if name.value in seen:
            first_kind, first = seen[name.value]
            where = (
                f" (first declared as {first_kind} at line {first.span.line})" if first.span else ""
            )
            yield _error("RAC010", f"duplicate name '{name.value}'{where}", name.span)
        else:
            seen[name.value] = (kind, name)
    topics: dict[str, Name] = {}
    for topic in model.topics:
        if topic.name.value in topics:
            yield _error("RAC010", f"duplicate topic '{topic.name.value}'", topic.name.span)
        topics.setdefault(topic.name.value, topic.name)
        fields: set[str] = set()
        for f in topic.fields:
            if f.value in fields:
                msg = f"duplicate field '{f.value}' in topic '{topic.name.value}'"
                yield _error("RAC015", msg, f.span)
            fields.add(f.value)


def check_references(model: Model) -> Iterator[Diagnostic]:
    """Every hardware and topic a node names is declared."""
    yield from _hardware_references(model)
    yield from _topic_references(model)


def _hardware_references(model: Model) -> Iterator[Diagnostic]:
    hardware = model.hardware_by_name()
    nodes = {n.name.value: n for n in model.nodes}
    for node in model.nodes:
        for hw in node.drives:
            if hw.value in nodes and hw.value not in hardware:  # named the driver, not its device
                msg = f"node '{node.name.value}' drives '{hw.value}', which is a node, not hardware"
                driven = [d.value for d in nodes[hw.value].drives]
                hint = (
                    f"'{hw.value}' drives {', '.join(repr(d) for d in driven)}; name that"
                    if driven
                    else "'drives' names hardware declared with 'hardware NAME'"
                )
                yield _error("RAC011", msg, hw.span, hint)
            elif hw.value not in hardware:
                msg = f"node '{node.name.value}' drives undefined hardware '{hw.value}'"
                yield _error("RAC011", msg, hw.span, did_you_mean(hw.value, hardware))


def _topic_references(model: Model) -> Iterator[Diagnostic]:
    """One RAC012 per undefined topic, at its first use: a misspelling has a did-you-mean; a
    topic used in several places and close to no declared one was not declared, and the
    hint says so (and where else it is used) instead of one error per use."""
    topics = model.topic_by_name()
    uses: dict[str, list[tuple[Name, str, str]]] = {}
    for node in model.nodes:
        used = [
            *((t, "subscribes") for t in node.subscribes),
            *((p.topic, "publishes") for p in node.publishes),
            *((a, "names as input") for p in node.publishes for a in p.affected_by),
        ]
        for ref, verb in used:
            if ref.value not in topics:
                uses.setdefault(ref.value, []).append((ref, verb, node.name.value))
    for name, found in uses.items():
        ref, verb, node_name = found[0]
        hint = did_you_mean(name, topics)
        if hint is None:
            others = sorted({n for _, _, n in found[1:]} - {node_name})
            hint = f"declare it: 'topic {name} : PACKAGE/Type'" + (
                f" (node {', '.join(repr(n) for n in others)} uses it too)" if others else ""
            )
        msg = f"node '{node_name}' {verb} undefined topic '{name}'"
        yield _error("RAC012", msg, ref.span, hint)


def check_duplicate_statements(model: Model) -> Iterator[Diagnostic]:
    """A node lists a hardware or topic once per role."""
    for node in model.nodes:
        groups = [
            ("drives", node.drives),
            ("subscribes", node.subscribes),
            ("publishes", tuple(p.topic for p in node.publishes)),
            ("reports", node.diagnostics),
        ]
        for verb, names in groups:
            seen: set[str] = set()
            for ref in names:
                if ref.value in seen:
                    msg = f"node '{node.name.value}' {verb} '{ref.value}' twice"
                    yield _error("RAC030", msg, ref.span)
                seen.add(ref.value)
    pairs: set[frozenset[str]] = set()
    for rel in model.related:
        key = frozenset((rel.a.text, rel.b.text))
        if key in pairs:
            yield _error("RAC030", f"fields {rel.a.text} and {rel.b.text} related twice", rel.span)
        pairs.add(key)
    # Two intervals on one pair would be two observers reporting the same equal(...) atom.
    bounded: set[frozenset[str]] = set()
    for iv in model.intervals:
        key = frozenset((iv.a.text, iv.b.text))
        if key in bounded:
            msg = f"fields {iv.a.text} and {iv.b.text} have two interval bounds"
            yield _error("RAC030", msg, iv.span, "keep one 'interval … within' line per pair")
        bounded.add(key)


def check_affected_by(model: Model) -> Iterator[Diagnostic]:
    """δ_aff(n, τ) ⊆ δ_in(n), and τ ∉ δ_aff(n, τ) (Proposition 4.1)."""
    topics = model.topic_by_name()
    for node in model.nodes:
        inputs = {t.value for t in node.subscribes}
        # A misspelt subscription is RAC012's, with its did-you-mean: the input it meant is
        # not reported again here as not subscribed.
        misspelt = [t for t in inputs if t not in topics]
        for pub in node.publishes:
            for ref in pub.affected_by:
                if any(did_you_mean(t, [ref.value]) for t in misspelt):
                    continue
                if ref.value == pub.topic.value:
                    msg = f"topic '{ref.value}' cannot be among its own inputs (Proposition 4.1)"
                    yield _error("RAC021", msg, ref.span, "remove it from the 'from' list")
                elif ref.value not in inputs:
                    msg = (
                        f"'{pub.topic.value}' of node '{node.name.value}' depends on "
                        f"'{ref.value}', which the node does not subscribe to"
                    )
                    yield _error("RAC020", msg, ref.span, f"add 'subscribes {ref.value}'")


def _field_refs(model: Model) -> Iterator[tuple[FieldRef, FieldRef, Span | None, str]]:
    for rel in model.related:
        yield rel.a, rel.b, rel.span, "relate"
    for iv in model.intervals:
        yield iv.a, iv.b, iv.span, "interval"


def check_field_pairs(model: Model) -> Iterator[Diagnostic]:
    """Related and interval pairs name two distinct, declared, published fields."""
    topics = model.topic_by_name()
    publishers = model.publishers()
    # Each topic's fields once, as a list (for the hints) and a set (the look-up): built per
    # reference, they made checking n relations on one topic quadratic.
    field_lists: dict[str, tuple[list[str], frozenset[str]]] = {}
    for a, b, span, what in _field_refs(model):
        # A field against its own integral is no relation either (Algorithm 16).
        if a.path == b.path:
            yield _error("RAC022", f"{what} names the field {a.path} twice", span)
        for ref in (a, b):
            topic = topics.get(ref.topic)
            if topic is None:
                msg = f"{what} names undefined topic '{ref.topic}'"
                yield _error("RAC012", msg, ref.span, did_you_mean(ref.topic, topics))
                continue
            if ref.topic not in field_lists:
                listed = [f.value for f in topic.fields]
                field_lists[ref.topic] = (listed, frozenset(listed))
            fields, declared = field_lists[ref.topic]
            if ref.field not in declared:
                msg = f"topic '{ref.topic}' has no field '{ref.field}'"
                hint = did_you_mean(ref.field, fields)
                if hint is None and fields:
                    hint = f"declare it in the topic's field list {{ {', '.join(fields)} }}"
                elif hint is None:
                    hint = f"declare it in a field list: topic {ref.topic} {{ {ref.field} }}"
                yield _error("RAC014", msg, ref.span, hint)
            elif ref.topic not in publishers:
                msg = f"{what} names topic '{ref.topic}', which no node publishes"
                yield _error("RAC023", msg, ref.span)


def check_interval_sides(model: Model) -> Iterator[Diagnostic]:
    """An interval bounds the difference of two raw values: I(...) belongs to 'relate'."""
    for iv in model.intervals:
        for ref in (iv.a, iv.b):
            if ref.integrated:
                msg = f"an interval cannot bound the integrated field {ref.text}"
                hint = (
                    f"write 'interval {ref.path} ~ …' to bound the raw value, or "
                    f"'relate {ref.text} ~ …' to compare trends"
                )
                yield _error("RAC031", msg, ref.span, hint)


def check_channels(model: Model) -> Iterator[Diagnostic]:
    """Switchable hardware sits on its own board channel (chapter 8)."""
    owners: dict[int, str] = {}
    for hw in model.hardware:
        if hw.switchable and hw.channel is None:
            hint = f"write 'hardware {hw.name.value} switchable channel N'"
            msg = f"switchable hardware '{hw.name.value}' has no board channel"
            yield _error("RAC024", msg, hw.span, hint)
        if not hw.switchable and hw.channel is not None:
            msg = f"hardware '{hw.name.value}' has a channel but is not switchable"
            yield _error("RAC026", msg, hw.span, "add 'switchable' or drop the channel")
        if hw.channel is not None and hw.channel < 1:
            yield _error("RAC029", f"board channels count from 1, not {hw.channel}", hw.span)
        if hw.switchable and hw.channel is not None:
            # The same name again is a duplicate declaration (RAC010 says so), not a clash.
            if owners.get(hw.channel, hw.name.value) != hw.name.value:
                msg = (
                    f"'{hw.name.value}' and '{owners[hw.channel]}' are both on channel {hw.channel}"
                )
                yield _error("RAC025", msg, hw.span)
            owners.setdefault(hw.channel, hw.name.value)


def check_ranges(model: Model) -> Iterator[Diagnostic]:
    """Every number within the documented limits (RAC007), whichever format it came from."""
    if not _numbers_in_range(model):
        yield from _number_problems(model)
        return
    for t in model.topics:  # a tiny rate (or rate - tolerance) has no finite period
        tol = t.rate_tolerance_hz
        if t.rate_hz is None or t.rate_hz <= 0 or (tol is not None and not 0 <= tol < t.rate_hz):
            continue  # check_values reports these
        if not all(map(math.isfinite, gobs_timing(t))):
            message = (
                f"topic '{t.name.value}': rate {t.rate_hz:g} Hz is too close to 0 "
                "(or to its tolerance): its period is not a finite number"
            )
            yield _error("RAC007", message, t.rate_span or t.span)


def _numbers(model: Model) -> Iterator[float | int | None]:
    for t in model.topics:
        yield from (t.rate_hz, t.rate_tolerance_hz, t.window_s, t.mismatch_threshold)
    for n in model.nodes:
        yield from (n.limits.cpu, n.limits.mem)
    yield from (h.channel for h in model.hardware)
    yield from (iv.max_diff for iv in model.intervals)


def _numbers_in_range(model: Model) -> bool:
    """Every number of the model finite and within ±NUMBER_MAX: the usual case, decided
    without writing what each number is."""
    given = [v for v in _numbers(model) if v is not None]
    if not given:
        return True
    if not (min(given) >= -NUMBER_MAX and max(given) <= NUMBER_MAX):
        return False  # an infinity, a huge number, or a NaN that comparisons skip over
    return not any(map(math.isnan, given))  # every number converts: none is that large


def _number_problems(model: Model) -> Iterator[Diagnostic]:
    """RAC007 for each number out of range, with what it is (rac.limits.number_problem)."""
    # (what, its name, value, span): ``what.format(name)`` is written only for a bad number.
    found: list[tuple[str, str, float | int | None, Span | None]] = []
    for t in model.topics:
        name = t.name.value
        found += [
            ("topic '{}': rate", name, t.rate_hz, t.rate_span or t.span),
            ("topic '{}': tolerance", name, t.rate_tolerance_hz, t.tolerance_span or t.span),
            ("topic '{}': window", name, t.window_s, t.window_span or t.span),
            ("topic '{}': mismatch", name, t.mismatch_threshold, t.mismatch_span or t.span),
        ]
    for n in model.nodes:
        name, limits = n.name.value, n.limits
        found += [
            ("node '{}': cpu limit", name, limits.cpu, limits.span),
            ("node '{}': memory limit (in bytes)", name, limits.mem, limits.span),
        ]
    found += [("hardware '{}': channel", h.name.value, h.channel, h.span) for h in model.hardware]
    found += [("an interval's 'within' bound", "", iv.max_diff, iv.span) for iv in model.intervals]
    for what, name, value, span in found:
        if value is None:
            continue
        problem = number_problem(value)
        if problem is not None:
            shown = f"{value:g}" if abs(value) < 1e300 else "(a huge number)"
            yield _error("RAC007", f"{what.format(name)} {shown} is {problem}", span)


# A GObs window holds 10 messages by default (docs/language.md); one that holds fewer than
# WINDOW_MIN_MESSAGES, or more than WINDOW_MAX_MESSAGES, is almost surely a slip of unit.
WINDOW_MIN_MESSAGES = 2
WINDOW_MAX_MESSAGES = 1000


def _window_range(
    name: str, window_s: float, rate_hz: float, span: Span | None
) -> Iterator[Diagnostic]:
    """RAC133 (warning) for a window far outside the sensible range of its rate."""
    messages = window_s * rate_hz
    default = f"the default is 10 messages, {10 / rate_hz:g} s"
    if messages < WINDOW_MIN_MESSAGES:
        msg = (
            f"topic '{name}': window {window_s:g} s holds {messages:.3g} messages at "
            f"{rate_hz:g} Hz; the observer cannot measure a rate from so few"
        )
        yield _warning("RAC133", msg, span, f"{default}; ms or s?")
    elif messages > WINDOW_MAX_MESSAGES:
        msg = (
            f"topic '{name}': window {window_s:g} s holds {messages:,.0f} messages at "
            f"{rate_hz:g} Hz; a fault on it shows up to {window_s:g} s late"
        )
        yield _warning("RAC133", msg, span, f"{default}; ms or s?")


def check_values(model: Model) -> Iterator[Diagnostic]:
    """Rates, limits and thresholds are positive and consistent."""
    for t in model.topics:
        name = t.name.value
        if t.rate_hz is not None and t.rate_hz <= 0:
            message = f"topic '{name}': rate must be above 0 Hz, not {t.rate_hz:g} Hz"
            yield _error("RAC029", message, t.rate_span or t.span)
        if t.rate_hz is None and (t.rate_tolerance_hz, t.window_s, t.mismatch_threshold) != (
            None,
            None,
            None,
        ):
            options = (t.tolerance_span, t.window_span, t.mismatch_span)
            at = min((s for s in options if s is not None), key=_start, default=t.span)
            yield _error(
                "RAC029", f"topic '{name}': tolerance, window and mismatch need a rate", at
            )
        tol = t.rate_tolerance_hz
        if tol is not None and t.rate_hz is not None and not 0 <= tol < t.rate_hz:
            msg = (
                f"topic '{name}': tolerance {tol:g} Hz must be in [0, rate), "
                f"below the rate {t.rate_hz:g} Hz"
            )
            hint = f"a tolerance is what the rate may deviate by: e.g. '+- {t.rate_hz / 10:g} Hz'"
            yield _error("RAC029", msg, t.tolerance_span or t.span, hint)
        if t.window_s is not None and t.window_s <= 0:
            message = f"topic '{name}': window must be above 0 s, not {t.window_s:g} s"
            yield _error("RAC029", message, t.window_span or t.span)
        elif t.window_s is not None and t.rate_hz is not None and t.rate_hz > 0:
            yield from _window_range(name, t.window_s, t.rate_hz, t.window_span or t.span)
    for n in model.nodes:
        lim = n.limits
        if (lim.cpu is not None and lim.cpu <= 0) or (lim.mem is not None and lim.mem <= 0):
            yield _error("RAC029", f"node '{n.name.value}': limits must be above 0", lim.span)
    for iv in model.intervals:
        if iv.max_diff < 0:
            yield _error("RAC029", "an interval's 'within' bound must not be negative", iv.span)


def _start(span: Span) -> tuple[int, int]:
    return (span.line, span.column)


def check_mangling(model: Model) -> Iterator[Diagnostic]:
    """Different names must not become the same atom argument (docs/spec.md)."""
    # Each distinct name is mangled once: topic names appear in two groups, and a few field
    # names recur in thousands of topics.
    atom_of = functools.lru_cache(maxsize=None)(_atom_arg)
    hardware = {h.name.value for h in model.hardware}
    topics = {t.name.value for t in model.topics}
    for kind, names in _mangling_groups(model, atom_of):
        values = {n.value for n in names}
        if _one_atom_each(values, atom_of):
            continue  # every atom comes from one name: nothing clashes (the usual case)
        by_atom: dict[str, list[Name]] = defaultdict(list)
        for name in names:
            by_atom[atom_of(name.value)].append(name)
        for atom, clash in by_atom.items():
            distinct = sorted({n.value for n in clash})
            seen_above = set(distinct) <= topics or set(distinct) <= hardware
            if len(distinct) > 1 and not (kind == "topic or reported device" and seen_above):
                first = next(n for n in clash if n.value != clash[-1].value)
                msg = f"{kind} names {' and '.join(repr(d) for d in distinct)} both become '{atom}'"
                hint = "rename one of them; '/', '.' and '-' all mangle to '_'"
                if any(d.startswith("I(") for d in distinct):
                    hint += "; I(FIELD) becomes I_FIELD"
                yield _error("RAC027", msg, clash[-1].span or first.span, hint)


def _one_atom_each(values: set[str], atom_of: Callable[[str], str]) -> bool:
    return len(set(map(atom_of, values))) == len(values)


def _mangling_groups(
    model: Model, atom_of: Callable[[str], str]
) -> Iterator[tuple[str, Sequence[Name]]]:
    """The groups of names whose atom arguments must differ, in the order reported; groups
    that cannot clash, as a cheaper check over all of them shows, are left out."""
    yield "component", [*(h.name for h in model.hardware), *(n.name for n in model.nodes)]
    # ok/1 is reported for topics (GObs) and for devices on /diagnostics (DObs), hardware
    # or not; clashes among topics alone or hardware alone are reported by the groups above.
    # Topics are a part of the second group: when it has no clash, neither do they.
    devices = [d for n in model.nodes for d in n.diagnostics]
    reported = [*(t.name for t in model.topics), *devices]
    if not _one_atom_each({n.value for n in reported}, atom_of):
        yield "topic", [t.name for t in model.topics]
        yield "topic or reported device", reported
    # matched(...) names an integrated side I_<field>: it must not meet a declared field.
    integrated: dict[str, list[Name]] = defaultdict(list)
    for rel in model.related:
        for ref in (rel.a, rel.b):
            if ref.integrated:
                integrated[ref.topic].append(Name(f"I({ref.field})", ref.span))
    # Two fields of one topic can clash only if two field names of the whole model do.
    every_field = {f.value for t in model.topics for f in t.fields}
    fields_may_clash = not _one_atom_each(every_field, atom_of)
    for t in model.topics:
        extra = integrated.get(t.name.value, ())
        if (fields_may_clash or extra) and len(t.fields) + len(extra) > 1:
            yield f"field of {t.name.value}", [*t.fields, *extra]


def _atom_arg(name: str) -> str:
    """The atom argument of a name; ``I(FIELD)`` stands for an integrated field."""
    if name.startswith("I(") and name.endswith(")"):
        return integral_arg(name[2:-1])
    return mangle(name)


def check_usage(model: Model) -> Iterator[Diagnostic]:
    """Warnings for parts of the model that nothing connects."""
    publishers = model.publishers()
    topics = model.topic_by_name()
    for node in model.nodes:
        for ref in node.subscribes:
            if ref.value in topics and ref.value not in publishers:
                msg = (
                    f"topic '{ref.value}' is subscribed by '{node.name.value}' "
                    "but no node publishes it"
                )
                yield _warning("RAC100", msg, ref.span)
        if not node.subscribes and not node.publishes:
            yield _warning("RAC102", f"node '{node.name.value}' has no topics", node.name.span)
    driven = {hw.value for n in model.nodes for hw in n.drives}
    for hw in model.hardware:
        if hw.name.value not in driven:
            yield _warning(
                "RAC101", f"hardware '{hw.name.value}' is driven by no node", hw.name.span
            )
    used = {t.value for n in model.nodes for t in n.subscribes} | set(publishers)
    for t in model.topics:
        if t.name.value not in used:
            yield _warning("RAC103", f"topic '{t.name.value}' is used by no node", t.name.span)


def check_loops(model: Model) -> Iterator[Diagnostic]:
    """A note naming each feedback loop; a warning when it is too large for the exact rule."""

    declared = model.topic_by_name()
    for loop in find_loops(model):
        first = declared.get(loop.topics[0])
        span = first.name.span if first else None
        nodes = ", ".join(loop.nodes)
        yield Diagnostic(
            "RAC104",
            f"feedback loop {loop.describe()} through {nodes}",
            span,
            Severity.NOTE,
            "the loop rule derives its topics ok when its nodes are healthy and its inputs "
            "from outside are ok",
        )
        if not is_exact(loop):
            yield _warning(
                "RAC105",
                f"the loop through {loop.topics[0]} has too many alternative paths for the "
                "exact loop rule: its topics are derived ok only when all of it is healthy",
                span,
                "split the loop, or give publications fewer 'from' inputs",
            )


# A machine names an observer host (racc_observer_NAME): one ROS name segment.  A
# container's name is what docker and podman accept.
_MACHINE_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
_CONTAINER_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.\-]*")


def check_machines(model: Model) -> Iterator[Diagnostic]:
    """Machines declared once with valid names; every ``on`` names one; containers are
    named as docker and podman name them."""
    seen: dict[str, Name] = {}
    for machine in model.machines:
        name = machine.name
        if not _MACHINE_NAME.fullmatch(name.value):
            hint = "a machine name is letters, digits and '_', starting with a letter"
            yield _error("RAC142", f"invalid machine name '{name.value}'", name.span, hint)
        if name.value in seen:
            yield _error("RAC141", f"machine '{name.value}' declared twice", name.span)
        seen[name.value] = name
    for node in model.nodes:
        where = node.machine
        if where is not None and where.value not in seen:
            msg = f"node '{node.name.value}' runs on undeclared machine '{where.value}'"
            hint = did_you_mean(where.value, seen) or "declare it: 'machine NAME address ADDR'"
            yield _error("RAC140", msg, where.span, hint)
        box = node.container
        if box is not None and not _CONTAINER_NAME.fullmatch(box.name.value):
            hint = "a container name is letters, digits, '_', '.' and '-', starting with one of"
            hint += " the first two"
            msg = f"invalid container name '{box.name.value}'"
            yield _error("RAC142", msg, box.name.span, hint)


RULES: tuple[Rule, ...] = (
    check_names,
    check_machines,
    check_duplicates,
    check_references,
    check_duplicate_statements,
    check_affected_by,
    check_field_pairs,
    check_interval_sides,
    check_channels,
    check_ranges,
    check_values,
    check_mangling,
    check_usage,
    check_loops,
)


def validate(model: Model) -> tuple[Diagnostic, ...]:
    """All diagnostics of the model, errors and warnings, in source order."""
    found = [d for rule in RULES for d in rule(model)]

    def key(d: Diagnostic) -> tuple[int, int, str]:
        return (d.span.line, d.span.column, d.code) if d.span else (0, 0, d.code)

    return tuple(sorted(dict.fromkeys(found), key=key))
