"""BiQObs parameters: each side's integral flag and the one regression window of the pair."""

from __future__ import annotations

import pytest

from rac.parse import parse_ram
from rac.pipeline import compile_model
from rac.targets import EmitOptions
from rac.targets.launch_ros1 import emit_launch_ros1

MODEL = """robot r
topic /pose { yaw, twist.twist.angular.z } @ 10 Hz
topic /imu { yaw } @ 100 Hz
topic /cmd { x }
topic /joy { y }
node base { publishes /pose }
node imu_driver { publishes /imu }
node teleop { publishes /cmd, /joy }
relate I(/pose.twist.twist.angular.z) ~ /imu.yaw
relate /imu.yaw ~ I(/cmd.x)
relate /cmd.x ~ /joy.y
"""


@pytest.fixture(scope="module")
def biqobs() -> list[dict[str, object]]:
    compiled = compile_model(parse_ram(MODEL, "r.ram"))
    return [dict(o.params) for o in compiled.observers if o.kind == "BiQObs"]


def test_parameters_in_order(biqobs: list[dict[str, object]]) -> None:
    assert list(biqobs[0]) == [
        "topic1", "field1", "integral1", "topic2", "field2", "integral2", "ws", "mismatch_th",
    ]  # fmt: skip
    assert biqobs[0]["integral1"] is True and biqobs[0]["integral2"] is False
    assert biqobs[1]["integral1"] is False and biqobs[1]["integral2"] is True
    assert biqobs[0]["field1"] == "twist.twist.angular.z"  # the field itself, not I(...)


def test_window_is_that_of_the_slower_regular_topic(biqobs: list[dict[str, object]]) -> None:
    assert biqobs[0]["ws"] == 1.0  # 10 / min(10 Hz, 100 Hz)
    # Only /imu is regular: 10 / 100 Hz = 0.1 s, raised to the shortest window, 1 s.
    assert biqobs[1]["ws"] == 1.0
    assert biqobs[2]["ws"] == 1.0  # neither is regular


def test_launch_file_writes_booleans_as_ros_reads_them() -> None:
    compiled = compile_model(parse_ram(MODEL, "r.ram"))
    # The dissertation's stack takes each observer's parameters as <param>s.
    text = emit_launch_ros1(compiled, EmitOptions(observers_package="tug_ist_diagnosis_observers"))
    assert '<param name="integral1" value="true"/>' in text
    assert '<param name="integral2" value="false"/>' in text
    assert "True" not in text and "False" not in text
