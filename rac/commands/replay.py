"""``racc replay``: a recording through the observers and the diagnosis engine."""

from __future__ import annotations

import argparse
import sys
import textwrap
import time
from pathlib import Path
from typing import Any

from rac.commands.common import add_command, checked_truth, load_and_compile
from rac.commands.options import add_replay_options
from rac.commands.reports import draw_health
from rac.load.drawing import check_suffix
from rac.load.kinds import PROPERTIES, RECORDING, check_kind
from rac.load.output import check_output_file, write_file_atomically


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "replay",
        "replay a recording through the observers and the diagnosis engine",
        textwrap.fill(
            "Feed a recording (a ROS 1 .bag or a ROS 2 bag directory) through every observer "
            "MODEL compiles to, in timestamp order; collect their observations as Algorithm 10 "
            "does and diagnose them every PERIOD.  Node liveness, CPU and memory come from the "
            "properties CSV (time,node,cpu,mem; by default RUN.properties.csv beside the run), "
            "/diagnostics from the recording.  Several RUNs are replayed back to back.  stdout "
            "summarises each episode (when a fault appeared, what was diagnosed, when it "
            "cleared); -o writes the timeline as JSON lines, --plot draws it (needs the plot "
            "extra: pip install 'racc[plot]').  See docs/evaluation.md.",
            88,
        ),
        "  racc replay models/pioneer.ram run.bag\n"
        "  racc replay models/pioneer.ram run.bag --properties run.csv -o timeline.jsonl\n"
        "  racc replay learned.ram run1.bag run2.bag --diagnose-every 500ms --plot run.png",
    )
    parser.add_argument("model", metavar="MODEL", help="a .ram file or a ram/1 .json")
    parser.add_argument("runs", metavar="RUN", nargs="+", help="recordings to replay")
    parser.add_argument(
        "--properties",
        metavar="CSV",
        action="append",
        default=[],
        help="a properties CSV, one per RUN in order (default: RUN.properties.csv if present)",
    )
    parser.add_argument(
        "--truth",
        metavar="FAULTS",
        help="the injected faults (default: RUN.faults.yaml beside a single RUN, if present)",
    )
    add_replay_options(parser)
    parser.add_argument("-o", "--output", metavar="FILE", help="write the timeline (JSON lines)")
    parser.add_argument(
        "--plot",
        metavar="FILE",
        help="draw the timeline to FILE, in the format its suffix names (.png, .svg, .pdf; "
        "PNG for any other)",
    )
    parser.add_argument(
        "--diagram-at",
        metavar="T",
        type=float,
        help="draw the architecture as the replay saw it T seconds in: diagnosed components "
        "and topics whose observers read bad coloured (docs/diagrams.md)",
    )
    parser.add_argument(
        "--diagram",
        metavar="FILE",
        default="diagram.svg",
        help="with --diagram-at: the file, its suffix the format (default: diagram.svg)",
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    parser.set_defaults(run=run)


def _messages(inputs: Any) -> str:
    """How many messages were replayed, and why not all the recording's: only the topics
    the observers read are (a bag synth wrote with 78,098 messages replays 69,800)."""
    shown = f"{inputs.messages:,} messages"
    if inputs.recorded > inputs.messages:
        topics = f"the {inputs.topics} topics" if inputs.topics else "the topics"
        shown += f" on {topics} the observers read (of {inputs.recorded:,} recorded)"
    return shown


def run(args: argparse.Namespace) -> int:
    from rac.evaluate.score import score_run
    from rac.replay.engine import ReplayOptions, replay
    from rac.replay.load import (
        load_runs,
        needs_of,
        properties_for,
        replayable,
        truth_for,
        truth_in_span,
    )
    from rac.replay.plot import draw, require_matplotlib
    from rac.replay.timeline import summary_lines, to_jsonl

    if args.plot:
        require_matplotlib()
    if args.diagram_at is not None:
        check_suffix(args.diagram)  # before the replay, not after it
    check_output_file(args.output)
    for run in args.runs:
        check_kind(run, RECORDING, "RAC080")
    compiled = load_and_compile(args.model, quiet=args.quiet)
    for given in args.properties or ():
        check_kind(given, PROPERTIES, "RAC082")
    model = replayable(compiled)
    truth_notes: list[str] = []
    truth = truth_for(args.runs, args.truth, truth_notes)
    if truth is not None and model.theory.model is not None:
        checked_truth(truth, [model.theory.model], quiet=args.quiet)
    started = time.perf_counter()
    inputs = load_runs(args.runs, properties_for(args.runs, args.properties), needs_of([model]))
    if truth is not None:
        truth = truth_in_span(truth, inputs.duration, inputs.path)
    if not args.quiet:
        for note in [*truth_notes, *inputs.notes]:
            print(f"note: {note}", file=sys.stderr)
    options = ReplayOptions(diagnose_every=args.diagnose_every, max_card=args.max_card)
    progress = _Progress(inputs.duration) if not args.quiet and sys.stderr.isatty() else None
    timeline = replay(model.specs, model.theory, inputs.events, inputs.duration, options, progress)
    if progress is not None:
        progress.done()
    elapsed = time.perf_counter() - started
    if args.output:
        write_file_atomically(Path(args.output), to_jsonl(timeline))
    if args.diagram_at is not None:
        draw_health(compiled, args.diagram_at, timeline, args.diagram)
    if args.plot:
        title = f"{model.name}: {', '.join(Path(r).name for r in args.runs)}"
        draw(timeline, truth.faults if truth else (), Path(args.plot), title)
    if args.quiet:
        return 0
    speed = inputs.duration / elapsed if elapsed > 0 else float("inf")
    print(
        f"replayed {inputs.path}: {_messages(inputs)}, {inputs.duration:.1f} s, through "
        f"{len(model.specs)} observers in {elapsed:.1f} s ({speed:.0f}x real time)"
    )
    lines = summary_lines(timeline)
    print("\n".join(lines) if lines else "no fault diagnosed: the observations stayed consistent")
    if truth is not None:
        score = score_run(timeline, truth.faults)
        for o in score.outcomes:
            f = o.fault
            print(f"fault {f.kind} {f.target} {f.start:g}-{f.end:g} s: {_outcome(o)}")
        for fp in score.false_positives:
            print(f"false positive at {fp.episode.start:.1f} s ({fp.kind})")
        if score.healthy_s > 0:
            hours = score.healthy_s / 3600
            print(
                f"false episodes: {len(score.false_positives)} in {score.healthy_s:.0f} s of "
                f"healthy recording ({len(score.false_positives) / hours:.1f} per hour, "
                f"{score.false_s:.1f} s of them)"
            )
    return 0


def _outcome(o: Any) -> str:
    """How a fault fared: detected when and how fast, and whether the culprit was isolated."""
    if o.first is None:
        return "NOT reported"
    text = f"reported at {o.first:.1f} s ({o.latency:.1f} s after it began)"
    if o.isolated:
        return f"{text}, isolated"
    return f"{text}, not isolated ({o.candidates} candidate diagnoses)"


class _Progress:
    """A one-line progress indicator on a terminal."""

    def __init__(self, total: float) -> None:
        self.total = max(total, 1e-9)
        self.shown = -1

    def __call__(self, t: float) -> None:
        percent = int(100 * t / self.total)
        if percent != self.shown:
            self.shown = percent
            print(f"\rreplaying: {percent:3d} %", end="", file=sys.stderr, flush=True)

    def done(self) -> None:
        print("\r" + " " * 20 + "\r", end="", file=sys.stderr, flush=True)
