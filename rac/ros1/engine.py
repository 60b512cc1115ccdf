"""The diagnosis node (``racc engine``): model server and diagnosis engine (§6.3, §6.4).

The schedule, the diagnoses and the reloads are :class:`rac.runtime.diagnoser.EngineLoop`'s;
this node moves arrays between it and rospy.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from rac.diagnosis import Theory
from rac.ros1.common import from_array, log_to_ros, require_ros, to_array
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
    rospy = require_ros()
    from diagnostic_msgs.msg import DiagnosticArray
    from std_msgs.msg import String

    rospy.init_node(name)
    log = log_to_ros(rospy)
    engine = EngineLoop(
        path, load, robot, rospy.get_name().lstrip("/"), log, rate_hz=rate_hz, max_card=max_card
    )
    pub = rospy.Publisher(DIAGNOSIS, DiagnosticArray, queue_size=10, latch=True)
    summary = rospy.Publisher("/diagnostics", DiagnosticArray, queue_size=10)

    def on_observations(array: Any) -> None:
        engine.observation_rows(from_array(array), time.time())

    def on_reload(msg: Any) -> None:
        engine.request_reload(msg.data)

    rospy.Subscriber("/observations", DiagnosticArray, on_observations, queue_size=50)
    rospy.Subscriber("~reload", String, on_reload)
    components = len(engine.diagnoser.theory.components)
    log(0, f"racc engine: {path}, {components} components, {rate_hz:.3g} Hz")
    while not rospy.is_shutdown():
        time.sleep(min(POLL_S, engine.period))
        tick = engine.step(time.time())
        if tick is not None:
            pub.publish(to_array(tick.rows))
            summary.publish(to_array([tick.summary]))
