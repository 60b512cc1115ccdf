"""``racc synth``: write a synthetic recording of the robot a model describes."""

from __future__ import annotations

import argparse
import math
import os
import re
import shutil
import sys
import tempfile
import textwrap
from pathlib import Path
from typing import Any

from rac.commands.common import add_command, load_checked
from rac.commands.common import count as plural
from rac.errors import Diagnostic, RacError, did_you_mean
from rac.synth.faults import FAULT_KINDS, FAULT_SPEC, Fault, parse_fault
from rac.synth.schedule import (
    MIN_FAULT_S,
    MIN_GAP_S,
    SCHEDULES,
    WARMUP_S,
    TooShort,
    thesis_schedule,
)
from rac.synth.truth import beside, dump_truth, ground_truth, truth_path

MAX_DURATION_S = 86_400
MAX_SEED = 99_999
KINDS = ", ".join(f"{k} (TARGET a {v})" for k, v in FAULT_KINDS.items())


def fault_arg(text: str) -> str:
    """argparse type: the shape KIND@T[+D]:TARGET with a known KIND is the command line's
    business (exit 2); whether TARGET is in the model is checked against the model later."""
    match = FAULT_SPEC.fullmatch(text.strip())
    if match is None or match["kind"] not in FAULT_KINDS:
        kinds = ", ".join(FAULT_KINDS)
        kind = text.strip().partition("@")[0]
        close = did_you_mean(kind, FAULT_KINDS) if kind not in FAULT_KINDS else None
        said = f"; {close}" if close else ""
        raise argparse.ArgumentTypeError(
            f"'{text}' is not KIND@T[+D]:TARGET with KIND in {kinds}{said}"
        )
    return text


def register(sub: Any) -> None:
    parser = add_command(
        sub,
        "synth",
        "write a synthetic recording (rosbag) of the robot a model describes",
        textwrap.fill(
            "Write a realistic recording of MODEL's robot for demos and tests: regular topics at "
            "their rates with timing jitter, event-driven topics irregular, sensors driven by one "
            "teleoperated motion (odometry yaw integrates its angular velocity, the IMU's yaw "
            "follows it, laser-alignment servos follow the IMU's pitch and roll), real ROS message "
            "types.  RUN ending in .bag is a ROS 1 bag, anything else a ROS 2 bag directory.  The "
            "nodes' CPU and memory samples go to RUN's name with .properties.csv beside it, the "
            "injected faults (the ground truth for evaluating diagnoses) to .faults.yaml.  "
            f"Faults KIND@T[+D]:TARGET start at T s and last D s (default: to the end): {KINDS}.  "
            "--schedule thesis injects the test run of §10.2.2 (two slips, cpu, mem, freq, "
            "crash, one after another) with targets chosen from the model.",
            88,
        ),
        "  racc synth models/tedusar.ram -o run.bag --duration 300\n"
        "  racc synth models/tedusar.ram -o run2 --ros2 --storage mcap --seed 7\n"
        "  racc synth models/tedusar.ram -o faulty.bag --fault slip@60+10:/pose "
        "--fault crash@120:joy_node --fault freq@90+20:/scan --fault cpu@150+10:hector_mapping\n"
        "  racc synth models/pioneer.ram -o test.bag --duration 600 --schedule thesis",
    )
    parser.add_argument("model", metavar="MODEL", help="a .ram file or a ram/1 .json")
    parser.add_argument(
        "-o",
        "--output",
        metavar="RUN",
        required=True,
        help="the recording: RUN.bag is a ROS 1 bag, any other name a ROS 2 bag directory",
    )
    version = parser.add_mutually_exclusive_group()
    version.add_argument(
        "--ros1",
        action="store_true",
        help="write a ROS 1 .bag file (default: when RUN ends in .bag)",
    )
    version.add_argument(
        "--ros2",
        action="store_true",
        help="write a ROS 2 bag directory (default: when RUN does not end in .bag)",
    )
    parser.add_argument(
        "--storage", choices=("sqlite3", "mcap"), help="ROS 2 storage (default: sqlite3)"
    )
    parser.add_argument(
        "--duration",
        metavar="S",
        type=float,
        default=120.0,
        help="length of the recording in seconds (default: 120)",
    )
    parser.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    parser.add_argument(
        "--fault",
        metavar="KIND@T[+D]:TARGET",
        action="append",
        default=[],
        type=fault_arg,
        help="inject a fault of KIND (slip, crash, freq, cpu, mem, trip) at T s for D s "
        "(default: to the end) into the node, topic or device TARGET (repeatable)",
    )
    parser.add_argument(
        "--schedule",
        choices=SCHEDULES,
        help="inject a fixed series of faults: thesis is §10.2.2's test run (six faults: 240 s)",
    )
    parser.add_argument(
        "--force",
        action="store_true",
        help="replace RUN and the files beside it if RUN is a previous recording (without it an "
        "existing output is an error)",
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    parser.set_defaults(run=run)


def properties_path(run: Path) -> Path:
    """``run.bag`` -> ``run.properties.csv``; ``run/`` -> ``run.properties.csv`` beside it."""
    return beside(run, ".properties.csv")


_STAGING = ".racc-synth-"  # + the writing process's id + a random part


def _remove_stale_staging(parent: Path) -> None:
    """Delete the staging directories a killed ``racc synth`` left in ``parent``: those
    whose process no longer runs (a running one's, another synth's, stays)."""
    try:
        entries = [p for p in parent.iterdir() if p.name.startswith(_STAGING) and p.is_dir()]
    except OSError:
        return
    for entry in entries:
        pid_text = entry.name.removeprefix(_STAGING).partition("-")[0]
        if pid_text.isdigit() and not _running(int(pid_text)):
            shutil.rmtree(entry, ignore_errors=True)


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True  # another user's process, or not a process id: left alone
    return True


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif path.exists() or path.is_symlink():
        path.unlink()


# What a ROS 2 bag directory holds: its metadata, and its storage files (with SQLite's
# journal files beside them).
_BAG_FILE = re.compile(r"metadata\.yaml|.+\.(?:db3|mcap)(?:-(?:shm|wal|journal))?(?:\.zstd)?")


def _not_a_recording(target: Path) -> str | None:
    """Why ``target`` is no output of a previous ``racc synth`` to replace, or None."""
    if target.is_symlink() or not target.is_dir():
        return None
    entries = list(target.iterdir())
    if not entries:
        return None
    bag_files = all(
        e.is_file() and not e.is_symlink() and _BAG_FILE.fullmatch(e.name) for e in entries
    )
    if not bag_files or not any(e.name == "metadata.yaml" for e in entries):
        return "is a directory that racc synth did not write (not a ROS 2 bag)"
    return None


def _check_targets(outputs: tuple[Path, ...], force: bool) -> None:
    """RAC084 for an output that exists (without ``force``) or that is not ours to replace."""
    for target in outputs:
        if (target.exists() or target.is_symlink()) and not force:
            raise RacError(
                [Diagnostic("RAC084", f"{target} exists", hint="remove it or pass --force")]
            )
        not_ours = _not_a_recording(target)
        if not_ours is not None:
            # --force replaces a previous recording, never a directory of other things
            # (`-o ~ --force` would have removed the home directory).
            hint = "choose another output name; --force replaces only a recording"
            raise RacError([Diagnostic("RAC084", f"{target}: {not_ours}", hint=hint)])


def _command_line_problem(args: argparse.Namespace, out: Path, ros_version: int) -> str | None:
    """What is wrong with the options (exit 2), or None."""
    if not (math.isfinite(args.duration) and 0 < args.duration <= MAX_DURATION_S):
        return f"--duration must be above 0 and at most {MAX_DURATION_S} s"
    if not 0 <= args.seed <= MAX_SEED:
        # Each seed starts its recording an hour later; ROS time stamps must stay in range.
        return f"--seed must be in 0..{MAX_SEED}"
    if ros_version == 1 and not out.name.endswith(".bag"):
        return f"a ROS 1 bag's name ends in .bag (readers tell the formats apart by it): {out}"
    if ros_version == 2 and out.name.endswith(".bag"):
        return f"a ROS 2 bag is a directory, not a name ending in .bag: {out}"
    if ros_version == 1 and args.storage is not None:
        return "--storage is for ROS 2 bags"
    return None


def run(args: argparse.Namespace) -> int:
    # rosbags loads here, not at every racc start-up.
    from rac.synth.recording import SynthOptions, fault_summary, plan_recording, write_recording

    out = Path(args.output)
    ros_version = 1 if args.ros1 or (not args.ros2 and out.name.endswith(".bag")) else 2
    problem = _command_line_problem(args, out, ros_version)
    if problem:
        print(f"racc synth: error: {problem}", file=sys.stderr)
        return 2
    model = load_checked(args.model)
    faults: tuple[Fault, ...] = ()
    if args.schedule == "thesis":
        try:
            schedule = thesis_schedule(model, args.duration)
        except TooShort as err:
            print(
                f"racc synth: error: --schedule thesis needs --duration {err.minimum:g} or more "
                f"({err.count} faults for {model.name.value}: a {WARMUP_S:g} s warm-up, then "
                f"{MIN_FAULT_S:g} s per fault and {MIN_GAP_S:g} s of recovery after each)",
                file=sys.stderr,
            )
            return 2
        for note in schedule.notes:
            print(f"racc synth: note: --schedule thesis: {note}", file=sys.stderr)
        faults = schedule.faults
    faults += tuple(parse_fault(f, model, args.duration) for f in args.fault)
    faults = tuple(sorted(faults, key=lambda f: (f.start, f.end, f.kind, f.target)))
    csv_path = properties_path(out)
    faults_path = truth_path(out)
    truth = dump_truth(ground_truth(model, args.duration, faults), out.name)
    outputs = (out, csv_path, faults_path)
    try:
        _check_targets(outputs, args.force)
    except OSError as err:  # a name too long for the file system, say
        raise RacError([Diagnostic("RAC004", f"{out}: cannot write: {err.strerror}")]) from None
    storage = args.storage or "sqlite3"
    options = SynthOptions(args.duration, args.seed, ros_version, storage, faults)
    plan = plan_recording(model, options)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        # Write beside the target, then move into place: no half-written recording remains.
        _remove_stale_staging(out.parent)
        staging_prefix = f"{_STAGING}{os.getpid()}-"
        with tempfile.TemporaryDirectory(prefix=staging_prefix, dir=out.parent) as tmp:
            staged = Path(tmp) / out.name
            count = write_recording(plan, staged)
            staged_csv = Path(tmp) / csv_path.name
            staged_csv.write_text(plan.properties, encoding="utf-8")
            staged_truth = Path(tmp) / faults_path.name
            staged_truth.write_text(truth, encoding="utf-8")
            for target in outputs:
                _remove(target)
            os.replace(staged, out)
            os.replace(staged_csv, csv_path)
            os.replace(staged_truth, faults_path)
    except OSError as err:
        raise RacError([Diagnostic("RAC004", f"{out}: cannot write: {err}")]) from None
    if not args.quiet:
        kind = "ROS 1 bag" if ros_version == 1 else f"ROS 2 bag ({storage})"
        print(
            f"wrote {out} ({kind}): {plural(count, 'message')} on "
            f"{plural(len(plan.topics), 'topic')}, "
            f"{args.duration:g} s; properties -> {csv_path}; faults -> {faults_path}"
        )
        for line in fault_summary(faults):
            print(f"  fault: {line}")
    return 0
