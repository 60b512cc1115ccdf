"""Load-time benchmark: observers.yaml as ``racc compile`` writes it, 2,000 to 50,000 nodes.

Run with ``.venv/bin/python bench/load_observers.py`` (``--sizes 2000 50000`` to pick sizes,
``--repeat N`` to keep the best of N runs, ``--yaml`` to time the YAML path as well).

Each size's observers.yaml is emitted from ``bench/compile.py``'s synthetic robot, then
``rac.load.files.load_observers`` is timed on it (CPU seconds): racc's own layout is read
line by line (``rac/load/observers_yaml.py``), whatever its size.  ``--yaml`` times
libyaml's ``CSafeLoader`` on the same text, what the YAML path costs past its size limit.
The figures are printed, never asserted.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))  # bench/compile.py

from compile import synthetic_model

from rac.load.files import load_observers
from rac.pipeline import compile_model
from rac.targets import EmitOptions
from rac.targets.observers_yaml import emit_observers_yaml


def _best(repeat: int, run: Callable[[], object]) -> float:
    best = float("inf")
    for _ in range(repeat):
        start = time.process_time()
        run()
        best = min(best, time.process_time() - start)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[2_000, 50_000])
    parser.add_argument("--repeat", type=int, default=3, help="best of N runs (default 3)")
    parser.add_argument("--yaml", action="store_true", help="time CSafeLoader too (slow)")
    parser.add_argument("models", nargs="*", help="observers.yaml files to time as well")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        paths = [Path(p) for p in args.models]
        for size in args.sizes:
            path = Path(tmp) / f"observers_{size}.yaml"
            compiled = compile_model(synthetic_model(size))
            path.write_text(emit_observers_yaml(compiled, EmitOptions()), encoding="utf-8")
            paths.append(path)
        for path in paths:
            text = path.read_text(encoding="utf-8")
            _, specs = load_observers(path)
            line = f"{path.name}: {len(text) / 1e6:.1f} MB, {len(specs):,} observers"
            took = _best(args.repeat, partial(load_observers, path))
            line += f", load_observers {took * 1e3:.1f} ms"
            if args.yaml:
                loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
                took = _best(1, partial(yaml.load, text, Loader=loader))
                line += f", CSafeLoader {took * 1e3:.1f} ms"
            print(line, flush=True)


if __name__ == "__main__":
    main()
