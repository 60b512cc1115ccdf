"""The diagnosis node (``racc engine``): model server and diagnosis engine (§6.3, §6.4)."""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from typing import Any

from rac.diagnosis import Theory
from rac.errors import RacError
from rac.ros1.common import from_array, require_ros, to_array
from rac.runtime.diagnoser import Diagnoser, diagnosis_line
from rac.runtime.status import row_verdict

DIAGNOSIS = "/diagnosis"
POLL_S = 0.05
MIN_GAP_S = 0.2  # between diagnoses triggered by changed observations


def _stamp(path: str) -> tuple[float, int] | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_mtime, st.st_size


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
    diagnoser = Diagnoser(load(path), robot, rospy.get_name().lstrip("/"), max_card)
    lock = threading.Lock()
    pub = rospy.Publisher(DIAGNOSIS, DiagnosticArray, queue_size=10, latch=True)
    summary = rospy.Publisher("/diagnostics", DiagnosticArray, queue_size=10)
    state = {"path": path, "stamp": _stamp(path), "request": ""}

    def on_observations(array: Any) -> None:
        t = time.time()
        with lock:
            for row in from_array(array):
                verdict = row_verdict(row, t)
                if verdict is not None:
                    diagnoser.observe(verdict)

    def on_reload(msg: Any) -> None:
        with lock:
            state["request"] = msg.data or state["path"]

    rospy.Subscriber("/observations", DiagnosticArray, on_observations, queue_size=50)
    rospy.Subscriber("~reload", String, on_reload)

    def reload(target: str) -> None:
        try:
            theory = load(target)
        except RacError as err:
            rospy.logerr(
                "racc engine: model %s not reloaded, keeping the old one:\n%s", target, err.render()
            )
            return
        with lock:
            diagnoser.load(theory)
            state["path"], state["stamp"] = target, _stamp(target)
        rospy.loginfo(
            "t=%.3f model reloaded from %s (%d clauses, %d components)",
            time.time(),
            target,
            len(theory.clauses),
            len(theory.components),
        )

    rospy.loginfo(
        "racc engine: %s, %d components, %.3g Hz", path, len(diagnoser.theory.components), rate_hz
    )
    period = 1.0 / rate_hz
    last = 0.0
    while not rospy.is_shutdown():
        time.sleep(min(POLL_S, period))
        now = time.time()
        with lock:
            due = now - last >= period or (diagnoser.pending and now - last >= MIN_GAP_S)
        if not due:
            continue
        last = now
        request = state["request"]
        if request:
            state["request"] = ""
            reload(str(request))
        elif _stamp(str(state["path"])) != state["stamp"]:
            reload(str(state["path"]))
        with lock:
            tick = diagnoser.tick()
        if tick.changed:
            rospy.loginfo(diagnosis_line(time.time(), tick.result))
        pub.publish(to_array(tick.rows))
        summary.publish(to_array([tick.summary]))
