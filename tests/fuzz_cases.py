"""Hostile inputs for racc, by kind, and the verdict on one run (tests/test_fuzz.py, bench/fuzz.py).

Every case is made from a seed alone, so a crash or a hang found by ``bench/fuzz.py`` is
reproduced with ``make_case(kind, seed)``.  Kinds: ``ram`` (the DSL), ``json`` (ram/1),
``yaml`` (a model-server model.yaml), ``literal`` (``--obs``), ``sqlite3`` and ``mcap`` (a
short ROS 2 recording with damaged bytes, through ``learn`` or ``replay``) and ``deepyaml``
(YAML nested up to thousands deep, in every YAML file racc or rosbags reads).  A run ends in one
of:
``accepted`` (exit 0, and every output parses back), ``error`` (a clean, coded error, exit 1),
``crash`` (anything else: exit 70, a traceback, an output racc cannot read back).
"""

from __future__ import annotations

import contextlib
import io
import json
import random
import shutil
import tempfile
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import yaml
from lxml import etree
from pddl.parser.domain import DomainParser

from rac.cli import main

ROOT = Path(__file__).resolve().parent.parent
MODELS = (ROOT / "models" / "tedusar.ram", ROOT / "models" / "pioneer.ram")
CORPUS = Path(__file__).resolve().parent / "fuzz_corpus"
KINDS = ("ram", "json", "yaml", "literal", "sqlite3", "mcap", "deepyaml")

# Hostile fragments: numbers out of range, odd names, characters no output format likes.
_NUMBERS = ["1e400", "1e999", "-1e999", "9" * 400, "0" * 60 + "1", "1e-400", "5e-324", "NaN",
            "Infinity", "-0", "1e15", "1e16", ".5", "00", "1.", "+-", "±"]  # fmt: skip
_CHARS = ["\x00", "\x01", "\x0c", "\ufffe", "\ud800", '"', "'", "<", ">", "&", ":", " ", "é",
          "~", "/", "\\", "(", ")", ",", ";", "{", "}", "#", "\n", "\t", "@", ".", "-", "ß",
          "\u202e", "\U0001f916"]  # fmt: skip
_WORDS = ["robot", "hardware", "topic", "node", "relate", "interval", "switchable", "channel",
          "drives", "subscribes", "publishes", "from", "limits", "cpu", "mem", "reports",
          "Hz", "window", "mismatch", "within", "MB", "ms", "~x", "/", "/t", "a.b", "x" * 300,
          "I(", "not", "ok", "NAB", "AB", "false", "->"]  # fmt: skip


@dataclass(frozen=True, slots=True)
class Case:
    kind: str
    seed: int
    text: str  # the model (``literal``: the literal; ``deepyaml``: the YAML; bags: the damage)
    data: bytes = b""  # a damaged bag's storage file
    target: str = ""  # ``deepyaml``: which file of which command the text is given as


@cache
def seeds_ram() -> tuple[str, ...]:
    texts = [p.read_text(encoding="utf-8") for p in MODELS]
    texts += [p.read_text(encoding="utf-8") for p in sorted(CORPUS.glob("*.ram"))]
    return tuple(texts)


@cache
def seeds_json() -> tuple[str, ...]:
    from rac.interchange import dumps
    from rac.load.files import load_model

    texts = [dumps(load_model(p)) for p in MODELS]
    texts += [p.read_text(encoding="utf-8") for p in sorted(CORPUS.glob("*.json"))]
    return tuple(texts)


@cache
def seeds_yaml() -> tuple[str, ...]:
    from rac.load.files import load_model
    from rac.pipeline import compile_model
    from rac.targets import EmitOptions, emit_all

    texts = [
        str(dict(emit_all(compile_model(load_model(p)), EmitOptions()))["model.yaml"])
        for p in MODELS
    ]
    texts += [p.read_text(encoding="utf-8") for p in sorted(CORPUS.glob("*.yaml"))]
    return tuple(texts)


def _fragment(rng: random.Random) -> str:
    pick = rng.random()
    if pick < 0.3:
        return rng.choice(_NUMBERS)
    if pick < 0.6:
        return rng.choice(_CHARS) * rng.choice([1, 1, 1, 2, 50])
    if pick < 0.9:
        return " " + rng.choice(_WORDS) + " "
    return rng.choice(["[", "{", "(", "ok(", " "]) * rng.choice([10, 1000, 5000])


def mutate_text(text: str, rng: random.Random) -> str:
    """A few random edits: insert a hostile fragment, delete, duplicate or swap a span."""
    for _ in range(rng.randint(1, 4)):
        i = rng.randrange(len(text) + 1)
        j = min(len(text), i + rng.randint(0, 40))
        op = rng.random()
        if op < 0.5:
            text = text[:i] + _fragment(rng) + text[i:]
        elif op < 0.7:
            text = text[:i] + text[j:]
        elif op < 0.85:
            text = text[:i] + text[i:j] * rng.randint(2, 5) + text[j:]
        elif text:
            k = rng.randrange(len(text))
            text = text[:i] + text[k : k + 20] + text[i:]
    return text


def _hostile_value(rng: random.Random) -> object:
    choices: list[object] = [
        float("nan"), float("inf"), 10**400, -(10**40), 1e-320, "a/\ud800", 'a"b', "a<b&c",
        "a b", "ü", "\x00", "x" * 2000, "~x", "/", "", None, True, [], {}, [[[[]]]], 3, 2.5,
        "ok(x)", "a:b",
    ]  # fmt: skip
    return rng.choice(choices)


def _mutate_json_doc(doc: object, rng: random.Random) -> object:
    """Replace one value anywhere in the document by a hostile one."""
    paths: list[tuple[object, object]] = []
    stack = [doc]
    while stack:
        item = stack.pop()
        if isinstance(item, dict):
            paths.extend((item, k) for k in item)
            stack.extend(item.values())
        elif isinstance(item, list):
            paths.extend((item, i) for i in range(len(item)))
            stack.extend(item)
    if not paths:
        return doc
    for _ in range(rng.randint(1, 3)):
        container, key = rng.choice(paths)
        if isinstance(container, dict) and rng.random() < 0.2:
            container.pop(key, None)
        else:
            container[key] = _hostile_value(rng)  # type: ignore[index]
    return doc


# ---------------------------------------------------------------------------------------------
# Damaged ROS 2 recordings: a short synthetic run of tedusar, its storage file with bytes
# changed, cut or overwritten (the structure's length and pointer fields more often than not).

_HOSTILE_U64 = (2**63, 2**64 - 1, 2**62, 2**32, 2**31 - 1, 0, 1)


_BASE_BAGS: dict[str, Path] = {}


def base_bag(storage: str) -> Path:
    """A 1 s recording of tedusar (``racc synth --ros2``), made once per process."""
    if storage not in _BASE_BAGS:
        run = Path(tempfile.mkdtemp(prefix="racc-fuzz-bag-")) / "run"
        code, _, err = _run(["synth", str(MODELS[0]), "-o", str(run), "--ros2", "--storage",
                             storage, "--duration", "1", "-q"])  # fmt: skip
        assert code == 0, err
        _BASE_BAGS[storage] = run
    return _BASE_BAGS[storage]


def remove_base_bags() -> None:
    """Delete the recordings :func:`base_bag` made in this process."""
    for run in _BASE_BAGS.values():
        shutil.rmtree(run.parent, ignore_errors=True)
    _BASE_BAGS.clear()


def _storage_file(run: Path) -> Path:
    return next(f for f in sorted(run.iterdir()) if f.suffix in (".db3", ".mcap"))


def _structure_offsets(data: bytes, storage: str) -> list[int]:
    """Where the damage hurts most: SQLite's page headers and cell pointers, MCAP's record
    opcodes and lengths (top-level and inside uncompressed chunks)."""
    if storage == "sqlite3":
        page = int.from_bytes(data[16:18], "big") or 65536
        return [p + i for p in range(0, len(data), page) for i in range(16)]
    offsets: list[int] = []
    at = 8
    while at + 9 <= len(data):
        offsets.extend(range(at, at + 9))
        length = int.from_bytes(data[at + 1 : at + 9], "little")
        if data[at] == 0x06:  # a chunk: its records follow a header of 28 bytes + compression
            inner = at + 9 + 28
            name = int.from_bytes(data[inner : inner + 4], "little")
            inner += 4 + name + 8
            while inner + 9 <= min(len(data), at + 9 + length):
                offsets.extend(range(inner, inner + 9))
                inner += 9 + int.from_bytes(data[inner + 1 : inner + 9], "little")
        at += 9 + length
    return offsets or [0]


def damage_bytes(data: bytes, storage: str, rng: random.Random) -> tuple[bytes, str]:
    """``data`` damaged in one to three ways, and what was done."""
    out = bytearray(data)
    done = []
    structure = _structure_offsets(data, storage)
    for _ in range(rng.choice([1, 1, 1, 2, 3])):
        at = rng.choice(structure) if rng.random() < 0.5 else rng.randrange(len(out))
        op = rng.random()
        if op < 0.6:
            out[at] = rng.randrange(256)
            done.append(f"byte {at} = {out[at]}")
        elif op < 0.75:
            value = rng.choice(_HOSTILE_U64)
            out[at : at + 8] = value.to_bytes(8, rng.choice(["little", "big"]))
            done.append(f"8 bytes at {at} = {value}")
        elif op < 0.85:
            size = rng.choice([1, 16, 512, 4096])
            out[at : at + size] = bytes(min(size, len(out) - at))
            done.append(f"{size} zero bytes at {at}")
        else:
            del out[at:]
            done.append(f"cut at {at}")
            break
    return bytes(out), "; ".join(done)


# ---------------------------------------------------------------------------------------------
# YAML nested deep: every YAML file racc reads, and the metadata.yaml rosbags reads.

DEEP_YAML_TARGETS = ("tug", "costs", "observers", "repairer", "truth", "faults", "model.yaml",
                     "graph", "metadata")  # fmt: skip


def deep_yaml(rng: random.Random) -> str:
    """A value nested ``depth`` deep (flow or block, lists or mappings), maybe left open or
    followed by junk."""
    depth = int(10 ** rng.uniform(0.5, 3.7))  # 3 to 5,000
    shape = rng.choice(["[", "{", "[{", "block-", "blockmap", "inline-"])
    if shape == "[":
        text = "[" * depth + ("]" * depth if rng.random() < 0.5 else "")
    elif shape == "{":
        text = "{a: " * depth + "1" + ("}" * depth if rng.random() < 0.5 else "")
    elif shape == "[{":
        text = "[{b: " * (depth // 2) + "x" + "}]" * (depth // 2)
    elif shape == "inline-":
        text = "- " * depth + "x"
    else:
        key = "- " if shape == "block-" else "k: "
        depth = min(depth, 1200)  # the indentation grows as depth squared
        text = "\n" + "".join("  " * (i + 1) + key + "\n" for i in range(depth))
        text += "  " * depth + "  x"
    if rng.random() < 0.3:
        text = text.replace("[", "[\n", rng.randint(1, 50))
    if rng.random() < 0.2:
        text += rng.choice(["@", "\t", "]", "}", ": :", "&a", "*a", "\x00", "'"])
    return text


def _deep_yaml_case(seed: int, rng: random.Random) -> Case:
    target = rng.choice(DEEP_YAML_TARGETS)
    nest = deep_yaml(rng)
    if target == "metadata":
        text = "rosbag2_bagfile_information:\n  custom_data: " + nest + "\n"
    else:
        keys = {"tug": "nodes", "observers": "observers", "repairer": "observers",
                "truth": "faults", "faults": "faults", "graph": "nodes"}  # fmt: skip
        key = keys.get(target, "a")
        text = f"{key}: {nest}\n" if rng.random() < 0.8 else nest
    return Case("deepyaml", seed, text, target=target)


def make_case(kind: str, seed: int) -> Case:
    rng = random.Random(f"{kind}:{seed}")
    if kind in ("sqlite3", "mcap"):
        data, done = damage_bytes(_storage_file(base_bag(kind)).read_bytes(), kind, rng)
        return Case(kind, seed, done, data)
    if kind == "deepyaml":
        return _deep_yaml_case(seed, rng)
    if kind == "ram":
        return Case(kind, seed, mutate_text(rng.choice(seeds_ram()), rng))
    if kind == "json":
        base = rng.choice(seeds_json())
        if rng.random() < 0.6:
            try:  # the corpus holds JSON Python itself cannot load
                doc = _mutate_json_doc(json.loads(base), rng)
                text = json.dumps(doc, ensure_ascii=rng.random() < 0.5)
            except (ValueError, RecursionError):
                text = base
            return Case(kind, seed, text)
        return Case(kind, seed, mutate_text(base, rng))
    if kind == "yaml":
        return Case(kind, seed, mutate_text(rng.choice(seeds_yaml()), rng))
    if kind == "literal":
        base = rng.choice(["ok(pose)", "not ok(pose)", "not_ok(scan)", "running(jaguar_node)",
                           "¬ok(imu_data)", "on(jaguar)", "ok(jaguar_node, cpu)"])  # fmt: skip
        return Case(kind, seed, mutate_text(base, rng))
    raise ValueError(kind)


# ---------------------------------------------------------------------------------------------


def _run(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as stop:  # argparse
            code = stop.code if isinstance(stop.code, int) else 2
    return code, out.getvalue(), err.getvalue()


def _verdict(code: int, err: str) -> str | None:
    if code == 0:
        return None
    if code in (1, 2) and "Traceback" not in err and ("error[RAC" in err or code == 2):
        return "error"
    return "crash"


def check_outputs(directory: Path) -> None:
    """Every output of ``racc compile`` parses back; raises AssertionError otherwise."""
    for name in ("observers.yaml",):
        yaml.safe_load((directory / name).read_text(encoding="utf-8"))
    for name in ("observers.launch", "observers.launch.xml"):
        root = etree.fromstring((directory / name).read_bytes())
        assert root.tag == "launch", name
    DomainParser()((directory / "repair_domain.pddl").read_text(encoding="utf-8"))
    code, _, err = _run(["diagnose", str(directory / "model.yaml"), "--max-card", "1"])
    assert code == 0, f"racc diagnose cannot read model.yaml back: {err[:500]}"


def run_case(case: Case, workdir: Path) -> tuple[str, str]:
    """``(outcome, detail)``: outcome is accepted, error or crash."""
    try:
        return _run_case(case, workdir)
    except AssertionError as err:
        return "crash", f"output does not read back: {err}"[:2000]
    except Exception as err:
        return "crash", f"{type(err).__name__}: {err}"[:2000]


def _run_bag_case(case: Case, workdir: Path) -> tuple[str, str]:
    """The damaged recording through ``learn`` (odd seeds) or ``replay`` (even seeds)."""
    base = base_bag(case.kind)
    run = workdir / "run"
    shutil.copytree(base, run)
    _storage_file(run).write_bytes(case.data)
    if case.seed % 2:
        argv = ["learn", str(run), "-o", str(workdir / "learned.ram"), "-q"]
    else:
        argv = ["replay", str(MODELS[0]), str(run), "-q"]
    code, _, err = _run(argv)
    return _verdict(code, err) or "accepted", err[-2000:]


def _run_deep_yaml_case(case: Case, workdir: Path) -> tuple[str, str]:
    """The YAML as the file ``case.target`` names, read by the command that reads it."""
    path = workdir / "deep.yaml"
    path.write_text(case.text, encoding="utf-8", errors="surrogatepass")
    model, out = str(MODELS[0]), str(workdir / "out.ram")
    run = workdir / "run"
    if case.target in ("truth", "faults", "graph", "metadata"):
        shutil.copytree(base_bag("sqlite3"), run)
    argv = {
        "tug": ["import", "tug", str(path), "-o", out, "-q"],
        "costs": ["place", model, "--costs", str(path), "-q"],
        "observers": ["observe", str(path)],
        "repairer": ["repairer", model, "--observers", str(path)],
        "truth": ["replay", model, str(run), "--truth", str(path), "-q"],
        "faults": ["evaluate", "--models", model, "--runs", str(run), "-q"],
        "model.yaml": ["diagnose", str(path), "--max-card", "1"],
        "graph": ["learn", str(run), "--graph", str(path), "-o", out, "-q"],
        "metadata": ["learn", str(run), "-o", out, "-q"],
    }[case.target]
    if case.target == "faults":
        shutil.copy(path, workdir / "run.faults.yaml")
    if case.target == "metadata":
        shutil.copy(path, run / "metadata.yaml")
    code, _, err = _run(argv)
    return _verdict(code, err) or "accepted", err[-2000:]


def _run_case(case: Case, workdir: Path) -> tuple[str, str]:
    if case.kind in ("sqlite3", "mcap"):
        return _run_bag_case(case, workdir)
    if case.kind == "deepyaml":
        return _run_deep_yaml_case(case, workdir)
    if case.kind == "literal":
        code, _, err = _run(["diagnose", str(_tedusar_yaml()), "--obs", case.text])
        return _verdict(code, err) or "accepted", err[-2000:]
    suffix = {"ram": ".ram", "json": ".json", "yaml": ".yaml"}[case.kind]
    model = workdir / f"case{suffix}"
    model.write_text(case.text, encoding="utf-8", errors="surrogatepass")
    if case.kind == "yaml":
        code, _, err = _run(["diagnose", str(model), "--max-card", "2"])
        return _verdict(code, err) or "accepted", err[-2000:]
    out = workdir / "out"
    code, _, err = _run(["compile", str(model), "-o", str(out), "-q", "--no-svg"])
    verdict = _verdict(code, err)
    if verdict is not None:
        return verdict, err[-2000:]
    check_outputs(out)
    code, _, err = _run(
        ["fmt", "--check", str(model)] if case.kind == "ram" else ["check", str(model)]
    )
    if code not in (0, 1) or "internal error" in err:
        return "crash", err[-2000:]
    return "accepted", ""


@cache
def _tedusar_yaml() -> Path:
    directory = Path(tempfile.mkdtemp(prefix="racc-fuzz-"))
    path = directory / "model.yaml"
    path.write_text(seeds_yaml()[0], encoding="utf-8")
    return path
