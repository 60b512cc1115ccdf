"""A stranger on the graph (issue 34), on ROS 1 and on ROS 2: every attack of
tests/attacks.py against the running demo robot and its runtime.  None may make racc act
(no plan, no node or device touched), every racc process stays up, each is reported on
/diagnostics, and a real fault afterwards is still diagnosed and repaired.

The robot is tedusar placed on one declared machine (``machine base``), so that its
observer host runs the machine's racc agent, which the agent attack aims at.
"""

from __future__ import annotations

import re
import subprocess
import time

from attacks import run_attack
from live_harness import LiveRobot, everything_observed, kill_node, placed_build
from soak_support import all_ok_since, named_since, plans

from rac.runtime.status import OK, STALE

ATTACK_S = 5.0
MEASURED = re.compile(r",(cpu|mem)\)$")  # PObs: racc's own reading of a process
# What each racc node must say it ignored, per attack: (node, words of its status).
REPORTED = {
    "flood": ("racc_observer_base", "intruder_flood on /imu_data"),
    "huge": ("racc_observer_base", "intruder_huge on /pose"),
    "wrong_type": ("racc_observer_base", "intruder_wrong_type on /pose"),
    "fake_observations": ("racc_engine", "on /observations: unsealed"),
    "fake_diagnosis": ("racc_repairer", "on /diagnosis: unsealed"),
    "fake_board": ("racc_observer_base", "on /board_measurements: unsealed"),
    "board_switch": ("racc_board_client", "on /board_switch: unsealed"),
    "reload": ("racc_engine", "outside the model directory"),
    "agent": ("racc_observer_base", "on /racc_agent/base: unsealed"),
    "confirm": ("racc_repairer", "on /racc_repairer/confirm: unsealed"),
}


def reported(robot: LiveRobot, since: float, node: str, words: str) -> bool:
    with robot.watch.lock:
        return any(
            t >= since and name == f"{node}: ignored" and words in message
            for t, name, _, message in robot.watch.statuses
        )


def test_attacks_from_the_graph_make_racc_do_nothing(robot: LiveRobot) -> None:
    watch, ros = robot.watch, robot.ros.version
    build = placed_build(robot)
    other = robot.tmp / "elsewhere"
    other.mkdir(exist_ok=True)
    (other / "model.yaml").write_text(
        (robot.build / "model.yaml").read_text(encoding="utf-8").replace("imu_node", "imu_nod"),
        encoding="utf-8",
    )
    demo = robot.start_demo("hostile")
    runtime: list[subprocess.Popen[bytes]] = []
    try:
        robot.wait_demo(60)
        launched = time.time()
        runtime = robot.launch_runtime(demo, build=build)
        ready = watch.wait(everything_observed(watch, launched, robot.quick_atoms), 45)
        assert ready is not None, "the runtime did not come up"
        healthy = watch.wait(all_ok_since(watch, launched, robot.quick_atoms), 30)
        assert healthy is not None, "never all ok after launch"
        start = time.time()
        # One after the other: a dozen ROS processes starting at once would starve the
        # demo's own Python nodes on two cores, a real slowdown of the robot.
        arguments = {"reload": str(other / "model.yaml"), "agent": "base"}
        for a in [*REPORTED, "fake_device"]:
            log = robot.tmp / f"attack_{a}.log"
            proc = run_attack(ros, a, ATTACK_S, robot.env, log, arguments.get(a, ""))
            assert proc.wait(ATTACK_S + 30) == 0, f"the {a} attack did not run"
        time.sleep(5.0)  # anything the attacks set off has had time to act
        end = time.time()
        print(f"\n{robot.ros.id}: attacks from {start - launched:.1f} s to {end - launched:.1f} s")
        acted = plans(watch, start, end)
        assert acted == [], f"racc acted on an attack: {acted}"
        # The engine's own word (its summary on /diagnostics; the monitor's /diagnosis and
        # /observations show the fake ones too): no fault all along, but one that racc
        # measured itself.  A process's cpu and memory may turn for real: the attackers
        # share the robot's two cores here, and every node of a ROS 2 domain spends CPU on
        # a new participant's discovery.  Nothing the graph's messages said may count.
        with watch.lock:
            faulty = [
                (t, message)
                for t, name, level, message in watch.statuses
                if start <= t < end and name == "racc_engine: diagnosis" and level != 0
            ]
            measured = [
                (t, literal)
                for t, rows in watch.observations
                if start - 5 <= t < end
                for literal, level in rows
                if level not in (OK, STALE) and MEASURED.search(literal)
            ]
        print(f"diagnoses during the attacks: {[(round(t - start, 1), m) for t, m in faulty]}")
        unexplained = [
            (round(t - start, 1), message)
            for t, message in faulty
            if not all(
                any(f"({node}," in lit and t - 5 <= when <= t for when, lit in measured)
                for node in re.split(r"[,| ]+", message.partition(":")[2].strip())
                if node
            )
        ]
        assert unexplained == [], f"the engine diagnosed a fault during the attacks: {unexplained}"
        for proc in runtime:
            assert proc.poll() is None, "a racc process died during the attacks"
        with watch.lock:
            racc_nodes = {n for n in watch.nodes if n.startswith("racc_")}
        assert {"racc_engine", "racc_repairer", "racc_board_client"} <= racc_nodes, racc_nodes
        missing = [
            a for a, (node, words) in REPORTED.items() if not reported(robot, start, node, words)
        ]
        if ros == 1:
            fake_device = reported(
                robot, start, "racc_observer_base", "intruder_fake_device on /diagnostics"
            )
            assert fake_device, "the stranger's status of hokuyo was not reported"
        else:
            assert reported(robot, start, "racc_observer_base", "on /diagnostics")
        assert not missing, f"attacks not reported on /diagnostics: {missing}"

        # A real fault afterwards is still diagnosed and repaired.
        crash = time.time()
        kill_node(robot.ros.version, "jaguar_node")
        diagnosed = watch.wait(named_since(watch, crash, "jaguar_node"), 30)
        assert diagnosed is not None, "the crash after the attacks was not diagnosed"
        ok_again = watch.wait(all_ok_since(watch, diagnosed, robot.atoms), 30)
        assert ok_again is not None, "not all ok again after the crash that followed the attacks"
        print(f"  crash after the attacks: diagnosed and repaired ({ok_again - diagnosed:.1f} s)")
    finally:
        robot.stop_scene(demo, runtime)
