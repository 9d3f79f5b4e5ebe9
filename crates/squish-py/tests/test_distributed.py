"""squish.distributed: a shot's frames as Ray tasks on a local cluster, byte for byte `squish run`."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from conftest import assert_same_files, write_scene

import squish
from squish.distributed import chunks_of, run_shot

ray = pytest.importorskip("ray", reason="ray is not installed (pip install 'squish[ray]')")


@pytest.fixture(scope="module")
def local_cluster():
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, configure_logging=False)
    yield
    ray.shutdown()


def test_chunks_cut_runs_of_consecutive_frames():
    assert chunks_of([1, 2, 3, 4, 5, 7, 8, 20], 3) == [(1, 3), (4, 5), (7, 8), (20, 20)]
    with pytest.raises(squish.InputError):
        chunks_of([1], 0)


def test_ray_frames_are_the_files_of_squish_run(local_cluster, cli, example_scene, tmp_path):
    cli("run", example_scene, "-o", tmp_path / "cli", "--threads", "2")
    run = run_shot(example_scene, tmp_path / "ray", chunk=5, progress=False)
    assert run.complete and run.computed == list(range(1, 49)) and not run.skipped and not run.failed
    assert_same_files(tmp_path / "cli", tmp_path / "ray")
    # The merged report: every frame, from ten parts (5 frames each, the last 3).
    report = run.report
    assert report["missing_frames"] == [] and report["run"]["status"] == "complete"
    assert [f["frame"] for f in report["per_frame"]] == list(range(1, 49))
    assert len(report["parts"]) == 10 and report["summary"]["frames_computed"] == 48
    cli_report = json.loads((tmp_path / "cli" / "report.json").read_text())
    assert report["summary"]["max_volume_change"] == cli_report["summary"]["max_volume_change"]

    # A re-run skips the frames already complete; a deleted file is computed again.
    (tmp_path / "ray" / "ball" / "0030.obj").unlink()
    again = run_shot(example_scene, tmp_path / "ray", chunk=5, progress=False)
    assert again.computed == [30] and len(again.skipped) == 47 and again.complete
    assert_same_files(tmp_path / "cli", tmp_path / "ray")


def test_ray_shots_in_files_holding_every_frame_merge_into_squish_runs(local_cluster, cli, example_scene, tmp_path):
    # glb and pc2: each task writes its part, the driver merges them into the file one run writes.
    text = example_scene.read_text()
    for format in ("glb", "pc2"):
        example_scene.write_text(text.replace('format = "obj"', f'format = "{format}"'))
        cli("run", example_scene, "-o", tmp_path / f"cli_{format}", "--threads", "2")
        run = run_shot(example_scene, tmp_path / f"ray_{format}", chunk=12, progress=False)
        assert run.complete and not run.incomplete and run.computed == list(range(1, 49))
        assert sorted(f.name for f in run.files) == [f"ball.{format}", f"ground.{format}"]
        for name in ("ball", "ground"):
            assert (tmp_path / f"ray_{format}" / f"{name}.13-24.{format}").is_file()
            merged = (tmp_path / f"ray_{format}" / f"{name}.{format}").read_bytes()
            assert merged == (tmp_path / f"cli_{format}" / f"{name}.{format}").read_bytes(), f"{name}.{format}"
        # A re-run finds every frame complete in the parts.
        again = run_shot(example_scene, tmp_path / f"ray_{format}", chunk=12, progress=False)
        assert again.computed == [] and len(again.skipped) == 48 and again.complete


def test_failing_chunks_are_retried_once_then_listed(local_cluster, tmp_path):
    # A mesh sequence whose frame 3 file is missing: the chunk holding frame 3 fails twice.
    scene_path = write_scene(tmp_path, frames=6)
    for frame in (1, 2, 4, 5, 6):
        (tmp_path / f"ball_{frame:04}.obj").write_bytes((tmp_path / "ball.obj").read_bytes())
    text = scene_path.read_text().replace('mesh = "ball.obj"', 'mesh = "ball_{frame:04}.obj"')
    scene_path.write_text(text.replace("transform = {", "# transform = {"))
    run = run_shot(scene_path, tmp_path / "out", chunk=2, progress=False)
    assert not run.complete
    assert run.retried == ["3:4"]
    assert [f["frames"] for f in run.failed] == ["3:4"] and "ball_0003.obj" in run.failed[0]["error"]
    assert run.computed == [1, 2, 5, 6]
    assert run.report["missing_frames"] == ["3:4"]


def test_the_command_line_runs_a_shot(example_scene, tmp_path):
    text = example_scene.read_text().replace("end = 48", "end = 4")
    example_scene.write_text(text)
    env = dict(os.environ, RAY_USAGE_STATS_ENABLED="0")
    process = subprocess.run(
        [sys.executable, "-m", "squish.distributed", str(example_scene), "-o", str(tmp_path / "out"), "--chunk", "2"],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )
    assert process.returncode == 0, process.stderr
    assert "4 frames computed" in process.stdout and "missing: none" in process.stdout
    assert sorted(p.name for p in (tmp_path / "out" / "ball").iterdir()) == [f"{f:04}.obj" for f in range(1, 5)]
