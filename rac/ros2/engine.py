"""The diagnosis node on ROS 2 (``racc engine --ros 2``): model server and diagnosis
engine.  The schedule, the diagnoses and the reloads are
:class:`rac.runtime.diagnoser.EngineLoop`'s; this node moves arrays between it and rclpy.
A reload is asked for on ``~/reload`` (``std_msgs/msg/String``)."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from rac.diagnosis import Theory
from rac.ros2.common import Session, from_array, reliable, to_array
from rac.runtime.diagnoser import EngineLoop

DIAGNOSIS = "/diagnosis"
POLL_S = 0.05


def run_engine(
    path: str,
    load: Callable[[str], Theory],
    robot: str,
    *,
    rate_hz: float = 1.0,
    max_card: int | None = None,
    name: str = "racc_engine",
) -> None:
    session = Session(name)
    from diagnostic_msgs.msg import DiagnosticArray
    from std_msgs.msg import String

    node = session.node
    engine = EngineLoop(
        path, load, robot, session.name, session.log, rate_hz=rate_hz, max_card=max_card
    )
    pub = node.create_publisher(DiagnosticArray, DIAGNOSIS, reliable(10, latched=True))
    summary = node.create_publisher(DiagnosticArray, "/diagnostics", reliable(10))

    def on_observations(array: Any) -> None:
        engine.observation_rows(from_array(array), time.time())

    node.create_subscription(
        DiagnosticArray, "/observations", on_observations, reliable(50, latched=True)
    )
    node.create_subscription(
        String, "~/reload", lambda msg: engine.request_reload(msg.data), reliable(5)
    )
    components = len(engine.diagnoser.theory.components)
    session.log(0, f"racc engine: {path}, {components} components, {rate_hz:.3g} Hz")
    try:
        while session.ok:
            time.sleep(min(POLL_S, engine.period))
            tick = engine.step(time.time())
            if tick is not None:
                pub.publish(to_array(session, tick.rows))
                summary.publish(to_array(session, [tick.summary]))
    finally:
        session.close()
