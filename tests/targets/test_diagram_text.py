"""No text racc puts in DOT breaks Graphviz's limits, whatever the model holds
(rac.targets.diagram.text): quoted strings cut below 16 kB with a digest, names elided in
labels, characters XML refuses replaced, Graphviz's escapes never fired."""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import pytest
from drawings import all_nodes, have_dot, parse, render
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from lxml import etree

from rac.cli import main
from rac.fmt import format_model
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
from rac.targets.diagram import View, emit_diagram
from rac.targets.diagram.text import (
    GRAPHVIZ_STRING_BYTES,
    MAX_QUOTED_BYTES,
    MAX_SHOWN_CHARS,
    elide,
    html_text,
    quote,
)

needs_dot = pytest.mark.skipif(not have_dot(), reason="Graphviz dot is not installed")

# What Graphviz's scanner refuses: a quoted or HTML-like string of 16,381 bytes or more.
STRINGS = re.compile(r'"(?:[^"\\]|\\.)*"')


def longest_string(text: str) -> int:
    """The longest double-quoted string of a DOT text, in bytes."""
    return max((len(m.group(0).encode()) for m in STRINGS.finditer(text)), default=0)


def test_a_long_quoted_string_is_cut_below_the_limit_with_a_digest() -> None:
    long = "/relay_0/out: " + "trend /relay_0/out.x ~ /relay_1/out.x (BiQObs); " * 600
    cut = quote(long)
    assert len(cut.encode()) <= MAX_QUOTED_BYTES + 2 < GRAPHVIZ_STRING_BYTES
    assert re.search(r"…\[\+[\d,]+ characters, #[0-9a-f]{12}\]\"$", cut)
    # two long ids with the same head stay two ids
    assert quote("a" * 9000 + "1") != quote("a" * 9000 + "2")
    assert quote("a" * 9000 + "1") == quote("a" * 9000 + "1")
    # multi-byte characters and escapes count as the bytes they are, and are never split
    wide = quote('ü"\\' * 4000)
    assert len(wide.encode()) <= MAX_QUOTED_BYTES + 2
    assert not re.search(r"[^\\](\\\\)*\\…", wide)  # no escape cut in half
    wide.encode("utf-8")


def test_characters_xml_refuses_are_replaced_and_escapes_never_fire() -> None:
    assert quote("a\x00b\x07c\ud800") == '"a\ufffdb\ufffdc\ufffd"'
    assert html_text("x\x01<y>&\\N") == "x\ufffd&lt;y&gt;&amp;\\\\N"
    assert quote("plain name") == '"plain name"'


def test_names_are_elided_in_their_middle_keeping_their_last_part() -> None:
    name = "/robot_41/" + "very_long_namespace/" * 10 + "amcl"
    shown = elide(name)
    assert len(shown) == MAX_SHOWN_CHARS and shown.endswith("/amcl") and "…" in shown
    assert elide("/short") == "/short"


def hostile_model(names: list[str], robot: str) -> Model:
    """Nodes, devices, topics, fields and relations named with ``names``, unvalidated."""
    topics = tuple(Topic(Name(f"{n}/t"), "m/" + n, (Name("f" + n),), rate_hz=10.0) for n in names)
    nodes = tuple(
        Node(
            Name(n),
            drives=(Name("hw" + n),),
            subscribes=(Name(f"{names[i - 1]}/t"),),
            publishes=(Publication(Name(f"{n}/t")),),
            limits=Limits(cpu=5.0),
        )
        for i, n in enumerate(names)
    )
    hardware = tuple(
        Hardware(Name("hw" + n), switchable=True, channel=i + 1) for i, n in enumerate(names)
    )
    related = tuple(
        Related(FieldRef(f"{a}/t", "f" + a), FieldRef(f"{b}/t", "f" + b))
        for a, b in itertools.pairwise(names)
    )
    intervals = (Interval(FieldRef(f"{names[0]}/t", "f"), FieldRef(f"{names[-1]}/t", "f"), 1.0),)
    return Model(Name(robot), hardware, topics, nodes, related, intervals)


VIEWS = (
    View(),
    View(level="nodes"),
    View(level="topics"),
    View(everything=True),
    View(summary=True),
)


def assert_graphviz_takes_it(text: str) -> None:
    assert longest_string(text) < GRAPHVIZ_STRING_BYTES
    svg = render(text)  # fails on any error or warning of Graphviz's
    etree.fromstring(svg)  # and what it writes is well-formed XML (the HTML page embeds it)


@needs_dot
def test_huge_names_draw_in_every_view() -> None:
    """Names of 20,000 characters, of 9,000 two-byte characters, and of control characters:
    every view renders, and every node is still one node."""
    names = [f"/{'x' * 20000}{i}" for i in range(3)]
    names += ["/" + "ü" * 9000, '/a\x00b\x01c\ud800d\ufffe&<>"\\N', "/ns-1/x"]
    model = hostile_model(names, "r" * 30000 + "\x07")
    for view in (*VIEWS, View(focus=names[0])):
        text = emit_diagram(model, (), view)
        assert_graphviz_takes_it(text)
        if not view.summary and view.focus is None:
            ids = {n for n in all_nodes(parse(text)) if "topic:" not in n and "→" not in n}
            assert len(ids) == 2 * len(names), view  # nodes and their devices


NAME = st.text(min_size=1, max_size=40) | st.text(alphabet='/ab\\"<>&\n', max_size=3000)


@needs_dot
@settings(
    max_examples=25,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(names=st.lists(NAME, min_size=2, max_size=4, unique=True), robot=NAME)
def test_any_names_draw(names: list[str], robot: str) -> None:
    model = hostile_model([f"/{n}" for n in names], robot)
    for view in (VIEWS[1], VIEWS[2], VIEWS[4]):
        assert_graphviz_takes_it(emit_diagram(model, (), view))


def relay_model(relays: int = 50) -> Model:
    """A model in the shape ``racc learn`` gives a live graph of relays: every relay's topics
    related to the first one's, three fields each, so that /relay_0/out has 294 observers."""
    fields = ("twist.twist.linear.x", "twist.twist.angular.z", "pose.pose.position.x")
    topics: list[Topic] = []
    nodes: list[Node] = []
    for i in range(relays):
        source, out = f"/relay_{i}/in", f"/relay_{i}/out"
        for t in (source, out):
            topics.append(Topic(Name(t), "nav_msgs/Odometry", tuple(map(Name, fields)), 10.0))
        subscribes = (Name(source),)
        nodes.append(
            Node(Name(f"/relay_{i}"), subscribes=subscribes, publishes=(Publication(Name(out)),))
        )
        nodes.append(Node(Name(f"/player_{i}"), publishes=(Publication(Name(source)),)))
    related = tuple(
        Related(FieldRef("/relay_0/out", f), FieldRef(f"/relay_{i}/{end}", f))
        for i in range(1, relays)
        for end in ("in", "out")
        for f in fields
    )
    return Model(Name("relays"), (), tuple(topics), tuple(nodes), related)


@needs_dot
def test_compile_draws_a_topic_with_hundreds_of_observers(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 37: racc compile of a model learned from a live graph of relays wrote all but
    the SVG ("syntax error in line 143 scanning a quoted string (missing endquote? longer
    than 16384?)") on a tooltip listing a topic's observers."""
    model = tmp_path / "relays.ram"
    model.write_text(format_model(relay_model()), "utf-8")
    out = tmp_path / "out"
    assert main(["compile", str(model), "-o", str(out), "--html"]) == 0
    err = capsys.readouterr().err
    assert "dot failed" not in err
    text = (out / "architecture.dot").read_text("utf-8")
    assert longest_string(text) <= MAX_QUOTED_BYTES + 2
    assert "more observers" in text  # the tooltip lists 12 and counts the rest
    etree.fromstring((out / "architecture.svg").read_bytes())
    assert (out / "architecture.html").exists()
