"""ROS 2 launch XML, read without ROS: the ``<node>`` entries of a launch file and the
command line ``ros2 launch`` would run for each.

``racc repairer`` restarts a node from its entry in the robot's launch file, ``racc demo``
starts the demo robot from the launch file it writes, and the tests start the processes
``observers.launch.xml`` names, all through :func:`load_launch` and :func:`command_line`.
What is read: ``<arg>`` (``default``, ``value``), ``<let>``, ``<group>``, ``<node>`` with
``pkg``, ``exec``, ``name``, ``namespace``, ``args``, ``ros_args`` and its ``<param
name value>``, ``<remap from to>``, ``<env name value>`` children; the substitutions
``$(var N)``, ``$(dirname)``, ``$(env N [D])``, ``$(optenv N [D])``,
``$(find-pkg-prefix P)`` and ``$(find-pkg-share P)``.  ``<include>``, ``<executable>``
and ``if``/``unless`` are not followed: a node behind them has no entry (RAC117 names the
file when it does not load at all).  An executable is found as ``ros2 run`` finds it: in
the first prefix of ``AMENT_PREFIX_PATH`` whose ament index lists the package, at
``PREFIX/lib/PKG/EXEC`` (RAC118 otherwise).
"""

from __future__ import annotations

import os
import re
import shlex
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from rac.errors import Diagnostic, RacError

SUBSTITUTION = re.compile(r"\$\(([a-z-]+)((?:\s+[^)\s]+)*)\s*\)")
INDEX = Path("share/ament_index/resource_index/packages")


@dataclass(frozen=True, slots=True)
class LaunchNode:
    package: str
    executable: str
    name: str  # "" when the launch file gives none
    namespace: str
    args: tuple[str, ...]
    ros_args: tuple[str, ...]
    params: tuple[tuple[str, str], ...]
    remaps: tuple[tuple[str, str], ...]
    env: tuple[tuple[str, str], ...]
    respawn: bool = False  # started again when it ends (racc run, as ros2 launch does)
    respawn_delay: float = 0.0

    @property
    def key(self) -> str:
        """ "name" or "ns/name", as the observers name nodes."""
        return f"{self.namespace.strip('/')}/{self.name}".lstrip("/")


def _bad(path: Path, why: str) -> RacError:
    return RacError([Diagnostic("RAC117", f"{path}: {why}")])


def _substitute(text: str, values: Mapping[str, str], path: Path) -> str:
    def one(match: re.Match[str]) -> str:
        kind, rest = match.group(1), match.group(2).split()
        if kind == "var" and len(rest) == 1:
            if rest[0] not in values:
                raise _bad(path, f"$(var {rest[0]}) names no <arg> or <let>")
            return values[rest[0]]
        if kind == "dirname" and not rest:
            return str(path.resolve().parent)
        if kind in ("env", "optenv") and rest:
            found = os.environ.get(rest[0])
            if found is not None:
                return found
            if len(rest) > 1 or kind == "optenv":
                return " ".join(rest[1:])
            raise _bad(path, f"$(env {rest[0]}): the variable is not set")
        if kind in ("find-pkg-prefix", "find-pkg-share") and len(rest) == 1:
            prefix = package_prefix(rest[0])
            return str(prefix if kind == "find-pkg-prefix" else prefix / "share" / rest[0])
        raise _bad(path, f"unsupported substitution {match.group(0)}")

    return SUBSTITUTION.sub(one, text)


def load_launch(path: str | Path, arguments: Mapping[str, str] | None = None) -> list[LaunchNode]:
    """The node entries of a ROS 2 launch XML file, its arguments set from ``arguments``
    (``name:=value`` on the ``ros2 launch`` command line) or their defaults."""
    path = Path(path)
    if not path.is_file():
        raise _bad(path, "no such launch file")
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as err:
        raise _bad(path, f"cannot read the launch file: {err}") from None
    if root.tag != "launch":
        raise _bad(path, f"the root element is <{root.tag}>, not <launch>")
    given = dict(arguments or {})
    values: dict[str, str] = {}
    nodes: list[LaunchNode] = []

    def sub(text: str | None) -> str:
        return _substitute(text or "", values, path)

    def walk(element: ET.Element) -> None:
        for e in element:
            if e.tag == "arg":
                name = e.get("name", "")
                if "value" in e.attrib:
                    values[name] = sub(e.get("value"))
                elif name in given:
                    values[name] = given[name]
                elif "default" in e.attrib:
                    values[name] = sub(e.get("default"))
                else:
                    raise _bad(path, f"argument '{name}' has no default: give {name}:=VALUE")
            elif e.tag == "let":
                values[e.get("name", e.get("var", ""))] = sub(e.get("value"))
            elif e.tag == "group":
                walk(e)
            elif e.tag == "node":
                nodes.append(_node(e, sub, path))

    walk(root)
    return nodes


def _node(e: ET.Element, sub: object, path: Path) -> LaunchNode:
    assert callable(sub)
    if not e.get("pkg") or not e.get("exec"):
        raise _bad(path, "a <node> needs pkg and exec")
    children = [(c.tag, {k: sub(v) for k, v in c.attrib.items()}) for c in e]
    return LaunchNode(
        package=sub(e.get("pkg")),
        executable=sub(e.get("exec")),
        name=sub(e.get("name")),
        namespace=sub(e.get("namespace") or e.get("ros_namespace") or e.get("ns")),
        args=tuple(shlex.split(sub(e.get("args")))),
        ros_args=tuple(shlex.split(sub(e.get("ros_args")))),
        params=tuple((a["name"], a.get("value", "")) for t, a in children if t == "param"),
        remaps=tuple((a["from"], a["to"]) for t, a in children if t == "remap"),
        env=tuple((a["name"], a["value"]) for t, a in children if t == "env"),
        respawn=sub(e.get("respawn")).strip().lower() == "true",
        respawn_delay=_seconds(sub(e.get("respawn_delay")), path),
    )


def _seconds(text: str, path: Path) -> float:
    if not text.strip():
        return 0.0
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not value >= 0:
        raise _bad(path, f"respawn_delay must be a number of seconds >= 0, not '{text}'")
    return value


def package_prefix(package: str) -> Path:
    """The install prefix whose ament index lists ``package`` (RAC118: none)."""
    prefixes = [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    for prefix in prefixes:
        if (Path(prefix) / INDEX / package).is_file():
            return Path(prefix)
    where = ", ".join(prefixes) or "AMENT_PREFIX_PATH is empty"
    hint = (
        "for racc's own package: 'racc ros-package --ros 2 -o PREFIX', then "
        "export AMENT_PREFIX_PATH=PREFIX:$AMENT_PREFIX_PATH"
    )
    raise RacError(
        [
            Diagnostic(
                "RAC118", f"no ROS 2 package '{package}' in the ament index ({where})", hint=hint
            )
        ]
    )


def command_line(node: LaunchNode) -> list[str]:
    """The command ``ros2 launch`` runs for ``node``: the executable, its args, then the
    node's name, namespace, parameters and remappings as ROS arguments."""
    exe = package_prefix(node.package) / "lib" / node.package / node.executable
    if not os.access(exe, os.X_OK):
        raise RacError([Diagnostic("RAC118", f"package '{node.package}' has no executable {exe}")])
    return [str(exe), *node_arguments(node)]


def node_arguments(node: LaunchNode) -> list[str]:
    """What follows the executable on the command line: its args, then the ROS arguments."""
    ros = list(node.ros_args)
    if node.name:
        ros += ["-r", f"__node:={node.name}"]
    if node.namespace:
        ros += ["-r", f"__ns:=/{node.namespace.strip('/')}"]
    for key, value in node.params:
        ros += ["-p", f"{key}:={value}"]
    for a, b in node.remaps:
        ros += ["-r", f"{a}:={b}"]
    return [*node.args, *(["--ros-args", *ros] if ros else [])]
