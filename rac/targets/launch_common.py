"""What the ROS 1 and ROS 2 launch emitters share: the observer nodes to start."""

from __future__ import annotations

from collections.abc import Callable

from rac.pipeline import Compiled
from rac.targets.options import EmitOptions
from rac.targets.templating import XML_SPECIAL, render, xmlattr

MODEL_SERVER_EXECUTABLE = "diagnosis_model_server.py"
MODEL_SERVER_NAME = "diagnosis_model_server"


def param_text(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"  # what roslaunch and ROS 2 read as a bool
    if isinstance(value, float):
        return repr(value)
    return str(value)


def observer_nodes(compiled: Compiled, options: EmitOptions) -> Callable[[str], str]:
    """The observer nodes' text, given the attribute naming a node's executable.

    ``observer_nodes(compiled, options)("type")`` is every observer node as ROS 1 writes it
    (ROS 2 says ``exec``), each after a blank line::

          <node pkg="PACKAGE" type="KIND.py" name="NAME">
            <param name="KEY" value="VALUE"/>
          </node>

    with one ``<param>`` line per parameter.  A large model has forty thousand observers
    and a quarter of a million parameters: a template loop over them took most of the
    launch files' time, so the nodes are written here, once per compilation for both
    launch files (``Compiled.memo``), and the templates place them.
    """
    key = "launch_observer_tails"  # the same for any options
    tails = compiled.memo.get(key)
    if tails is None:
        tails = compiled.memo[key] = _node_tails(compiled)
    assert isinstance(tails, list)
    opening = f"\n  <node pkg={xmlattr(options.observers)} "
    return lambda attribute: (opening + attribute).join(tails)


def _node_tails(compiled: Compiled) -> list[str]:
    """``["", tail, tail, ...]``: each node's text from ``="KIND.py"`` on."""
    quoted: dict[str, str] = {}  # xmlattr of a string
    floats: dict[float, str] = {}  # xmlattr(repr(x)); never 0.0, whose sign shows
    get = quoted.get

    def string(text: str) -> str:
        quoted[text] = found = xmlattr(text)
        return found

    def other(value: object) -> str:
        """``xmlattr(param_text(value))`` for anything but a str."""
        if type(value) is int:
            return f'"{value}"'  # digits and '-': nothing to escape
        if type(value) is float and value:
            found = floats.get(value)
            if found is None:
                found = floats[value] = xmlattr(repr(value))
            return found
        return xmlattr(param_text(value))

    heads: dict[tuple[str, ...], tuple[str, ...]] = {}  # keys -> '    <param name="K" value='
    executables: dict[str, str] = {}  # kind -> xmlattr("KIND.py")
    special = XML_SPECIAL.search
    tails = [""]
    append = tails.append
    for o in compiled.observers:
        params = o.params
        if params:
            keys, values = zip(*params, strict=True)
            lead = heads.get(keys)
            if lead is None:
                lead = heads[keys] = tuple(f"    <param name={xmlattr(k)} value=" for k in keys)
            lines = "".join(
                [
                    f"{head}{get(v) or string(v)}/>\n"
                    if type(v) is str
                    else f'{head}"{v}"/>\n'  # an int: digits and '-', nothing to escape
                    if type(v) is int
                    else f"{head}{other(v)}/>\n"
                    for head, v in zip(lead, values, strict=True)
                ]
            )
        else:
            lines = ""
        executable, name = executables.get(o.kind), o.name
        if executable is None:
            executable = executables[o.kind] = xmlattr(f"{o.kind}.py")
        # xmlattr(name), its usual case (nothing to escape) without the call
        plain = type(name) is str and special(name) is None
        name = f'"{name}"' if plain else xmlattr(name)
        append(f"={executable} name={name}>\n{lines}  </node>\n")
    return tails


def render_launch(template: str, compiled: Compiled, options: EmitOptions) -> str:
    """A launch file starting the model server on model.yaml and every observer."""
    return render(
        template,
        robot=compiled.model.name.value,
        model_package=options.model_server,
        model_executable=MODEL_SERVER_EXECUTABLE,
        model_name=MODEL_SERVER_NAME,
        observer_nodes=observer_nodes(compiled, options),
    )


def render_runtime_launch(compiled: Compiled, template: str = "runtime.launch.j2") -> str:
    """A launch file (ROS 1, or ROS 2 with ``runtime.launch.xml.j2``) starting racc's
    runtime: the observer host, the diagnosis engine, the repair engine and, with
    switchable hardware, the board client."""
    board = any(h.switchable for h in compiled.model.hardware)
    machines = [
        {"name": m.name.value, "address": m.address or m.name.value}
        for m in compiled.model.machines
    ]
    return render(
        template,
        robot=compiled.model.name.value,
        board=board,
        observers=len(compiled.observers),
        machines=machines,
        hosts=",".join(f"racc_observer_{m['name']}" for m in machines) or "racc_observer",
    )
