"""Do learned relations mean something, hold on the next recording, and find value faults?
(issue 35; docs/learning.md "Figures")

Every model is learned as a user learns it (``racc learn``), then replayed with the
diagnosis engine and scored honestly (rac.evaluate.score: a fault counts only when a
diagnosis naming its culprit starts within its window; isolated when every minimal
diagnosis names it):

- **jackal**: the shared real bag (a simulated Clearpath Jackal, 61 s, IMU and wheel
  odometry at 50 Hz).  Learned on its first 60 %, held out on the rest with a 20 s lead-in
  from the training part (the relation observers need their history; episodes count from the
  end of the lead-in); then each value fault of bench/bag_faults.py is written into that
  held-out part, one at a time, and scored.  Also: learned on the first 50 % and on the first
  60 %, how many kept relations differ (the stability of the kept set).
- **synth**: ``racc synth`` runs of models/pioneer.ram and models/tedusar.ram (600 s): learned
  on seeds 1 and 2 with the base's structure and every field (learning chooses the pairs);
  held out on the fault-free seed 5; scored on the thesis schedule (seeds 3, 4) and on
  value faults written into seed 5.
- **relays** (ROS 1; ``--no-live`` skips it): a roscore on a free port, ``rosbag play
  --loop`` of the Jackal bag and N topic_tools relays in two chains (IMU and odometry),
  recorded for 60 s with ``racc record``, learned with its graph: learning time and relation
  count against N (10, 50, 100).

    .venv/bin/python bench/learning_quality.py --no-live
    .venv-ros1/bin/python bench/learning_quality.py --only relays
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

import bag_faults  # noqa: E402

DATA = ROOT.parent / "shared" / "data"
if not DATA.is_dir():
    DATA = Path("/work/shared/data")
JACKAL = DATA / "jackal_imu_odom.bag"
IMU, ODOM = "/imu/data", "/jackal_velocity_controller/odom"
JACKAL_GRAPH = f"""nodes:
  /imu_node:
    publications: [{IMU}]
  /jackal_velocity_controller:
    publications: [{ODOM}]
"""
LEAD_S = 20.0
FAULT_S = 10.0


def racc(*args: str, python: str = sys.executable) -> str:
    done = subprocess.run([python, "-m", "rac", *args], capture_output=True, text=True, check=False)
    if done.returncode != 0:
        sys.exit(f"racc {' '.join(args)} failed ({done.returncode}):\n{done.stderr}")
    return done.stdout


def row(*cells: object) -> None:
    print("| " + " | ".join(str(c) for c in cells) + " |", flush=True)


def cpu_seconds() -> float:
    """CPU seconds (user and system) of this process's finished children: the machine is
    shared, and wall time says more about the others' load than about racc."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def learn(runs: list[Path], out: Path, *extra: str) -> tuple[dict[str, Any], float]:
    """``racc learn``; its report and the seconds it took (wall); the CPU seconds are in
    the report's ``timing.cpu_s``."""
    report = out.with_suffix(".json")
    started, cpu = time.perf_counter(), cpu_seconds()
    racc("learn", *map(str, runs), "-o", str(out), "--report", str(report), "-q", *extra)
    took = time.perf_counter() - started
    doc: dict[str, Any] = json.loads(report.read_text())
    doc["timing"]["cpu_s"] = cpu_seconds() - cpu
    return doc, took


def readings(doc: dict[str, Any]) -> list[str]:
    out = []
    for rel in doc["related"]:
        out.append(f"`{rel['declared'][len('relate ') :]}` ({rel['reading']}: {rel['meaning']})")
    return out


def score(
    model: Path, bag: Path, faults: list[dict[str, object]], lead: float
) -> dict[str, object]:
    """Replay ``bag`` through ``model`` and score it (episodes before ``lead`` s left out)."""
    from rac.commands.common import load_and_compile
    from rac.evaluate.score import score_run
    from rac.replay.engine import ReplayOptions, replay
    from rac.replay.load import load_runs, needs_of, properties_for, replayable
    from rac.synth.truth import InjectedFault

    m = replayable(load_and_compile(str(model), quiet=True))
    # RUN.properties.csv beside the run when there is one (a synth run's), as racc replay.
    inputs = load_runs([str(bag)], properties_for([str(bag)], []), needs_of([m]))
    timeline = replay(m.specs, m.theory, inputs.events, inputs.duration, ReplayOptions())
    truth = [
        InjectedFault(
            str(f["kind"]),
            str(f["target"]),
            float(f["start"]),
            float(f["end"]),
            tuple(f["culprits"]),
        )
        for f in faults
    ]
    s = score_run(timeline, truth)
    false = [fp for fp in s.false_positives if fp.episode.start >= lead]
    healthy = max(s.healthy_s - lead, 1e-9)
    return {
        "outcomes": s.outcomes,
        "false": len(false),
        "false_per_hour": len(false) * 3600 / healthy,
        "healthy_s": healthy,
    }


def outcome_text(o: Any) -> str:
    if not o.reported:
        return "missed"
    isolated = "isolated" if o.isolated else f"not isolated ({o.candidates} candidates)"
    return f"detected after {o.latency:.1f} s, {isolated}"


# -- the Jackal bag ----------------------------------------------------------------------


def jackal(scratch: Path) -> None:
    from rosbags.rosbag1 import Reader

    with Reader(JACKAL) as reader:
        length = (reader.end_time - reader.start_time) * 1e-9
    graph = scratch / "jackal.graph.yaml"
    graph.write_text(JACKAL_GRAPH)
    split = 0.6 * length
    train = bag_faults.cut(JACKAL, scratch / "jackal_train60.bag", 0.0, split)
    test = bag_faults.cut(JACKAL, scratch / "jackal_test40.bag", split - LEAD_S)
    model = scratch / "jackal60.ram"
    doc, took = learn([train], model, "--graph", str(graph))
    print(
        f"\n### Jackal bag: learned on the first 60 % ({split:.1f} s) in {took:.1f} s "
        f"({doc['timing']['cpu_s']:.1f} s of CPU)\n"
    )
    for text in readings(doc) or ["(no relation kept)"]:
        print(f"- kept: {text}")
    held = score(model, test, [], LEAD_S)
    print(
        f"\nHeld out: the last {length - split:.1f} s after a {LEAD_S:g} s lead-in: "
        f"{held['false']} false episodes ({held['false_per_hour']:.1f} per hour)\n"
    )
    row("fault", "target", "start (s into the held-out part)", "outcome")
    row(*["---"] * 4)
    cases = (
        ("yaw-flip", IMU, "imu_node"),
        ("gyro-flip", IMU, "imu_node"),
        ("stop", IMU, "imu_node"),
        ("yaw-flip", ODOM, "jackal_velocity_controller"),
        ("freeze", ODOM, "jackal_velocity_controller"),
        ("slip", ODOM, "jackal_velocity_controller"),
    )
    for kind, topic, culprit in cases:
        start = LEAD_S + 2.0
        faulty = bag_faults.inject(test, scratch / f"jackal_{kind}_{culprit}.bag", topic, kind,
                                   start, start + FAULT_S)  # fmt: skip
        fault = {"kind": kind, "target": topic, "start": start, "end": start + FAULT_S,
                 "culprits": [culprit]}  # fmt: skip
        result = score(model, faulty, [fault], LEAD_S)
        (o,) = result["outcomes"]
        extra = f"; {result['false']} false episodes" if result["false"] else ""
        row(kind, topic, f"{start - LEAD_S:g}-{start - LEAD_S + FAULT_S:g}",
            outcome_text(o) + extra)  # fmt: skip
    stability(scratch, JACKAL, length, ["--graph", str(graph)], "Jackal bag")


def stability(scratch: Path, bag: Path, length: float, extra: list[str], name: str) -> None:
    """How many kept relations differ when learned on the first 50 % and on the first 60 %."""
    kept = []
    for share in (0.5, 0.6):
        part = bag_faults.cut(
            bag, scratch / f"{bag.stem}_{int(share * 100)}.bag", 0, share * length
        )
        doc, _ = learn([part], part.with_suffix(".ram"), *extra)
        kept.append({r["declared"] for r in doc["related"]})
        changed = doc["stability"]["changed"]
        print(
            f"\n{name}, first {share:.0%}: {len(kept[-1])} relations kept; {changed} candidates "
            "changed their verdict between the learner's two splits"
        )
    diff = kept[0] ^ kept[1]
    print(
        f"{name}: {len(diff)} of {len(kept[0] | kept[1])} relations differ between the 50 % "
        f"and the 60 % model" + (f": {', '.join(sorted(diff))}" if diff else "")
    )


# -- synthetic runs ------------------------------------------------------------------------


def _all_fields(base: Path, out: Path) -> None:
    """``base`` with every topic's field list emptied, its relations and intervals gone:
    learning then chooses its pairs among every field."""
    from dataclasses import replace

    from rac.fmt import format_model
    from rac.load.files import load_model

    model = load_model(base)
    topics = tuple(replace(t, fields=()) for t in model.topics)
    out.write_text(format_model(replace(model, topics=topics, related=(), intervals=())))


def synth(scratch: Path, duration: float) -> None:
    from rac.load.faults import load_truth

    for robot, imu, odom, imu_node, odom_node in (
        ("pioneer", "/imu/data", "/pose", "xsens_driver", "p2os"),
        ("tedusar", "/imu_data", "/pose", "imu_node", "jaguar_node"),
    ):
        base = ROOT / "models" / f"{robot}.ram"
        bags = {}
        plan = (("train1", 1, []), ("train2", 2, []), ("test1", 3, ["--schedule", "thesis"]),
                ("test2", 4, ["--schedule", "thesis"]), ("clean", 5, []))  # fmt: skip
        for name, seed, extra in plan:
            bags[name] = scratch / f"{robot}_{name}.bag"
            if not bags[name].exists():
                racc("synth", str(base), "-o", str(bags[name]), "--duration", f"{duration:g}",
                     "--seed", str(seed), "--force", "-q", *extra)  # fmt: skip
        everything = scratch / f"{robot}_all_fields_base.ram"
        _all_fields(base, everything)
        model = scratch / f"{robot}_learned.ram"
        csv = str(bags["train1"].with_suffix(".properties.csv"))
        doc, took = learn(
            [bags["train1"], bags["train2"]], model, "--base", str(everything), "--properties", csv
        )
        print(
            f"\n### Synth {robot} ({duration:g} s runs): learned on seeds 1 and 2 in {took:.1f} s\n"
        )
        for text in readings(doc):
            print(f"- kept: {text}")
        clean = score(model, bags["clean"], [], 0.0)
        print(
            f"\nHeld out (seed 5, fault-free, from its first second): {clean['false']} false "
            f"episodes ({clean['false_per_hour']:.1f} per hour)\n"
        )
        row("run", "fault", "target", "outcome")
        row(*["---"] * 4)
        for name in ("test1", "test2"):
            truth = load_truth(
                bags[name].with_suffix("").with_name(f"{bags[name].stem}.faults.yaml")
            )
            faults = [{"kind": f.kind, "target": f.target, "start": f.start, "end": f.end,
                       "culprits": list(f.culprits)} for f in truth.faults]  # fmt: skip
            result = score(model, bags[name], faults, 0.0)
            for o in result["outcomes"]:
                row(name, o.fault.kind, o.fault.target, outcome_text(o))
            if result["false"]:
                row(name, "(false episodes)", "", result["false"])
        value_faults = (
            ("yaw-flip", imu, imu_node),
            ("gyro-flip", imu, imu_node),
            ("freeze", odom, odom_node),
            ("yaw-flip", odom, odom_node),
        )
        for kind, topic, culprit in value_faults:
            start = 120.0
            faulty = bag_faults.inject(bags["clean"], scratch / f"{robot}_{kind}_{culprit}.bag",
                                       topic, kind, start, start + FAULT_S)  # fmt: skip
            fault = {"kind": kind, "target": topic, "start": start, "end": start + FAULT_S,
                     "culprits": [culprit]}  # fmt: skip
            result = score(model, faulty, [fault], 0.0)
            (o,) = result["outcomes"]
            note = f"; {result['false']} false episodes" if result["false"] else ""
            row("clean + value fault", kind, topic, outcome_text(o) + note)


# -- a live graph of relays ------------------------------------------------------------------


def _launch(relays: int) -> str:
    """rosbag play of the Jackal bag and ``relays`` relays in two chains."""
    lines = [
        "<launch>",
        f'  <node pkg="rosbag" type="play" name="jackal_player" args="--loop -q {JACKAL}"/>',
    ]
    for source, short in ((IMU, "imu"), (ODOM, "odom")):
        previous = source
        for k in range(relays // 2):
            topic = f"/{short}_r{k}"
            lines.append(
                f'  <node pkg="topic_tools" type="relay" name="{short}_relay{k}" '
                f'args="{previous} {topic}"/>'
            )
            previous = topic
    lines.append("</launch>")
    return "\n".join(lines) + "\n"


def relays(scratch: Path, counts: list[int], seconds: float) -> None:
    python = ROOT / ".venv-ros1" / "bin" / "python"
    if not python.exists():
        print("\n(relays skipped: no .venv-ros1, see README's development set-up)")
        return
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = dict(os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{port}", ROS_IP="127.0.0.1",
               ROS_HOME=str(scratch / "ros_home"))  # fmt: skip
    print(f"\n### A live graph of topic_tools relays ({seconds:g} s recordings)\n")
    row("relays", "topics", "messages", "candidates", "relations kept", "learn time (s)",
        "of which reading (s)", "CPU (s)")  # fmt: skip
    row(*["---"] * 8)
    core = subprocess.Popen(["roscore", "-p", str(port)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)  # fmt: skip
    try:
        time.sleep(5)
        for n in counts:
            launch = scratch / f"relays{n}.launch"
            launch.write_text(_launch(n))
            graph = subprocess.Popen(["roslaunch", str(launch)], env=env,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                     start_new_session=True)  # fmt: skip
            try:
                time.sleep(10 + n / 10)
                bag = scratch / f"relays{n}.bag"
                bag.unlink(missing_ok=True)
                subprocess.run([str(python), "-m", "rac", "record", "-o", str(bag), "--duration",
                                f"{seconds:g}", "-q"], env=env, check=True)  # fmt: skip
            finally:
                os.killpg(graph.pid, signal.SIGINT)
                try:
                    graph.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    os.killpg(graph.pid, signal.SIGKILL)
            stem = bag.with_suffix("")
            doc, took = learn([bag], scratch / f"relays{n}.ram", "--graph", f"{stem}.graph.yaml",
                              "--properties", f"{stem}.properties.csv")  # fmt: skip
            runs = doc["runs"]
            text = (scratch / f"relays{n}.ram").read_text()
            topics = len(re.findall(r"^topic ", text, re.M))
            row(n, topics, runs[0]["messages"], len(doc["candidates"]), len(doc["related"]),
                f"{took:.1f}", f"{doc['timing']['read_s']:.1f}",
                f"{doc['timing']['cpu_s']:.1f}")  # fmt: skip
    finally:
        os.killpg(core.pid, signal.SIGINT)
        try:
            core.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(core.pid, signal.SIGKILL)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=600.0, help="seconds per synth run")
    parser.add_argument("--no-live", action="store_true", help="skip the live relay graph")
    parser.add_argument("--only", choices=("jackal", "synth", "relays"), nargs="+")
    parser.add_argument("--relays", type=int, nargs="+", default=[10, 50, 100])
    parser.add_argument("--record", type=float, default=60.0, help="seconds of each recording")
    parser.add_argument("--keep", metavar="DIR", help="keep the runs and models here")
    args = parser.parse_args()
    scratch = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="racc-quality-"))
    scratch.mkdir(parents=True, exist_ok=True)
    parts = args.only or ["jackal", "synth", *([] if args.no_live else ["relays"])]
    started = time.perf_counter()
    if "jackal" in parts:
        jackal(scratch)
    if "synth" in parts:
        synth(scratch, args.duration)
    if "relays" in parts:
        relays(scratch, args.relays, args.record)
    print(f"\n({time.perf_counter() - started:.0f} s; runs and models in {scratch})")


if __name__ == "__main__":
    main()
