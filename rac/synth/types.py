"""ROS message types for synthetic recordings: the standard ones from rosbags' typestores,
custom ones (``tedusar_msgs/ServoState``) generated from the model's field list.

A custom type gets one ``float64`` per field; a dotted field (``info.width``) becomes a
nested generated type (``InfoOfServoState``-style names: ``<Type><Part>``).  The message
definitions go into the bag, so any ROS tool can read them.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from rac.ir import Topic
from rac.learn.fields import NUMERIC_TYPES

CUSTOM_PACKAGE = "racc_synth_msgs"  # for topics whose model gives no type
DTYPES = {
    "bool": np.uint8,
    "byte": np.uint8,
    "char": np.uint8,
    "octet": np.uint8,
    "int8": np.int8,
    "uint8": np.uint8,
    "int16": np.int16,
    "uint16": np.uint16,
    "int32": np.int32,
    "uint32": np.uint32,
    "int64": np.int64,
    "uint64": np.uint64,
    "float32": np.float32,
    "float64": np.float64,
}


def field_defs(store: Typestore, typename: str) -> list[tuple[str, tuple[Any, Any]]]:
    """The (name, (node type, detail)) fields of a type, loosely typed for walking."""
    fields: list[tuple[str, tuple[Any, Any]]] = list(store.fielddefs[typename][1])
    return fields


def new_typestore(ros_version: int) -> Typestore:
    return get_typestore(Stores.ROS1_NOETIC if ros_version == 1 else Stores.ROS2_HUMBLE)


def store_name(model_type: str) -> str:
    """``sensor_msgs/Imu`` -> ``sensor_msgs/msg/Imu``."""
    if "/msg/" in model_type:
        return model_type
    package, _, name = model_type.rpartition("/")
    return f"{package}/msg/{name}"


def _camel(text: str) -> str:
    return "".join(p[:1].upper() + p[1:] for p in text.replace("/", "_").split("_") if p)


def resolve_type(topic: Topic, store: Typestore) -> str:
    """The typestore name of ``topic``'s message type, registering a custom one if needed."""
    if topic.msg_type is None:
        if not topic.fields:
            return "std_msgs/msg/Empty"
        name = f"{CUSTOM_PACKAGE}/msg/{_camel(topic.name.value)}"
    else:
        name = store_name(topic.msg_type)
    if name not in store.fielddefs:
        _register(name, [f.value for f in topic.fields] or ["data"], store)
    return name


def _register(name: str, fields: list[str], store: Typestore) -> None:
    package = name.split("/")[0]
    types: dict[str, Any] = {}

    def define(typename: str, paths: list[str]) -> None:
        lines: list[str] = []
        groups: dict[str, list[str]] = {}
        for p in paths:
            head, _, rest = p.partition(".")
            if rest:
                groups.setdefault(head, []).append(rest)
            elif f"float64 {head}" not in lines:
                lines.append(f"float64 {head}")
        for head, inner_paths in groups.items():
            sub = f"{typename}{_camel(head)}"
            define(sub, inner_paths)
            lines.append(f"{package}/{sub.rpartition('/')[2]} {head}")
        types.update(get_types_from_msg("\n".join(lines) + "\n", typename))

    define(name, fields)
    store.register(types)


class MessageFactory:
    """Builds zero-valued messages of any type in a typestore, fast: the per-type recipe
    (which fields are numbers, strings, arrays, nested messages) is worked out once."""

    def __init__(self, store: Typestore) -> None:
        self.store = store
        self._recipes: dict[str, list[tuple[str, str, Any]]] = {}

    def _recipe(self, typename: str) -> list[tuple[str, str, Any]]:
        recipe = self._recipes.get(typename)
        if recipe is not None:
            return recipe
        recipe = []
        for name, (nodetype, detail) in field_defs(self.store, typename):
            if nodetype == Nodetype.BASE:
                base = detail[0]
                value: Any = "" if base == "string" else False if base == "bool" else 0
                if base in ("float32", "float64"):
                    value = 0.0
                recipe.append((name, "value", value))
            elif nodetype == Nodetype.NAME:
                recipe.append((name, "message", detail))
            else:
                (inner_type, inner), length = detail
                fixed = length if nodetype == Nodetype.ARRAY else 0
                if inner_type == Nodetype.BASE and inner[0] in DTYPES:
                    recipe.append((name, "array", (fixed, DTYPES[inner[0]])))
                elif inner_type == Nodetype.BASE:
                    recipe.append((name, "strings", fixed))
                else:
                    recipe.append((name, "messages", (fixed, inner)))
        self._recipes[typename] = recipe
        return recipe

    def new(self, typename: str) -> Any:
        """A message of ``typename`` with every field at its zero value."""
        kwargs: dict[str, Any] = {}
        for name, kind, arg in self._recipe(typename):
            if kind == "value":
                kwargs[name] = arg
            elif kind == "message":
                kwargs[name] = self.new(arg)
            elif kind == "array":
                kwargs[name] = np.zeros(arg[0], dtype=arg[1])
            elif kind == "strings":
                kwargs[name] = [""] * arg
            else:
                kwargs[name] = [self.new(arg[1]) for _ in range(arg[0])]
        return self.store.types[typename](**kwargs)


def leaf_types(store: Typestore, typename: str, prefix: str = "") -> dict[str, str]:
    """Dotted path -> base type of every numeric scalar, and ``path[]`` for numeric arrays."""
    out: dict[str, str] = {}
    for name, (nodetype, detail) in field_defs(store, typename):
        path = prefix + name
        if nodetype == Nodetype.BASE and detail[0] in NUMERIC_TYPES:
            out[path] = detail[0]
        elif nodetype == Nodetype.NAME:
            out.update(leaf_types(store, detail, path + "."))
        elif nodetype in (Nodetype.ARRAY, Nodetype.SEQUENCE):
            (inner_type, inner), _ = detail
            if inner_type == Nodetype.BASE and inner[0] in DTYPES:
                out[path + "[]"] = inner[0]
    return out
