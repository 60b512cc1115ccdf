"""architecture.dot and racc diagram's views: Figure 3.1's conventions, namespaces, folded
topics, observer coverage, focus, diagnosis and summary; valid, escaped, deterministic DOT."""

from __future__ import annotations

import html
import random
import re
from pathlib import Path
from typing import Any

import pydot
import pytest
from drawings import (
    all_nodes,
    arrows,
    attrs,
    edges_of,
    have_dot,
    is_label,
    parse,
    render,
    text_of,
)
from goldens import assert_golden

from rac.analysis.analyze import undetected
from rac.commands.reports import (
    COMPILE_ANALYSIS_UP_TO_NODES,
    compile_undetected,
    replay_health,
)
from rac.diagnosis.modes import MODES
from rac.diagnosis.theory import theory_of
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
from rac.load.files import load_model
from rac.logic import Atom
from rac.parse import parse_ram
from rac.pipeline import compile_model
from rac.replay.timeline import DiagnosisRecord, ObservationRecord, Timeline
from rac.targets import EmitOptions
from rac.targets.coverage import Health
from rac.targets.dot import (
    MAX_RELATIONS_SHOWN,
    SUMMARY_ABOVE_NODES,
    View,
    emit_diagram,
    emit_dot,
    quote,
)

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = ROOT / "models" / "tedusar.ram"
WAREHOUSE = ROOT / "models" / "warehouse.ram"
GOLDEN = Path(__file__).resolve().parents[1] / "golden" / "diagrams"


def emit(model: Model) -> str:
    return emit_dot(compile_model(model), EmitOptions())


def view_of(model: Model, **kwargs: object) -> str:
    compiled = compile_model(model)
    return emit_diagram(compiled.model, compiled.observers, View(**kwargs))  # type: ignore[arg-type]


def emit_unchecked(model: Model) -> str:
    """Emit without validation, for names no valid model may hold."""
    return emit_diagram(model, (), View(everything=True))


def grey(colour: str) -> int:
    """Brightness 0..255 of a #rrggbb colour."""
    assert re.fullmatch(r"#[0-9a-fA-F]{6}", colour), colour
    return sum(int(colour[i : i + 2], 16) for i in (1, 3, 5)) // 3


def render_svg(text: str) -> str:
    if not have_dot():
        pytest.skip("Graphviz dot is not installed")
    return render(text).decode()


def caption(text: str) -> str:
    """The graph's HTML label: name, notes, legend and related signals."""
    label = parse(text).get_node("graph")[0].get_attributes()["label"]
    assert label.startswith("<") and label.endswith(">")
    return str(label)


def shown_topics(graph: pydot.Dot) -> set[str]:
    """Topic names as the labels of arrows and boxes show them ("/pose @ 10 Hz ~" -> /pose,
    "2 topics: /a" -> /a)."""
    labels = [a.get("label", "") for a in all_nodes(graph).values()]
    lines = [line.split(": ", 1)[-1] for lb in labels for line in text_of(lb)]
    return {line.split(" @ ")[0].removesuffix(" ~") for line in lines}


@pytest.fixture(scope="module")
def tedusar() -> Model:
    return load_model(TEDUSAR)


@pytest.fixture(scope="module")
def tedusar_dot(tedusar: Model) -> str:
    return emit(tedusar)


@pytest.fixture(scope="module")
def warehouse() -> Model:
    return load_model(WAREHOUSE)


def test_tedusar_parses_as_one_digraph(tedusar_dot: str) -> None:
    graph = parse(tedusar_dot)
    assert graph.get_type() == "digraph"
    assert graph.get_name() == '"tedusar"'


def test_every_node_hardware_and_topic_appears(tedusar: Model, tedusar_dot: str) -> None:
    graph = parse(tedusar_dot)
    nodes = all_nodes(graph)
    components: list[Node | Hardware] = [*tedusar.nodes, *tedusar.hardware]
    for component in components:
        assert quote(component.name.value) in nodes, component.name.value
    shown = shown_topics(graph)
    for topic in tedusar.topics:  # every tedusar topic has a publisher and a reader
        assert topic.name.value in shown, topic.name.value


def test_colours_follow_sn_hn_n(tedusar_dot: str) -> None:
    nodes = all_nodes(parse(tedusar_dot))
    sn = grey(nodes['"jaguar_node"']["fillcolor"])
    hn = grey(nodes['"imu_node"']["fillcolor"])
    n = grey(nodes['"hector_mapping"']["fillcolor"])
    assert sn < hn < n == 255  # dark grey, grey, white
    for name in ("hokuyo_node", "laser_alignment_node"):
        assert nodes[f'"{name}"']["fillcolor"] == nodes['"jaguar_node"']["fillcolor"]
    assert nodes['"joy_node"']["fillcolor"] == nodes['"imu_node"']["fillcolor"]
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


def test_nodes_show_what_watches_them(tedusar_dot: str) -> None:
    nodes = all_nodes(parse(tedusar_dot))
    assert text_of(nodes['"jaguar"']["label"]) == ["jaguar", "ch 1"]
    assert text_of(nodes['"imu"']["label"]) == ["imu"]
    hokuyo = text_of(nodes['"hokuyo_node"']["label"])
    assert hokuyo == ["hokuyo_node", "cpu 20 % · mem 48 MB", "reports hokuyo"]
    tip = nodes['"hokuyo_node"']["tooltip"]
    assert "process running (NObs)" in tip and "cpu ≤ 20 % (PObs)" in tip
    assert "diagnostics of hokuyo from hokuyo_node (DObs)" in nodes['"hokuyo"']["tooltip"]


def test_topics_label_arrows_coloured_by_their_observers(tedusar_dot: str) -> None:
    edges = {ends: a.label for ends, a in arrows(parse(tedusar_dot)).items()}
    pose = edges['"jaguar_node"', '"hector_mapping"']
    assert text_of(pose) == ["/pose @ 10 Hz ~"]  # a rate observer and a related pair
    assert 'COLOR="#1f4e79"' in pose
    rviz = edges['"hector_mapping"', '"rviz"']
    assert text_of(rviz) == ["/map"] and 'COLOR="#8a8a8a"' in rviz  # nothing watches /map
    both = edges['"laser_alignment_control"', '"laser_alignment_node"']
    assert text_of(both) == ["/la_servo1_moving @ 20 Hz ~", "/la_servo2_moving @ 20 Hz"]


def test_related_and_interval_pairs_are_noted(tedusar: Model, tedusar_dot: str) -> None:
    cells = re.findall(r"<TD[^>]*>([^<]*)</TD>", caption(tedusar_dot))
    for r in tedusar.related:
        assert f"{r.a.text} ~ {r.b.text}" in cells
    for i in tedusar.intervals:
        assert f"{i.a.text} ~ {i.b.text} within 0.05" in cells


def legend_texts(text: str) -> set[str]:
    return set(re.findall(r'<TD ALIGN="LEFT">([^<]*)</TD>', caption(text)))


def test_the_legend_shows_only_the_symbols_drawn(tedusar_dot: str) -> None:
    legend = legend_texts(tedusar_dot)
    assert {"driver of switchable hardware", "software node", "drives"} <= legend
    assert "topic no observer watches" in legend  # /map, /joy, /cmd_vel
    # tedusar has no topic box, no namespace, nothing folded, no diagnosis
    for absent in (
        "topic of several publishers or readers",
        "namespace",
        "folded topics of the node",
        "diagnosed faulty (every diagnosis)",
    ):
        assert absent not in legend
    software_only = parse_ram(
        "robot r\ntopic /a : m/M\nnode p { publishes /a }\nnode s { subscribes /a }\n"
    )
    legend = legend_texts(emit(software_only))
    assert "software node" in legend and "hardware" not in legend
    assert "driver of switchable hardware" not in legend and "drives" not in legend


def test_many_relations_fill_columns_and_the_rest_is_counted() -> None:
    n = MAX_RELATIONS_SHOWN + 6
    lines = "".join(f"relate /a.f{i} ~ /b.f{i}\n" for i in range(n))
    fields = ", ".join(f"f{i}" for i in range(n))
    model = parse_ram(
        f"robot r\ntopic /a : m/M {{ {fields} }}\ntopic /b : m/M {{ {fields} }}\n"
        "node p { publishes /a, /b }\nnode s { subscribes /a, /b }\n" + lines
    )
    text = caption(emit(model))
    assert "/a.f0 ~ /b.f0" in text and f"/a.f{MAX_RELATIONS_SHOWN - 2} ~" in text
    assert f"/a.f{MAX_RELATIONS_SHOWN - 1} ~" not in text
    assert "+7 more (racc diagram --all)" in text


FOLDING = (
    "robot r\n"
    "topic /in : std_msgs/Empty\n"
    "topic /out : std_msgs/Empty @ 5 Hz\n"
    "topic /idle : std_msgs/Empty\n"
    "topic /bus : std_msgs/Empty\n"
    "topic /tf : tf2_msgs/TFMessage\n"
    "topic /rosout : rosgraph_msgs/Log\n"
    "topic /debug1 : std_msgs/String\n"
    "topic /debug2 : std_msgs/String\n"
    "node a { subscribes /in\n publishes /bus, /tf, /rosout, /debug1, /debug2 }\n"
    "node b { publishes /bus, /out, /tf, /rosout }\n"
    "node c { subscribes /bus, /tf }\n"
    "node d { subscribes /bus, /tf }\n"
)


def test_unwatched_single_node_and_infrastructure_topics_are_folded() -> None:
    model = parse_ram(FOLDING)
    graph = parse(emit(model))
    shown = shown_topics(graph)
    assert "/bus" in shown  # shared
    assert "/out" in shown  # one node touches it, but a rate observer watches it
    for folded in ("/in", "/idle", "/debug1", "/debug2", "/tf", "/rosout"):
        assert folded not in shown, folded
    nodes = all_nodes(graph)
    assert text_of(nodes['"a"']["label"])[-1] == "+5 topics"  # /in, /debug1/2, /tf, /rosout
    assert text_of(nodes['"b"']["label"])[-1] == "+2 topics"  # /tf, /rosout
    assert text_of(nodes['"c"']["label"])[-1] == "+1 topic"
    notes = caption(emit(model))
    assert "folded: 4 topic(s) that at most one node touches" in notes  # /idle: none
    assert "unobserved infrastructure topics /tf, /rosout" in notes


def test_everything_draws_every_topic_with_boxes_for_shared_and_loose_ones() -> None:
    model = parse_ram(FOLDING)
    graph = parse(view_of(model, everything=True))
    nodes = all_nodes(graph)
    for name in ("/in", "/out", "/idle", "/debug1"):
        box = nodes[quote("topic:" + name)]
        assert "dashed" in box["style"], name
    assert "dashed" not in nodes[quote("topic:/bus")]["style"]
    edges = {(t, h) for t, h, _ in edges_of(graph)}
    assert ('"topic:/in"', '"a"') in edges and ('"b"', '"topic:/out"') in edges
    # 2 publishers x 2 subscribers: 4 arrows through one box, not 4 labelled arrows
    assert {e for e in edges if '"topic:/bus"' in e} == {
        ('"a"', '"topic:/bus"'),
        ('"b"', '"topic:/bus"'),
        ('"topic:/bus"', '"c"'),
        ('"topic:/bus"', '"d"'),
    }
    assert all("+" not in " ".join(text_of(a["label"])) for a in nodes.values())


def test_an_observed_infrastructure_topic_is_drawn() -> None:
    model = parse_ram(FOLDING.replace("topic /tf : tf2_msgs/TFMessage", "topic /tf : t/T @ 50 Hz"))
    assert "/tf" in shown_topics(parse(emit(model)))


def test_parallel_topics_share_one_arrow_and_a_long_list_is_cut() -> None:
    topics = "".join(f"topic /t{i} : m/M @ 5 Hz\n" for i in range(7))
    names = ", ".join(f"/t{i}" for i in range(7))
    model = parse_ram(
        f"robot r\n{topics}node p {{ publishes {names} }}\nnode s {{ subscribes {names} }}\n"
    )
    drawn = arrows(parse(emit(model)))
    assert list(drawn) == [('"p"', '"s"')]  # one arrow
    assert text_of(drawn['"p"', '"s"'].label) == [
        "/t0 @ 5 Hz",
        "/t1 @ 5 Hz",
        "/t2 @ 5 Hz",
        "/t3 @ 5 Hz",
        "+3 more",
    ]
    assert "/t6 (m/M, 5 Hz)" in drawn['"p"', '"s"'].tooltip


@pytest.mark.slow
def test_nodes_are_clustered_by_namespace_below_the_shared_prefix(warehouse: Model) -> None:
    """The topic view clusters the namespaces; the node view (the warehouse's default) names
    them in each node's name: around clusters, Graphviz routed arrows through nodes."""
    text = view_of(warehouse, level="topics")
    graph = parse(text)
    clusters = {s.get_name(): s for s in graph.get_subgraphs() if "cluster_" in str(s.get_name())}
    assert set(clusters) == {
        quote(f"cluster_/robot_41/{ns}")
        for ns in ("drivers", "localization", "navigation", "perception", "mission", "system")
    }
    drivers = clusters['"cluster_/robot_41/drivers"']
    assert drivers.get_attributes()["label"] == '"drivers"'
    members = {n.get_name() for n in drivers.get_nodes()}
    assert '"/robot_41/drivers/plc_bridge"' in members and '"plc"' in members
    nodes = all_nodes(graph)
    plc = text_of(nodes['"/robot_41/drivers/plc_bridge"']["label"])
    # one line of details in the compact drawing: limits and the folded count (90 I/O, /rosout)
    assert plc == ["plc_bridge", "15 % · 128 MB · +91"]
    assert "reports base" in nodes['"/robot_41/drivers/can_driver"']["tooltip"]
    assert "names under /robot_41/ are drawn without it" in caption(text)
    by_nodes = emit(warehouse)
    assert "cluster_" not in by_nodes
    plc = text_of(all_nodes(parse(by_nodes))['"/robot_41/drivers/plc_bridge"']["label"])
    assert plc == ["drivers/plc_bridge", "15 % · 128 MB · +91"]
    assert "names under /robot_41/ are drawn without it" in caption(by_nodes)


def test_the_warehouse_is_readable_size(warehouse: Model) -> None:
    """30 nodes and 150 topics: about 35 topics drawn, the rest counted on their nodes; one
    arrow per pair of nodes (the node view)."""
    assert len(warehouse.nodes) >= 30 and len(warehouse.topics) >= 150
    graph = parse(emit(warehouse))
    assert (
        len(
            shown_topics(graph)
            & {t.name.value.removeprefix("/robot_41/") for t in warehouse.topics}
        )
        < 45
    )
    assert len(arrows(graph)) < 80


def graph_attrs(text: str) -> dict[str, str]:
    return attrs(parse(text).get_node("graph")[0])


@pytest.mark.slow
def test_namespaces_make_the_drawing_compact(tedusar: Model, warehouse: Model) -> None:
    """Several namespace clusters: top-down, rounded boxes, one line of details; a robot
    without namespaces keeps Figure 3.1's left-to-right ellipses, and so does --all."""
    compact = emit(warehouse)
    assert graph_attrs(compact)["rankdir"] == "TB" and graph_attrs(compact)["newrank"] == "true"
    assert 'node [shape=box, style="rounded,filled"' in compact
    assert "a node's cpu and memory limits" in legend_texts(compact)
    for text in (emit(tedusar), view_of(warehouse, everything=True)):
        assert graph_attrs(text)["rankdir"] == "LR"
        assert "node [shape=ellipse" in text
        assert "a node's cpu and memory limits" not in legend_texts(text)


def test_the_whole_warehouse_fits_a_1920_by_1080_screen_readably(warehouse: Model) -> None:
    """Shrunk to fit 1920 × 1080 px (96 dpi), node names (11 pt) stay at least 10 px high
    and topic names (9 pt) 8 px: before the compact layout they came out at 7 and 6 px."""
    svg = render_svg(emit(warehouse))
    width, height = (
        float(v) for v in re.findall(r'viewBox="0\.00 0\.00 ([\d.]+) ([\d.]+)"', svg)[0]
    )
    scale = min(1920 / (width * 96 / 72), 1080 / (height * 96 / 72))
    assert 11 * 96 / 72 * scale >= 10, (width, height)
    assert 9 * 96 / 72 * scale >= 8, (width, height)


def test_compile_marks_the_faults_no_observer_detects(tedusar: Model) -> None:
    compiled = compile_model(tedusar)
    missed = undetected(theory_of(compiled), MODES)
    text = emit_dot(compiled, EmitOptions(undetected=tuple(sorted(missed.items()))))
    assert text_of(all_nodes(parse(text))['"hector_mapping"']["label"])[-1] == "unseen: output"
    assert "not analysed" not in caption(text)


@pytest.mark.slow
def test_compile_analyses_up_to_its_node_bound(tedusar: Model) -> None:
    assert compile_undetected(compile_model(tedusar), quiet=True) is not None
    larger = compile_model(big_model(COMPILE_ANALYSIS_UP_TO_NODES + 1))
    assert compile_undetected(larger, quiet=True) is None
    assert "not analysed" in caption(emit_dot(larger, EmitOptions()))


def test_the_unseen_line_reads_on_a_dark_node_in_a_diagnosis_view(tedusar: Model) -> None:
    """jaguar_node (SN, dark grey) keeps white-ish text when a diagnosis is drawn that does
    not name it; filled orange as a suspect, its text turns black and the line red."""
    compiled = compile_model(tedusar)
    unseen = (("jaguar_node", ("output",)),)
    for diagnoses, colour in (
        ((("hokuyo",),), "#ffcdd2"),
        ((("jaguar_node",), ("jaguar",)), "#c62828"),
    ):
        view = View(undetected=unseen, health=Health("d", diagnoses))
        label = all_nodes(parse(emit_diagram(compiled.model, compiled.observers, view)))[
            '"jaguar_node"'
        ]["label"]
        assert f'<FONT POINT-SIZE="8" COLOR="{colour}">unseen: output</FONT>' in label


def test_undetected_faults_stand_out(tedusar: Model) -> None:
    compiled = compile_model(tedusar)
    missed = undetected(theory_of(compiled), MODES)
    assert missed["hector_mapping"] == ("output",)  # /map: no observer
    view = View(undetected=tuple(sorted(missed.items())))
    text = emit_diagram(compiled.model, compiled.observers, view)
    nodes = all_nodes(parse(text))
    hector = nodes['"hector_mapping"']
    assert "dashed" in hector["style"] and hector["color"] == "#c62828"
    assert text_of(hector["label"])[-1] == "unseen: output"
    assert text_of(nodes['"laser_alignment"']["label"])[-1] == "unseen: silent-hardware"
    assert "dashed" not in nodes['"jaguar_node"'].get("style", "")  # /pose is watched
    assert "a fault no observer detects (racc analyze)" in legend_texts(text)
    assert "not analysed" not in caption(text)
    assert "not analysed" in caption(emit(tedusar))


def drawn_nodes(text: str) -> set[str]:
    """The nodes and hardware drawn: no topic box, no arrow's label."""
    nodes = all_nodes(parse(text))
    return {n.strip('"') for n in nodes if not n.startswith('"topic:') and not is_label(n)}


def test_focus_draws_what_feeds_a_node_and_what_it_feeds(tedusar: Model) -> None:
    one = drawn_nodes(view_of(tedusar, focus="hector_mapping", depth=1))
    assert one == {"hector_mapping", "jaguar_node", "hokuyo_node", "rviz", "jaguar", "hokuyo"}
    two = drawn_nodes(view_of(tedusar, focus="hector_mapping", depth=2))
    assert two == one | {"jaguar_teleop_node"}  # upstream of jaguar_node; rviz feeds nothing
    topic = drawn_nodes(view_of(tedusar, focus="/pose", depth=1))
    assert topic == {"jaguar_node", "hector_mapping", "jaguar"}
    device = drawn_nodes(view_of(tedusar, focus="imu", depth=0))
    assert device == {"imu_node", "imu"}
    nodes = all_nodes(parse(view_of(tedusar, focus="hector_mapping")))
    assert nodes['"hector_mapping"']["penwidth"] == "3"


def test_a_diagnosis_colours_its_components(tedusar: Model) -> None:
    text = view_of(tedusar, health=Health("diagnosis: jaguar_node", (("jaguar_node",),)))
    nodes = all_nodes(parse(text))
    assert nodes['"jaguar_node"']["fillcolor"] == "#e53935"
    assert nodes['"hokuyo_node"']["fillcolor"] == "#555555"
    assert "diagnosis: jaguar_node" in caption(text)
    two = Health("t", (("jaguar",), ("jaguar_node",)))
    nodes = all_nodes(parse(view_of(tedusar, health=two)))
    assert nodes['"jaguar"']["fillcolor"] == nodes['"jaguar_node"']["fillcolor"] == "#ffb74d"


def test_observations_colour_what_their_observers_watch(tedusar: Model) -> None:
    observed = ((Atom("ok", ("pose",)), False), (Atom("running", ("rviz",)), True))
    text = view_of(tedusar, health=Health("t", (), observed))
    graph = parse(text)
    edges = {ends: a.label for ends, a in arrows(graph).items()}
    pose = edges['"jaguar_node"', '"hector_mapping"']
    assert 'COLOR="#c62828"' in pose and "<B>" in pose
    assert 'COLOR="#c62828"' not in edges['"hokuyo_node"', '"hector_mapping"']
    assert all_nodes(graph)['"rviz"']["color"] == "#2e7d32"
    assert "topic an observer reads bad" in legend_texts(text)


def test_the_replay_state_at_a_time() -> None:
    timeline = Timeline(
        (
            ObservationRecord(1.0, "ok(pose)"),
            ObservationRecord(5.0, "not_ok(pose)"),
            DiagnosisRecord(6.0, (("jaguar_node",), ("jaguar",))),
            ObservationRecord(9.0, "ok(pose)"),
            DiagnosisRecord(10.0, ()),
        ),
        12.0,
    )
    at7 = replay_health(timeline, 7.0)
    assert at7.diagnoses == (("jaguar_node",), ("jaguar",))
    assert at7.observations == ((Atom("ok", ("pose",)), False),)
    assert at7.title.startswith("replay at 7 s, 1 observations, 1 bad: minimal diagnoses")
    at11 = replay_health(timeline, 11.0)
    assert at11.diagnoses == () and at11.observations == ((Atom("ok", ("pose",)), True),)


def big_model(nodes: int, spaces: int = 12) -> Model:
    """``nodes`` nodes in ``spaces`` namespaces, each reading its neighbour's topic."""
    built = []
    topics = []
    for i in range(nodes):
        topic = f"/area{i % spaces}/t{i}"
        topics.append(Topic(Name(topic), "m/M", rate_hz=10.0))
        reads = (Name(f"/area{(i - 1) % spaces}/t{i - 1}"),) if i else ()
        built.append(
            Node(
                Name(f"/area{i % spaces}/n{i}"),
                subscribes=reads,
                publishes=(Publication(Name(topic)),),
                limits=Limits(cpu=10.0),
            )
        )
    return Model(Name("big"), (), tuple(topics), tuple(built))


def test_a_large_model_gets_the_summary() -> None:
    n = SUMMARY_ABOVE_NODES + 1
    model = big_model(n)
    text = emit(model)
    graph = parse(text)
    boxes = {k for k in all_nodes(graph) if not is_label(k)}
    assert boxes == {quote(f"group:/area{k}") for k in range(12)}
    in_area0 = len(range(0, n, 12))
    box = all_nodes(graph)['"group:/area0"']
    assert text_of(box["label"])[:2] == ["/area0", f"{in_area0} nodes, 0 hardware"]
    assert "--focus /area0 opens it" in text_of(box["label"])
    assert f"summary of {n} nodes in 12 namespaces" in caption(text)
    drawn = arrows(graph)
    assert len(drawn) <= 2 * 12
    labels = {text_of(a.label)[0] for a in drawn.values()}
    assert labels <= {f"{in_area0 - 1} topics", f"{in_area0} topics"}
    small = emit(big_model(SUMMARY_ABOVE_NODES))
    assert "group:" not in small


def test_output_is_deterministic(tedusar: Model, tedusar_dot: str, warehouse: Model) -> None:
    assert emit(load_model(TEDUSAR)) == tedusar_dot
    assert emit(load_model(WAREHOUSE)) == emit(warehouse)
    assert emit(synthetic()) == emit(synthetic())
    assert render_svg(tedusar_dot) == render_svg(tedusar_dot)


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
    nodes = all_nodes(graph)
    for s in AWKWARD:
        assert quote(s) in nodes and quote(f"hw {s}") in nodes
    svg = render_svg(text)
    shown = {html.unescape(t) for t in re.findall(r"<text[^>]*>([^<]*)</text>", svg)}
    for s in AWKWARD:
        # Graphviz draws the name verbatim (no escape fired); one in a namespace by its
        # last part, inside the namespace's cluster
        assert s in shown or s.rpartition("/")[2] in shown, s
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


@pytest.mark.slow
def test_fifty_node_robot_stays_compact() -> None:
    model = synthetic()
    text = emit(model)
    graph = parse(text)
    nodes = all_nodes(graph)
    assert all(quote(n.name.value) in nodes for n in model.nodes)
    # /tf (4 publishers, 6 readers, observed at 100 Hz) is a box of its own without arrows
    assert not [e for e in edges_of(graph) if '"topic:/tf"' in e[:2]]
    assert text_of(nodes['"topic:/tf"']["label"]) == ["/tf @ 100 Hz", "4 publishers · 6 readers"]
    pairs = {
        (p, s.name.value)
        for s in model.nodes
        for t in s.subscribes
        if t.value != "/tf"
        for p in model.publishers().get(t.value, ())
    }
    hardware_links = sum(len(n.drives) for n in model.nodes)
    boxes = [n for n in nodes if n.startswith('"topic:')]  # one arrow more than pairs, each
    assert len(arrows(graph)) <= len(pairs) + len(boxes) + hardware_links
    svg = render_svg(text)
    width, height = (
        float(v) for v in re.findall(r'viewBox="0\.00 0\.00 ([\d.]+) ([\d.]+)"', svg)[0]
    )
    assert width * height < 3000 * 2000  # points: about A0 at most


# The views of docs/diagrams.md, as goldens: DOT text is deterministic (SVG is Graphviz's).
VIEWS: dict[str, tuple[Path, dict[str, Any]]] = {
    "tedusar.coverage": (TEDUSAR, {"analysis": True}),
    "tedusar.focus_hector_mapping": (TEDUSAR, {"focus": "hector_mapping", "depth": 1}),
    "tedusar.diagnosis_jaguar_node": (TEDUSAR, {"diagnosis": (("jaguar_node",),)}),
    "warehouse.coverage": (WAREHOUSE, {"analysis": True}),
    "warehouse.all": (WAREHOUSE, {"everything": True}),
    "warehouse.focus_amcl": (WAREHOUSE, {"focus": "/robot_41/localization/amcl", "depth": 1}),
    "warehouse.summary": (WAREHOUSE, {"summary": True}),
    "warehouse.obs_scan_front": (
        WAREHOUSE,
        {
            "observed": ((Atom("ok", ("robot_41_scan_front",)), False),),
            "diagnosis": (("/robot_41/drivers/sick_front",),),
        },
    ),
}


@pytest.mark.parametrize("name", sorted(VIEWS))
def test_view_goldens(name: str, update_goldens: bool) -> None:
    path, options = VIEWS[name]
    compiled = compile_model(load_model(path))
    view_options: dict[str, object] = {
        k: v for k, v in options.items() if k in ("focus", "depth", "everything", "summary")
    }
    if options.get("analysis"):
        found = undetected(theory_of(compiled), MODES)
        view_options["undetected"] = tuple(sorted(found.items()))
    if "diagnosis" in options or "observed" in options:
        diagnoses = options.get("diagnosis", ())
        title = "diagnosis: " + " | ".join(", ".join(d) for d in diagnoses)
        view_options["health"] = Health(title, diagnoses, options.get("observed", ()))
    text = emit_diagram(compiled.model, compiled.observers, View(**view_options))  # type: ignore[arg-type]
    assert_golden(GOLDEN / f"{name}.dot", text, update_goldens)


@pytest.mark.parametrize("name", sorted(VIEWS))
def test_every_view_renders_without_a_graphviz_warning(name: str) -> None:
    """A legend cell too small for its symbol, say, is a warning Graphviz prints and a
    clipped symbol in the picture."""
    render_svg((GOLDEN / f"{name}.dot").read_text("utf-8"))
