"""The validation rules that decide the usual case in one pass (names checked once per distinct
name, numbers by their range, mangling by whole groups) report exactly what the
straightforward rules report, name by name and number by number: checked on random valid
models (tests/ram_strategies.py) with random damage (hypothesis).
"""

from __future__ import annotations

import dataclasses
import math
from collections import defaultdict
from collections.abc import Iterator

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from ram_strategies import models

from rac.errors import Diagnostic
from rac.ir import FieldRef, Limits, Model, Name, Related, Topic
from rac.limits import MAX_NAME, name_problem, number_problem, shown_name
from rac.logic import integral_arg, mangle
from rac.passes import validate
from rac.passes.observers import gobs_params

# --- the straightforward rules (the code before the fast paths), as the reference -------


def reference_name_sets(model: Model) -> Iterator[Diagnostic]:
    for name in [
        model.name,
        *(h.name for h in model.hardware),
        *(n.name for n in model.nodes),
        *(t.name for t in model.topics),
    ]:
        if len(name.value) > MAX_NAME:
            message = f"name {shown_name(name.value)} is too long (at most {MAX_NAME} characters)"
            yield validate._error("RAC008", message, name.span)
    typed = [
        *(("field", f.value, f.span) for t in model.topics for f in t.fields),
        *(("device", d.value, d.span) for n in model.nodes for d in n.diagnostics),
        *(("message type", t.msg_type, t.span) for t in model.topics if t.msg_type is not None),
    ]
    for kind, value, span in typed:
        problem = name_problem(kind, value)
        if problem is not None:
            yield validate._error("RAC008", f"{kind} name {shown_name(value)} {problem}", span)


def reference_ranges(model: Model) -> Iterator[Diagnostic]:
    found = []
    for t in model.topics:
        name = t.name.value
        found += [
            (f"topic '{name}': rate", t.rate_hz, t.span),
            (f"topic '{name}': tolerance", t.rate_tolerance_hz, t.span),
            (f"topic '{name}': window", t.window_s, t.span),
            (f"topic '{name}': mismatch", t.mismatch_threshold, t.span),
        ]
    for n in model.nodes:
        found += [
            (f"node '{n.name.value}': cpu limit", n.limits.cpu, n.limits.span),
            (f"node '{n.name.value}': memory limit (in bytes)", n.limits.mem, n.limits.span),
        ]
    found += [(f"hardware '{h.name.value}': channel", h.channel, h.span) for h in model.hardware]
    found += [("an interval's 'within' bound", iv.max_diff, iv.span) for iv in model.intervals]
    bad = False
    for what, value, span in found:
        problem = None if value is None else number_problem(value)
        if problem is not None:
            assert value is not None
            bad = True
            shown = f"{value:g}" if abs(value) < 1e300 else "(a huge number)"
            yield validate._error("RAC007", f"{what} {shown} is {problem}", span)
    if bad:
        return
    for t in model.topics:
        tol = t.rate_tolerance_hz
        if t.rate_hz is None or t.rate_hz <= 0 or (tol is not None and not 0 <= tol < t.rate_hz):
            continue
        if any(isinstance(v, float) and not math.isfinite(v) for _, v in gobs_params(t)):
            message = (
                f"topic '{t.name.value}': rate {t.rate_hz:g} Hz is too close to 0 "
                "(or to its tolerance): its period is not a finite number"
            )
            yield validate._error("RAC007", message, t.span)


def _arg(name: str) -> str:
    if name.startswith("I(") and name.endswith(")"):
        return integral_arg(name[2:-1])
    return mangle(name)


def reference_mangling(model: Model) -> Iterator[Diagnostic]:
    groups = [
        ("component", [*(h.name for h in model.hardware), *(n.name for n in model.nodes)]),
        ("topic", [t.name for t in model.topics]),
    ]
    hardware = {h.name.value for h in model.hardware}
    topics = {t.name.value for t in model.topics}
    devices = [d for n in model.nodes for d in n.diagnostics]
    groups.append(("topic or reported device", [*(t.name for t in model.topics), *devices]))
    integrated: dict[str, list[Name]] = defaultdict(list)
    for rel in model.related:
        for ref in (rel.a, rel.b):
            if ref.integrated:
                integrated[ref.topic].append(Name(f"I({ref.field})", ref.span))
    groups += [
        (f"field of {t.name.value}", [*t.fields, *integrated.get(t.name.value, ())])
        for t in model.topics
    ]
    for kind, names in groups:
        by_atom: dict[str, list[Name]] = defaultdict(list)
        for name in names:
            by_atom[_arg(name.value)].append(name)
        for atom, clash in by_atom.items():
            distinct = sorted({n.value for n in clash})
            seen_above = set(distinct) <= topics or set(distinct) <= hardware
            if len(distinct) > 1 and not (kind == "topic or reported device" and seen_above):
                first = next(n for n in clash if n.value != clash[-1].value)
                msg = f"{kind} names {' and '.join(repr(d) for d in distinct)} both become '{atom}'"
                hint = "rename one of them; '/', '.' and '-' all mangle to '_'"
                if any(d.startswith("I(") for d in distinct):
                    hint += "; I(FIELD) becomes I_FIELD"
                yield validate._error("RAC027", msg, clash[-1].span or first.span, hint)


# --- damage: what a hand-written or imported model may hold ------------------------------

_NUMBERS = [math.nan, math.inf, -math.inf, 1e16, -1e16, 1e-320, 5e-324, -5.0, 0.0, 3.0, 2**60]
_NAMES = ["a.b", "a_b", "a-b", "x" * (MAX_NAME + 1), "b@d", "", "yaw", "I_yaw", "Ω", "/t/x"]


_DAMAGE = ["number", "field", "clash", "type", "device", "name", "long", "integral", "alias"]


@st.composite
def damaged_models(draw: st.DrawFn) -> Model:
    model: Model = draw(models())
    topics, nodes, hardware = list(model.topics), list(model.nodes), list(model.hardware)
    related = list(model.related)
    replace = dataclasses.replace
    for what in draw(st.lists(st.sampled_from(_DAMAGE), max_size=4)):
        number, name = draw(st.sampled_from(_NUMBERS)), Name(draw(st.sampled_from(_NAMES)))
        t = draw(st.integers(0, len(topics) - 1)) if topics else -1
        n = draw(st.integers(0, len(nodes) - 1)) if nodes else -1
        h = draw(st.integers(0, len(hardware) - 1)) if hardware else -1
        if what == "number" and t >= 0:
            key = draw(st.sampled_from(["rate_hz", "rate_tolerance_hz", "window_s"]))
            topics[t] = replace(topics[t], **{key: number})
        elif what == "number" and n >= 0:
            nodes[n] = replace(nodes[n], limits=Limits(number, nodes[n].limits.mem))
        elif what in ("field", "clash") and t >= 0:  # a clash: two fields that mangle alike
            more = (name,) if what == "field" else (Name("a.b"), Name("a_b"))
            topics[t] = replace(topics[t], fields=(*topics[t].fields, *more))
        elif what == "type" and t >= 0:
            topics[t] = replace(topics[t], msg_type=name.value)
        elif what == "device" and n >= 0:
            nodes[n] = replace(nodes[n], diagnostics=(*nodes[n].diagnostics, name))
        elif what == "name" and h >= 0:
            hardware[h] = replace(hardware[h], name=name)
        elif what == "long" and n >= 0:  # still a ROS name, but too long
            nodes[n] = replace(nodes[n], name=Name(nodes[n].name.value + "_" * MAX_NAME))
        elif what == "alias" and t >= 0:  # another spelling of a topic, as a topic or device
            value = topics[t].name.value
            alias = Name(value[1:] if value.startswith("/") else "/" + value)
            if draw(st.booleans()):
                topics.append(Topic(alias))
            elif n >= 0:
                nodes[n] = replace(nodes[n], diagnostics=(*nodes[n].diagnostics, alias))
        elif what == "integral" and t >= 0:
            topic = topics[t].name.value
            side = FieldRef(topic, draw(st.sampled_from(["yaw", "a.b", "x"])), integrated=True)
            related.append(Related(side, FieldRef(topic, "other")))
    return replace(
        model, topics=tuple(topics), nodes=tuple(nodes), hardware=tuple(hardware),
        related=tuple(related),
    )  # fmt: skip


@pytest.mark.slow
@settings(max_examples=400, deadline=None)
@given(damaged_models())
def test_the_fast_rules_report_what_the_straightforward_ones_do(model: Model) -> None:
    assert list(validate._check_name_sets(model)) == list(reference_name_sets(model))
    assert list(validate.check_ranges(model)) == list(reference_ranges(model))
    assert list(validate.check_mangling(model)) == list(reference_mangling(model))
