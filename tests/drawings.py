"""Reading racc's drawings back, for the diagram tests and bench/diagram.py.

- the DOT text (pydot): its nodes, its edges, and its *arrows*: an arrow with a label is
  two edges through the node that is its label (rac.targets.diagram.scene.arrow), and a
  feedback arrow is written head to tail with ``dir=back``; :func:`arrows` undoes both;
- Graphviz's layout (``dot -Tjson``): the page size, and from the edges' splines the
  crossings between arrows, the arrows that run through a node or a label that is not
  theirs (:func:`measure`).
"""

from __future__ import annotations

import html
import json
import re
import shutil
import subprocess
from dataclasses import dataclass
from typing import Any

import numpy as np
import pydot

from rac.targets.diagram.scene import ARROW


def parse(text: str) -> pydot.Dot:
    graphs = pydot.graph_from_dot_data(text)
    assert graphs is not None and len(graphs) == 1
    return graphs[0]


def attrs(item: pydot.Node | pydot.Edge) -> dict[str, str]:
    """Attributes with their DOT quotes taken off (escapes left as written)."""
    return {k: v[1:-1] if v.startswith('"') else v for k, v in item.get_attributes().items()}


def all_nodes(graph: pydot.Dot | pydot.Subgraph) -> dict[str, dict[str, str]]:
    """Every node statement's attributes by id, merged (the first layer's ``rank=min``
    subgraph names nodes again, without attributes)."""
    found: dict[str, dict[str, str]] = {}
    for n in graph.get_nodes():
        found.setdefault(n.get_name(), {}).update(attrs(n))
    for sub in graph.get_subgraphs():
        for name, more in all_nodes(sub).items():
            found.setdefault(name, {}).update(more)
    for name in ("node", "graph", "edge"):
        found.pop(name, None)
    return found


def edges_of(graph: pydot.Dot) -> list[tuple[str, str, dict[str, str]]]:
    return [(str(e.get_source()), str(e.get_destination()), attrs(e)) for e in graph.get_edges()]


def text_of(label: str) -> list[str]:
    """The lines of a label, plain or HTML-like, without markup."""
    if label.startswith("<") and label.endswith(">"):
        body = label[1:-1]
        lines = [html.unescape(re.sub(r"<[^>]+>", "", part)) for part in re.split(r"<BR/>", body)]
        return [line for line in lines if line.strip()]  # not the gap under a node's name
    return label.split("\\n")


def is_label(node_id: str) -> bool:
    """Whether a node (its id as pydot or Graphviz gives it) is an arrow's label."""
    return ARROW in node_id


@dataclass(frozen=True, slots=True)
class Arrow:
    label: str  # the label's DOT text ("" without)
    tooltip: str
    backwards: bool  # a feedback arrow, drawn against the layering
    attrs: dict[str, str]


def arrows(graph: pydot.Dot) -> dict[tuple[str, str], Arrow]:
    """Every arrow as (tail, head) -> what it shows, as drawn (quoted ids)."""
    nodes = all_nodes(graph)
    found: dict[tuple[str, str], Arrow] = {}
    through: dict[str, dict[str, Any]] = {}
    for tail, head, a in edges_of(graph):
        backwards = a.get("dir") == "back"
        if is_label(tail) or is_label(head):
            label = tail if is_label(tail) else head
            parts = through.setdefault(label, {"attrs": a})
            end = head if label == tail else tail
            if a.get("dir") == "none":  # the half without an arrowhead: the arrow's tail
                parts["tail"] = end
            else:
                parts["head"] = end
                parts["backwards"] = backwards
            continue
        if backwards:
            tail, head = head, tail
        found[(tail, head)] = Arrow(a.get("label", ""), a.get("tooltip", ""), backwards, a)
    for label, parts in through.items():
        node = nodes[label]
        key = (parts["tail"], parts["head"])
        found[key] = Arrow(node["label"], node["tooltip"], parts["backwards"], parts["attrs"])
    return found


def have_dot() -> bool:
    return shutil.which("dot") is not None


def render(text: str, fmt: str = "svg", *options: str) -> bytes:
    """Graphviz's output; fails on any warning or error it prints."""
    dot = shutil.which("dot")
    assert dot is not None, "Graphviz's dot is not installed"
    done = subprocess.run(
        [dot, f"-T{fmt}", *options], input=text.encode("utf-8"), capture_output=True, check=False
    )
    assert done.returncode == 0, done.stderr.decode(errors="replace")
    assert b"Warning" not in done.stderr and b"Error" not in done.stderr, done.stderr.decode()
    return done.stdout


def layout(text: str) -> dict[str, Any]:
    """Graphviz's layout of ``text`` (``dot -Tjson``)."""
    data: dict[str, Any] = json.loads(render(text, "json"))
    return data


@dataclass(frozen=True, slots=True)
class Measures:
    width: float  # points
    height: float
    arrows: int  # arrows as a reader counts them: an arrow and its label are one
    crossings: int  # pairs of arrows without a common end whose lines cross
    through_nodes: int  # (node, arrow) where the arrow's line runs through a node not its end
    on_labels: int  # (label, arrow) where an arrow runs through another arrow's label


def _curve(draw: list[dict[str, Any]]) -> np.ndarray[Any, Any]:
    """The points of an edge's spline (its cubic Béziers sampled)."""
    points: list[np.ndarray[Any, Any]] = []
    steps = np.linspace(0.0, 1.0, 9)[:, None]
    for op in draw:
        if op.get("op") != "b":
            continue
        p = np.array(op["points"], dtype=float)
        for i in range(0, len(p) - 3, 3):
            a, b, c, d = p[i], p[i + 1], p[i + 2], p[i + 3]
            t = steps
            points.append(
                (1 - t) ** 3 * a + 3 * (1 - t) ** 2 * t * b + 3 * (1 - t) * t**2 * c + t**3 * d
            )
    return np.concatenate(points) if points else np.zeros((0, 2))


def measure(data: dict[str, Any]) -> Measures:
    """What a reader of the picture meets: its size, its arrows, how they cross."""
    x0, y0, x1, y1 = (float(v) for v in data["bb"].split(","))
    objects = data.get("objects", [])
    names = {o["_gvid"]: o["name"] for o in objects}
    edges = data.get("edges", [])
    owner: list[str] = []  # per edge: the arrow it belongs to
    ends: dict[str, set[int]] = {}
    for k, e in enumerate(edges):
        tail, head = e["tail"], e["head"]
        via = [g for g in (tail, head) if is_label(names.get(g, ""))]
        key = names[via[0]] if via else f"edge {k}"
        owner.append(key)
        ends.setdefault(key, set()).update(g for g in (tail, head) if g not in via)
    curves = [_curve(e.get("_draw_", [])) for e in edges]
    segments: list[np.ndarray[Any, Any]] = []
    seg_owner: list[int] = []
    keys = list(ends)
    index = {k: i for i, k in enumerate(keys)}
    for k, pts in enumerate(curves):
        if len(pts) > 1:
            segments.append(np.hstack([pts[:-1], pts[1:]]))
            seg_owner += [index[owner[k]]] * (len(pts) - 1)
    crossing: set[tuple[int, int]] = set()
    if segments:
        s = np.concatenate(segments)
        who = np.array(seg_owner)
        for i in range(len(s)):
            a, o = s[i], s[i + 1 :]
            d1 = (a[2] - a[0]) * (o[:, 1] - a[1]) - (a[3] - a[1]) * (o[:, 0] - a[0])
            d2 = (a[2] - a[0]) * (o[:, 3] - a[1]) - (a[3] - a[1]) * (o[:, 2] - a[0])
            d3 = (o[:, 2] - o[:, 0]) * (a[1] - o[:, 1]) - (o[:, 3] - o[:, 1]) * (a[0] - o[:, 0])
            d4 = (o[:, 2] - o[:, 0]) * (a[3] - o[:, 1]) - (o[:, 3] - o[:, 1]) * (a[2] - o[:, 0])
            for j in np.nonzero((d1 * d2 < 0) & (d3 * d4 < 0))[0]:
                p, q = who[i], who[i + 1 + j]
                if p != q and not (ends[keys[p]] & ends[keys[q]]):
                    crossing.add((min(p, q), max(p, q)))
    through = on_labels = 0
    boxes = []
    for o in objects:
        if is_label(o.get("name", "")):  # an arrow's label: the box of its text
            text = _label_box(o.get("_ldraw_", []))
            if text is not None:
                boxes.append((o["_gvid"], *text))
        elif "pos" in o and "width" in o:
            x, y = (float(v) for v in o["pos"].split(","))
            w, h = float(o["width"]) * 36 - 2, float(o["height"]) * 36 - 2
            boxes.append((o["_gvid"], x - w, y - h, x + w, y + h))
    for k, e in enumerate(edges):  # an edge's own label (a drawing of racc before issue 37)
        box = _label_box(e.get("_ldraw_", []))
        if box is not None:
            boxes.append((f"label {k}", *box))
    for k, pts in enumerate(curves):
        if len(pts) < 2:
            continue
        fine = np.concatenate(
            [pts[:-1] + (pts[1:] - pts[:-1]) * t for t in np.linspace(0, 1, 5)[:-1]] + [pts[-1:]]
        )
        mine = {edges[k]["tail"], edges[k]["head"], f"label {k}"}
        for gid, bx0, by0, bx1, by1 in boxes:
            if gid in mine:
                continue
            inside = (fine[:, 0] > bx0) & (fine[:, 0] < bx1) & (fine[:, 1] > by0)
            if (inside & (fine[:, 1] < by1)).any():
                if isinstance(gid, str) or is_label(names.get(gid, "")):
                    on_labels += 1
                else:
                    through += 1
    return Measures(x1 - x0, y1 - y0, len(ends), len(crossing), through, on_labels)


def _label_box(draw: list[dict[str, Any]]) -> tuple[float, float, float, float] | None:
    """The box of an edge label's text, from its drawing operations."""
    size = 14.0
    xs: list[float] = []
    ys: list[float] = []
    for op in draw:
        if op.get("op") == "F":
            size = float(op["size"])
        elif op.get("op") == "T":
            x, y = (float(v) for v in op["pt"])
            width = float(op["width"])
            left = x - {"l": 0.0, "c": 0.5, "r": 1.0}[op.get("align", "c")] * width
            xs += [left, left + width]
            ys += [y - 0.2 * size, y + 0.7 * size]
    return (min(xs), min(ys), max(xs), max(ys)) if xs else None
