"""Robots for the diagram's tests and bench/diagram.py: synthetic robots of any size, in one
namespace or several, with one hub, and a newcomer's small robot (issue 37).

A synthetic robot has the shape of a real one: drivers publish sensor data (some of them
also take a command, which closes a loop through the robot's software), processing stages
read earlier stages (mostly the recent ones), a coordinator reads the status of about 40 %
of the nodes and sends goals to some, most nodes publish debug topics that nobody reads,
every node publishes /diagnostics and some read /tf.  Everything is made from the seed.
"""

from __future__ import annotations

import random
from pathlib import Path

from rac.ir import FieldRef, Hardware, Limits, Model, Name, Node, Publication, Related, Topic
from rac.parse import parse_ram
from rac.tug import import_tug

TUGGER = Path(__file__).resolve().parent / "tug" / "tugger.yaml"

SUBSYSTEMS = ("sensing", "perception", "localization", "planning", "control", "mission")
WORDS = ("cam", "lidar", "radar", "sonar", "gps", "arm", "grip", "wheel", "lift", "light")


def synthetic_robot(nodes: int, namespaces: int = 1, seed: int = 1, hub: bool = True) -> Model:
    """A robot of ``nodes`` nodes in ``namespaces`` namespaces (1: all under /robot)."""
    rng = random.Random(seed)
    drivers = max(3, nodes // 7)
    coordinator = 1 if hub else 0
    stages = nodes - drivers - coordinator
    hardware: list[Hardware] = []
    topics: dict[str, Topic] = {}
    built: list[Node] = []

    def space(i: int) -> str:
        """Namespaces by subsystem: consecutive stages share one, as real robots group."""
        if namespaces == 1:
            return "/robot"
        k = i * namespaces // nodes
        return f"/robot/{SUBSYSTEMS[k % len(SUBSYSTEMS)]}{k}"

    def topic(name: str, rate: float | None = None) -> str:
        if name not in topics:
            topics[name] = Topic(Name(name), "std_msgs/Float64", (Name("data"),), rate_hz=rate)
        return name

    def word(i: int) -> str:
        return f"{WORDS[i % len(WORDS)]}{i // len(WORDS)}"

    sensor_topics: list[str] = []
    stage_topics: list[str] = []
    status_topics: list[str] = []
    commands: list[tuple[int, str]] = []  # (driver index, its command topic)
    for i in range(drivers):
        ns = space(i)
        device = f"{word(i)}_device"
        switchable = i % 2 == 0
        hardware.append(Hardware(Name(device), switchable, i // 2 + 1 if switchable else None))
        outs = [topic(f"{ns}/{word(i)}/data", rate=float(rng.choice((10, 20, 50))))]
        outs += [topic(f"{ns}/{word(i)}/debug_{k}") for k in range(rng.randint(1, 6))]
        outs.append(topic("/diagnostics"))
        if i % 3 == 0:
            outs.append(topic("/tf", rate=50.0))
        reads: list[str] = []
        if i % 4 == 1:  # an actuator: takes a command
            command = topic(f"{ns}/{word(i)}/command")
            reads.append(command)
            commands.append((i, command))
        sensor_topics.append(outs[0])
        built.append(
            Node(
                Name(f"{ns}/{word(i)}_driver"),
                drives=(Name(device),),
                subscribes=tuple(Name(t) for t in reads),
                publishes=tuple(Publication(Name(t)) for t in outs),
                limits=Limits(cpu=float(rng.choice((5, 10, 20))), mem=64 * 1000**2),
            )
        )
    for j in range(stages):
        i = drivers + j
        ns = space(i)
        name = f"{ns}/{word(j)}_{SUBSYSTEMS[j * len(SUBSYSTEMS) // max(stages, 1)]}"
        pool = sensor_topics + stage_topics[-12:]
        reads = sorted(set(rng.sample(pool, k=min(len(pool), rng.randint(1, 3)))))
        if j % 9 == 0:
            reads.append(topic("/tf", rate=50.0))
        outs = [topic(f"{name}/out", rate=float(rng.choice((5, 10))) if j % 3 == 0 else None)]
        if commands and j >= stages - len(commands):  # the last stages command the actuators
            outs.append(commands.pop()[1])
        if j % 2 == 0:
            outs.append(topic(f"{name}/status"))
            status_topics.append(outs[-1])
        outs += [topic(f"{name}/debug_{k}") for k in range(rng.randint(0, 5))]
        outs.append(topic("/diagnostics"))
        stage_topics.append(outs[0])
        built.append(
            Node(
                Name(name),
                subscribes=tuple(Name(t) for t in reads),
                publishes=tuple(
                    Publication(Name(t), tuple(Name(r) for r in reads if r != "/tf")) for t in outs
                ),
                limits=Limits(cpu=float(rng.choice((5, 10, 20, 40)))),
            )
        )
    if hub:
        ns = space(nodes - 1)
        goals = [topic(f"{ns}/coordinator/goal_{k}") for k in range(max(2, nodes // 15))]
        readers = rng.sample(range(drivers, len(built)), k=min(len(goals), len(built) - drivers))
        for k, index in zip(range(len(goals)), readers, strict=False):
            node = built[index]
            built[index] = Node(
                node.name,
                node.drives,
                (*node.subscribes, Name(goals[k])),
                node.publishes,
                node.limits,
            )
        reads = status_topics[: max(1, int(nodes * 0.4) - len(goals))]
        built.append(
            Node(
                Name(f"{ns}/coordinator"),
                subscribes=tuple(Name(t) for t in reads),
                publishes=tuple(Publication(Name(t), tuple(Name(r) for r in reads)) for t in goals),
                limits=Limits(cpu=10.0),
            )
        )
    related: tuple[Related, ...] = ()
    if len(sensor_topics) >= 2:
        related = (Related(FieldRef(sensor_topics[0], "data"), FieldRef(sensor_topics[1], "data")),)
    published = {p.topic.value for n in built for p in n.publishes}
    assert all(t in published for t in topics)  # every command found its publisher
    return Model(
        Name(f"synthetic_{nodes}_{namespaces}"),
        tuple(hardware),
        tuple(topics.values()),
        tuple(built),
        related,
    )


NEWCOMER = """\
# A newcomer's own robot (issue 37): 9 nodes, 3 devices, 2 relations, one namespace.  In
# this order of declarations, racc before issue 37 drew the /joint_states @ 50 Hz label on
# the ekf → planner arrow.
robot rover

hardware lidar switchable channel 1
hardware base switchable channel 2
hardware imu

topic /scan : sensor_msgs/LaserScan { ranges } @ 10 Hz
topic /odom : nav_msgs/Odometry { twist.twist.linear.x, twist.twist.angular.z } @ 50 Hz
topic /imu/data : sensor_msgs/Imu { angular_velocity.z } @ 100 Hz
topic /odometry/filtered : nav_msgs/Odometry { twist.twist.angular.z } @ 30 Hz
topic /map : nav_msgs/OccupancyGrid
topic /goal : geometry_msgs/PoseStamped
topic /plan : nav_msgs/Path
topic /cmd_vel : geometry_msgs/Twist { linear.x, angular.z } @ 20 Hz
topic /joint_states : sensor_msgs/JointState @ 50 Hz
topic /tf : tf2_msgs/TFMessage

node imu_driver drives imu {
  publishes /imu/data
  limits cpu 5 %, mem 32 MB
}

node slam {
  subscribes /scan, /odom
  publishes /map from /scan, /odom
  limits cpu 60 %, mem 512 MB
}

node lidar_driver drives lidar {
  publishes /scan
  limits cpu 10 %, mem 64 MB
}

node mission {
  publishes /goal
  limits cpu 5 %, mem 64 MB
}

node robot_state_publisher {
  subscribes /joint_states
  publishes /tf from /joint_states
  limits cpu 5 %, mem 64 MB
}

node ekf {
  subscribes /odom, /imu/data
  publishes /odometry/filtered from /odom, /imu/data
  limits cpu 20 %, mem 128 MB
}

node controller {
  subscribes /plan, /scan, /odometry/filtered
  publishes /cmd_vel from /plan, /scan, /odometry/filtered
  limits cpu 20 %, mem 128 MB
}

node planner {
  subscribes /map, /odometry/filtered, /goal
  publishes /plan from /map, /odometry/filtered, /goal
  limits cpu 40 %, mem 256 MB
}

node base_driver drives base {
  subscribes /cmd_vel
  publishes /odom, /joint_states
  limits cpu 15 %, mem 64 MB
}

relate /cmd_vel.linear.x ~ /odom.twist.twist.linear.x
relate /odometry/filtered.twist.twist.angular.z ~ /imu/data.angular_velocity.z
"""


def newcomer_robot() -> Model:
    """The newcomer's robot: a laser, a base and an IMU, an EKF, SLAM, a planner."""
    return parse_ram(NEWCOMER)


def tugger() -> Model:
    """The stand-in for issue 37's real 30-node warehouse robot, as ``racc import tug`` makes
    it from tests/tug/tugger.yaml."""
    return import_tug(TUGGER.read_text("utf-8"), str(TUGGER), "tugger").model
