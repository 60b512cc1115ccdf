"""How late a 10 Hz loop's ticks come, as the observer host's sample loop runs: the figure
behind its starvation threshold (a tick overdue by more than 0.1 s, docs/runtime.md).

Run it alone and under load, e.g.:

    .venv/bin/python bench/host_lateness.py --seconds 20
    stress-ng --cpu 2 --cpu-load 95 --timeout 25s & .venv/bin/python bench/host_lateness.py

A second thread does a message callback's work meanwhile (some Python, every 10 ms).
Printed: the lateness of the ticks (median, 99th percentile, maximum) and how many were
late by more than 50, 100 and 250 ms.
"""

from __future__ import annotations

import argparse
import threading
import time

import numpy as np

from rac.runtime.host import ticks


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="how long (default 20)")
    args = parser.parse_args()
    period = 0.1
    stop = threading.Event()

    def callbacks() -> None:
        while not stop.is_set():
            sum(range(2000))
            time.sleep(0.01)

    threading.Thread(target=callbacks, daemon=True).start()
    lates: list[float] = []
    end, previous = time.monotonic() + args.seconds, None
    # The observer host's own pacing (rac.runtime.host.ticks), on the monotonic clock.
    for now in ticks(period, lambda: time.monotonic() < end, clock=time.monotonic):
        if previous is not None:
            lates.append(now - previous - period)
        previous = now
    stop.set()
    late = np.asarray(lates) * 1e3
    print(
        f"{late.size} ticks: late by median {np.median(late):.1f} ms, p99 "
        f"{np.percentile(late, 99):.1f} ms, max {late.max():.1f} ms; "
        f"over 50 ms {(late > 50).sum()}, over 100 ms {(late > 100).sum()}, "
        f"over 250 ms {(late > 250).sum()}"
    )


if __name__ == "__main__":
    main()
