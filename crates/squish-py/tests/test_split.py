"""A shot split over runs (`Scene.run(frames=…)`) in the formats holding every frame: the parts
merge into the file one run writes, byte for byte (`squish run`'s), as `Scene.merge` reports."""

from __future__ import annotations

import squish


def test_parts_merge_into_the_file_of_one_run(cli, example_scene, tmp_path):
    example_scene.write_text(example_scene.read_text().replace('format = "obj"', 'format = "glb"'))
    cli("run", example_scene, "-o", tmp_path / "cli", "--threads", "2")
    scene = squish.Scene.load(example_scene)
    out = tmp_path / "parts"
    scene.run(out, frames=range(1, 21), threads=2)
    merged = scene.merge(out)
    assert merged["files"] == [] and merged["incomplete"] == {"ball": ["21:48"], "ground": ["21:48"]}
    assert scene.completed_frames(out) == list(range(1, 21))
    # The run that completes the shot merges the parts.
    scene.run(out, frames=range(21, 49), threads=2)
    for name in ("ball", "ground"):
        assert (out / f"{name}.glb").read_bytes() == (tmp_path / "cli" / f"{name}.glb").read_bytes(), name
    merged = scene.merge(out)
    assert [p.rsplit("/", 1)[-1] for p in map(str, merged["files"])] == ["ball.glb", "ground.glb"]
    assert merged["incomplete"] == {}
    assert scene.completed_frames(out) == list(range(1, 49))
