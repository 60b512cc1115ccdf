"""The figures of docs/learning.md: run this and paste its tables there.

    .venv/bin/python bench/learning_figures.py [--duration 300] [--model models/tedusar.ram]

It writes a synthetic ROS 1 recording of the model (``racc synth``, seed 0), learns from it
with the model as base (``racc learn --base``), and prints: the learn time, the largest
rate error and whether the odometry/IMU yaw relation was found; then the counts per
observer kind (Table 10.1) for Q in 0.9, 0.8, 0.5 and α in 10, 2.5, 0.5.  Times depend on
the machine; the counts do not (the recording is deterministic).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import tempfile
import time
from pathlib import Path

from rac.cli import main
from rac.load.files import load_model


def racc(*argv: str) -> None:
    with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
        code = main(list(argv))
    if code != 0:
        raise SystemExit(f"racc {' '.join(argv)} exited {code}")


def learn(run: Path, base: str, out: Path, *extra: str) -> tuple[dict[str, object], float]:
    report = out.with_suffix(".json")
    start = time.perf_counter()
    racc("learn", str(run), "--base", base, "-o", str(out), "--report", str(report), *extra)
    doc: dict[str, object] = json.loads(report.read_text())
    return doc, time.perf_counter() - start


def main_() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="models/tedusar.ram")
    parser.add_argument("--duration", type=float, default=300.0)
    args = parser.parse_args()
    model = load_model(args.model)
    with tempfile.TemporaryDirectory() as tmp:
        run = Path(tmp) / "run.bag"
        racc("synth", args.model, "-o", str(run), "--duration", f"{args.duration:g}")
        props = str(run.with_name("run.properties.csv"))
        out = Path(tmp) / "learned.ram"
        doc, seconds = learn(run, args.model, out, "--properties", props)
        learned = load_model(out).topic_by_name()
        errors = [
            abs(learned[t.name.value].rate_hz - t.rate_hz) / t.rate_hz  # type: ignore[operator]
            for t in model.topics
            if t.rate_hz is not None and learned[t.name.value].rate_hz is not None
        ]
        odometry = next(t.name.value for t in model.topics if t.msg_type == "nav_msgs/Odometry")
        imu = next(t.name.value for t in model.topics if t.msg_type == "sensor_msgs/Imu")
        pair = {f"{imu}.yaw", f"{odometry}.yaw"}
        found = [
            v
            for r in doc["related"]  # type: ignore[attr-defined]
            for v in r["variants"]
            if {v["a"], v["b"]} == pair
        ]
        print(f"racc synth {args.model} -o run.bag --duration {args.duration:g}")
        print(
            f"racc learn run.bag --base {args.model} -o learned.ram "
            "--properties run.properties.csv\n"
        )
        print("| recording | learn time | max rate error | yaw relation at Q 0.5 |")
        print("| --- | --- | --- | --- |")
        verdict = f"found, ratio {found[0]['ratio']:.2f}" if found else "not found"
        print(
            f"| ROS 1 bag, {args.duration:g} s | {seconds:.1f} s | "
            f"{max(errors, default=0) * 100:.3f} % | {verdict} |\n"
        )
        print(f"racc learn run.bag --base {args.model} -o learned.ram -Q Q --alpha A \\")
        print("  --properties run.properties.csv\n")
        print("each cell: α 10 / 2.5 / 0.5\n")
        print("| Q | BiQObs | GObs | NObs | PObs cpu | PObs mem |")
        print("| --- | --- | --- | --- | --- | --- |")
        for q in ("0.9", "0.8", "0.5"):
            row: list[dict[str, int]] = []
            for alpha in ("10", "2.5", "0.5"):
                doc, _ = learn(
                    run, args.model, out, "-Q", q, "--alpha", alpha, "--properties", props
                )
                row.append(doc["observers"])  # type: ignore[arg-type]
            gobs = " / ".join(str(c["GObs"]) for c in row)
            biq = " / ".join(str(c["BiQObs"]) for c in row)
            c = row[0]
            print(f"| {q} | {biq} | {gobs} | {c['NObs']} | {c['PObs_cpu']} | {c['PObs_mem']} |")


if __name__ == "__main__":
    main_()
