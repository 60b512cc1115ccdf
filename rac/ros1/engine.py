"""The diagnosis node (``racc engine``): model server and diagnosis engine (§6.3, §6.4).

The schedule, the diagnoses and the reloads are :class:`rac.runtime.diagnoser.EngineLoop`'s,
the node's loop is :func:`rac.runtime.nodes.run_engine_node`'s; this module gives it rospy.
"""

from __future__ import annotations

from collections.abc import Callable

from rac.diagnosis import Theory
from rac.ros1.common import Ros1Bus
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
    run_engine_node(
        Ros1Bus(name, key, ENGINE),
        path,
        load,
        robot,
        rate_hz=rate_hz,
        max_card=max_card,
        hosts=hosts,
        reload_dir=reload_dir,
    )
