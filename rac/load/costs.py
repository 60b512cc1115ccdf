"""Cost files of ``racc place --costs``: what each added observer would cost."""

from __future__ import annotations

import yaml

from rac.errors import Diagnostic, RacError
from rac.limits import safe_yaml, yaml_error_diagnostic
from rac.load.files import read_text
from rac.load.kinds import COSTS, check_kind


def load_costs(path: str) -> dict[str, float]:
    """Observer kind, candidate or watched name -> a positive cost (RAC062 otherwise)."""
    check_kind(path, COSTS, "RAC062")
    text = read_text(path)
    try:
        doc = safe_yaml(text, path)
    except yaml.YAMLError as err:
        raise RacError([yaml_error_diagnostic(err, path, "RAC062")], text) from None
    if doc is None:
        return {}
    bad = not isinstance(doc, dict) or any(
        not isinstance(k, str) or isinstance(v, bool) or not isinstance(v, int | float) or v <= 0
        for k, v in doc.items()
    )
    if bad:
        raise RacError(
            [
                Diagnostic(
                    "RAC062",
                    f"{path}: costs must map observer kinds or names to positive numbers",
                    hint="e.g. 'GObs: 1', 'PObs: 2', 'GObs /map: 5'",
                )
            ]
        )
    return {str(k): float(v) for k, v in doc.items()}
