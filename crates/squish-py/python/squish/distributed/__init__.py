"""A shot's frames spread over a Ray cluster (extra ``squish[ray]``).

``run_shot(scene_path, output)`` cuts the scene's frames into chunks of ``chunk`` consecutive
frames and runs each chunk as a Ray task. A task is ``Scene.load(scene_path).run(output,
frames=range(first, last + 1))``: the code of ``squish run --frames first:last``, so it writes each
frame's files atomically (for glb, gltf and pc2, its part ``<object>.first-last.<ext>`` holding its
frames) and its report part ``report.first-last.json``. The driver then merges the parts exactly as
``squish run`` does (``Scene.merge``): the reports into ``report.json``, and the parts of the files
holding every frame into ``<object>.<ext>`` — morph targets for every frame and one animation, or
one point cache. The files are the same, byte for byte, as ``squish run`` of the same scene:
every frame is computed from scratch, whatever the machine, the chunk or the thread count.

- A chunk whose task fails (an exception, or its worker dying) is run once more; chunks that fail
  again are listed with their error, and their frames appear in ``missing_frames``.
- A re-run skips the frames already complete in ``output``: listed by a report part there, with
  every object's file of the frame present (files are written atomically, so a file present is
  whole).

Every node must see the scene file, its meshes and ``output`` at the same paths (a shared file
system). To use an existing cluster, start it with ``ray start --head`` on one machine and
``ray start --address=HEAD:6379`` on the others, then pass ``address="auto"`` on a node of the
cluster, or ``address="ray://HEAD:10001"`` through Ray Client from elsewhere; without an address a
local Ray instance is started (``ray.init()``), unless one is already running in the process.
"""

from __future__ import annotations

import dataclasses
import os
import sys
from collections.abc import Callable
from pathlib import Path

import squish

__all__ = ["ShotRun", "chunks_of", "run_shot"]


@dataclasses.dataclass
class ShotRun:
    """What ``run_shot`` did."""

    report_path: Path
    """The merged ``report.json``."""
    report: dict
    """The merged report (``missing_frames`` lists the scene's frames without results)."""
    computed: list[int]
    """Frames computed by this run."""
    skipped: list[int]
    """Frames already complete in the output folder, not computed again."""
    failed: list[dict]
    """Chunks that failed twice: ``{"frames": "A:B", "failed_frame": F or None, "error": text}``."""
    retried: list[str]
    """Chunks (``"A:B"``) run a second time."""
    files: list[Path] = dataclasses.field(default_factory=list)
    """For glb, gltf and pc2: the files holding every frame, merged from the chunks' parts."""
    incomplete: dict[str, list[str]] = dataclasses.field(default_factory=dict)
    """For glb, gltf and pc2: per object whose parts miss frames, the frames missing (``"A:B"``)."""

    @property
    def complete(self) -> bool:
        return not self.failed and not self.report.get("missing_frames") and not self.incomplete


def chunks_of(frames: list[int], chunk: int) -> list[tuple[int, int]]:
    """Runs of consecutive frames, each cut into pieces of at most ``chunk`` frames."""
    if chunk < 1:
        raise squish.InputError(f"chunk = {chunk}: give at least 1 frame per task")
    pieces: list[tuple[int, int]] = []
    for frame in sorted(frames):
        if pieces and pieces[-1][1] + 1 == frame and frame - pieces[-1][0] < chunk:
            pieces[-1] = (pieces[-1][0], frame)
        else:
            pieces.append((frame, frame))
    return pieces


def _run_chunk(scene_path: str, output: str, first: int, last: int, threads: int) -> dict:
    """One task: frames ``first..last`` written into ``output``; never raises (its error is data)."""
    try:
        result = squish.Scene.load(scene_path).run(output, frames=range(first, last + 1), threads=threads)
        return {"frames": (first, last), "ok": True, "computed": result.frames, "error": None}
    except Exception as error:  # the driver retries and reports; the part says which frame failed
        return {"frames": (first, last), "ok": False, "computed": [], "error": f"{type(error).__name__}: {error}"}


def _failed_frame(output: Path, first: int, last: int) -> int | None:
    """The frame a chunk's report part names as failed, if any."""
    import json

    try:
        part = json.loads((output / f"report.{first}-{last}.json").read_text())
        return part.get("run", {}).get("failed_frame")
    except (OSError, ValueError):
        return None


def run_shot(
    scene_path: str | os.PathLike,
    output: str | os.PathLike,
    address: str | None = None,
    chunk: int = 8,
    threads_per_task: int = 1,
    progress: bool | Callable[[int], None] = True,
) -> ShotRun:
    """Runs a scene's frames as Ray tasks of ``chunk`` frames each and merges their reports.

    ``address``: the Ray cluster (``"auto"``, ``"ray://HEAD:10001"``; ``None``: the Ray instance
    already running in this process, or a new local one). ``threads_per_task``: the worker threads
    of each task, and the CPUs it asks Ray for. ``progress``: a progress bar on stderr (tqdm), or a
    function called with the number of frames each finished chunk computed.

    Returns a ``ShotRun``; raises ``squish.InputError`` for a scene that cannot be loaded. Ctrl-C
    cancels the tasks not started, merges the parts of what was done, and raises
    ``KeyboardInterrupt``.
    """
    import ray

    scene_path = Path(scene_path).resolve()
    output = Path(output).resolve()
    scene = squish.Scene.load(scene_path)
    if threads_per_task < 1:
        raise squish.InputError(f"threads_per_task = {threads_per_task}: give at least 1")
    first, last = scene.frame_range
    skipped = scene.completed_frames(output)
    todo = [f for f in range(first, last + 1) if f not in set(skipped)]
    pieces = chunks_of(todo, chunk)
    output.mkdir(parents=True, exist_ok=True)

    if not ray.is_initialized():
        ray.init(address=address, include_dashboard=False, log_to_driver=False)
    task = ray.remote(num_cpus=threads_per_task, max_retries=0)(_run_chunk)
    bar, advance = _progress(progress, len(todo), len(skipped))

    def submit(piece: tuple[int, int]):
        return task.remote(str(scene_path), str(output), piece[0], piece[1], threads_per_task)

    pending = {submit(p): (p, 1) for p in pieces}
    computed: list[int] = []
    failed: list[dict] = []
    retried: list[str] = []
    try:
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            for ref in ready:
                piece, attempt = pending.pop(ref)
                try:
                    outcome = ray.get(ref)
                except Exception as error:  # the worker died, or Ray lost the task
                    outcome = {"ok": False, "computed": [], "error": f"{type(error).__name__}: {error}"}
                computed.extend(outcome["computed"])
                advance(len(outcome["computed"]))
                if outcome["ok"]:
                    continue
                text = f"{piece[0]}:{piece[1]}"
                if attempt == 1:
                    retried.append(text)
                    pending[submit(piece)] = (piece, 2)
                else:
                    failed.append(
                        {
                            "frames": text,
                            "failed_frame": _failed_frame(output, *piece),
                            "error": outcome["error"],
                        }
                    )
    except KeyboardInterrupt:
        for ref in pending:
            ray.cancel(ref)
        scene.merge(output)
        raise
    finally:
        if bar is not None:
            bar.close()
    merged = scene.merge(output)
    report_path = Path(merged["report"])
    import json

    report = json.loads(report_path.read_text())
    files = [Path(f) for f in merged["files"]]
    return ShotRun(report_path, report, sorted(computed), skipped, failed, retried, files, merged["incomplete"])


def _progress(progress, total: int, skipped: int):
    """A tqdm bar (or the caller's function) advanced by the frames each chunk computed."""
    if callable(progress):
        return None, progress
    if not progress:
        return None, lambda n: None
    try:
        from tqdm import tqdm
    except ImportError:
        return None, lambda n: None
    bar = tqdm(total=total, unit="frame", desc="squish", file=sys.stderr, postfix={"skipped": skipped})
    return bar, bar.update
