"""Reading the ``ram/1`` JSON interchange: a valid file, and one with structure errors.

Run with ``.venv/bin/python bench/interchange.py`` (``--nodes N`` for the model size,
``--repeat N`` to keep the best of N runs).

The synthetic model of bench/compile.py is exported with ``racc export --json``'s writer,
then read back with ``parse_json`` (what ``load_model`` does after reading the file).  The
valid file stays on the C ``json`` decoder; the broken one (a wrong type, an unknown key and
a missing key near the end of the file) also pays for the second, position-recording read
that locates each RAC005 error; the worst case has two errors in every node, so the second
read walks the whole file.  A file of the right shape with one semantic error (a node
subscribing an undeclared topic, found by validation) is read, validated, then read again
with spans and validated again to locate it; a valid file with one warning pays that only
when the warning is shown (``racc check`` without ``--quiet``): both are printed beside
the plain read and validation they add to.  CPU times are printed, never asserted.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))  # bench/compile.py

from compile import synthetic_model

from rac.errors import RacError
from rac.interchange import dumps, parse_json
from rac.passes.validate import validate
from rac.pipeline import check_model, located


def best_of(repeat: int, text: str) -> tuple[float, int]:
    """The best CPU time of reading ``text``, and how many diagnostics it gave."""
    best, found = float("inf"), 0
    for _ in range(repeat):
        start = time.process_time()
        try:
            parse_json(text, "bench.json")
        except RacError as err:
            found = len(err.diagnostics)
        best = min(best, time.process_time() - start)
    return best, found


def best_checked(repeat: int, text: str) -> tuple[float, float, int]:
    """The best CPU times of reading and validating ``text``, without and with locating its
    diagnostics (``check_model`` raising, or ``located`` on the warnings a valid one has)."""
    plain, spanned, found = float("inf"), float("inf"), 0
    for _ in range(repeat):
        start = time.process_time()
        validate(parse_json(text, "bench.json"))
        plain = min(plain, time.process_time() - start)
        start = time.process_time()
        model = parse_json(text, "bench.json")
        try:
            diagnostics = located(model, check_model(model))
        except RacError as err:
            diagnostics = err.diagnostics
        spanned = min(spanned, time.process_time() - start)
        found = sum(d.span is not None for d in diagnostics)
    return plain, spanned, found


def semantic_error(text: str) -> str:
    doc = json.loads(text)
    doc["nodes"][-1]["subscribes"].append("/nowhere")
    return json.dumps(doc, indent=2, ensure_ascii=False) + "\n"


def warning(text: str) -> str:
    doc = json.loads(text)
    doc["topics"].append({"name": "/unused"})  # RAC103: declared, used by no node
    return json.dumps(doc, indent=2, ensure_ascii=False) + "\n"


def broken(text: str) -> str:
    doc = json.loads(text)
    last = doc["nodes"][-1]
    last["colour"] = "red"  # unknown key
    del last["name"]  # missing key
    doc["topics"][-1]["rate_hz"] = "fast"  # wrong type
    return json.dumps(doc, indent=2, ensure_ascii=False) + "\n"


def broken_everywhere(text: str) -> str:
    doc = json.loads(text)
    for node in doc["nodes"]:
        node["colour"] = "red"
        node["drives"].append(3)
    return json.dumps(doc, indent=2, ensure_ascii=False) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, default=10000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    text = dumps(synthetic_model(args.nodes))
    print(f"ram/1 model of {args.nodes:,} nodes: {len(text) / 2**20:.1f} MiB")
    seconds, _ = best_of(args.repeat, text)
    print(f"  valid file:  {seconds * 1000:8.1f} ms")
    seconds, found = best_of(args.repeat, broken(text))
    print(f"  with errors: {seconds * 1000:8.1f} ms ({found} diagnostics)")
    seconds, found = best_of(args.repeat, broken_everywhere(text))
    print(f"  worst case:  {seconds * 1000:8.1f} ms ({found:,} diagnostics)")
    for what, changed in (("semantic error", semantic_error), ("shown warning", warning)):
        plain, spanned, found = best_checked(args.repeat, changed(text))
        print(
            f"  {what}: read and validate {plain * 1000:8.1f} ms, "
            f"located {spanned * 1000:8.1f} ms ({found} located)"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
