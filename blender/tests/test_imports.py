"""The add-on's modules import each other without a circle, function-level imports included (a
circle once hid behind an import inside a function: schema_props → live → evaluate →
schema_props). Read from the source text, so it needs no Blender."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "squish_blender"


def imports_of(path: Path) -> set[str]:
    """The add-on's modules a file imports, wherever the import statement is."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            if node.module:
                found.add(node.module.split(".")[0])
            else:
                found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("squish_blender."):
            found.add(node.module.split(".")[1])
    return found


def test_the_modules_import_each_other_without_a_circle():
    modules = {path.stem: path for path in PACKAGE.glob("*.py") if path.stem != "__init__"}
    graph = {name: imports_of(path) & modules.keys() for name, path in modules.items()}
    assert graph["schema_props"] == set(), graph["schema_props"]
    state: dict[str, str] = {}

    def visit(name: str, path: list[str]) -> None:
        if state.get(name) == "done":
            return
        assert state.get(name) != "open", "import circle: " + " → ".join([*path, name])
        state[name] = "open"
        for other in sorted(graph[name]):
            visit(other, [*path, name])
        state[name] = "done"

    for name in sorted(graph):
        visit(name, [])


def test_the_check_sees_function_level_imports(tmp_path):
    source = tmp_path / "example.py"
    source.write_text("def f():\n    from . import live\n    from .evaluate import SetupError\n")
    assert imports_of(source) == {"live", "evaluate"}
