"""The observation set at 10,000 observers: what each hop of /observations costs, and the
engine's time from a crash's verdict to its diagnosis (issue 36, goal 3).

    .venv-ros1/bin/python bench/observations_scale.py             # 100 relays, ~10,000 observers
    .venv-ros1/bin/python bench/observations_scale.py --relations 0   # the hand model alone

The model is the relay graph's hand model (tests/ros1/relay_graph.py: 100 relays, 413
observers) with as many ``relate`` lines as --relations between the IMU chain's fields (a
model the size of a learned one: the issue's had 12,920 relations).  Measured in one
process, CPU time, best of --repeat:

- the host: every row of the set, sealed (once a second, and at start), against the rows
  of one change (what goes out at each change);
- the transport (ROS 1, when rospy is importable): a DiagnosticArray of every row, built,
  serialized and read back, as the engine and the repairer receive it;
- the engine: the rows checked and merged into Θ, then a diagnosis of Θ, for the whole set
  and for one change; and the diagnosis after ``not_running`` of a relay, which is what
  stands between a crash's verdict and /diagnosis.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "ros1"))

import relay_graph  # noqa: E402

from rac.load.files import load_model  # noqa: E402
from rac.load.theory import load_theory  # noqa: E402
from rac.logic import Atom  # noqa: E402
from rac.observe import Verdict  # noqa: E402
from rac.pipeline import compile_model  # noqa: E402
from rac.runtime.diagnoser import EngineLoop  # noqa: E402
from rac.runtime.host import ObserverHost  # noqa: E402
from rac.runtime.trust import OBSERVER, Trust, rows_body  # noqa: E402
from rac.targets import EmitOptions, emit_all  # noqa: E402

FIELDS = (
    "angular_velocity.x",
    "angular_velocity.y",
    "angular_velocity.z",
    "linear_acceleration.x",
    "linear_acceleration.y",
    "linear_acceleration.z",
)


def model_text(relations: int) -> str:
    """The hand model of 100 relays with ``relations`` relate lines on the IMU chain."""
    text = relay_graph.model_text(100)
    imu = ["/imu/data", *(f"/imu_{i}" for i in range(1, 51))]
    fields = " { " + ", ".join(FIELDS) + " }"
    for topic in imu:
        text = text.replace(
            f"topic {topic} : sensor_msgs/Imu @", f"topic {topic} : sensor_msgs/Imu{fields} @"
        )
    sides = [f"{t}.{f}" for t in imu for f in FIELDS]
    lines: list[str] = []
    for i, a in enumerate(sides):
        for b in sides[i + 1 :]:
            if len(lines) >= relations:
                break
            if a.rsplit(".", 2)[0] != b.rsplit(".", 2)[0]:
                lines.append(f"relate {a} ~ {b}")
    return text + "\n".join(lines) + "\n"


def best(fn: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.process_time()
        fn()
        times.append(time.process_time() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--relations", type=int, default=9600, help="relate lines (default 9600)")
    parser.add_argument("--repeat", type=int, default=5, help="best of (default 5)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "relays.ram"
        path.write_text(model_text(args.relations), encoding="utf-8")
        compiled = compile_model(load_model(path))
        (Path(tmp) / "model.yaml").write_text(
            emit_all(compiled, EmitOptions())["model.yaml"], encoding="utf-8"
        )
        theory = load_theory(str(Path(tmp) / "model.yaml"))
        specs = compiled.observers
        atoms = [a for s in specs for a in s.atoms]
        print(
            f"model: {len(compiled.components)} components, {len(specs)} observers, "
            f"{len(atoms)} atoms, {len(theory.clauses)} clauses"
        )
        host = ObserverHost(specs)
        host.source = "racc_observer"
        for atom in atoms:
            host._keep([Verdict(0.0, atom, True)])
        trust = Trust(b"k" * 32, OBSERVER, "racc_observer", lambda level, text: None)
        one = {Atom("running", ("imu_relay_25",))}

        def publish_all() -> None:
            rows = host.rows()
            trust.seal_rows("/observations", rows)

        def publish_one() -> None:
            rows = host.rows(one)
            trust.seal_rows("/observations", rows)

        full_rows = host.rows()
        print(
            f"host, every row sealed: {1e3 * best(publish_all, args.repeat):8.1f} ms"
            f"   one change: {1e3 * best(publish_one, args.repeat):6.2f} ms"
        )
        try:
            from rospy.msg import AnyMsg  # noqa: F401  (rospy is here)

            from rac.ros1.common import to_array
        except ImportError:
            print("transport: rospy is not importable here (run in the ROS 1 venv)")
        else:
            import io

            from diagnostic_msgs.msg import DiagnosticArray

            def transport() -> None:
                import rospy

                array = to_array(full_rows, stamp=rospy.Time(1, 0), frame_id="x")
                buff = io.BytesIO()
                array.serialize(buff)
                DiagnosticArray().deserialize(buff.getvalue())

            print(
                f"transport, every row built, serialized, read: "
                f"{1e3 * best(transport, args.repeat):8.1f} ms"
            )
        engine = EngineLoop(
            str(Path(tmp) / "model.yaml"), load_theory, "relays", "racc_engine", lambda *a: None
        )
        clock = [100.0]

        def engine_all() -> None:
            rows_body(full_rows)  # what the seal check hashes
            engine.observation_rows(full_rows, clock[0])
            engine.diagnoser._dirty = True
            clock[0] += 1.0
            engine.step(clock[0])

        crash = host.rows(one)
        crashed = [
            r.__class__(r.name, 2, "not_running(imu_relay_25)", r.hardware_id, r.values)
            for r in crash
        ]

        def engine_crash() -> None:
            rows_body(crashed)
            engine.observation_rows(crashed, clock[0])
            clock[0] += 1.0
            tick = engine.step(clock[0])
            assert tick is not None and tick.result.diagnoses == (("imu_relay_25",),)
            engine.observation_rows(crash, clock[0])
            clock[0] += 1.0
            engine.step(clock[0])

        print(
            f"engine, every row merged and diagnosed: {1e3 * best(engine_all, args.repeat):8.1f} ms"
        )
        print(
            f"engine, a crash's row to its diagnosis and back: "
            f"{1e3 * best(engine_crash, args.repeat) / 2:8.1f} ms a change"
        )


if __name__ == "__main__":
    main()
