"""Hypothesis: random valid models compile, and every output file parses as what it claims.

YAML with ``yaml.safe_load``, both launch files with ``lxml``, the repair domain with the
``pddl`` library, the diagram with ``pydot``; ``racc fmt`` is idempotent on the model text.
"""

from __future__ import annotations

import functools
from typing import Any

import pydot
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from lxml import etree
from pddl.parser.domain import DomainParser
from ram_strategies import models

from rac.fmt import format_model
from rac.ir import Model
from rac.parse import parse_ram
from rac.pipeline import compile_model
from rac.targets import EmitOptions, targets

pytestmark = pytest.mark.filterwarnings("ignore:.*deprecated - use:DeprecationWarning")

SETTINGS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@functools.cache
def domain_parser() -> DomainParser:
    return DomainParser()


def compile_text(text: str) -> dict[str, str]:
    compiled = compile_model(parse_ram(text, "random.ram"))
    files = {t.filename: t.emit(compiled, EmitOptions()) for t in targets()}
    stack = EmitOptions(observers_package="tug_ist_diagnosis_observers")
    files["stack.launch"] = next(t for t in targets() if t.name == "ros1").emit(compiled, stack)
    files["stack.launch.xml"] = next(t for t in targets() if t.name == "ros2").emit(compiled, stack)
    return files


def check_runtime_launch(
    text: str, switchable: bool, kind_attr: str = "type", hosts: int = 1
) -> None:
    """racc's runtime: observer hosts (one per machine), engine, repairer, and the board
    client with hardware."""
    root = etree.fromstring(text.encode("utf-8"))
    types = sorted(n.get(kind_attr) for n in root.findall("node"))
    expected = ["engine", *["observe"] * hosts, "repairer"]
    expected += ["board_client"] if switchable else []
    assert types == sorted(expected)
    assert all(n.get("pkg") == "racc" for n in root.findall("node"))


def check_launch(text: str, kind_attr: str, observers: list[dict[str, Any]]) -> None:
    root = etree.fromstring(text.encode("utf-8"))
    assert root.tag == "launch"
    nodes = root.findall("node")
    by_name = {n.get("name"): n for n in nodes}
    assert len(by_name) == len(nodes), "two launch nodes share a name"
    for obs in observers:
        node = by_name.get(obs["name"])
        assert node is not None, f"no <node> for observer {obs['name']}"
        assert node.get(kind_attr) == f"{obs['kind']}.py"
        params = {p.get("name"): p.get("value") for p in node.findall("param")}
        assert set(params) == set(obs["params"]), obs["name"]
        for key, value in obs["params"].items():
            if isinstance(value, str):
                assert params[key] == value, (key, value)
            elif isinstance(value, bool):
                assert params[key] == ("true" if value else "false"), (key, value)
            else:
                assert float(params[key]) == value, (key, value)
    assert len(nodes) == len(observers) + 1, "one node per observer plus the model server"


def dot_node_names(graph: Any) -> set[str]:
    """Every node a pydot graph declares or connects, its subgraphs included, unquoted."""
    names = {n.get_name().strip('"') for n in graph.get_nodes()}
    for edge in graph.get_edges():
        names.update(str(end).strip('"') for end in (edge.get_source(), edge.get_destination()))
    for sub in graph.get_subgraphs():
        names |= dot_node_names(sub)
    return names


@pytest.mark.slow
@SETTINGS
@given(models())
def test_random_models_compile_and_every_output_parses(model: Model) -> None:
    text = format_model(model)
    files = compile_text(text)

    diagnosis = yaml.safe_load(files["model.yaml"])
    assert isinstance(diagnosis["rules"], list) and isinstance(diagnosis["props"], list)
    assert all(isinstance(r, str) and "->" in r for r in diagnosis["rules"])

    observers = yaml.safe_load(files["observers.yaml"])["observers"]
    names = [o["name"] for o in observers]
    assert len(names) == len(set(names))
    kinds = [o["kind"] for o in observers]
    devices = {d.value for n in model.nodes for d in n.diagnostics}
    assert {k: kinds.count(k) for k in set(kinds)} == {  # contract §2, one line per observer
        k: v
        for k, v in {
            "NObs": len(model.nodes),
            "GObs": sum(t.regular for t in model.topics),
            "PObs": sum(len(n.limits.declared) for n in model.nodes),
            "DObs": len(devices),
            "HObs": int(any(h.switchable for h in model.hardware)),
            "BiQObs": len(model.related),
            "IObs": len(model.intervals),
        }.items()
        if v
    }
    reported = [a for o in observers for a in o["reports"]]
    assert set(reported) == set(diagnosis["props"])

    switchable = any(h.switchable for h in model.hardware)
    # ROS 1 starts one observer host per machine (roslaunch's <machine>); ROS 2 the first's.
    check_runtime_launch(files["observers.launch"], switchable, hosts=max(1, len(model.machines)))
    check_runtime_launch(files["observers.launch.xml"], switchable, "exec")
    check_launch(files["stack.launch"], "type", observers)
    check_launch(files["stack.launch.xml"], "exec", observers)

    domain = domain_parser()(files["repair_domain.pddl"])
    assert {a.name for a in domain.actions} >= {"start_node", "stop_node", "power_up", "shutdown"}

    graphs = pydot.graph_from_dot_data(files["architecture.dot"])
    assert graphs is not None and len(graphs) == 1
    drawn = dot_node_names(graphs[0])
    for name in [*(n.name.value for n in model.nodes), *(h.name.value for h in model.hardware)]:
        assert name in drawn, f"{name} is not in the diagram"

    assert format_model(parse_ram(text)) == text


@SETTINGS
@given(models())
def test_compile_is_deterministic_and_pure(model: Model) -> None:
    text = format_model(model)
    assert compile_text(text) == compile_text(text)
    assert format_model(model) == text, "compiling changed the model"
