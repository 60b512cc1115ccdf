"""``racc replay --plot``: the timeline at a glance (matplotlib, the optional ``plot`` extra).

One lane per observed atom (green while it holds, red while its negation holds), one lane
for the diagnoses (shaded while they are not empty, labelled with what they name), and the
known fault windows shaded grey behind everything, labelled with kind and target.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from rac.errors import Diagnostic, RacError
from rac.replay.timeline import ObservationRecord, Timeline, diagnoses_text, episodes
from rac.synth.truth import InjectedFault

if TYPE_CHECKING:  # matplotlib is the optional plot extra: imported where a plot is drawn
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

OK_COLOUR = "#4caf50"
BAD_COLOUR = "#e53935"
FAULT_COLOUR = "#9e9e9e"


def _lanes(timeline: Timeline) -> dict[str, list[tuple[float, float, bool]]]:
    """atom -> [(start, end, holds)] segments."""
    open_: dict[str, tuple[float, bool]] = {}
    lanes: dict[str, list[tuple[float, float, bool]]] = {}
    for r in timeline.records:
        if not isinstance(r, ObservationRecord):
            continue
        positive = not r.literal.startswith("not_")
        atom = r.literal.removeprefix("not_")
        if atom in open_:
            start, holds = open_[atom]
            lanes.setdefault(atom, []).append((start, r.t, holds))
        else:
            lanes.setdefault(atom, [])
        open_[atom] = (r.t, positive)
    for atom, (start, holds) in open_.items():
        lanes[atom].append((start, timeline.duration, holds))
    return lanes


def require_matplotlib() -> None:
    """RAC055 when the plot extra is missing: checked before a long replay, not after it."""
    try:
        import matplotlib

        matplotlib.use("Agg")
    except ImportError:
        hint = "install the plot extra: pip install 'racc[plot]'"
        raise RacError([Diagnostic("RAC055", "--plot needs matplotlib", hint=hint)]) from None


# A row of labels above the lanes, in lane units, and the gap kept between two labels of a row
# (in points: a space of their 7 pt type).
LABEL_ROW = 0.42
LABEL_GAP_PT = 4.0


def draw(timeline: Timeline, faults: Sequence[InjectedFault], out: Path, title: str) -> None:
    """The timeline drawn to ``out``, in the format its suffix names (PNG for any other, the
    file name kept as given: matplotlib would add ``.png`` to a name without a suffix)."""
    require_matplotlib()
    import matplotlib.pyplot as plt

    fig = figure(timeline, faults, title)
    kinds = fig.canvas.get_supported_filetypes()
    kind = out.suffix[1:].lower() if out.suffix[1:].lower() in kinds else "png"
    try:
        fig.savefig(out, dpi=110, format=kind)
    except OSError as err:
        raise RacError([Diagnostic("RAC004", f"{out}: cannot write: {err}")]) from None
    finally:
        plt.close(fig)


def figure(timeline: Timeline, faults: Sequence[InjectedFault], title: str) -> Figure:
    """The timeline as a matplotlib figure.  The labels of the fault windows and of the
    diagnoses go in rows above the lanes, as many as it takes for no two to overlap: faults
    a second apart wrote their labels over each other on one line."""
    require_matplotlib()
    import matplotlib.pyplot as plt

    lanes = _lanes(timeline)
    names = sorted(lanes)
    fig, ax = plt.subplots(figsize=(12, 3.0))
    ax.set_xlim(0, max(timeline.duration, 1e-3))
    eps = episodes(timeline.records)
    diagnosed = [(ep.start, diagnoses_text(ep.diagnoses[:3]), 6.0) for ep in eps]
    injected = [(f.start, f"{f.kind} {f.target}", 7.0) for f in faults]
    diagnosis_rows = _rows(ax, diagnosed)
    fault_rows = _rows(ax, injected)
    lane = len(names) + 0.6  # the diagnoses' lane
    first_diagnosis = lane + 0.45
    rows = max((r for r, _ in diagnosis_rows), default=-1) + 1
    first_fault = first_diagnosis + rows * LABEL_ROW + 0.1
    top = first_fault + (max((r for r, _ in fault_rows), default=-1) + 1) * LABEL_ROW
    fig.set_figheight(1.2 + 0.28 * (top + 0.8))
    for f in faults:
        ax.axvspan(f.start, f.end, color=FAULT_COLOUR, alpha=0.25, lw=0)
    for (_, text, size), (row, x) in zip(injected, fault_rows, strict=True):
        ax.text(x, first_fault + row * LABEL_ROW, text, fontsize=size, va="bottom")
    for y, atom in enumerate(names):
        for start, end, holds in lanes[atom]:
            ax.broken_barh(
                [(start, max(end - start, 1e-3))],
                (y - 0.35, 0.7),
                color=OK_COLOUR if holds else BAD_COLOUR,
            )
    for ep in eps:
        end = timeline.duration if ep.end is None else ep.end
        ax.broken_barh(
            [(ep.start, max(end - ep.start, 1e-3))], (lane - 0.35, 0.7), color=BAD_COLOUR
        )
    for (_, text, size), (row, x) in zip(diagnosed, diagnosis_rows, strict=True):
        ax.text(x, first_diagnosis + row * LABEL_ROW, text, fontsize=size, va="bottom")
    ax.set_yticks([*range(len(names)), lane], [*names, "diagnoses"], fontsize=7)
    ax.set_ylim(-0.8, top + 0.2)
    ax.set_xlabel("seconds from the start of the recording")
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    return fig


def _rows(ax: Axes, labels: Sequence[tuple[float, str, float]]) -> list[tuple[int, float]]:
    """Per label (x, text, font size), its row and its x: the first row where it starts after
    the previous label of that row ends; a label that would run past the right edge ends
    there.  Widths are measured as matplotlib draws them: the x axis's limits are set and the
    figure's width is final (only its height changes later)."""
    renderer = ax.figure.canvas.get_renderer()  # type: ignore[attr-defined]
    gap = LABEL_GAP_PT * ax.figure.dpi / 72
    right = ax.transData.transform((ax.get_xlim()[1], 0))[0]
    left = ax.transData.transform((ax.get_xlim()[0], 0))[0]
    ends: list[float] = []  # per row, where its last label ends (display units)
    placed = [(0, 0.0)] * len(labels)
    for k in sorted(range(len(labels)), key=lambda k: labels[k][0]):
        x, text, size = labels[k]
        probe = ax.text(x, 0, text, fontsize=size)
        width = probe.get_window_extent(renderer).width
        probe.remove()
        start = ax.transData.transform((x, 0))[0]
        start = max(left, min(start, right - width))
        row = next((r for r, end in enumerate(ends) if start >= end + gap), len(ends))
        if row == len(ends):
            ends.append(0.0)
        ends[row] = start + width
        placed[k] = (row, float(ax.transData.inverted().transform((start, 0))[0]))
    return placed
