"""``racc learn``: learn a model from recorded fault-free runs (chapter 9)."""

from __future__ import annotations

import argparse
import json
import math
import sys
import textwrap
import time
from pathlib import Path
from typing import Any

from rac.commands.common import add_command, count, load_checked
from rac.fmt import format_model
from rac.learn.options import (
    DEFAULT_ALPHA,
    DEFAULT_BLOCKS,
    DEFAULT_MIN_LIFT,
    DEFAULT_OCCURRENCES,
    DEFAULT_PER_EDGE,
    DEFAULT_Q,
    DEFAULT_SIGMAS,
    DEFAULT_SIGNIFICANCE,
)
from rac.load.kinds import RECORDING, check_kind
from rac.load.output import check_output_file, write_file_atomically
from rac.pipeline import compile_model


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "learn",
        "learn a model from recorded fault-free runs (rosbags)",
        textwrap.fill(
            "Learn a robot model from one or more fault-free recordings: which topics are regular "
            "(frequency observers with their rate and tolerance), node CPU and memory limits "
            "(from --properties) and which fields are qualitatively related (binary qualitative "
            "observers).  Several runs are merged into one training set (Algorithm 19).  The "
            "structure (subscriptions, hardware, drivers) comes from --base or --graph; a ROS 1 "
            "recording names each topic's publishers.  Every learned value carries a comment with "
            "its evidence; the written model compiles.",
            88,
        ),
        "  racc learn run.bag --base models/tedusar.ram -o learned.ram\n"
        "  racc learn run1.bag run2.bag --base robot.ram -Q 0.8 --alpha 10 -o m.ram "
        "--report m.json\n"
        "  racc learn ros2_run/ --graph graph.yaml --properties run.properties.csv -o m.ram\n"
        "  racc learn run.bag --include-fields 'ranges' 'header.*' -o m.ram\n"
        "  racc learn day1.bag day2.bag day3.bag --graph graph.yaml --exclude '/camera/*' "
        "-o m.ram",
    )
    parser.add_argument(
        "runs", metavar="RUN", nargs="+", help="a ROS 1 .bag file or a ROS 2 bag directory"
    )
    parser.add_argument("-o", "--output", metavar="FILE", required=True, help="the learned .ram")
    structure = parser.add_mutually_exclusive_group()
    structure.add_argument(
        "--base", metavar="MODEL", help="a model whose structure is kept and parameters learned"
    )
    structure.add_argument(
        "--graph", metavar="YAML", help="the computation graph (docs/learning.md shows the shape)"
    )
    parser.add_argument(
        "--alpha",
        type=float,
        default=DEFAULT_ALPHA,
        help="a topic is regular when mean/σ of its intervals exceeds α (default: %(default)s)",
    )
    parser.add_argument(
        "-Q",
        dest="q",
        type=float,
        default=DEFAULT_Q,
        help="fields are related when their trend match ratio exceeds Q (default: %(default)s)",
    )
    parser.add_argument(
        "--occurrences",
        metavar="C",
        type=int,
        default=DEFAULT_OCCURRENCES,
        help="occurrences per regression window (default: %(default)s)",
    )
    parser.add_argument(
        "--min-lift",
        type=float,
        default=DEFAULT_MIN_LIFT,
        help="a relation's ratio must also beat chance by this much; 0 is the dissertation's "
        "rule (default: %(default)s)",
    )
    parser.add_argument(
        "--no-integrated",
        action="store_true",
        help="do not correlate integrated signals I(M)",
    )
    parser.add_argument(
        "--no-validate",
        action="store_true",
        help="keep learned rates and relations whose observers report a fault on the "
        "training runs themselves (default: drop them, with a comment)",
    )
    parser.add_argument(
        "--blocks",
        metavar="K",
        type=int,
        default=DEFAULT_BLOCKS,
        help="held-out validation: cut a single training run into K time blocks (several "
        "runs: one block per run) and keep only the relations and rate bands that hold on "
        "blocks they were not fitted on; 0 turns it off (default: %(default)s)",
    )
    parser.add_argument(
        "--significance",
        metavar="A",
        type=float,
        default=DEFAULT_SIGNIFICANCE,
        help="held-out validation: family-wise error rate of Holm's correction over every "
        "pair tried (default: %(default)s)",
    )
    parser.add_argument(
        "--blind",
        action="store_true",
        help="also try the field pairs that neither the graph (a node's input against its "
        "output) nor the message types (one quantity measured twice: a heading, a turn "
        "rate, a velocity) explain; they are judged against the number of every pair tried "
        "and marked unexplained (default: only when nothing else applies)",
    )
    parser.add_argument(
        "--per-edge",
        metavar="N",
        type=int,
        default=DEFAULT_PER_EDGE,
        help="relations kept per graph edge (a node's input against its output), the "
        "strongest first; 0 keeps all (default: %(default)s)",
    )
    parser.add_argument(
        "--exclude",
        metavar="PATTERN",
        nargs="+",
        default=[],
        help="leave out the topics matching these globs ('/imu_data', '/camera/*'); with "
        "--graph, recorded topics the graph does not name are left out too (default: none)",
    )
    parser.add_argument(
        "-j",
        "--jobs",
        metavar="N",
        type=int,
        default=0,
        help="read and summarise the runs on N processes (default: one per core)",
    )
    parser.add_argument(
        "--properties",
        metavar="CSV",
        help="node samples, a CSV with the header time,node,cpu,mem (cpu %%, mem bytes); without "
        "it no limits are learned (a base model's are kept)",
    )
    parser.add_argument(
        "--sigmas",
        metavar="K",
        type=float,
        default=DEFAULT_SIGMAS,
        help="a limit is mean + K·σ of the samples, at least their max (default: %(default)s)",
    )
    parser.add_argument(
        "--include-fields",
        metavar="PATTERN",
        nargs="+",
        default=[],
        help="also use fields matching these glob patterns (arrays, header fields, fields "
        "the base model does not list): 'ranges', 'header.*', '/scan.ranges'",
    )
    parser.add_argument(
        "--include",
        metavar="PATTERN",
        nargs="+",
        default=[],
        help="keep nodes and topics matching these globs, which are left out by default "
        "without --base: racc's own topics (/diagnosis, /observations, /repair_log, "
        "/board_measurements, /board_switch) and nodes (/racc_*), ROS's tool nodes "
        "(/rostopic_*, /rosnode_*, /rosservice_*, /record_*, /rqt*) and /rosout "
        "(default: none)",
    )
    parser.add_argument(
        "--name",
        help="the robot's name when there is no base model (default: the first RUN's stem)",
    )
    parser.add_argument("--report", metavar="FILE", help="write counts and evidence as JSON")
    parser.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    parser.set_defaults(run=run)


def _check_options(args: argparse.Namespace) -> None:
    problems = [
        f"{flag} must be a finite number"
        for flag, value in (
            ("--alpha", args.alpha),
            ("--sigmas", args.sigmas),
            ("--min-lift", args.min_lift),
        )
        if not math.isfinite(value)
    ]
    if args.alpha <= 0:
        problems.append("--alpha must be above 0")
    if not 0 <= args.q < 1:
        problems.append("-Q must be in [0, 1)")
    if args.blocks < 0 or args.blocks == 1:
        problems.append("--blocks must be 0 (off) or at least 2")
    if not 0 < args.significance < 1:
        problems.append("--significance must be in (0, 1)")
    if args.occurrences < 2:
        problems.append("--occurrences must be at least 2")
    if args.sigmas < 0:
        problems.append("--sigmas must not be negative")
    if args.per_edge < 0:
        problems.append("--per-edge must not be negative")
    if args.jobs < 0:
        problems.append("--jobs must not be negative")
    if problems:
        print("racc learn: error: " + "; ".join(problems), file=sys.stderr)
        raise SystemExit(2)


def run(args: argparse.Namespace) -> int:
    # NumPy and rosbags load here, not at start-up: every racc command pays for imports
    # made at module level.
    from rac.learn.fields import FieldSelector
    from rac.learn.learner import learn, observer_counts, report
    from rac.learn.options import LearnOptions
    from rac.learn.properties import property_stats
    from rac.load.bags import read_recording
    from rac.load.recorded import load_graph, load_properties
    from rac.parallel import default_jobs, mapper

    _check_options(args)
    check_output_file(args.output)
    check_output_file(args.report, "--report")
    for run in args.runs:  # before the base and graph: what each path is, at once
        check_kind(run, RECORDING, "RAC080")
    base = load_checked(args.base) if args.base else None
    graph = load_graph(args.graph) if args.graph else None
    properties = []
    if args.properties:
        properties = property_stats(load_properties(args.properties))
    declared = None
    only = None
    if base is not None:
        # A base topic that lists no fields gives all its numeric signals, as without a base.
        declared = {
            t.name.value: frozenset(f.value for f in t.fields) for t in base.topics if t.fields
        }
        only = frozenset(t.name.value for t in base.topics)
    elif graph is not None:
        # Topics outside the graph are not the robot the graph describes: not read at all,
        # so that their names cannot collide with its topics' (named in a note).
        only = frozenset(t for g in graph.nodes for t in (*g.publications, *g.subscriptions))
    selector = FieldSelector(declared, tuple(args.include_fields))
    jobs = args.jobs or default_jobs()
    started = time.perf_counter()
    recording = read_recording(args.runs, selector, only, jobs)
    read_s = time.perf_counter() - started
    options = LearnOptions(
        alpha=args.alpha,
        q=args.q,
        occurrences=args.occurrences,
        min_lift=args.min_lift,
        sigmas=args.sigmas,
        integrate=not args.no_integrated,
        validate=not args.no_validate,
        blocks=args.blocks,
        significance=args.significance,
        name=args.name,
        include=tuple(args.include),
        exclude=tuple(args.exclude),
        blind=args.blind,
        per_edge=args.per_edge,
    )
    result = learn(
        recording, options, base=base, graph=graph, properties=properties, mapper=mapper(jobs)
    )
    compile_model(result.model)  # the learned model must compile; a failure here is a bug
    total_s = time.perf_counter() - started
    for note in () if args.quiet else result.notes:
        print(f"note: {note}", file=sys.stderr)
    write_file_atomically(Path(args.output), format_model(result.model))
    if args.report:
        doc = report(result)
        doc["runs"] = [
            {
                "path": r.path,
                "ros_version": r.ros_version,
                "messages": r.messages,
                "duration_s": r.end - r.start,
            }
            for r in recording.runs
        ]
        doc["timing"] = {"read_s": read_s, **dict(result.seconds), "total_s": total_s}
        write_file_atomically(Path(args.report), json.dumps(doc, indent=2) + "\n")
    if not args.quiet:
        counts = observer_counts(result.model)
        summary = ", ".join(f"{v} {k}" for k, v in counts.items() if k != "total")
        print(
            f"learned {result.model.name.value} from {count(recording.messages, 'message')} in "
            f"{count(len(recording.runs), 'run')} ({total_s:.1f} s): {summary} -> {args.output}"
        )
    return 0
