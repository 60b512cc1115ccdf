"""``racc evaluate``: models, or a learning grid, against test runs with known faults."""

from __future__ import annotations

import argparse
import math
import sys
import textwrap
from pathlib import Path
from typing import Any

from rac.commands.common import add_command, checked_truth, load_and_compile, load_checked
from rac.commands.options import add_replay_options
from rac.errors import Diagnostic, RacError
from rac.evaluate.evaluation import Candidate
from rac.ir import Model
from rac.load.kinds import RECORDING, check_kind
from rac.load.output import check_output_file, write_file_atomically


def _number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"not a finite number: {text!r}")
    return value


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "evaluate",
        "evaluate models against test runs with known faults (§10.2)",
        textwrap.fill(
            "Replay every test RUN through every model and score the diagnoses against the "
            "run's injected faults (RUN.faults.yaml beside it, as racc synth writes).  The "
            "models are given (--models) or learned from fault-free training runs for every "
            "pair of -Q and --alpha (--learn-from; M1, M2, … in the order of Table 10.1).  "
            "Prints the observers per model (Table 10.1), the correctly reported faults, false "
            "negatives and false positives per fault kind (Table 10.2), the per-fault table "
            "with mean and standard deviation (§10.2.3), and compares the best model with the "
            "worst: the z-test as the dissertation computes it and as corrected, and "
            "McNemar's exact test.  Definitions in docs/evaluation.md.",
            88,
        ),
        "  racc evaluate --models a.ram b.ram --runs test1.bag test2.bag\n"
        "  racc evaluate --learn-from train1.bag train2.bag --base models/pioneer.ram \\\n"
        "      -Q 0.9 0.8 0.5 --alpha 10 2.5 0.5 --runs test1.bag test2.bag --markdown",
    )
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--models", metavar="MODEL", nargs="+", help=".ram or .json models")
    source.add_argument(
        "--learn-from", metavar="TRAIN", nargs="+", help="fault-free runs to learn models from"
    )
    parser.add_argument(
        "--runs", metavar="RUN", nargs="+", required=True, help="test runs with RUN.faults.yaml"
    )
    parser.add_argument(
        "-Q",
        dest="q",
        metavar="Q",
        type=_number,
        nargs="+",
        default=[0.9, 0.8, 0.5],
        help="learning: match ratios to try (default: 0.9 0.8 0.5)",
    )
    parser.add_argument(
        "--alpha",
        metavar="A",
        type=_number,
        nargs="+",
        default=[10.0, 2.5, 0.5],
        help="learning: regularity thresholds to try (default: 10 2.5 0.5)",
    )
    parser.add_argument(
        "--base", metavar="MODEL", help="learning: the structure (nodes, hardware, topics)"
    )
    parser.add_argument(
        "--save-models", metavar="DIR", help="learning: write the learned models M1.ram … here"
    )
    parser.add_argument(
        "--grace",
        metavar="S",
        type=_number,
        default=5.0,
        help="seconds after a fault's end that still count (default: 5)",
    )
    add_replay_options(parser)
    parser.add_argument(
        "-j",
        "--jobs",
        metavar="N",
        type=int,
        default=0,
        help="learn and replay on N processes (default: one per core)",
    )
    form = parser.add_mutually_exclusive_group()
    form.add_argument("--markdown", action="store_true", help="print Markdown tables")
    form.add_argument("--json", action="store_true", help="print JSON")
    parser.add_argument("-o", "--output", metavar="FILE", help="write the report here too")
    parser.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    parser.set_defaults(run=run)


def _check(args: argparse.Namespace) -> None:
    problems = []
    if any(not 0 <= q < 1 for q in args.q):
        problems.append("-Q values must be in [0, 1)")
    if any(a <= 0 for a in args.alpha):
        problems.append("--alpha values must be above 0")
    if args.grace < 0:
        problems.append("--grace must not be negative")
    if args.models and (args.base or args.save_models):
        problems.append("--base and --save-models go with --learn-from")
    if problems:
        print("racc evaluate: error: " + "; ".join(problems), file=sys.stderr)
        raise SystemExit(2)


def run(args: argparse.Namespace) -> int:
    from rac.evaluate.evaluation import TestRun, evaluate
    from rac.evaluate.parallel import default_jobs
    from rac.evaluate.report import render, to_json
    from rac.replay.engine import ReplayOptions
    from rac.replay.load import load_runs, needs_of, properties_for, truth_for, truth_in_span

    _check(args)
    check_output_file(args.output)
    for run in [*args.runs, *(args.learn_from or ())]:
        check_kind(run, RECORDING, "RAC080")
    candidates = _given(args.models) if args.models else _learned(args, quiet=args.quiet)
    needs = needs_of([c.model for c in candidates])
    models = [c.model.theory.model for c in candidates if c.model.theory.model is not None]
    runs = []
    for path in args.runs:
        truth = truth_for([path], None)
        if truth is None:
            hint = (
                "racc synth writes it; for other recordings write it by hand (docs/evaluation.md)"
            )
            message = f"{path}: no ground truth (expected the faults file beside it)"
            raise RacError([Diagnostic("RAC052", message, hint=hint)])
        checked_truth(truth, models, quiet=args.quiet, robot=bool(args.models or args.base))
        inputs = load_runs([path], properties_for([path], []), needs)
        if not args.quiet:
            for note in inputs.notes:
                print(f"note: {note}", file=sys.stderr)
        fitted = truth_in_span(truth, inputs.duration, path)
        runs.append(TestRun(path, inputs, fitted.faults, inputs.duration))
    options = ReplayOptions(diagnose_every=args.diagnose_every, max_card=args.max_card)
    jobs = args.jobs or default_jobs()
    if not args.quiet and sys.stderr.isatty():
        cores = min(jobs, len(candidates) * len(runs))
        what = f"{len(candidates)} models over {len(runs)} runs on {cores} processes"
        print(f"replaying {what} …", file=sys.stderr, flush=True)
    result = evaluate(candidates, runs, options, args.grace, jobs)
    text = to_json(result, args.pretty) if args.json else render(result, markdown=args.markdown)
    if args.output:
        write_file_atomically(Path(args.output), text)
    if not args.quiet:
        sys.stdout.write(text)
    return 0


def _given(paths: list[str]) -> list[Candidate]:
    from rac.replay.load import replayable

    return [
        Candidate(Path(p).stem, p, replayable(load_and_compile(p, quiet=True), Path(p).stem))
        for p in paths
    ]


def _learned(args: argparse.Namespace, quiet: bool) -> list[Candidate]:
    from rac.fmt import format_model
    from rac.learn.fields import FieldSelector
    from rac.learn.learner import learn
    from rac.learn.options import LearnOptions
    from rac.learn.properties import property_stats
    from rac.load.bags import read_recording
    from rac.load.files import is_file
    from rac.load.recorded import load_properties
    from rac.pipeline import compile_model
    from rac.replay.load import replayable
    from rac.replay.sources import properties_beside

    base = load_checked(args.base) if args.base else None
    declared = None
    if base is not None:
        declared = {t.name.value: frozenset(f.value for f in t.fields) for t in base.topics}
    only = frozenset(declared) if declared is not None else None
    recording = read_recording(args.learn_from, FieldSelector(declared), only)
    samples: dict[str, dict[str, list[float]]] = {}
    for run in args.learn_from:
        csv = properties_beside(run)
        if is_file(csv):
            for node, props in load_properties(csv).items():
                into = samples.setdefault(node, {"cpu": [], "mem": []})
                for prop, values in props.items():
                    into[prop].extend(values)
    properties = property_stats(samples)
    grid = [(q, alpha) for q in args.q for alpha in args.alpha]

    def learn_one(params: tuple[float, float]) -> Model:
        q, alpha = params
        return learn(
            recording, LearnOptions(alpha=alpha, q=q), base=base, properties=properties
        ).model

    from rac.evaluate.parallel import default_jobs, run_all
    from rac.learn.validate import prepare

    prepare(recording)  # the workers inherit the training runs' message streams
    models = run_all(learn_one, grid, args.jobs or default_jobs())
    out: list[Candidate] = []
    for (q, alpha), model in zip(grid, models, strict=True):
        label = f"M{len(out) + 1}"
        compiled = compile_model(model)
        if args.save_models:
            Path(args.save_models).mkdir(parents=True, exist_ok=True)
            write_file_atomically(Path(args.save_models) / f"{label}.ram", format_model(model))
        source = f"learned Q={q:g} alpha={alpha:g}"
        out.append(Candidate(label, source, replayable(compiled, label), q, alpha))
    if not quiet:
        print(
            f"learned {_count(len(out), 'model')} from {recording.messages} messages in "
            f"{_count(len(recording.runs), 'run')}",
            file=sys.stderr,
        )
    return out


def _count(n: int, word: str) -> str:
    return f"{n} {word}" if n == 1 else f"{n} {word}s"
