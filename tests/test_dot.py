"""architecture.dot: Figure 3.1's conventions, nothing of the model invisible, valid DOT."""

from __future__ import annotations

import html
import random
import re
import shutil
import subprocess
from pathlib import Path

import pydot
import pytest

from rac.ir import FieldRef, Hardware, Interval, Model, Name, Node, Publication, Related, Topic
from rac.loader import load_model
from rac.parse import parse_ram
from rac.pipeline import Compiled, compile_model
from rac.targets import EmitOptions
from rac.targets.dot import emit_dot, quote

TEDUSAR = Path(__file__).resolve().parents[1] / "models" / "tedusar.ram"


def emit(model: Model) -> str:
    return emit_dot(compile_model(model), EmitOptions())


def emit_unchecked(model: Model) -> str:
    """Emit without validation, for names no valid model may hold."""
    return emit_dot(Compiled(model, (), (), (), ()), EmitOptions())


def parse(text: str) -> pydot.Dot:
    graphs = pydot.graph_from_dot_data(text)
    assert graphs is not None and len(graphs) == 1
    return graphs[0]


def attrs(item: pydot.Node | pydot.Edge) -> dict[str, str]:
    """Attributes with their DOT quotes taken off (escapes left as written)."""
    return {k: v[1:-1] if v.startswith('"') else v for k, v in item.get_attributes().items()}


def nodes_of(graph: pydot.Dot) -> dict[str, dict[str, str]]:
    return {n.get_name(): attrs(n) for n in graph.get_nodes()}


def edges_of(graph: pydot.Dot) -> list[tuple[str, str, dict[str, str]]]:
    return [(e.get_source(), e.get_destination(), attrs(e)) for e in graph.get_edges()]


def grey(colour: str) -> int:
    """Brightness 0..255 of a #rrggbb colour."""
    assert re.fullmatch(r"#[0-9a-fA-F]{6}", colour), colour
    return sum(int(colour[i : i + 2], 16) for i in (1, 3, 5)) // 3


def render_svg(text: str) -> str:
    dot = shutil.which("dot")
    if dot is None:
        pytest.skip("Graphviz dot is not installed")
    done = subprocess.run([dot, "-Tsvg"], input=text.encode(), capture_output=True, check=False)
    assert done.returncode == 0, done.stderr.decode()
    assert b"Warning" not in done.stderr and b"Error" not in done.stderr, done.stderr.decode()
    return done.stdout.decode()


@pytest.fixture(scope="module")
def tedusar() -> Model:
    return load_model(TEDUSAR)


@pytest.fixture(scope="module")
def tedusar_dot(tedusar: Model) -> str:
    return emit(tedusar)


def test_tedusar_parses_as_one_digraph(tedusar_dot: str) -> None:
    graph = parse(tedusar_dot)
    assert graph.get_type() == "digraph"
    assert graph.get_name() == '"tedusar"'


def test_every_node_hardware_and_topic_appears(tedusar: Model, tedusar_dot: str) -> None:
    graph = parse(tedusar_dot)
    nodes = nodes_of(graph)
    for component in [*tedusar.nodes, *tedusar.hardware]:
        assert quote(component.name.value) in nodes, component.name.value
    labels = [a.get("label", "") for a in nodes.values()]
    labels += [a.get("label", "") for _, _, a in edges_of(graph)]
    # a topic is a line "/name" or "/name @ rate" of an arrow's or a box's label
    shown = {line.split(" @ ")[0] for label in labels for line in label.split("\\n")}
    for topic in tedusar.topics:
        assert topic.name.value in shown, topic.name.value


def test_colours_follow_sn_hn_n(tedusar_dot: str) -> None:
    nodes = nodes_of(parse(tedusar_dot))
    sn = grey(nodes['"jaguar_node"']["fillcolor"])
    hn = grey(nodes['"imu_node"']["fillcolor"])
    n = grey(nodes['"hector_mapping"']["fillcolor"])
    assert sn < hn < n == 255  # dark grey, grey, white
    for name in ("hokuyo_node", "laser_alignment_node"):
        assert nodes[f'"{name}"']["fillcolor"] == nodes['"jaguar_node"']["fillcolor"]
    assert nodes['"joy_node"']["fillcolor"] == nodes['"imu_node"']["fillcolor"]
    for name in ("jaguar_teleop_node", "laser_alignment_control", "rviz"):
        assert grey(nodes[f'"{name}"']["fillcolor"]) == 255
    assert nodes['"jaguar"']["shape"] == "box"
    assert nodes['"imu"']["shape"] == "box"


def test_dotted_links_join_drivers_and_hardware(tedusar: Model, tedusar_dot: str) -> None:
    links = {
        (tail, head)
        for tail, head, a in edges_of(parse(tedusar_dot))
        if a.get("style") == "dotted" and a.get("dir") == "none"
    }
    expected = {(quote(h.value), quote(n.name.value)) for n in tedusar.nodes for h in n.drives}
    assert links == expected


def test_switchable_hardware_shows_its_channel(tedusar_dot: str) -> None:
    nodes = nodes_of(parse(tedusar_dot))
    assert nodes['"jaguar"']["label"] == "jaguar\\nch 1"
    assert nodes['"imu"']["label"] == "imu"


def test_topics_label_publish_subscribe_arrows(tedusar_dot: str) -> None:
    edges = {(t, h): a for t, h, a in edges_of(parse(tedusar_dot))}
    assert edges['"jaguar_node"', '"hector_mapping"']["label"] == "/pose @ 10 Hz"
    assert edges['"hector_mapping"', '"rviz"']["label"] == "/map"
    # two topics between the same pair share one arrow
    both = edges['"laser_alignment_control"', '"laser_alignment_node"']["label"]
    assert both == "/la_servo1_moving @ 20 Hz\\n/la_servo2_moving @ 20 Hz"


def caption(graph: pydot.Dot) -> str:
    """The graph's HTML label: name, legend and related signals."""
    label = graph.get_node("graph")[0].get_attributes()["label"]
    assert label.startswith("<") and label.endswith(">")
    return str(label)


def test_related_and_interval_pairs_are_noted(tedusar: Model, tedusar_dot: str) -> None:
    cells = re.findall(r"<TD[^>]*>([^<]*)</TD>", caption(parse(tedusar_dot)))
    for r in tedusar.related:
        assert f"{r.a.text} ~ {r.b.text}" in cells
    for i in tedusar.intervals:
        assert f"{i.a.text} ~ {i.b.text} within 0.05" in cells


def test_legend_is_drawn(tedusar_dot: str) -> None:
    text = caption(parse(tedusar_dot))
    assert "<B>robot tedusar</B>" in text
    for words in ("switchable", "hardware link", "software node", "/topic @ rate"):
        assert words in text


def test_many_relations_fill_columns() -> None:
    lines = "".join(f"relate /a.f{i} ~ /b.f{i}\n" for i in range(8))
    fields = ", ".join(f"f{i}" for i in range(8))
    model = parse_ram(
        f"robot r\ntopic /a : m/M {{ {fields} }}\ntopic /b : m/M {{ {fields} }}\n"
        "node p { publishes /a, /b }\nnode s { subscribes /a, /b }\n" + lines
    )
    rows = re.findall(r"<TR>(.*?)</TR>", caption(parse(emit(model))))
    related = [row for row in rows if "/a.f" in row]
    assert len(related) == 6  # six to a column, two columns
    assert related[0].count("<TD") == 2 and related[-1].endswith('<TD ALIGN="LEFT"></TD>')


def test_loose_and_shared_topics_get_boxes() -> None:
    model = parse_ram(
        "robot r\n"
        "topic /in : std_msgs/Empty\n"
        "topic /out : std_msgs/Empty @ 5 Hz\n"
        "topic /idle : std_msgs/Empty\n"
        "topic /bus : std_msgs/Empty\n"
        "node a { subscribes /in\n publishes /bus }\n"
        "node b { publishes /bus, /out }\n"
        "node c { subscribes /bus }\n"
        "node d { subscribes /bus }\n"
    )
    graph = parse(emit(model))
    nodes = nodes_of(graph)
    for name, label in [("/in", "/in"), ("/out", "/out @ 5 Hz"), ("/idle", "/idle")]:
        box = nodes[quote("topic:" + name)]
        assert box["label"] == label
        assert "dashed" in box["style"]
    bus = nodes[quote("topic:/bus")]
    assert "dashed" not in bus["style"]
    edges = {(t, h) for t, h, _ in edges_of(graph)}
    assert ('"topic:/in"', '"a"') in edges and ('"b"', '"topic:/out"') in edges
    # 2 publishers x 2 subscribers: 4 arrows through one box, not 4 labelled arrows
    shared = {e for e in edges if '"topic:/bus"' in e}
    assert shared == {
        ('"a"', '"topic:/bus"'),
        ('"b"', '"topic:/bus"'),
        ('"topic:/bus"', '"c"'),
        ('"topic:/bus"', '"d"'),
    }


AWKWARD = [
    'say "hi"',
    "back\\slash",
    "\\N",
    "/ns-1/x",
    "graph",
    "node",
    "a;b",
    "a->b",
    "ü/∑",
    "x<y>&z",
    "</TD>",
]


def awkward_model() -> Model:
    """Every awkward string as node, hardware, topic, field and robot name."""
    hw = tuple(
        Hardware(Name(f"hw {s}"), switchable=True, channel=i + 1) for i, s in enumerate(AWKWARD)
    )
    topics = tuple(Topic(Name(f"/t {s}"), 'type"x', (Name("f"),), rate_hz=2.5) for s in AWKWARD)
    nodes = tuple(
        Node(
            Name(s),
            drives=(Name(f"hw {s}"),),
            subscribes=(Name(f"/t {AWKWARD[i - 1]}"),),
            publishes=(Publication(Name(f"/t {s}")),),
        )
        for i, s in enumerate(AWKWARD)
    )
    related = (Related(FieldRef('/t say "hi"', "f"), FieldRef("/t \\N", "f")),)
    intervals = (Interval(FieldRef("/t x<y>&z", "f"), FieldRef("/t </TD>", "f"), 0.5),)
    return Model(Name('bot "x"\nline'), hw, topics, nodes, related, intervals)


def test_awkward_names_are_escaped() -> None:
    text = emit_unchecked(awkward_model())
    assert "\r" not in text
    graph = parse(text)
    assert graph.get_name() == quote('bot "x"\nline')
    nodes = nodes_of(graph)
    for s in AWKWARD:
        assert quote(s) in nodes and quote(f"hw {s}") in nodes
    svg = render_svg(text)
    shown = {html.unescape(t) for t in re.findall(r"<text[^>]*>([^<]*)</text>", svg)}
    for s in AWKWARD:
        assert s in shown, s  # Graphviz draws the name verbatim: no escape fired
        assert f"/t {s} @ 2.5 Hz" in shown
    assert '/t say "hi".f ~ /t \\N.f' in shown
    assert "/t x<y>&z.f ~ /t </TD>.f within 0.5" in shown
    assert 'robot bot "x"' in shown and "line" in shown  # <BR/> broke the line


def test_quote() -> None:
    assert quote("a") == '"a"'
    assert quote('a"b') == '"a\\"b"'
    assert quote("a\\b") == '"a\\\\b"'
    assert quote("a\nb") == '"a\\nb"'
    assert quote("a\r\nb") == '"a\\nb"'


def test_output_is_deterministic(tedusar: Model, tedusar_dot: str) -> None:
    assert emit(load_model(TEDUSAR)) == tedusar_dot
    assert emit(tedusar) == tedusar_dot
    big = synthetic()
    assert emit(big) == emit(synthetic())
    assert render_svg(tedusar_dot) == render_svg(tedusar_dot)


def test_dot_renders_tedusar_svg(tedusar_dot: str) -> None:
    svg = render_svg(tedusar_dot)
    assert svg.lstrip().startswith("<?xml")
    assert "jaguar_node" in svg and "/pose @ 10 Hz" in svg


def synthetic(n_nodes: int = 50, seed: int = 2) -> Model:
    """A 50-node robot: 14 drivers, a pipeline of workers, a /tf everybody shares."""
    rng = random.Random(seed)
    drivers = 14
    workers = n_nodes - drivers
    hw = tuple(
        Hardware(Name(f"dev{i}"), switchable=i % 2 == 0, channel=i // 2 + 1 if i % 2 == 0 else None)
        for i in range(drivers)
    )
    sensors = [f"/sensor{i}/data" for i in range(drivers)]
    stages = [f"/stage{j}" for j in range(workers)]
    topics = [Topic(Name(t), "std_msgs/Float64", (Name("x"),), rate_hz=20.0) for t in sensors]
    topics += [Topic(Name(t), "std_msgs/Float64", (Name("x"),)) for t in stages]
    topics.append(Topic(Name("/tf"), "tf2_msgs/TFMessage", rate_hz=100.0))
    nodes = [
        Node(
            Name(f"driver{i}"),
            drives=(Name(f"dev{i}"),),
            publishes=(Publication(Name(sensors[i])), *([Publication(Name("/tf"))] * (i % 4 == 0))),
        )
        for i in range(drivers)
    ]
    for j in range(workers):
        inputs = sorted(set(rng.sample(sensors + stages[:j], k=2))) + ["/tf"] * (j % 6 == 0)
        nodes.append(
            Node(
                Name(f"worker{j}"),
                subscribes=tuple(Name(t) for t in inputs),
                publishes=(Publication(Name(stages[j]), (Name(inputs[0]),)),),
            )
        )
    related = (Related(FieldRef(sensors[0], "x"), FieldRef(sensors[1], "x")),)
    return Model(Name("synthetic"), hw, tuple(topics), tuple(nodes), related)


def test_fifty_node_robot_stays_compact() -> None:
    model = synthetic()
    text = emit(model)
    graph = parse(text)
    nodes = nodes_of(graph)
    assert all(quote(n.name.value) in nodes for n in model.nodes)
    # /tf (4 publishers, 6 readers) is one box with 10 arrows, not 24 labelled ones
    tf = [e for e in edges_of(graph) if '"topic:/tf"' in e[:2]]
    assert len(tf) == 4 + 6
    publications = sum(len(n.publishes) for n in model.nodes)
    subscriptions = sum(len(n.subscribes) for n in model.nodes)
    hardware_links = sum(len(n.drives) for n in model.nodes)
    assert len(graph.get_edges()) <= publications + subscriptions + hardware_links + 1
    svg = render_svg(text)
    width, height = (
        float(v) for v in re.findall(r'viewBox="0\.00 0\.00 ([\d.]+) ([\d.]+)"', svg)[0]
    )
    assert width * height < 3000 * 2000  # points: about A0 at most
