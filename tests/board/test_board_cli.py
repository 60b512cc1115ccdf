"""``racc board-sim`` as a user starts it, a raw-socket client written from the issue's table,
and ``racc board status|switch|control`` against it."""

from __future__ import annotations

import json
import os
import selectors
import socket
import struct
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from rac.cli import main

ROOT = Path(__file__).resolve().parents[2]
TEDUSAR = str(ROOT / "models" / "tedusar.ram")
WAIT_S = 2.0


def read_lines(process: subprocess.Popen[bytes], count: int, within_s: float = 15.0) -> list[str]:
    """The first ``count`` lines of the process's output, never waiting past ``within_s``."""
    assert process.stdout is not None
    fd = process.stdout.fileno()
    data = b""
    deadline = time.monotonic() + within_s
    with selectors.DefaultSelector() as selector:
        selector.register(fd, selectors.EVENT_READ)
        while data.count(b"\n") < count:
            left = deadline - time.monotonic()
            assert left > 0 and selector.select(left), f"board-sim printed only {data!r}"
            chunk = os.read(fd, 4096)
            assert chunk, f"board-sim ended after {data!r}"
            data += chunk
    return data.decode().splitlines()[:count]


@pytest.fixture(scope="module")
def sim() -> Iterator[dict[str, str]]:
    """``racc board-sim --model models/tedusar.ram``: its ``board`` and ``control`` addresses."""
    process = subprocess.Popen(
        [sys.executable, "-m", "rac", "board-sim", "--model", TEDUSAR, "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
    )
    try:
        lines = read_lines(process, 2)
        yield dict(line.split(" ", 1) for line in lines)
    finally:
        process.terminate()
        process.wait(timeout=10)


# -- a client from the table only: raw sockets and struct -----------------------------


def read_exact(sock: socket.socket, count: int) -> bytes:
    data = b""
    while len(data) < count:
        chunk = sock.recv(count - len(data))
        assert chunk, "connection closed"
        data += chunk
    return data


def read_frame(sock: socket.socket) -> tuple[int, bytes]:
    stx, cmd, length = struct.unpack(">BBH", read_exact(sock, 4))
    assert stx == 6
    return cmd, read_exact(sock, length)


def read_until(sock: socket.socket, cmd: int, within_s: float = 5 * WAIT_S) -> bytes:
    """The next frame of kind ``cmd``; MSRs keep arriving, so the wait has its own bound."""
    deadline = time.monotonic() + within_s
    while time.monotonic() < deadline:
        got, data = read_frame(sock)
        if got == cmd:
            return data
    raise AssertionError(f"no CMD {cmd} within {within_s} s")


def states(msr: bytes) -> list[int]:
    n = msr[0]
    assert len(msr) == 9 * n + 1
    return [msr[1 + 9 * i] for i in range(n)]


def test_a_client_written_from_the_table_alone(sim: dict[str, str]) -> None:
    host, port = sim["board"].rsplit(":", 1)
    with socket.create_connection((host, int(port)), timeout=WAIT_S) as sock:
        sock.settimeout(WAIT_S)
        cmd, data = read_frame(sock)  # INT
        assert cmd == 0 and data[0] == 10 and len(data) == 8 * 10 + 1
        max_current, max_voltage = struct.unpack(">ff", data[1:9])
        assert (max_current, max_voltage) == (15.0, 60.0)

        sock.sendall(bytes([6, 1, 0, 1, 25]))  # BRD 25 Hz
        assert read_until(sock, 5) == bytes([0])
        start = time.monotonic()
        msrs = [read_until(sock, 2) for _ in range(13)]
        rate = 12 / (time.monotonic() - start)
        assert 12 < rate < 40, rate
        assert states(msrs[-1])[:3] == [1, 1, 1]
        current, voltage = struct.unpack(">ff", msrs[-1][2:10])
        assert 0.5 < current < 15.0 and 10.0 < voltage < 60.0

        sock.sendall(bytes([6, 4, 0, 2, 1, 0]))  # SWT channel 1 (jaguar) off
        assert read_until(sock, 5) == bytes([0])
        assert states(read_until(sock, 2))[0] == 0
        sock.sendall(bytes([6, 4, 0, 2, 1, 1]))  # and on again
        assert read_until(sock, 5) == bytes([0])
        assert states(read_until(sock, 2))[0] == 1

        sock.sendall(bytes([6, 7, 0, 0]))  # unknown command
        assert read_until(sock, 5) == bytes([1])
        sock.sendall(bytes([6, 4, 0, 2, 99, 1]))  # no channel 99
        assert read_until(sock, 5) == bytes([1])
        sock.sendall(bytes([6, 1, 0, 1, 0]))  # BRD 0: stop broadcasting
        assert read_until(sock, 5) == bytes([0])


# -- the commands --------------------------------------------------------------------------


def test_status_prints_the_table_and_the_hardware_literals(
    sim: dict[str, str], capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["board", "status", "--board", sim["board"], "--model", TEDUSAR]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0].split() == [
        "channel",
        "device",
        "state",
        "current",
        "A",
        "voltage",
        "V",
    ]
    assert any(line.split()[:3] == ["2", "hokuyo", "on"] for line in out.splitlines())
    assert any(line.split()[:3] == ["4", "-", "off"] for line in out.splitlines())
    assert "observations: on(jaguar) on(hokuyo) on(laser_alignment)" in out


def test_control_trip_switch_and_status_json(
    sim: dict[str, str], capsys: pytest.CaptureFixture[str]
) -> None:
    board = ["--board", sim["board"], "--model", TEDUSAR]
    assert main(["board", "control", "--control", sim["control"], "trip", "laser_alignment"]) == 0
    capsys.readouterr()
    assert main(["board", "status", *board, "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["observations"] == ["on(jaguar)", "on(hokuyo)", "not_on(laser_alignment)"]
    assert report["channels"][2] == {
        "channel": 3,
        "device": "laser_alignment",
        "on": False,
        "current": 0.0,
        "voltage": 0.0,
    }
    assert main(["board", "switch", *board, "laser_alignment", "on"]) == 0
    assert "channel 3 (laser_alignment) is on" in capsys.readouterr().out
    assert main(["board", "switch", "--board", sim["board"], "5", "off"]) == 0
    assert "channel 5 (spare) is off" in capsys.readouterr().out


def test_bad_input_exits_1_with_a_message(
    sim: dict[str, str], capsys: pytest.CaptureFixture[str]
) -> None:
    board = ["--board", sim["board"], "--model", TEDUSAR]
    assert main(["board", "switch", *board, "jaguur", "off"]) == 1
    err = capsys.readouterr().err
    assert "RAC092" in err and "did you mean 'jaguar'?" in err
    assert main(["board", "switch", *board, "12", "off"]) == 1
    assert main(["board", "control", "--control", sim["control"], "trip", "kinect"]) == 1


def test_command_line_errors_exit_2() -> None:
    with pytest.raises(SystemExit) as caught:
        main(["board", "switch", "--board", "127.0.0.1:1", "jaguar", "maybe"])
    assert caught.value.code == 2
    assert main(["board"]) == 2
    with pytest.raises(SystemExit) as caught:  # a malformed address is the command line's
        main(["board", "status", "--board", "nowhere"])
    assert caught.value.code == 2


def test_board_sim_refuses_a_model_that_does_not_fit(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["board-sim", "--model", TEDUSAR, "--channels", "2"]) == 1
    assert "laser_alignment (channel 3)" in capsys.readouterr().err


# -- closing the loop: racc repair --execute and racc scenario --board ---------------------


def test_repair_execute_power_cycles_through_the_board(
    sim: dict[str, str], capsys: pytest.CaptureFixture[str]
) -> None:
    obs = ["--obs", "on(jaguar)", "--obs", "running(jaguar_node)", "--obs", "not ok(pose)"]
    nodes = ["--node-commands", "start=true {node}", "--node-commands", "stop=true {node}"]
    argv = ["repair", TEDUSAR, *obs, "--execute", "--board", sim["board"], *nodes, "--json"]
    assert main(argv) == 0
    plan_line, executed_line = capsys.readouterr().out.splitlines()
    plan = json.loads(plan_line)["plan"]
    executed = json.loads(executed_line)["executed"]
    assert len(executed) == len(plan)
    assert "shutdown(jaguar): channel 1 (jaguar) off, 0.00 A, 0.00 V" in executed
    assert any(e.startswith("power_up(jaguar): channel 1 (jaguar) on") for e in executed)
    assert "start_node(jaguar_node): ran: true jaguar_node" in executed


def test_repair_execute_without_a_board_is_an_input_error(
    capsys: pytest.CaptureFixture[str],
) -> None:
    obs = ["--obs", "on(jaguar)", "--obs", "running(jaguar_node)", "--obs", "not ok(pose)"]
    assert main(["repair", TEDUSAR, *obs, "--execute"]) == 1
    assert "RAC090" in capsys.readouterr().err


def test_scenario_device_shutdown_against_the_board(
    sim: dict[str, str], capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["scenario", TEDUSAR, "device-shutdown", "--device", "hokuyo"]
    argv += ["--board", sim["board"], "--board-control", sim["control"], "--json"]
    assert main(argv) == 0
    report = json.loads(capsys.readouterr().out)
    assert "not_on(hokuyo)" in report["board_tripped"] and report["tripped_by"] == "control port"
    assert report["diagnosis"]["bad"] == ["hokuyo"]
    assert "on(hokuyo)" in report["board_after"]
    assert main(["scenario", TEDUSAR, "power-up", "--board", sim["board"]]) == 2


def closed_port() -> str:
    """A loopback address where nothing listens (the OS just handed the port out)."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return f"127.0.0.1:{sock.getsockname()[1]}"


@pytest.mark.parametrize(
    "argv",
    [
        ["board", "status", "--board", "127.0.0.1:1", "--timeout", "0"],
        ["board", "switch", "--board", "127.0.0.1:1", "--timeout", "nan", "1", "on"],
        ["board-sim", "--port", "99999"],
        ["board-sim", "--control-port", "-1"],
        ["board-sim", "--channels", "0"],
    ],
)
def test_bad_options_exit_2(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    assert "error:" in capsys.readouterr().err


def test_a_control_port_that_refuses_is_an_error_not_a_traceback(
    sim: dict[str, str], capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["scenario", TEDUSAR, "device-shutdown", "--board", sim["board"]]
    assert main([*argv, "--board-control", closed_port()]) == 1
    err = capsys.readouterr().err
    assert "RAC090" in err and "cannot reach the control port" in err
    assert (
        main(["board", "switch", "--board", sim["board"], "--model", TEDUSAR, "jaguar", "on"]) == 0
    )
