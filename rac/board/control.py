"""The simulator's control interface: one text line in, one line out, over loopback TCP.

Faults are injected while the simulator runs without signals or a second process:

    trip jaguar          the device's supply trips off (MSR shows it off)
    overcurrent 2        the channel draws 125 % of its maximum while on
    disconnect hokuyo    powered, but no current flows
    jam jaguar           the relay ignores SWT (a switch the board ACKs but never does)
    clear jaguar         remove the fault (a tripped channel stays off until switched on)
    on jaguar | off 3    switch, as SWT would
    status               one JSON line with every channel
    help | quit

A target is a device name from the model or a channel number.  Replies start with
``ok`` or ``error``.
"""

from __future__ import annotations

import asyncio
import json
from collections.abc import Callable

from rac.board.channels import ChannelMap, resolve_target
from rac.board.state import BoardState, Fault
from rac.errors import RacError

MAX_LINE = 1024
FAULT_VERBS = {
    "overcurrent": Fault.OVERCURRENT,
    "disconnect": Fault.DISCONNECTED,
    "jam": Fault.JAMMED,
}
VERBS = ("status", "trip", "overcurrent", "disconnect", "jam", "clear", "on", "off", "help", "quit")
HELP = "commands: status, trip T, overcurrent T, disconnect T, jam T, clear T, on T, off T, quit"


def _status(state: BoardState) -> str:
    readings = state.measurements().channels
    rows = [
        {
            "channel": c.number,
            "device": c.device,
            "on": r.on,
            "current": round(r.current, 3),
            "voltage": round(r.voltage, 3),
            "fault": c.fault.value if c.fault else None,
        }
        for c, r in zip(state.channels, readings, strict=True)
    ]
    return "ok " + json.dumps(rows, sort_keys=True)


def apply_control(state: BoardState, channels: ChannelMap, line: str) -> str:
    """Carry out one control line on the board; the reply line (without newline)."""
    words = line.split()
    if not words:
        return "error empty command; " + HELP
    verb, rest = words[0].lower(), words[1:]
    if verb == "help":
        return "ok " + HELP
    if verb == "status":
        return _status(state)
    if verb not in VERBS:
        return f"error unknown command '{verb}'; " + HELP
    if len(rest) != 1:
        return f"error '{verb}' takes one target (device or channel); " + HELP
    try:
        number = resolve_target(rest[0], channels, len(state.channels))
    except RacError as err:
        return "error " + "; ".join(
            d.message + (f" ({d.hint})" if d.hint else "") for d in err.diagnostics
        )
    label = f"channel {number} ({state.channels[number - 1].label})"
    if verb == "trip":
        state.trip(number)
    elif verb in ("on", "off"):
        state.switch(number, verb == "on")
    elif verb in FAULT_VERBS:
        state.inject(number, FAULT_VERBS[verb])
    elif verb == "clear":
        state.clear(number)
    else:
        return f"error unknown command '{verb}'; " + HELP
    return f"ok {verb} {label}"


async def serve_control(
    state: BoardState,
    channels: ChannelMap,
    reader: asyncio.StreamReader,
    writer: asyncio.StreamWriter,
    log: Callable[[str], None],
    seen: Callable[[], None] = lambda: None,
) -> None:
    """One control connection: lines until ``quit`` or EOF; bad lines get ``error``.
    ``seen`` is called on each line (the simulator closes the longest-idle connection to
    make room for a new one)."""
    try:
        while True:
            try:
                raw = await reader.readuntil(b"\n")
                seen()
            except asyncio.IncompleteReadError as partial:
                raw = partial.partial
                if not raw:
                    return
            except asyncio.LimitOverrunError:
                writer.write(b"error line too long\n")
                return
            line = raw.decode("utf-8", errors="replace").strip()
            if line.lower() == "quit":
                writer.write(b"ok bye\n")
                return
            reply = apply_control(state, channels, line)
            if reply.startswith("ok") and not line.lower().startswith(("status", "help")):
                log(f"control: {reply[3:]}")
            writer.write(reply.encode() + b"\n")
            await asyncio.wait_for(writer.drain(), 5.0)
            if not raw.endswith(b"\n"):
                return
    except (ConnectionError, TimeoutError, asyncio.TimeoutError, asyncio.CancelledError):
        return  # a cancelled handler task would only make asyncio print noise
    finally:
        writer.close()


async def send_control(host: str, port: int, line: str, timeout: float = 2.0) -> str:
    """Send one control line and return the reply (without ``ok``/``error`` parsing)."""
    reader, writer = await asyncio.wait_for(asyncio.open_connection(host, port), timeout)
    try:
        writer.write(line.encode() + b"\n")
        await asyncio.wait_for(writer.drain(), timeout)
        reply = await asyncio.wait_for(reader.readline(), timeout)
        return reply.decode("utf-8", errors="replace").strip()
    finally:
        writer.close()
