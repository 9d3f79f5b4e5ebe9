"""The type stubs and the docstrings follow the parameter schema."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import squish

TOOLS = Path(__file__).resolve().parents[1] / "tools" / "gen_stubs.py"


def test_the_stubs_are_up_to_date():
    spec = importlib.util.spec_from_file_location("gen_stubs", TOOLS)
    generator = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(generator)
    assert generator.STUBS.read_text() == generator.stubs(), (
        "python/squish/__init__.pyi is stale: run python crates/squish-py/tools/gen_stubs.py"
    )


def test_help_lists_every_parameter_with_its_default_and_meaning():
    schema = squish.params_schema()
    docs = {
        "object": [squish.deform.__doc__, squish.contact.__doc__, squish.Frame.add_object.__doc__],
        "pair": [squish.deform.__doc__, squish.Frame.add_pair.__doc__],
        "articulation": [squish.Frame.add_articulation.__doc__],
    }
    for row in schema:
        for doc in docs.get(row["level"], []):
            entry = f"{row['key']} ({row['kind']}, default {row['default']!r}): {row['summary']}"
            assert entry in doc, entry
