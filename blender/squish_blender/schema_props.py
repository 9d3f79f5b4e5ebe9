"""Blender properties generated from the parameter schema (`squish.params_schema()`).

The add-on declares no deformer parameter by hand: each object, pair and articulation key of the
schema becomes a Blender property with the schema's name, default, range and meaning, so the
add-on follows the library when a parameter is added or its range changes. Blender stores
numbers as 32-bit floats, so a value is passed to squish only when it differs from the schema's
default as Blender stores it: untouched properties give exactly the library's defaults.

Mapping from a schema row to properties (`key` is the schema's key):
- bool → BoolProperty `key`; number → FloatProperty `key`; choice → EnumProperty `key`;
  vector → FloatVectorProperty `key` (3); pair → FloatVectorProperty `key` (2);
- optional keys (their default is a word: "auto", "none", "joints") get a BoolProperty
  `use_key` (off: the word, the schema's default) beside the value property;
- per-vertex keys (`bulge_map`, `region_mask`) are StringProperty `key` naming a vertex group
  (empty: the word, e.g. "uniform").
"""

from __future__ import annotations

import functools
import math

import bpy
import numpy as np

import squish

# Numbers Blender shows and steps with; the schema's ranges are the hard limits.
_FLOAT_UI = {"precision": 3, "step": 10}
# The value a number property holds while its optional key is at its word ("auto"): a value
# inside the range that the user starts from when switching the key on.
_OPTIONAL_START = 1.0
_VECTOR_START = (0.0, 0.0, 1.0)


@functools.cache
def schema_rows(level: str) -> tuple[dict, ...]:
    """The schema's rows of one level ("object", "pair", "articulation"), in schema order (the
    schema is fixed for the loaded squish package: read once, not at every frame)."""
    return tuple(row for row in squish.params_schema() if row["level"] == level)


def _label(key: str) -> str:
    return key.replace("_", " ").capitalize()


def _tooltip(row: dict) -> str:
    """The schema's one-line meaning with its symbol, thesis section and valid range."""
    details = [part for part in (row.get("symbol"), row.get("section")) if part]
    if "range" in row:
        details.append("valid: " + row["range"]["text"])
    if row.get("unit"):
        details.append(row["unit"])
    text = row["summary"]
    if details:
        text += " [" + "; ".join(details) + "]"
    # Blender tooltips end without a period of their own; the schema's summaries end with one.
    return text.rstrip(".")


def _bound(value) -> float | None:
    """A schema bound as a Blender limit (None when unbounded)."""
    if isinstance(value, str):
        return None
    return float(value) if math.isfinite(value) else None


def _number_limits(row: dict) -> dict:
    limits = {}
    if "range" in row:
        low, high = _bound(row["range"]["min"]), _bound(row["range"]["max"])
        # Blender limits are inclusive; an exclusive bound (stiffness > 0) is kept as the limit
        # and squish rejects the bound itself with a ParameterError the add-on reports.
        if low is not None:
            limits["min"] = low
        if high is not None:
            limits["max"] = high
    return limits


def _start_value(row: dict) -> float:
    """A start value for an optional number: 1 if the range allows it, else its midpoint."""
    limits = _number_limits(row)
    low, high = limits.get("min", -math.inf), limits.get("max", math.inf)
    if low <= _OPTIONAL_START <= high:
        return _OPTIONAL_START
    return (low + high) / 2 if math.isfinite(high) else low + 1.0


def properties_of(level: str, update) -> dict[str, bpy.props._PropertyDeferred]:
    """Blender property definitions (annotations) for every key of one schema level; `update` is
    every property's update callback (live mode's: Blender runs no depsgraph update when an
    add-on's property changes). Given by the caller, so that this module imports no other module
    of the add-on (tests/test_imports.py)."""
    annotations = {}
    for row in schema_rows(level):
        key, kind = row["key"], row["kind"]
        optional = row["optional"]
        default = row["default"]
        # What every property of a key shares: its label, tooltip and the live-mode refresh.
        common = {"name": _label(key), "description": _tooltip(row), "update": update}
        if optional and kind != "per_vertex":
            auto = f": {row['auto']}" if row.get("auto") else ""
            annotations[f"use_{key}"] = bpy.props.BoolProperty(
                name=f"Set {_label(key)}", description=f"Off: {row['word']}{auto}. On: the value below",
                default=False, update=update,
            )
        if kind == "bool":
            annotations[key] = bpy.props.BoolProperty(default=bool(default) if not optional else False, **common)
        elif kind == "number":
            value = float(default) if not optional else _start_value(row)
            annotations[key] = bpy.props.FloatProperty(default=value, **_number_limits(row), **_FLOAT_UI, **common)
        elif kind == "choice":
            items = [(choice, _label(choice), f"{key} = \"{choice}\"") for choice in row["choices"]]
            annotations[key] = bpy.props.EnumProperty(items=items, default=default, **common)
        elif kind == "vector":
            start = tuple(default) if not optional else _VECTOR_START
            annotations[key] = bpy.props.FloatVectorProperty(size=3, default=start, subtype="XYZ", **common)
        elif kind == "pair":
            annotations[key] = bpy.props.FloatVectorProperty(
                size=2, default=tuple(default), **_number_limits(row), **_FLOAT_UI, **common
            )
        elif kind == "per_vertex":
            common["description"] += (f". A vertex group of the object (its weights, 0 outside the group); "
                                      f"empty: {row['word']}")
            annotations[key] = bpy.props.StringProperty(default="", **common)
        else:
            # A kind this add-on does not know yet must fail loudly at registration rather than
            # leave a parameter out of the interface.
            raise TypeError(f"schema key {level}.{key}: kind {kind!r} has no Blender property mapping")
    return annotations


def _as_float32(value: float) -> float:
    return float(np.float32(value))


def _differs(row: dict, value) -> bool:
    """Whether a property's value differs from the schema's default as Blender stores it."""
    default = row["default"]
    if row["kind"] == "number":
        return _as_float32(value) != _as_float32(default)
    if row["kind"] == "pair":
        return [_as_float32(v) for v in value] != [_as_float32(v) for v in default]
    if row["kind"] == "vector":
        return True
    return value != default


def parameters_from(settings, level: str, vertex_group_weights=None) -> dict:
    """The squish parameters of a settings PropertyGroup: only keys that differ from the schema's
    defaults (Blender's 32-bit numbers would otherwise shift every default slightly).

    `vertex_group_weights(key, group_name)` turns a per-vertex key's vertex group into weights;
    it raises the add-on's SetupError for a group that does not exist."""
    params = {}
    for row in schema_rows(level):
        key, kind = row["key"], row["kind"]
        if kind == "per_vertex":
            group = getattr(settings, key)
            if group:
                params[key] = vertex_group_weights(key, group)
            continue
        if row["optional"] and not getattr(settings, f"use_{key}"):
            continue
        value = getattr(settings, key)
        if kind in ("vector", "pair"):
            value = [float(v) for v in value]
        elif kind == "number":
            value = float(value)
        if row["optional"] or _differs(row, value):
            params[key] = value
    return params


def draw_level(layout, settings, level: str, skip=()) -> None:
    """Draws every property of one schema level (optional keys as a checkbox and their value)."""
    for row in schema_rows(level):
        key = row["key"]
        if key in skip:
            continue
        if row["optional"] and row["kind"] != "per_vertex":
            line = layout.row(align=True)
            line.prop(settings, f"use_{key}", text="")
            value = line.row(align=True)
            value.active = getattr(settings, f"use_{key}")
            value.prop(settings, key)
            if not getattr(settings, f"use_{key}"):
                line.label(text=row["word"])
        else:
            layout.prop(settings, key)
