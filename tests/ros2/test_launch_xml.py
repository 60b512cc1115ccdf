"""The compiled observers.launch.xml and the demo's robot.launch.xml against the ROS 2
launch XML format (no ROS needed): the tags and attributes ``launch_xml``/``launch_ros``
accept, with the required ones, and substitutions that resolve.

Written from the ROS 2 launch documentation ("Migrating launch files", the launch XML
format design article and the launch_ros frontend argument names): ``<launch>`` holds
``arg``, ``let``, ``node``, ``executable``, ``include``, ``group``, ``set_env``,
``unset_env``...; ``<node>`` needs ``pkg`` and ``exec`` (ROS 1's ``type`` and ``ns`` are
not accepted) and holds ``param``, ``remap``, ``env``; ``output`` is ``log``, ``screen``
or ``both``; ``$(var X)`` needs an ``<arg>``/``<let>`` declared before it.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from rac.load.files import load_model
from rac.pipeline import compile_model
from rac.ros2.launch import load_launch
from rac.targets import EmitOptions, targets
from rac.targets.demo_launch import launch_xml_text

ROOT = Path(__file__).resolve().parents[2]

LAUNCH_CHILDREN = {
    "arg", "let", "node", "executable", "include", "group", "set_env", "unset_env",
    "push_ros_namespace", "set_parameter", "set_remap", "node_container", "timer", "log",
}  # fmt: skip
ATTRIBUTES = {  # tag -> (required, optional)
    "arg": ({"name"}, {"default", "value", "description", "choices"}),
    "let": ({"name", "value"}, set()),
    "node": (
        {"pkg", "exec"},
        {
            "name",
            "namespace",
            "ros_namespace",
            "exec_name",
            "args",
            "ros_args",
            "output",
            "respawn",
            "respawn_delay",
            "launch-prefix",
            "if",
            "unless",
            "emulate_tty",
        },
    ),
    "param": (set(), {"name", "value", "sep", "from"}),
    "remap": ({"from", "to"}, set()),
    "env": ({"name", "value"}, set()),
}
NODE_CHILDREN = {"param", "remap", "env"}
SUBSTITUTIONS = {
    "var",
    "dirname",
    "env",
    "optenv",
    "find-pkg-share",
    "find-pkg-prefix",
    "find-exec",
    "anon",
    "eval",
    "command",
    "filename",
    "not",
    "and",
    "or",
}


def problems(text: str) -> list[str]:
    out: list[str] = []
    root = ET.fromstring(text)
    if root.tag != "launch":
        return [f"root <{root.tag}>"]
    declared: set[str] = set()

    def check(e: ET.Element) -> None:
        required, optional = ATTRIBUTES.get(e.tag, (set(), set()))
        if e.tag in ATTRIBUTES:
            missing = required - set(e.attrib)
            extra = set(e.attrib) - required - optional
            out.extend(f"<{e.tag}> lacks {m}" for m in sorted(missing))
            out.extend(f"<{e.tag}> has unknown attribute {x}" for x in sorted(extra))
        if e.tag == "param" and ("name" in e.attrib) == ("from" in e.attrib):
            out.append("<param> needs name or from")
        if e.get("output") not in (None, "log", "screen", "both"):
            out.append(f"output={e.get('output')}")
        for value in e.attrib.values():
            for kind, arg in re.findall(r"\$\((\S+?)(?:\s+([^)]*))?\)", value):
                if kind not in SUBSTITUTIONS:
                    out.append(f"unknown substitution $({kind})")
                if kind == "var" and arg.strip() not in declared:
                    out.append(f"$(var {arg}) before any <arg name='{arg}'>")
        if e.tag in ("arg", "let"):
            declared.add(e.get("name", ""))
        for c in e:
            if e.tag == "node" and c.tag not in NODE_CHILDREN:
                out.append(f"<node> holds <{c.tag}>")
            check(c)

    for child in root:
        if child.tag not in LAUNCH_CHILDREN:
            out.append(f"<launch> holds <{child.tag}>")
        check(child)
    return out


def emit(model: str, options: EmitOptions) -> str:
    compiled = compile_model(load_model(ROOT / "models" / model))
    return next(t for t in targets() if t.name == "ros2").emit(compiled, options)


@pytest.mark.parametrize("model", ["tedusar.ram", "pioneer.ram"])
def test_observers_launch_xml_follows_the_ros2_format(model: str, tmp_path: Path) -> None:
    text = emit(model, EmitOptions())
    assert problems(text) == []
    nodes = ET.fromstring(text).findall("node")
    assert {n.get("pkg") for n in nodes} == {"racc"}
    assert {"observe", "engine", "repairer"} <= {n.get("exec") for n in nodes}
    stack = emit(model, EmitOptions(observers_package="tug_ist_diagnosis_observers"))
    assert problems(stack) == []
    # The reader racc's repairer and the tests use resolves every argument.
    (tmp_path / "observers.launch.xml").write_text(text)
    entries = load_launch(tmp_path / "observers.launch.xml", {"robot_launch": "r.launch.xml"})
    assert all("$(" not in a for e in entries for a in e.args)
    repairer = next(e for e in entries if e.executable == "repairer")
    assert "--launch=r.launch.xml" in repairer.args


def test_a_bad_launch_file_is_caught_by_the_checks() -> None:
    bad = '<launch><node pkg="p" type="t" ns="x" output="loud"/><rosparam/></launch>'
    found = problems(bad)
    assert "<node> lacks exec" in found and "<node> has unknown attribute type" in found
    assert "output=loud" in found and "<launch> holds <rosparam>" in found
    assert problems('<launch><node pkg="p" exec="e" args="$(var x)"/></launch>')


def test_demo_robot_launch_xml_follows_the_ros2_format() -> None:
    text = launch_xml_text("/m/robot it's.ram", ["a_node", "b_node"], 1.5, 0, ["crash@3:a_node"])
    assert problems(text) == []
    assert [n.get("name") for n in ET.fromstring(text).findall("node")] == ["a_node", "b_node"]
