"""The board's channels of a model file: which device is on which channel (docs/board.md)."""

from __future__ import annotations

from rac.board.channels import ChannelMap, channel_map
from rac.errors import Diagnostic, RacError
from rac.load.files import load_model
from rac.pipeline import compile_model


def load_board_channels(model_path: str) -> ChannelMap:
    """RAC092 for a model.yaml (it has no devices); a .ram or .json is compiled (quietly)."""
    if model_path.endswith((".yaml", ".yml")):
        raise RacError(
            [
                Diagnostic(
                    "RAC092",
                    "a model.yaml does not say which channel a device is on",
                    hint="give the .ram or ram/1 .json model to use the board",
                )
            ]
        )
    return channel_map(compile_model(load_model(model_path)).model)
