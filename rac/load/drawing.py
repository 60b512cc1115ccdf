"""Diagram files: DOT text written as it is (.dot, .gv), drawn by Graphviz's ``dot`` into
an image (.svg, .png, .pdf, .jpg), or the SVG in racc's self-contained page (.html), each
written atomically."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

from rac.errors import Diagnostic, RacError
from rac.load.output import write_file_atomically
from rac.targets.html import emit_html

# What Graphviz writes for each suffix; .dot and .gv are the DOT text itself.
FORMATS = {".svg": "svg", ".png": "png", ".pdf": "pdf", ".jpg": "jpg", ".jpeg": "jpg"}
# The self-contained page (rac.targets.html): Graphviz's SVG with racc's pan/zoom/search.
HTML_SUFFIXES = (".html", ".htm")
DOT_SUFFIXES = (".dot", ".gv")

RENDER_TIMEOUT_S = 300


def check_suffix(output: str | None) -> str:
    if output is None:
        return ".dot"
    suffix = Path(output).suffix.lower()
    if suffix not in DOT_SUFFIXES and suffix not in FORMATS and suffix not in HTML_SUFFIXES:
        known = ", ".join([*DOT_SUFFIXES, *FORMATS, *HTML_SUFFIXES])
        raise RacError(
            [
                Diagnostic(
                    "RAC068",
                    f"{output}: the suffix names no diagram format",
                    hint=f"end the file name in one of {known}",
                )
            ]
        )
    return suffix


def write_diagram(output: str | None, text: str, suffix: str, title: str = "architecture") -> None:
    """``text`` (DOT) to ``output``, rendered by Graphviz unless the suffix is .dot/.gv; an
    .html page is the SVG in racc's viewer, titled ``title``."""
    if output is None:
        return
    if suffix in DOT_SUFFIXES:
        write_file_atomically(Path(output), text)
        return
    if suffix in HTML_SUFFIXES:
        svg = render(text, "svg", output).decode("utf-8")
        write_file_atomically(Path(output), emit_html(svg, title))
        return
    write_file_atomically(Path(output), render(text, FORMATS[suffix], output))


def render(text: str, fmt: str, output: str) -> bytes:
    dot = shutil.which("dot")
    if dot is None:
        raise RacError(
            [
                Diagnostic(
                    "RAC065",
                    f"{output}: drawing this format needs Graphviz's dot, which is not installed",
                    hint="install Graphviz (Debian/Ubuntu: apt-get install graphviz), or write "
                    "a .dot file and render it elsewhere",
                )
            ]
        )
    done = run_dot(dot, text, fmt, RENDER_TIMEOUT_S)
    if done.returncode != 0:
        why = done.stderr.decode(errors="replace").strip()
        raise RacError(
            [
                Diagnostic(
                    "RAC065",
                    f"{output}: Graphviz's dot failed: {why}",
                    hint="write a .dot file and report the failure with it",
                )
            ]
        )
    return done.stdout


def run_dot(dot: str, text: str, fmt: str, timeout: float) -> subprocess.CompletedProcess[bytes]:
    """Graphviz's ``dot -TFMT`` of ``text``, once more with ``newrank`` if it fails.

    dot's classic ranking fails on some graphs with clusters ("trouble in init_rank"; a
    300-node robot in 37 namespaces does); ``newrank`` ranks them, with a layout that is
    often wider, so it is the second choice only.
    """
    data = text.encode("utf-8")
    done = subprocess.run(
        [dot, f"-T{fmt}"], input=data, capture_output=True, timeout=timeout, check=False
    )
    if done.returncode != 0 and b"init_rank" in done.stderr:
        done = subprocess.run(
            [dot, "-Gnewrank=true", f"-T{fmt}"],
            input=data,
            capture_output=True,
            timeout=timeout,
            check=False,
        )
    return done
