"""Diagnostics: one small hierarchy, a stable code per error, gcc-style rendering.

Every problem the compiler reports is a :class:`Diagnostic` with a stable code
(``RAC012``) and, where it came from source, a :class:`Span`.  Passes collect
diagnostics instead of raising on the first one, so a user sees every error of
a file in one run; :class:`RacError` carries them out to the CLI.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from rac.compat import StrEnum


@dataclass(frozen=True, slots=True)
class Span:
    """A region of a source file; lines and columns are 1-based, end exclusive."""

    file: str
    line: int
    column: int
    end_line: int
    end_column: int


class Severity(StrEnum):
    ERROR = "error"
    WARNING = "warning"
    NOTE = "note"  # information the engineer should know; never stops anything


@dataclass(frozen=True, slots=True)
class Diagnostic:
    code: str
    message: str
    span: Span | None = None
    severity: Severity = Severity.ERROR
    hint: str | None = None

    @property
    def is_error(self) -> bool:
        return self.severity is Severity.ERROR

    def render(self, source: str | Sequence[str] | None = None) -> str:
        """``FILE:LINE:COL: error[RAC012]: message`` plus the source line and carets.

        ``source`` is the text, or its lines when the caller renders many diagnostics of it.
        """
        head = f"{self.severity.value}[{self.code}]: {_clip(self.message)}"
        if self.span is None:
            lines = [head]
        else:
            lines = [f"{self.span.file}:{self.span.line}:{self.span.column}: {head}"]
            if source is not None:
                text = source.splitlines() if isinstance(source, str) else source
                lines.extend(_caret_lines(text, self.span))
        if self.hint:
            lines.append(f"  = help: {_clip(self.hint)}")
        return "\n".join(lines)


# Rendering stays linear in the input however hostile it is: at most MAX_SHOWN diagnostics,
# each with one source line cut to a window around its column and one caret line, and
# messages cut short (a message may quote a megabyte-long name).
MAX_SHOWN = 50
_WINDOW = 120
_MESSAGE = 400


def _clip(text: str) -> str:
    return text if len(text) <= _MESSAGE else text[:_MESSAGE] + f"… ({len(text):,} characters)"


def _caret_lines(text: Sequence[str], span: Span) -> list[str]:
    if not 1 <= span.line <= len(text):
        return []
    line = text[span.line - 1].expandtabs(1)
    if span.end_line == span.line:
        width = max(1, span.end_column - span.column)
    else:
        width = max(1, len(line) - span.column + 1)
    start = span.column - 1
    if len(line) > _WINDOW:  # show the window around the column, marking what is cut
        left = max(0, min(start - 20, len(line) - _WINDOW))
        shown = line[left : left + _WINDOW]
        prefix = "…" if left > 0 else ""
        line = prefix + shown + ("…" if left + _WINDOW < len(line) else "")
        start = start - left + len(prefix)
        width = max(1, min(width, _WINDOW - (start - len(prefix))))
    gutter = f"{span.line:>4} | "
    return [gutter + line, " " * (len(gutter) + start) + "^" * width]


class RacError(Exception):
    """Raised with every diagnostic of a failed step; the CLI renders and exits 1."""

    def __init__(self, diagnostics: Sequence[Diagnostic], source: str | None = None) -> None:
        self.diagnostics = tuple(diagnostics)
        self.source = source
        super().__init__("\n".join(d.render() for d in self.diagnostics[:MAX_SHOWN]))

    def __reduce__(self) -> tuple[type[RacError], tuple[tuple[Diagnostic, ...], str | None]]:
        # As it was made, not from its message: a worker process raises it to its parent.
        return (type(self), (self.diagnostics, self.source))

    def render(self) -> str:
        """Every diagnostic, up to :data:`MAX_SHOWN` of them, then how many more there are."""
        lines = self.source.splitlines() if self.source is not None else None
        shown = [d.render(lines) for d in self.diagnostics[:MAX_SHOWN]]
        hidden = len(self.diagnostics) - MAX_SHOWN
        if hidden > 0:
            shown.append(f"… and {hidden} more")
        return "\n".join(shown)


def closest(name: str, candidates: Iterable[str]) -> str | None:
    """The candidate closest to ``name``, or None when nothing is close."""
    close = difflib.get_close_matches(name, sorted(set(candidates)), n=1, cutoff=0.6)
    return close[0] if close else None


def did_you_mean(name: str, candidates: Iterable[str]) -> str | None:
    """A hint naming the closest candidate, or None when nothing is close."""
    close = closest(name, candidates)
    return f"did you mean '{close}'?" if close else None


# The stable codes.  Never renumber: users grep for them and tests pin them.
CODES: dict[str, str] = {
    "RAC001": "syntax error",
    "RAC002": "unexpected end of file",
    "RAC003": "invalid character",
    "RAC004": "cannot read an input file (or write an output directory)",
    "RAC005": "invalid JSON interchange",
    "RAC006": "invalid model-server YAML",
    # The documented limits on every input (rac/limits.py, issue 10).
    "RAC007": "number out of range",
    "RAC008": "name outside the documented character set",
    "RAC009": "an input too large, or a JSON or YAML document too deep",
    "RAC010": "duplicate name",
    "RAC011": "undefined hardware",
    "RAC012": "undefined topic",
    "RAC013": "undefined node",
    "RAC014": "undefined field",
    "RAC015": "duplicate field",
    "RAC020": "affected_by topic not subscribed",
    "RAC021": "topic in its own affected_by (Proposition 4.1)",
    "RAC022": "pair names the same field twice",
    "RAC023": "related or interval topic has no publisher",
    "RAC024": "switchable hardware without a channel",
    "RAC025": "two switchable devices on one channel",
    "RAC026": "channel given for non-switchable hardware",
    "RAC027": "names mangle to the same atom",
    "RAC028": "invalid ROS name",
    "RAC029": "invalid value",
    "RAC030": "duplicate statement",
    "RAC031": "integrated field I(...) in an interval",
    "RAC040": "unknown atom in an observation",
    "RAC041": "malformed literal",
    "RAC042": "unknown component",
    # Observers (chapter 5).
    "RAC050": "invalid observer specification",
    "RAC051": "invalid observer parameter value",
    # Replay and evaluation (docs/observers.md, docs/evaluation.md).
    "RAC052": "a test run has no ground truth",
    "RAC055": "--plot needs matplotlib",
    # The live runtime (issue 13): ROS 1 nodes, demo robot, recorder.
    "RAC056": "invalid observers.yaml",
    "RAC057": "ROS 1 is not available to this Python",
    "RAC058": "no ROS master",
    "RAC059": "cannot load the robot's launch file",
    # Repair (chapter 7, issue 4): the repair commands exit 3 on RAC070-RAC075, RAC077, RAC078.
    # Analysis, placement and import (issue 12).
    "RAC060": "a fault mode or command needs a .ram or .json model (racc fmt: a .ram)",
    "RAC061": "a component cannot fail in the given fault mode",
    "RAC062": "invalid costs file",
    "RAC063": "the LP relaxation failed",
    "RAC064": "invalid tug_diagnosis configuration",
    # Diagrams (docs/diagrams.md, issue 25).
    "RAC065": "drawing the format needs Graphviz's dot (missing or failed)",
    "RAC066": "--focus names no node, hardware or topic of the model",
    "RAC067": "--diagnosis names a component the model lacks",
    "RAC068": "the diagram file's suffix names no format",
    "RAC069": "nothing arrived on /diagnosis for a live diagram",
    "RAC070": "no diagnosis explains the observations",
    "RAC071": "a component to repair has no repair action",
    "RAC072": "the planner is not installed",
    "RAC073": "the planner failed",
    "RAC074": "the planner timed out",
    "RAC075": "the repair problem is unsolvable",
    "RAC076": "no such device for the scenario",
    "RAC077": "the plan validator is not installed",
    "RAC078": "the plan is not valid",
    # The diagnostic board (chapter 8, issue 6).
    "RAC090": "cannot reach the diagnostic board",
    "RAC091": "the board refused or garbled a command",
    "RAC092": "unknown board device or channel",
    "RAC093": "the board did not show the switched state",
    "RAC094": "the model names a channel the board lacks",
    "RAC095": "invalid node command templates",
    "RAC096": "a repair step cannot be executed",
    "RAC080": "cannot read a recording",
    "RAC081": "invalid computation graph YAML",
    "RAC082": "invalid properties CSV",
    "RAC083": "invalid fault specification",
    "RAC084": "output already exists",
    "RAC085": "invalid faults file (ground truth)",
    "RAC086": "ground truth does not fit the recording or the model",
    # Learning and evaluation that mean something (issue 35).
    "RAC160": "the ground truth lies outside the replayed recording",
    "RAC110": "a repair step did not take effect (escalated)",
    "RAC111": "a node cannot be restarted from the launch file",
    "RAC112": "unknown repair action",
    "RAC113": "invalid demo fault or node",
    "RAC114": "no board client for a switch",
    "RAC115": "the demo robot's roslaunch ended early",
    "RAC116": "ROS 2 (rclpy) is not available to this Python",
    "RAC117": "a ROS 2 launch file cannot be read, or names no such node",
    "RAC118": "a package or executable is not in the ament index",
    "RAC124": "a node that did not stop cannot be killed (it runs on another machine)",
    "RAC125": "a repairer option is out of range",
    "RAC130": "racc run: no launch file, or a wrong argument for it",
    "RAC131": "racc run: a node's executable cannot be found",
    "RAC132": "racc demo: the board simulator cannot listen on its ports",
    "RAC133": "a frequency window far outside the range its rate makes sensible (warning)",
    "RAC140": "a node runs on a machine the model does not declare",
    "RAC141": "a machine declared twice",
    "RAC142": "an invalid machine or container name",
    "RAC143": "a node cannot be restarted on its machine or in its container",
    # racc's control surfaces are authenticated (issue 34, docs/security.md).
    "RAC150": "the robot's racc secret cannot be used (missing, readable by others, damaged)",
    "RAC151": "racc confirm: no such repair plan awaits confirmation",
    "RAC152": "racc confirm: no repairer answered",
    "RAC155": "a node's old process is still alive and could not be stopped (never two copies)",
    "RAC156": "a node's old process may run where racc cannot stop it (never two copies)",
    "RAC100": "subscribed topic has no publisher",
    "RAC101": "hardware driven by no node",
    "RAC102": "node with no topics",
    "RAC103": "declared topic used by no node",
    "RAC104": "a feedback loop in the data flow (note)",
    "RAC105": "a feedback loop too large for the exact loop rule",
    "RAC106": "part of an imported configuration has no counterpart (note)",
    "RAC107": "the ground truth names another robot",
    # Usability pass 3 (issue 38).
    "RAC180": "a name in an imported configuration has white space around it (warning)",
    "RAC181": "a key of racc place's costs file prices no candidate observer (warning)",
}
