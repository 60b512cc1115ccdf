"""The observer host's CPU: tedusar at nominal rates on a real roscore, and a 100-node
synthetic robot.

    .venv-ros1/bin/python bench/live.py            # both (about 70 s)
    .venv-ros1/bin/python bench/live.py --only synthetic

tedusar: a roscore on a free port, the demo robot (``racc demo``), then ``racc observe``
alone; its process's CPU time over --seconds, in percent of one core (psutil), and how
many messages it received per second.

synthetic: a 100-node robot (each node publishes one topic at 10, 20 or 50 Hz, every tenth
pair of neighbours related) cannot run as 100 ROS processes on a CI machine.  The host is
fed in real time in this process instead: each message is serialized (rosbags) and then
decoded, observed and its verdicts collected exactly as the node does, and all 100 nodes
are probed at 10 Hz against live pids.  rospy's own cost of receiving a message, measured on
tedusar (the node's CPU minus the in-process cost of its message rate), is added per message.
"""

from __future__ import annotations

import argparse
import heapq
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import psutil

ROOT = Path(__file__).resolve().parents[1]
RACC = [sys.executable, "-m", "rac"]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def synthetic_ram(nodes: int = 100) -> str:
    lines = ["robot synthetic100"]
    rates = (10, 20, 50)
    for i in range(nodes):
        lines.append(
            f"topic /t{i:03d} : geometry_msgs/Twist {{ linear.x, angular.z }} @ {rates[i % 3]} Hz"
        )
    for i in range(nodes):
        sub = f"  subscribes /t{i - 1:03d}\n" if i else ""
        lines.append(
            f"node n{i:03d} {{\n{sub}  publishes /t{i:03d}\n  limits cpu 20 %, mem 256 MB\n}}"
        )
    for i in range(0, nodes - 1, 10):
        lines.append(f"relate /t{i:03d}.linear.x ~ /t{i + 1:03d}.linear.x")
    return "\n".join(lines) + "\n"


def in_process(model_path: Path, seconds: float) -> tuple[float, float]:
    """(percent of one core, messages per second) of the host fed in real time here."""
    from rac.load.files import load_model
    from rac.observe import NodeSample
    from rac.pipeline import compile_model
    from rac.runtime.demo import DemoNode
    from rac.runtime.host import HostLoop, ObserverHost
    from rac.runtime.procs import ProcessProbe
    from rac.runtime.values import Decoders

    model = load_model(model_path)
    specs = compile_model(model).observers
    host = ObserverHost(specs)
    decoders = Decoders()
    fields = host.bank.topic_fields()
    epoch = time.time()
    demos = [
        DemoNode(model, n.name.value, epoch=epoch, started=epoch, period_s=60.0)
        for n in model.nodes
    ]
    topics = [(d, t) for d in demos for t in d.topics]
    readers = {
        t.name: decoders.for_topic(
            t.name, fields.get(t.name, frozenset()), t.ros_type, t.definition
        )
        for _, t in topics
    }
    # Messages are made ahead (the publisher's work is not the host's).
    made = {t.name: [d.message(t, epoch + k / t.rate_hz) for k in range(50)] for d, t in topics}
    probe = ProcessProbe(host.bank.nodes, lambda _n: os.getpid(), host.bank.properties, settle_s=0)
    loop = HostLoop(host, probe)
    me = psutil.Process()
    queue = [(epoch, i) for i in range(len(topics))]
    heapq.heapify(queue)
    count, next_probe = 0, epoch
    start_cpu, start = me.cpu_times(), time.time()
    while time.time() - start < seconds:
        now = time.time()
        while queue and queue[0][0] <= now:
            due, i = heapq.heappop(queue)
            _, t = topics[i]
            raw, reader = made[t.name][count % 50], readers[t.name]
            host.message(t.name, reader.values(raw), reader.stamp(raw))
            count += 1
            heapq.heappush(queue, (due + 1 / t.rate_hz, i))
        if now >= next_probe:
            loop.step(now)
            next_probe += 0.1
        time.sleep(max(0.0, min(queue[0][0], next_probe) - time.time()))
    end_cpu, wall = me.cpu_times(), time.time() - start
    cpu = (end_cpu.user + end_cpu.system - start_cpu.user - start_cpu.system) / wall
    assert NodeSample  # the probe's events are NodeSample/PropertySample
    return 100 * cpu, count / wall


def tedusar_live(seconds: float) -> tuple[float, float]:
    """(percent of one core of 'racc observe', messages per second it receives)."""
    tmp = Path(tempfile.mkdtemp(prefix="racc-bench-live-"))
    port = free_port()
    env = dict(
        os.environ,
        ROS_MASTER_URI=f"http://127.0.0.1:{port}",
        ROS_IP="127.0.0.1",
        ROS_HOME=str(tmp / "ros"),
    )
    procs: list[subprocess.Popen[bytes]] = []
    log = open(tmp / "log.txt", "wb")  # noqa: SIM115
    try:
        procs.append(
            subprocess.Popen(["roscore", "-p", str(port)], env=env, stdout=log, stderr=log)
        )
        time.sleep(3)
        subprocess.run(
            [
                *RACC,
                "compile",
                str(ROOT / "models/tedusar.ram"),
                "-o",
                str(tmp / "build"),
                "--no-svg",
                "-q",
            ],
            check=True,
            env=env,
        )
        procs.append(
            subprocess.Popen(
                [
                    *RACC,
                    "demo",
                    str(ROOT / "models/tedusar.ram"),
                    "-o",
                    str(tmp / "demo"),
                    "--board-port",
                    str(free_port()),
                    "--control-port",
                    str(free_port()),
                ],
                env=env,
                stdout=log,
                stderr=log,
            )
        )
        time.sleep(6)
        observer = subprocess.Popen(
            [*RACC, "observe", str(tmp / "build/observers.yaml")], env=env, stdout=log, stderr=log
        )
        procs.append(observer)
        time.sleep(5)  # imports, subscriptions, windows
        rates = {
            "/imu_data": 100,
            "/scan": 40,
            "/pose": 10,
            "/la_servo1_moving": 20,
            "/la_servo2_moving": 20,
            "/cmd_vel": 2,
            "/diagnostics": 1,
            "/board_measurements": 10,
        }
        p = psutil.Process(observer.pid)
        c0, t0 = p.cpu_times(), time.time()
        time.sleep(seconds)
        c1, wall = p.cpu_times(), time.time() - t0
        cpu = (c1.user + c1.system - c0.user - c0.system) / wall
        return 100 * cpu, float(sum(rates.values()))
    finally:
        for proc in reversed(procs):
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
                try:
                    proc.wait(20)
                except subprocess.TimeoutExpired:
                    proc.kill()
        log.close()
        shutil.rmtree(tmp, ignore_errors=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--only", choices=("tedusar", "synthetic"))
    args = parser.parse_args()
    per_msg_ros = 0.0
    if args.only != "synthetic":
        cpu, rate = tedusar_live(args.seconds)
        base, base_rate = in_process(ROOT / "models/tedusar.ram", min(args.seconds, 10.0))
        per_msg_ros = max(0.0, (cpu - base) / 100 / rate)
        print(
            f"tedusar live ('racc observe' on a real roscore): {cpu:.2f} % of one core "
            f"at ~{rate:.0f} messages/s (bound: 5 %)"
        )
        print(
            f"  in-process share (decode, observe, probe): {base:.2f} % at {base_rate:.0f}/s; "
            f"rospy receive cost ~{per_msg_ros * 1e6:.0f} µs per message"
        )
    if args.only != "tedusar":
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "synthetic100.ram"
            path.write_text(synthetic_ram(), encoding="utf-8")
            cpu, rate = in_process(path, min(args.seconds, 10.0))
        per_msg = per_msg_ros or 100e-6  # without the live run: a conservative 100 µs
        total = cpu + 100 * per_msg * rate
        print(
            f"synthetic 100-node robot: {cpu:.1f} % of one core in process at {rate:.0f} "
            f"messages/s, {total:.1f} % with rospy's receive cost (bound: 100 %)"
        )


if __name__ == "__main__":
    main()
