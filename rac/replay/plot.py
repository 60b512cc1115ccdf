"""``racc replay --plot``: the timeline at a glance (matplotlib, the optional ``plot`` extra).

One lane per observed atom (green while it holds, red while its negation holds), one lane
for the diagnoses (shaded while they are not empty, labelled with what they name), and the
known fault windows shaded grey behind everything, labelled with kind and target.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from rac.errors import Diagnostic, RacError
from rac.replay.timeline import ObservationRecord, Timeline, diagnoses_text, episodes
from rac.synth.truth import InjectedFault

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


def draw(timeline: Timeline, faults: Sequence[InjectedFault], out: Path, title: str) -> None:
    """The timeline drawn to ``out``, in the format its suffix names (PNG for any other, the
    file name kept as given: matplotlib would add ``.png`` to a name without a suffix)."""
    require_matplotlib()
    import matplotlib.pyplot as plt

    lanes = _lanes(timeline)
    names = sorted(lanes)
    height = 1.2 + 0.28 * (len(names) + 2)
    fig, ax = plt.subplots(figsize=(12, height))
    for f in faults:
        ax.axvspan(f.start, f.end, color=FAULT_COLOUR, alpha=0.25, lw=0)
        ax.text(f.start, len(names) + 1.45, f"{f.kind} {f.target}", fontsize=7, va="bottom")
    for y, atom in enumerate(names):
        for start, end, holds in lanes[atom]:
            ax.broken_barh(
                [(start, max(end - start, 1e-3))],
                (y - 0.35, 0.7),
                color=OK_COLOUR if holds else BAD_COLOUR,
            )
    lane = len(names) + 0.6
    for ep in episodes(timeline.records):
        end = timeline.duration if ep.end is None else ep.end
        ax.broken_barh(
            [(ep.start, max(end - ep.start, 1e-3))], (lane - 0.35, 0.7), color=BAD_COLOUR
        )
        ax.text(ep.start, lane + 0.4, diagnoses_text(ep.diagnoses[:3]), fontsize=6, va="bottom")
    ax.set_yticks([*range(len(names)), lane], [*names, "diagnoses"], fontsize=7)
    ax.set_ylim(-0.8, len(names) + 2.2)
    ax.set_xlim(0, max(timeline.duration, 1e-3))
    ax.set_xlabel("seconds from the start of the recording")
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    kinds = fig.canvas.get_supported_filetypes()
    kind = out.suffix[1:].lower() if out.suffix[1:].lower() in kinds else "png"
    try:
        fig.savefig(out, dpi=110, format=kind)
    except OSError as err:
        raise RacError([Diagnostic("RAC004", f"{out}: cannot write: {err}")]) from None
    finally:
        plt.close(fig)
