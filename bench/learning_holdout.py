"""Do learned models hold on the next recording?  (issue 23; docs/learning.md)

A model learned from fault-free recordings is replayed on *other* fault-free recordings of
the same robot, which the learner never saw; every episode diagnosed there is a false
alarm.  Each case is learned twice: with racc's defaults (held-out validation, invariance
rules) and with ``--blocks 0`` (only the chapter-9 rule, checked on the training runs).

- **jackal**: the shared real bag (a Clearpath Jackal, 61 s), cut in two halves in time:
  learn on one half, replay the other, both ways.
- **synth**: ``racc synth`` runs of models/tedusar.ram and models/pioneer.ram: learn on
  seed 1, replay seeds 2 and 3.
- **faulty**: synth's thesis schedule (seeds 3, 4) and a fault-free run (seed 5): the base
  model (relations on yaw only) against a model learned from all fields of every topic
  (seeds 1 and 2; the base's ``interval`` lines left out, as they name fields of its field
  lists), scored by ``racc evaluate`` (correct reports and false positives).
- **live** (ROS 1; ``--no-live`` skips it): ``racc demo`` of models/tedusar.ram on a free
  roscore port, recorded twice with ``racc record``; learn on one recording, replay the
  other; then the model learned on the first runs live (``racc run``, repairs dry-run) on
  the same robot for ``--live-run`` seconds, and its diagnosis episodes are counted.

    .venv/bin/python bench/learning_holdout.py                 # everything, ~5 min
    .venv/bin/python bench/learning_holdout.py --no-live --duration 120
"""

from __future__ import annotations

import argparse
import json
import os
import random
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT.parent / "shared" / "data"
if not DATA.is_dir():
    DATA = Path("/work/shared/data")
JACKAL = DATA / "jackal_imu_odom.bag"
JACKAL_GRAPH = """nodes:
  /imu_node:
    publications: [/imu/data]
  /jackal_velocity_controller:
    publications: [/jackal_velocity_controller/odom]
"""
SETTINGS = {"default": [], "--blocks 0": ["--blocks", "0"]}


def racc(*args: str, env: dict[str, str] | None = None) -> str:
    done = subprocess.run(
        [sys.executable, "-m", "rac", *args],
        capture_output=True,
        text=True,
        check=False,
        env=env,
    )
    if done.returncode != 0:
        sys.exit(f"racc {' '.join(args)} failed ({done.returncode}):\n{done.stderr}")
    return done.stdout


def split_bag(bag: Path, first: Path, second: Path) -> tuple[Path, Path]:
    """The bag's messages before and after its middle instant, as two ROS 1 bags."""
    from rosbags.rosbag1 import Reader, Writer

    with Reader(bag) as reader:
        middle = (reader.start_time + reader.end_time) // 2
        for out, keep in ((first, lambda t: t < middle), (second, lambda t: t >= middle)):
            out.unlink(missing_ok=True)
            with Writer(out) as writer:
                conns = {
                    c.id: writer.add_connection(
                        c.topic,
                        c.msgtype,
                        msgdef=c.msgdef.data,
                        md5sum=c.digest,
                        callerid=c.ext.callerid,
                        latching=c.ext.latching,
                    )
                    for c in reader.connections
                }
                for conn, stamp, raw in reader.messages():
                    if keep(stamp):
                        writer.write(conns[conn.id], stamp, raw)
    return first, second


def episodes(model: Path, run: Path) -> int:
    """Episodes diagnosed when ``run`` is replayed through ``model``."""
    return len(re.findall(r"^episode \d+:", racc("replay", str(model), str(run)), re.M))


def relations(model: Path) -> int:
    return sum(1 for line in model.read_text().splitlines() if line.startswith("relate"))


def row(*cells: object) -> None:
    print("| " + " | ".join(str(c) for c in cells) + " |", flush=True)


def jackal(scratch: Path) -> None:
    print("\n### Jackal bag, split in time (learn on one half, replay the other)\n")
    row("learned on", "replayed", "setting", "relations", "episodes")
    row(*["---"] * 5)
    halves = split_bag(JACKAL, scratch / "jackal_first.bag", scratch / "jackal_second.bag")
    graph = scratch / "jackal.graph.yaml"
    graph.write_text(JACKAL_GRAPH)
    for train, test in (halves, halves[::-1]):
        for label, extra in SETTINGS.items():
            model = scratch / f"{train.stem}{'_b0' if extra else ''}.ram"
            racc("learn", str(train), "--graph", str(graph), "-o", str(model), "-q", *extra)
            row(train.name, test.name, label, relations(model), episodes(model, test))


def synth(scratch: Path, duration: float) -> None:
    print(f"\n### Synth runs ({duration:g} s): learn on seed 1, replay seeds 2 and 3\n")
    row("robot", "setting", "relations", "episodes on seed 2", "episodes on seed 3")
    row(*["---"] * 5)
    for robot in ("tedusar", "pioneer"):
        base = ROOT / "models" / f"{robot}.ram"
        runs = {}
        for seed in (1, 2, 3):
            runs[seed] = scratch / f"{robot}_{seed}.bag"
            racc("synth", str(base), "-o", str(runs[seed]), "--duration", f"{duration:g}",
                 "--seed", str(seed), "--force", "-q")  # fmt: skip
        for label, extra in SETTINGS.items():
            model = scratch / f"{robot}{'_b0' if extra else ''}.ram"
            racc("learn", str(runs[1]), "--base", str(base), "-o", str(model), "-q",
                 "--properties", str(runs[1].with_suffix(".properties.csv")), *extra)  # fmt: skip
            row(robot, label, relations(model), episodes(model, runs[2]), episodes(model, runs[3]))


def _all_fields(base: Path, out: Path) -> None:
    """``base`` with every topic's field list emptied: learning then takes every field.
    Its ``interval`` lines go too (they name fields of the lists); the thesis schedule
    injects no fault that only they see."""
    from dataclasses import replace

    from rac.fmt import format_model
    from rac.load.files import load_model

    model = load_model(base)
    topics = tuple(replace(t, fields=()) for t in model.topics)
    out.write_text(format_model(replace(model, topics=topics, related=(), intervals=())))


def faulty(scratch: Path, duration: float) -> None:
    duration = max(duration, 240.0)  # the thesis schedule needs 240 s
    print(f"\n### Faulty synth runs ({duration:g} s, thesis schedule, seeds 3 and 4; clean 5)\n")
    row("robot", "model", "relations", "correct", "missed", "false positives")
    row(*["---"] * 6)
    for robot in ("pioneer", "tedusar"):
        base = ROOT / "models" / f"{robot}.ram"
        bags = {}
        thesis = ["--schedule", "thesis"]
        plan = (("train1", 1, []), ("train2", 2, []), ("test1", 3, thesis), ("test2", 4, thesis),
                ("clean", 5, []))  # fmt: skip
        for name, seed, extra in plan:
            bags[name] = scratch / f"{robot}_f_{name}.bag"
            racc("synth", str(base), "-o", str(bags[name]), "--duration", f"{duration:g}",
                 "--seed", str(seed), "--force", "-q", *extra)  # fmt: skip
        everything = scratch / f"{robot}_all_fields_base.ram"
        _all_fields(base, everything)
        learned = scratch / f"{robot}_all_fields.ram"
        racc("learn", str(bags["train1"]), str(bags["train2"]), "--base", str(everything),
             "-o", str(learned), "-q")  # fmt: skip
        tests = [str(bags[n]) for n in ("test1", "test2", "clean")]
        doc = json.loads(racc("evaluate", "--models", str(base), str(learned), "--runs", *tests,
                              "--json"))  # fmt: skip
        for label, model, path in (("base (yaw)", doc["models"][0], base),
                                   ("learned, all fields", doc["models"][1], learned)):  # fmt: skip
            counts = {k: sum(v.values()) for k, v in model["counts"].items()}
            row(robot, label, relations(path), counts["CR"], counts["FN"], counts["FP"])


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def live_episodes(
    python: Path, model: Path, scratch: Path, env: dict[str, str], board: int, seconds: float
) -> tuple[int, list[str]]:
    """Run ``model`` live on the running demo robot for ``seconds`` (repairs dry-run): its
    diagnosis episodes (the engine's log lines that turn a fault-free diagnosis into one)."""
    build = scratch / f"{model.stem}_build"
    racc("compile", str(model), "-o", str(build), "-q")
    log = scratch / f"{model.stem}_live.log"
    with log.open("w") as out:
        command = [str(python), "-m", "rac", "run", str(build), "repair_mode:=dry-run"]
        if "board" in (build / "observers.launch").read_text():  # a model with a board
            command.append(f"board:=127.0.0.1:{board}")
        run = subprocess.Popen(
            command, env=env, stdout=out, stderr=subprocess.STDOUT, start_new_session=True
        )
        try:
            time.sleep(seconds)
            if run.poll() is not None:
                sys.exit(f"racc run ended early ({run.returncode}); see {log}")
        finally:
            os.killpg(run.pid, signal.SIGINT)
            try:
                run.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(run.pid, signal.SIGKILL)
    found: list[str] = []
    faulty = False
    if "diagnosis none" not in log.read_text(errors="replace"):
        sys.exit(f"racc run logged no diagnosis; see {log}")
    for line in log.read_text(errors="replace").splitlines():
        m = re.search(r"t=[\d.]+ diagnosis (.*)$", line)
        if m is None:
            continue
        now = not m.group(1).startswith("none")
        if now and not faulty:
            found.append(line.strip())
        faulty = now
    return len(found), found


def live(scratch: Path, duration: float, run_s: float) -> None:
    """racc demo on ROS 1, recorded twice with racc record (needs .venv-ros1)."""
    python = ROOT / ".venv-ros1" / "bin" / "python"
    if not python.exists():
        print("\n(live part skipped: no .venv-ros1; see the brief's set-up)")
        return
    port = _free_port()
    env = dict(os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{port}", ROS_HOSTNAME="127.0.0.1")
    procs: list[subprocess.Popen[bytes]] = []
    try:
        procs.append(subprocess.Popen(["roscore", "-p", str(port)], env=env,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                      start_new_session=True))  # fmt: skip
        time.sleep(4)
        base = ROOT / "models" / "tedusar.ram"
        board = _free_port()
        procs.append(subprocess.Popen([str(python), "-m", "rac", "demo", str(base), "-o",
                                       str(scratch / "demo"), "--board-port", str(board),
                                       "--control-port", str(_free_port())], env=env,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                      start_new_session=True))  # fmt: skip
        time.sleep(15)
        # A rostopic echo beside the robot, as a user watching it: left out of the model.
        procs.append(subprocess.Popen(["rostopic", "hz", "/pose"], env=env,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                      start_new_session=True))  # fmt: skip
        recs = []
        for i in (1, 2):
            bag = scratch / f"live{i}.bag"
            bag.unlink(missing_ok=True)
            subprocess.run([str(python), "-m", "rac", "record", "-o", str(bag), "--duration",
                            f"{duration:g}", "-q"], env=env, check=True)  # fmt: skip
            recs.append(bag)
        if run_s > 0:
            stem = recs[0].with_suffix("")
            model = scratch / "live1_run.ram"
            racc("learn", str(recs[0]), "--graph", f"{stem}.graph.yaml", "--properties",
                 f"{stem}.properties.csv", "-o", str(model), "-q")  # fmt: skip
            count, lines = live_episodes(python, model, scratch, env, board, run_s)
            print(f"\nlive run of the model learned on live1.bag: {count} episodes in "
                  f"{run_s:g} s" + "".join(f"\n  {x}" for x in lines))  # fmt: skip
    finally:
        for p in reversed(procs):
            try:
                os.killpg(p.pid, signal.SIGINT)
                p.wait(timeout=20)
            except (ProcessLookupError, subprocess.TimeoutExpired):
                os.killpg(p.pid, signal.SIGKILL)
    print(f"\n### Live demo (ROS 1, models/tedusar.ram), two {duration:g} s recordings\n")
    row("learned on", "replayed", "setting", "topics", "nodes", "relations", "episodes")
    row(*["---"] * 7)
    for train, test in (recs, recs[::-1]):
        stem = train.with_suffix("")
        for label, extra in SETTINGS.items():
            model = scratch / f"{train.stem}{'_b0' if extra else ''}.ram"
            racc("learn", str(train), "--graph", f"{stem}.graph.yaml", "--properties",
                 f"{stem}.properties.csv", "-o", str(model), "-q", *extra)  # fmt: skip
            text = model.read_text()
            topics = len(re.findall(r"^topic ", text, re.M))
            nodes = len(re.findall(r"^node ", text, re.M))
            test_csv = test.with_suffix("").with_name(test.stem + ".properties.csv")
            replayed = racc("replay", str(model), str(test), "--properties", str(test_csv))
            count = len(re.findall(r"^episode \d+:", replayed, re.M))
            row(train.name, test.name, label, topics, nodes, relations(model), count)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=300.0, help="seconds per synth run")
    parser.add_argument("--live-duration", type=float, default=40.0, help="seconds per live run")
    parser.add_argument("--no-live", action="store_true", help="skip the live ROS 1 part")
    parser.add_argument(
        "--live-run", type=float, default=90.0, help="seconds of the live run (default 90; 0: none)"
    )
    parser.add_argument("--only", choices=("jackal", "synth", "faulty", "live"), nargs="+")
    parser.add_argument("--keep", metavar="DIR", help="keep the runs and models here")
    args = parser.parse_args()
    scratch = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="racc-holdout-"))
    scratch.mkdir(parents=True, exist_ok=True)
    random.seed(0)
    parts = args.only or ["jackal", "synth", "faulty", *([] if args.no_live else ["live"])]
    started = time.perf_counter()
    if "jackal" in parts:
        jackal(scratch)
    if "synth" in parts:
        synth(scratch, args.duration)
    if "faulty" in parts:
        faulty(scratch, args.duration)
    if "live" in parts:
        live(scratch, args.live_duration, args.live_run)
    print(f"\n({time.perf_counter() - started:.0f} s; runs and models in {scratch})")


if __name__ == "__main__":
    main()
