"""The live tests of tests/live/ run once per ROS version (tests/live_harness.py): the
``robot`` fixture is parametrized over ROS 1 and ROS 2.  A version that cannot run here
(its client library is not importable, or its tools are missing) is deselected, unless its
``RACC_REQUIRE_ROS*`` variable is 1: then it is kept and fails loudly (.ci/run)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from live_harness import VERSIONS, LiveRobot, Ros, check_runnable, live_robot, runnable


@pytest.fixture(scope="module", params=VERSIONS, ids=[r.id for r in VERSIONS])
def ros(request: pytest.FixtureRequest) -> Ros:
    """The ROS version of this run of the module; one that must run here (RACC_REQUIRE_ROS*)
    but cannot is an error with the reason."""
    version: Ros = request.param
    check_runnable(version)
    return version


@pytest.fixture(scope="module")
def robot(ros: Ros, tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveRobot]:
    """A ROS graph of this module's own (roscore on a free port, or a domain of its own),
    tedusar compiled, the monitor subscribed; tests start the demo and the runtime."""
    tmp: Path = tmp_path_factory.mktemp(f"live_{ros.id}")
    with live_robot(ros, tmp) as live:
        yield live


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    kept, dropped = [], []
    for item in items:
        callspec = getattr(item, "callspec", None)
        version = callspec.params.get("ros") if callspec is not None else None
        if isinstance(version, Ros) and not runnable(version):
            dropped.append(item)
        else:
            kept.append(item)
    if dropped:
        config.hook.pytest_deselected(items=dropped)
        items[:] = kept
