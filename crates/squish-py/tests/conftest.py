"""Shared fixtures: procedural meshes, the repository's example scene, and the `squish` command
built from the same workspace (the CLI comparisons run it)."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import squish

REPOSITORY = Path(__file__).resolve().parents[3]
EXAMPLE_SCENE = REPOSITORY / "examples" / "press" / "press.toml"


def squish_command() -> Path:
    """The `squish` binary: $SQUISH_CLI, else the workspace's target/debug or target/release."""
    if "SQUISH_CLI" in os.environ:
        return Path(os.environ["SQUISH_CLI"])
    for profile in ("debug", "release"):
        path = REPOSITORY / "target" / profile / "squish"
        if path.is_file():
            return path
    pytest.fail("no squish binary: build it with `cargo build -p squish-cli` or set SQUISH_CLI")


@pytest.fixture(scope="session")
def cli():
    """Runs `squish ARGS…`, returning the completed process (output as text)."""
    binary = squish_command()

    def run(*args, check=True):
        process = subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True)
        if check and process.returncode != 0:
            raise AssertionError(f"squish {' '.join(map(str, args))} failed ({process.returncode}): {process.stderr}")
        return process

    return run


def ball_and_slab(depth: float = 0.3, subdivisions: int = 3, cells: int = 16):
    """A unit sphere pressed `depth` into the top (z = 0) of a 4 × 4 × 1 slab."""
    ball = squish.Mesh.icosphere(1.0, subdivisions)
    ball = ball.with_vertices(ball.vertices + [0.0, 0.0, 1.0 - depth])
    slab = squish.Mesh.cuboid((4.0, 4.0, 1.0), cells)
    slab = slab.with_vertices(slab.vertices + [0.0, 0.0, -0.5])
    return ball, slab


@pytest.fixture
def example_scene(tmp_path) -> Path:
    """A copy of examples/press (a ball pressed into soft ground, 48 frames) in a temporary folder."""
    folder = tmp_path / "press"
    shutil.copytree(EXAMPLE_SCENE.parent, folder, ignore=shutil.ignore_patterns("out"))
    return folder / "press.toml"


def files_of(folder: Path) -> dict[str, bytes]:
    """Every mesh file under `folder` (relative path → bytes)."""
    return {
        str(path.relative_to(folder)): path.read_bytes()
        for path in sorted(folder.rglob("*"))
        if path.suffix in (".obj", ".ply") and path.is_file()
    }


def assert_same_files(a: Path, b: Path) -> None:
    """The two folders hold the same mesh files, byte for byte."""
    files_a, files_b = files_of(a), files_of(b)
    assert files_a, f"no mesh file in {a}"
    assert sorted(files_a) == sorted(files_b)
    different = [name for name in files_a if files_a[name] != files_b[name]]
    assert not different, f"files differ: {different[:5]}"


def write_scene(folder: Path, frames: int, extra: str = "") -> Path:
    """A short scene of a ball pressed into a slab (OBJ meshes written here)."""
    ball, slab = ball_and_slab(depth=0.0, subdivisions=2, cells=8)
    squish.write_mesh(folder / "ball.obj", ball)
    squish.write_mesh(folder / "slab.obj", slab)
    path = folder / "scene.toml"
    path.write_text(
        f"""frames = {{ start = 1, end = {frames}, fps = 24 }}
output = {{ dir = "out", format = "obj" }}

[[objects]]
name = "ball"
mesh = "ball.obj"
transform = {{ translate = {{ keys = [[1, [0, 0, 0.05]], [{frames}, [0, 0, -0.3]]] }} }}
{extra}
[[objects]]
name = "slab"
mesh = "slab.obj"
stiffness = 2.0

[[pairs]]
objects = ["ball", "slab"]
"""
    )
    return path


def np_equal(a, b) -> bool:
    return a.shape == b.shape and np.array_equal(a, b)
