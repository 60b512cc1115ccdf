"""A diagnosis :class:`~rac.diagnosis.theory.Theory` from the file a user names."""

from __future__ import annotations

import re
from pathlib import Path

from rac.diagnosis.theory import Theory, theory_of
from rac.load.files import load_model, read_text
from rac.load.kinds import THEORY, check_kind
from rac.load.model_yaml import parse_model_yaml
from rac.logic import mangle


def load_theory(path: str) -> Theory:
    """A theory from a ``.ram``/``.json`` model (compiled) or a ``.yaml``/``.yml`` file."""
    check_kind(path, THEORY, "RAC004")
    if path.endswith((".yaml", ".yml")):
        return parse_model_yaml(read_text(path), path)
    # On first use, for start-up time: `racc diagnose model.yaml` never loads the compiler.
    from rac.pipeline import compile_model

    return theory_of(compile_model(load_model(path)))


def robot_name(theory: Theory, path: str) -> str:
    """The RAM's name; for a model server file, the name in racc's header line, else its
    stem (its directory's name for model.yaml)."""
    if theory.model is not None:
        return theory.model.name.value
    if theory.robot is not None:
        return theory.robot
    file = Path(path)
    stem = file.parent.resolve().name if file.stem == "model" else file.stem
    return re.sub(r"[^A-Za-z0-9_]", "_", mangle(stem)) or "robot"
