"""Machines and where nodes run (issue 28): ``machine NAME address ADDR``, ``node n on M``,
``in container C via docker|podman`` through the parser, ``racc fmt``, the ``ram/1`` JSON,
validation (RAC140-RAC142) and learning from a recorded graph's hosts."""

from __future__ import annotations

import json

import pytest

from rac.errors import RacError, Severity
from rac.fmt import format_model
from rac.interchange import dumps, parse_json
from rac.learn.graph import parse_graph
from rac.learn.structure import machines_from_graph
from rac.parse import parse_ram
from rac.passes.validate import validate
from rac.runtime.record import graph_yaml

TWO = """robot rover
machine base address 10.0.0.2
machine operator address laptop.local
topic /joy : sensor_msgs/Joy @ 20 Hz
topic /image : sensor_msgs/Image @ 15 Hz
node joy_node on operator { publishes /joy }
node camera on base in container camera_1 via docker { publishes /image }
node teleop in container tele via podman { subscribes /joy }
"""


def test_placements_are_read() -> None:
    model = parse_ram(TWO, "two.ram")
    assert [(m.name.value, m.address) for m in model.machines] == [
        ("base", "10.0.0.2"),
        ("operator", "laptop.local"),
    ]
    nodes = model.node_by_name()
    assert nodes["joy_node"].machine is not None and nodes["joy_node"].machine.value == "operator"
    camera = nodes["camera"].container
    assert camera is not None and (camera.name.value, camera.runtime) == ("camera_1", "docker")
    # A node without 'on' runs on the first machine.
    assert model.machine_of(nodes["teleop"]) == "base"
    assert not [d for d in validate(model) if d.severity is Severity.ERROR]


def test_fmt_and_json_round_trip() -> None:
    model = parse_ram(TWO, "two.ram")
    text = format_model(model)
    assert "node camera on base in container camera_1 via docker {" in text
    assert "machine operator address laptop.local" in text
    again = parse_ram(text, "two.ram")
    assert again == model and format_model(again) == text
    doc = json.loads(dumps(model))
    assert doc["machines"] == [
        {"name": "base", "address": "10.0.0.2"},
        {"name": "operator", "address": "laptop.local"},
    ]
    camera = next(n for n in doc["nodes"] if n["name"] == "camera")
    assert camera["machine"] == "base"
    assert camera["container"] == {"name": "camera_1", "runtime": "docker"}
    assert parse_json(dumps(model), "two.json") == model


def test_a_model_without_machines_exports_as_before() -> None:
    model = parse_ram("robot r\ntopic /t\nnode n { publishes /t }\n", "r.ram")
    doc = json.loads(dumps(model))
    assert "machines" not in doc and set(doc["nodes"][0]) == {
        "name",
        "drives",
        "subscribes",
        "publishes",
        "diagnostics",
    }
    assert model.machine_of(model.nodes[0]) is None


def test_a_json_container_runtime_must_be_docker_or_podman() -> None:
    doc = json.loads(dumps(parse_ram(TWO, "two.ram")))
    doc["nodes"][1]["container"]["runtime"] = "lxc"
    with pytest.raises(RacError) as err:
        parse_json(json.dumps(doc), "two.json")
    assert "RAC005" in err.value.render() and "docker or podman" in err.value.render()


@pytest.mark.parametrize(
    ("text", "code"),
    [
        ("machine a\nnode n on b { publishes /t }\n", "RAC140"),
        ("machine a\nmachine a\nnode n { publishes /t }\n", "RAC141"),
        ("machine a-b\nnode n { publishes /t }\n", "RAC142"),
        ("node n in container a/b via docker { publishes /t }\n", "RAC142"),
    ],
)
def test_placement_errors(text: str, code: str) -> None:
    model = parse_ram("robot r\ntopic /t\n" + text, "r.ram")
    assert code in [d.code for d in validate(model)]


GRAPH = """nodes:
  /talker: {publications: [/chatter], host: 10.0.0.7}
  /listener: {subscriptions: [/chatter], host: base.local}
  /mapper: {subscriptions: [/chatter], host: base.local}
"""


def test_learning_places_nodes_on_the_hosts_of_the_graph() -> None:
    machines, placed = machines_from_graph(parse_graph(GRAPH, "g.yaml"))
    # The host of most nodes first: a node without 'on' runs there.
    assert [(m.name.value, m.address) for m in machines] == [
        ("base_local", "base.local"),
        ("host_10_0_0_7", "10.0.0.7"),
    ]
    assert placed == {"talker": "host_10_0_0_7", "listener": "base_local", "mapper": "base_local"}
    one_host = GRAPH.replace("10.0.0.7", "base.local")
    assert machines_from_graph(parse_graph(one_host, "g.yaml")) == ((), {})


def test_the_recorded_graph_names_each_nodes_host() -> None:
    text = graph_yaml(
        [("/chatter", ["/talker"])], [("/chatter", ["/listener"])], hosts={"/talker": "10.0.0.7"}
    )
    graph = parse_graph(text, "g.yaml")
    hosts = {n.name: n.host for n in graph.nodes}
    assert hosts == {"talker": "10.0.0.7", "listener": None}
