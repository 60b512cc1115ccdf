"""A ROS 1 graph of a real robot's size that racc did not write: Debian's C++
``topic_tools/relay`` nodes in two chains, fed by ``rosbag play --loop`` of two public
recordings (a Jackal's 50 Hz IMU, a PR2's 100 Hz joint states), and robot_state_publisher,
for ``bench/live_scale.py`` and ``tests/ros1/test_relay_graph.py``.

With ``relays`` = 2k the graph has k relays per chain::

    jackal_player -> /imu/data -> imu_relay_1 -> /imu_1 -> ... -> imu_relay_k -> /imu_k
    pr2_player -> /joint_states -> js_relay_1 -> /js_1 -> ... -> js_relay_k -> /js_k
                               \\-> robot_state_publisher -> /tf

and the Jackal's odometry, which nothing but racc receives.  The hand model
(:func:`model_text`) says what the graph is: each topic's rate, each relay's output from
its input, each node's cpu and memory limits; no relation between fields (a rates-only
model, as an operator would first write).  A relay's output keeps its input's bytes, so
the header stamps at a chain's end are the player's.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
URDF = HERE / "pr2_subset.urdf"
BAGS = ("jackal_imu_odom.bag", "pr2_joint_states_roslib_header.bag")
PLAYERS = ("jackal_player", "pr2_player")
# (relay name prefix, first topic, topic prefix, rate in Hz, type)
CHAINS = (
    ("imu_relay", "/imu/data", "/imu", 50, "sensor_msgs/Imu"),
    ("js_relay", "/joint_states", "/js", 100, "sensor_msgs/JointState"),
)
ODOM = "/jackal_velocity_controller/odom"


def chain_length(relays: int) -> int:
    if relays < 2 or relays % 2:
        raise ValueError(f"relays must be even and at least 2, not {relays}")
    return relays // 2


def relay_nodes(relays: int) -> list[str]:
    k = chain_length(relays)
    return [f"{prefix}_{i}" for prefix, *_ in CHAINS for i in range(1, k + 1)]


def nodes(relays: int) -> list[str]:
    """Every node of the graph: the players, the relays, robot_state_publisher."""
    return [*PLAYERS, *relay_nodes(relays), "robot_state_publisher"]


def chain_topics(relays: int) -> list[tuple[str, str, str]]:
    """(relay, input topic, output topic) of every relay, chain by chain."""
    k = chain_length(relays)
    out = []
    for prefix, first, topic_prefix, _, _ in CHAINS:
        source = first
        for i in range(1, k + 1):
            target = f"{topic_prefix}_{i}"
            out.append((f"{prefix}_{i}", source, target))
            source = target
    return out


def chain_end(relays: int, chain: int) -> str:
    """The last topic of chain 0 (the IMU's) or 1 (the joint states')."""
    return f"{CHAINS[chain][2]}_{chain_length(relays)}"


def messages_per_second(relays: int) -> float:
    """What the graph publishes, about: each chain's rate on each of its topics, the
    odometry, and /tf (about 65 Hz: robot_state_publisher skips clumped joint states)."""
    k = chain_length(relays)
    return sum(rate * (k + 1) for _, _, _, rate, _ in CHAINS) + 50 + 65


def launch_text(relays: int, data: Path, statistics: bool = False) -> str:
    """The robot's launch file.  ``statistics``: roscpp's topic statistics on, set before
    any node starts (``/enable_statistics``), in windows of one second."""
    lines = [
        "<launch>",
        f'  <param name="robot_description" textfile="{URDF}"/>',
    ]
    if statistics:
        lines += [
            '  <param name="enable_statistics" value="true"/>',
            '  <param name="statistics_window_max_size" value="1"/>',
        ]
    lines += [
        f'  <node pkg="rosbag" type="play" name="jackal_player" '
        f'args="--loop -q {data / BAGS[0]}"/>',
        f'  <node pkg="rosbag" type="play" name="pr2_player" args="--loop -q {data / BAGS[1]}"/>',
    ]
    for relay, source, target in chain_topics(relays):
        lines.append(
            f'  <node pkg="topic_tools" type="relay" name="{relay}" args="{source} {target}"/>'
        )
    lines += [
        '  <node pkg="robot_state_publisher" type="robot_state_publisher" '
        'name="robot_state_publisher">',
        '    <param name="ignore_timestamp" value="true"/>',
        "  </node>",
        "</launch>",
        "",
    ]
    return "\n".join(lines)


@dataclass(frozen=True)
class ModelOptions:
    """How the hand model differs on ROS 2 (tests/ros2/rclpy_graph.py): no
    robot_state_publisher, every rate divided by ``divisor`` (the players publish every
    n-th message), and the memory of Python nodes."""

    state_publisher: bool = True
    divisor: int = 1
    player_mem_mb: int = 128
    relay_mem_mb: int = 64


def model_text(relays: int, options: ModelOptions = ModelOptions()) -> str:
    """The hand model of the graph: rates, outputs from inputs, limits."""
    k = chain_length(relays)
    d = options.divisor
    out = [
        f"# {relays} relays in two chains of {k} (tests/ros1/relay_graph.py).",
        f"robot relays_{relays}",
        "",
        f"topic /imu/data : sensor_msgs/Imu @ {50 // d} Hz",
        f"topic {ODOM} : nav_msgs/Odometry @ {50 // d} Hz",
        f"topic /joint_states : sensor_msgs/JointState @ {100 // d} Hz",
    ]
    if options.state_publisher:
        out.append("topic /tf : tf2_msgs/TFMessage @ 65 Hz +- 25 Hz")
    for _, _, prefix, rate, kind in CHAINS:
        out += [f"topic {prefix}_{i} : {kind} @ {rate // d} Hz" for i in range(1, k + 1)]
    out += [
        "",
        "node jackal_player {",
        f"  publishes /imu/data, {ODOM}",
        f"  limits cpu 40 %, mem {options.player_mem_mb} MB",
        "}",
        "node pr2_player {",
        "  publishes /joint_states",
        f"  limits cpu 40 %, mem {options.player_mem_mb} MB",
        "}",
    ]
    if options.state_publisher:
        out += [
            "node robot_state_publisher {",
            "  subscribes /joint_states",
            "  publishes /tf from /joint_states",
            "  limits cpu 40 %, mem 128 MB",
            "}",
        ]
    for relay, source, target in chain_topics(relays):
        out += [
            f"node {relay} {{",
            f"  subscribes {source}",
            f"  publishes {target} from {source}",
            f"  limits cpu 30 %, mem {options.relay_mem_mb} MB",
            "}",
        ]
    return "\n".join(out) + "\n"


def write(directory: Path, relays: int, data: Path, statistics: bool = False) -> tuple[Path, Path]:
    """``relays_N.launch`` and ``relays_N.ram`` in ``directory``."""
    launch = directory / f"relays_{relays}.launch"
    launch.write_text(launch_text(relays, data, statistics), encoding="utf-8")
    model = directory / f"relays_{relays}.ram"
    model.write_text(model_text(relays), encoding="utf-8")
    return launch, model
