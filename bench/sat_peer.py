"""The python-sat peer of ``racc diagnose MODEL.yaml --obs-file F --json``, whole process.

Run:  python bench/sat_peer.py MODEL.yaml OBS.txt [--max-card K]
Needs python-sat (``.venv/bin/pip install python-sat``); a bench comparison, never a racc
dependency.  It reads model.yaml with PyYAML's C loader, encodes the Horn clauses as CNF
(``p`` and ``not_p`` exclusive, AB(c) xor NAB(c), observations as units) and enumerates the
minimal diagnoses with RC2 (soft NAB(c), each found diagnosis blocked with its supersets),
printing them as racc's JSON does.
"""

import json
import re
import sys

import yaml
from pysat.examples.rc2 import RC2
from pysat.formula import WCNF

path, obs_path = sys.argv[1], sys.argv[2]
max_card = int(sys.argv[4]) if len(sys.argv) > 4 and sys.argv[3] == "--max-card" else None
with open(path, encoding="utf-8") as stream:
    doc = yaml.load(stream, Loader=yaml.CSafeLoader)
ab, nab, neg = doc.get("ab", "AB"), doc.get("nab", "NAB"), doc.get("neg_prefix", "not_")
ids: dict[str, int] = {}


def var(atom: str) -> int:
    atom = atom.replace(" ", "")
    found = ids.get(atom)
    if found is None:
        found = ids[atom] = len(ids) + 1
    return found


split = re.compile(r",\s*(?![^()]*\))")
wcnf = WCNF()
for rule in doc["rules"]:
    body, _, head = rule.partition("->")
    clause = [-var(a) for a in split.split(body.strip()) if a]
    head = head.strip()
    wcnf.append(clause if head == "false" else [*clause, var(head)])
for atom in list(ids):  # complementary atoms exclude each other
    if atom.startswith(neg) and atom.removeprefix(neg) in ids:
        wcnf.append([-ids[atom], -ids[atom.removeprefix(neg)]])
comps = sorted({a[len(nab) + 1 : -1] for a in ids if a.startswith(nab + "(")})
comps += sorted({a[len(ab) + 1 : -1] for a in ids if a.startswith(ab + "(")} - set(comps))
comps.sort()
for c in comps:  # exactly one of AB(c), NAB(c); NAB(c) is preferred (soft)
    wcnf.append([var(f"{ab}({c})"), var(f"{nab}({c})")])
    wcnf.append([-var(f"{ab}({c})"), -var(f"{nab}({c})")])
    wcnf.append([var(f"{nab}({c})")], weight=1)
with open(obs_path, encoding="utf-8") as stream:
    lines = stream.read().splitlines()
for line in lines:
    text = line.split("#", 1)[0].strip()
    if text:
        negative = text.startswith("not ")
        atom = text.removeprefix("not ").strip()
        wcnf.append([-var(atom) if negative else var(atom)])
diagnoses: list[list[str]] = []
with RC2(wcnf, solver="g4") as rc2:
    while (model := rc2.compute()) is not None:
        if max_card is not None and rc2.cost > max_card:
            break
        true = {v for v in model if v > 0}
        bad = sorted(c for c in comps if ids[f"{nab}({c})"] not in true)
        diagnoses.append(bad)
        rc2.add_clause([ids[f"{nab}({c})"] for c in bad])  # block it and its supersets
        if not bad:
            break
print(json.dumps({"consistent": diagnoses == [[]], "diagnoses": [{"bad": d} for d in diagnoses]}))
