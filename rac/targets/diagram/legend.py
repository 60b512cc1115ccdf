"""The caption's legend (only the symbols drawn) and its table of related signals."""

from __future__ import annotations

from collections.abc import Iterable

from rac.targets.diagram.scene import COLOURS
from rac.targets.diagram.text import html_text

RELATIONS_PER_COLUMN = 6

# The legend: each key, its symbol (an HTML table cell) and what it means.
LEGEND: dict[str, tuple[str, str]] = {
    "hardware": ('<TD BORDER="1" WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE">hw</TD>', "hardware"),
    "switchable": (
        '<TD BORDER="1" WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE">ch N</TD>',
        "switchable hardware, board channel N",
    ),
    "sn": (
        '<TD BORDER="1" STYLE="rounded" BGCOLOR="#555555" WIDTH="40" HEIGHT="16" '
        'FIXEDSIZE="TRUE"><FONT COLOR="#ffffff">SN</FONT></TD>',
        "driver of switchable hardware",
    ),
    "hn": (
        '<TD BORDER="1" STYLE="rounded" BGCOLOR="#bdbdbd" WIDTH="40" HEIGHT="16" '
        'FIXEDSIZE="TRUE">HN</TD>',
        "driver of other hardware",
    ),
    "n": (
        '<TD BORDER="1" STYLE="rounded" WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE">N</TD>',
        "software node",
    ),
    "hardware_link": ('<TD WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE">┈┈┈</TD>', "drives"),
    "wire": (
        '<TD WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE">──▶</TD>',
        "publisher to subscriber: topic @ rate (rate observed)",
    ),
    "pair": (
        '<TD WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE">──▶</TD>',
        "node to node: its topic, or N topics: the first (all in the tooltip)",
    ),
    "feedback": (
        '<TD WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE">◀──</TD>',
        "against the flow: the arrow that closes a loop",
    ),
    "topic": (
        '<TD BORDER="1" STYLE="rounded" COLOR="#7f9fbf" BGCOLOR="#e8f0f8" WIDTH="40" '
        'HEIGHT="16" FIXEDSIZE="TRUE"><FONT COLOR="#1f4e79">/t</FONT></TD>',
        "topic of several publishers or readers",
    ),
    "loose_topic": (
        '<TD BORDER="1" STYLE="dashed" COLOR="#7f9fbf" BGCOLOR="#e8f0f8" WIDTH="40" '
        'HEIGHT="16" FIXEDSIZE="TRUE"><FONT COLOR="#1f4e79">/t</FONT></TD>',
        "topic nobody publishes or nobody reads",
    ),
    "alone": (
        '<TD BORDER="1" STYLE="rounded" COLOR="#7f9fbf" BGCOLOR="#e8f0f8" WIDTH="40" '
        'HEIGHT="16" FIXEDSIZE="TRUE"><FONT COLOR="#1f4e79">/tf</FONT></TD>',
        "observed infrastructure topic: how many publish and read it",
    ),
    "hub": (
        '<TD BORDER="1" STYLE="rounded,dashed" WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE">'
        '<FONT POINT-SIZE="8">hub</FONT></TD>',
        "a hub, drawn again beside the nodes it talks to",
    ),
    "unwatched": (
        f'<TD WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE"><FONT COLOR="{COLOURS["unwatched"]}">'
        "/t</FONT></TD>",
        "topic no observer watches",
    ),
    "related": (
        '<TD WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE"><FONT COLOR="#1f4e79">/t ~</FONT></TD>',
        "in a related pair (listed right)",
    ),
    "folded": (
        '<TD WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE"><FONT POINT-SIZE="8">+N</FONT></TD>',
        "folded topics of the node",
    ),
    "details": (
        '<TD WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE"><FONT POINT-SIZE="8">% · MB</FONT></TD>',
        "a node's cpu and memory limits",
    ),
    "namespace": (
        '<TD BORDER="1" STYLE="rounded" COLOR="#b0bec5" BGCOLOR="#f7f9fa" WIDTH="40" '
        'HEIGHT="16" FIXEDSIZE="TRUE"><FONT POINT-SIZE="8">/ns</FONT></TD>',
        "namespace",
    ),
    "group": (
        '<TD BORDER="1" STYLE="rounded" COLOR="#607d8b" BGCOLOR="#f4f6f8" WIDTH="40" '
        'HEIGHT="16" FIXEDSIZE="TRUE"><FONT POINT-SIZE="8">/ns</FONT></TD>',
        "namespace: its nodes and topics; arrows count topics between",
    ),
    "undetected": (
        f'<TD BORDER="1" STYLE="rounded,dashed" COLOR="{COLOURS["undetected"]}" WIDTH="40" '
        'HEIGHT="16" FIXEDSIZE="TRUE"><FONT POINT-SIZE="8">unseen</FONT></TD>',
        "a fault no observer detects (racc analyze)",
    ),
    "faulty": (
        f'<TD BORDER="1" STYLE="rounded" BGCOLOR="{COLOURS["faulty"]}" WIDTH="40" HEIGHT="16" '
        'FIXEDSIZE="TRUE"><FONT COLOR="#ffffff">c</FONT></TD>',
        "diagnosed faulty (every diagnosis)",
    ),
    "suspect": (
        f'<TD BORDER="1" STYLE="rounded" BGCOLOR="{COLOURS["suspect"]}" WIDTH="40" HEIGHT="16" '
        'FIXEDSIZE="TRUE">c</TD>',
        "suspect (some diagnosis)",
    ),
    "bad": (
        f'<TD BORDER="2" STYLE="rounded" COLOR="{COLOURS["bad"]}" WIDTH="40" HEIGHT="20" '
        'FIXEDSIZE="TRUE">c</TD>',
        "an observer of it reads bad",
    ),
    "good": (
        f'<TD BORDER="2" STYLE="rounded" COLOR="{COLOURS["good"]}" WIDTH="40" HEIGHT="20" '
        'FIXEDSIZE="TRUE">c</TD>',
        "its observers read good",
    ),
    "bad_topic": (
        f'<TD WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE"><FONT COLOR="{COLOURS["bad"]}"><B>/t</B>'
        "</FONT></TD>",
        "topic an observer reads bad",
    ),
    "good_topic": (
        f'<TD WIDTH="40" HEIGHT="16" FIXEDSIZE="TRUE"><FONT COLOR="{COLOURS["good"]}">/t'
        "</FONT></TD>",
        "topic its observers read good",
    ),
}
LEGEND_PER_ROW = 3


def legend_rows(keys: Iterable[str]) -> list[str]:
    """The legend's table rows, the keys in LEGEND's order, LEGEND_PER_ROW to a row."""
    used = [k for k in LEGEND if k in set(keys)]
    cells = [f'{LEGEND[k][0]}<TD ALIGN="LEFT">{html_text(LEGEND[k][1])}</TD>' for k in used]
    return ["".join(cells[i : i + LEGEND_PER_ROW]) for i in range(0, len(cells), LEGEND_PER_ROW)]


def relation_rows(pairs: list[str]) -> list[str]:
    columns = [
        pairs[i : i + RELATIONS_PER_COLUMN] for i in range(0, len(pairs), RELATIONS_PER_COLUMN)
    ]
    height = len(columns[0]) if columns else 0
    return [
        "".join(f'<TD ALIGN="LEFT">{html_text(c[r]) if r < len(c) else ""}</TD>' for c in columns)
        for r in range(height)
    ]
