"""The DOT text of a scene: namespace clusters, nested as the names nest, and the template."""

from __future__ import annotations

from collections.abc import Mapping

from rac.ir import Model
from rac.targets.diagram.legend import legend_rows, relation_rows
from rac.targets.diagram.scene import Item, Scene
from rac.targets.diagram.text import elide, fits, html_text, quote, shown
from rac.targets.diagram.topology import namespace
from rac.targets.templating import render

# dot's classic ranking of many clusters fails ("trouble in init_rank": a 300-node robot in
# 37 namespaces) or takes long; newrank does not, at the price of a wider drawing of a few.
NEWRANK_ABOVE_CLUSTERS = 12
# What the template's caption holds besides the texts: its tables, a row per note (bytes).
CAPTION_MARKUP = " " * 2000


def node_statement(item: Item, indent: str) -> str:
    return (
        f"{indent}{quote(item.id)} [{item.attrs}, label={item.label}, "
        f"tooltip={quote(item.tooltip)}];\n"
    )


def cluster_text(clusters: Mapping[str, list[Item]], prefix: str) -> str:
    """Each namespace below ``prefix`` a cluster, nested as the names nest; items outside
    any at the top.  A namespace holding only other namespaces gets a cluster when two or
    more of them share it."""
    spaces = set(clusters) - {""}
    for space in sorted(spaces):
        parent = namespace(space)
        while len(parent) > len(prefix) and parent not in spaces:
            if sum(1 for s in spaces if s.startswith(parent + "/")) > 1:
                spaces.add(parent)
            parent = namespace(parent)
    children: dict[str, list[str]] = {}
    for space in sorted(spaces):
        parent = namespace(space)
        while parent and parent not in spaces:
            parent = namespace(parent)
        children.setdefault(parent, []).append(space)
    shown_from = {space: prefix for space in children.get("", [])}

    def body(space: str, depth: int) -> list[str]:
        indent = "  " * depth
        out = [node_statement(item, indent) for item in clusters.get(space, [])]
        for child in children.get(space, []):
            shown = child[len(space or shown_from.get(child, "")) + 1 :] or child
            out.append(
                f"{indent}subgraph {quote('cluster_' + child)} {{\n"
                f"{indent}  label={quote(elide(shown))}; tooltip={quote(child)}; "
                'style="rounded,filled"; '
                f'fillcolor="#f7f9fa"; color="#b0bec5"; fontsize=10; fontcolor="#455a64";\n'
            )
            out += body(child, depth + 1)
            out.append(f"{indent}}}\n")
        return out

    return "".join(body("", 1))


def write_scene(
    model: Model, scene: Scene, clusters: Mapping[str, list[Item]], summary: bool
) -> str:
    if not clusters:
        clusters = {"": scene.items}
    caption = shown(f"robot {model.name.value}")
    notes = [html_text(n) for n in scene.notes]
    legend = legend_rows(scene.legend)
    relations = relation_rows(scene.relations)
    # The caption is one HTML-like label: within Graphviz's limit whatever the model's names
    # (rac.targets.diagram.text); the related signals give way first, then the notes.
    while not fits(CAPTION_MARKUP + "".join([caption, *notes, *legend, *relations])):
        if len(scene.relations) > 1:
            scene.relations = scene.relations[: len(scene.relations) // 2]
            relations = relation_rows([*scene.relations, "(more: racc diagram --all)"])
        elif notes:
            notes.pop()
        else:
            relations = []
            break
    return render(
        "architecture.dot.j2",
        name=quote(model.name.value),
        caption=caption,
        notes=notes,
        legend=legend,
        relations=relations,
        statements=cluster_text(clusters, scene.prefix),
        newrank=len(clusters) > NEWRANK_ABOVE_CLUSTERS or scene.compact or bool(scene.sources),
        compact=scene.compact,
        rankdir=scene.rankdir,
        sources=" ".join(quote(s) + ";" for s in scene.sources),
        edges="".join(scene.edges),
        summary=summary,
    )
