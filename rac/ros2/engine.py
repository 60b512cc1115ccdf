"""The diagnosis node on ROS 2 (``racc engine --ros 2``): model server and diagnosis
engine.  The schedule, the diagnoses and the reloads are
:class:`rac.runtime.diagnoser.EngineLoop`'s, the node's loop is
:func:`rac.runtime.nodes.run_engine_node`'s; this module gives it rclpy.  A reload is asked
for on ``~/reload`` (``std_msgs/msg/String``)."""

from __future__ import annotations

from collections.abc import Callable

from rac.diagnosis import Theory
from rac.ros2.common import Session
from rac.runtime.nodes import run_engine_node
from rac.runtime.trust import ENGINE


def run_engine(
    path: str,
    load: Callable[[str], Theory],
    robot: str,
    *,
    rate_hz: float = 1.0,
    max_card: int | None = None,
    name: str = "racc_engine",
    key: bytes | None = None,
    hosts: tuple[str, ...] = (),
    reload_dir: str | None = None,
) -> None:
    session = Session(name, key=key, role=ENGINE)
    try:
        run_engine_node(
            session,
            path,
            load,
            robot,
            rate_hz=rate_hz,
            max_card=max_card,
            hosts=hosts,
            reload_dir=reload_dir,
        )
    finally:
        session.close()
