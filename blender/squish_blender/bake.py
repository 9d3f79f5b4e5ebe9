"""Bake: a frame range to keyed shape keys or to .pc2 point caches read by Mesh Cache modifiers.

Blender's data is read on the main thread only: the bake steps through the frames, gathers each
frame's input (evaluate.gather) and hands it to a thread pool, where `squish.Frame.deform`
computes with the GIL released, so several frames deform at once while the next ones are being
gathered. Nothing is written to Blender until every frame is done, so a cancelled bake leaves the
scene as it was.
"""

from __future__ import annotations

import json
import os
import struct
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from dataclasses import dataclass, field

import bpy
import numpy as np

import squish

from . import evaluate, live
from .evaluate import BAKED_KEY_PREFIX as SHAPE_KEY_PREFIX
from .evaluate import CACHE_MODIFIER, SetupError
REPORT_TEXT = "Squish bake report"


def _shape_key_name(frame: int) -> str:
    return f"{SHAPE_KEY_PREFIX}{frame:05d}"


def write_pc2(path: str, start_frame: int, frames: list[np.ndarray]) -> None:
    """A .pc2 point cache: the header (signature, version 1, point count, start frame, sample
    rate 1, sample count) and float32 positions, frame after frame."""
    count = frames[0].shape[0]
    with open(path + ".part", "wb") as file:
        file.write(struct.pack("<12siiffi", b"POINTCACHE2\0", 1, count, float(start_frame), 1.0, len(frames)))
        for positions in frames:
            file.write(np.ascontiguousarray(positions, dtype="<f4").tobytes())
    # Written beside the target, then renamed: a Mesh Cache modifier never reads half a file.
    os.replace(path + ".part", path)


def remove_bake(obj) -> None:
    """Removes the add-on's baked shape keys and cache modifier from an object."""
    modifier = obj.modifiers.get(CACHE_MODIFIER)
    if modifier is not None and modifier.type == "MESH_CACHE":
        obj.modifiers.remove(modifier)
    keys = obj.data.shape_keys if obj.type == "MESH" else None
    if keys is None:
        return
    for block in [b for b in keys.key_blocks if b.name.startswith(SHAPE_KEY_PREFIX)]:
        obj.shape_key_remove(block)
    if len(keys.key_blocks) == 1 and keys.key_blocks[0] == keys.reference_key and obj.get("squish_added_basis"):
        obj.shape_key_remove(keys.reference_key)
        del obj["squish_added_basis"]
    animation = obj.data.shape_keys.animation_data if obj.data.shape_keys is not None else None
    if animation is not None and animation.action is not None:
        # The keys' F-curves would be left pointing at keys that no longer exist.
        for owner, curve in list(_fcurves(animation.action)):
            if curve.data_path.startswith(f'key_blocks["{SHAPE_KEY_PREFIX}'):
                owner.fcurves.remove(curve)
        if not any(True for _ in _fcurves(animation.action)):
            obj.data.shape_keys.animation_data_clear()


def _fcurves(action):
    """(owner, F-curve) pairs of an action: Blender 4.4+ keeps them in channel bags of layered
    actions, older versions on the action."""
    if hasattr(action, "layers"):
        for layer in action.layers:
            for strip in layer.strips:
                for bag in strip.channelbags:
                    for curve in bag.fcurves:
                        yield bag, curve
    else:
        for curve in action.fcurves:
            yield action, curve


@dataclass
class FrameFigures:
    frame: int
    seconds: float = 0.0
    volumes: dict[str, tuple[float, float]] = field(default_factory=dict)  # before, after (world space)
    penetration: dict[str, tuple] = field(default_factory=dict)  # pair → (before, after)
    self_intersections: dict[str, tuple[int, int]] = field(default_factory=dict)  # articulation → (before, after)
    warnings: list[str] = field(default_factory=list)
    error: str = ""


class Bake:
    """A bake in progress. `step()` does a bounded amount of work (for a modal operator);
    `run()` does it all (scripts, tests)."""

    def __init__(self, context):
        scene = context.scene
        settings = scene.squish
        if settings.bake_end < settings.bake_start:
            raise SetupError(f"Bake: the range {settings.bake_start}–{settings.bake_end} is empty; set End ≥ Start")
        self.scene = scene
        self.objects = evaluate.check_setup(scene)
        self.target = settings.bake_target
        self.frames = list(range(settings.bake_start, settings.bake_end + 1))
        self.threads = settings.bake_threads
        if self.target == "POINT_CACHE":
            self.directory = bpy.path.abspath(settings.bake_directory)
            if settings.bake_directory.startswith("//") and not bpy.data.filepath:
                raise SetupError("Bake: the cache folder is relative (//) but the .blend file is not saved; save it "
                                 "or pick an absolute folder")
        self.live_was_on = settings.live
        self.original_frame = scene.frame_current
        if self.target == "SHAPE_KEYS":
            for obj in self.objects:
                self._check_shape_key_target(obj)
        # The previous bake (and live mode's modifier) would change the input: live mode goes, the
        # previous bake is switched off while baking (put back if the bake is cancelled, removed
        # when the new one is written).
        if self.live_was_on:
            live.disable(scene)
        self.suspended = self._suspend_previous_bake()
        self.pool = ThreadPoolExecutor(max_workers=self.threads, thread_name_prefix="squish-bake")
        self.pending: dict[int, Future] = {}
        self.results: dict[int, evaluate.FrameResult] = {}
        self.figures: dict[int, FrameFigures] = {}
        self.inputs: dict[int, dict[str, np.ndarray]] = {}
        self.next_index = 0
        # Vertex-group weights (bulge maps, regions) do not change while the bake runs.
        self.groups = evaluate.GroupWeights()

    def _suspend_previous_bake(self) -> list[tuple[object, str, bool]]:
        """Switches off the objects' previous bake (cache modifiers hidden, baked shape keys
        muted); returns what to put back."""
        changed = []
        for obj in self.objects:
            modifier = obj.modifiers.get(CACHE_MODIFIER)
            if modifier is not None and modifier.type == "MESH_CACHE":
                changed += [(modifier, "show_viewport", modifier.show_viewport),
                            (modifier, "show_render", modifier.show_render)]
                modifier.show_viewport = modifier.show_render = False
            keys = obj.data.shape_keys
            for block in keys.key_blocks if keys is not None else []:
                if block.name.startswith(SHAPE_KEY_PREFIX):
                    changed.append((block, "mute", block.mute))
                    block.mute = True
        return changed

    @staticmethod
    def _check_shape_key_target(obj) -> None:
        movers = [m.name for m in obj.modifiers if m.name != evaluate.LIVE_MODIFIER and m.name != CACHE_MODIFIER
                  and (m.show_viewport or m.show_render)]
        if movers:
            raise SetupError(f"{obj.name}: has modifiers ({', '.join(movers)}) that act after shape keys; bake to a "
                             "point cache instead")
        keys = obj.data.shape_keys
        if keys is not None:
            others = [b.name for b in keys.key_blocks[1:] if not b.name.startswith(SHAPE_KEY_PREFIX)]
            if others:
                raise SetupError(f"{obj.name}: has shape keys of its own ({', '.join(others)}); bake to a point "
                                 "cache instead")

    @property
    def done(self) -> int:
        return len(self.figures)

    def _gather_next(self) -> None:
        frame = self.frames[self.next_index]
        self.next_index += 1
        self.scene.frame_set(frame)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        try:
            frame_input = evaluate.gather(self.scene, depsgraph, self.groups)
        except SetupError as error:
            # A setup error at one frame (a keyed value out of range) fails that frame only.
            self.figures[frame] = FrameFigures(frame, error=str(error))
            return
        self.inputs[frame] = {o.name: (o.positions, o.triangles) for o in frame_input.objects}
        self.pending[frame] = self.pool.submit(evaluate.deform, frame_input, 1)

    def _collect(self) -> None:
        """Takes the finished frames' results (never waits)."""
        for frame, future in list(self.pending.items()):
            if not future.done():
                continue
            del self.pending[frame]
            try:
                result = future.result()
            except SetupError as error:
                self.figures[frame] = FrameFigures(frame, error=str(error))
                continue
            except Exception as error:  # noqa: BLE001 - the frame is listed as failed with it
                self.figures[frame] = FrameFigures(frame, error=f"unexpected {type(error).__name__}: {error}")
                continue
            self.results[frame] = result
            self.figures[frame] = self._figures_of(frame, result)

    def _figures_of(self, frame: int, result: evaluate.FrameResult) -> FrameFigures:
        """Volumes before and after (float64, world space) and each pair's deepest penetration
        before and after (squish's report; None for open meshes)."""
        figures = FrameFigures(frame, seconds=result.seconds, warnings=result.warnings)
        for name, (before, triangles) in self.inputs[frame].items():
            after = result.world_positions[name]
            figures.volumes[name] = (squish.Mesh(before, triangles).volume(), squish.Mesh(after, triangles).volume())
        for pair in result.report.get("pairs", []):
            figures.penetration["/".join(pair["objects"])] = (pair.get("penetration_before"),
                                                              pair.get("penetration_after"))
        for articulation in result.report.get("articulations", []):
            figures.self_intersections[f"{articulation['object']}.{articulation['name']}"] = (
                articulation["self_intersecting_faces_before"], articulation["self_intersecting_faces_after"])
        return figures

    def _queue_full(self) -> bool:
        # Two frames per worker: one computing, one gathered and waiting.
        return self.next_index >= len(self.frames) or len(self.pending) >= 2 * self.threads

    def step(self) -> bool:
        """Gathers one frame if a worker will want it and collects finished ones (never blocks);
        True when every frame is done."""
        if not self._queue_full():
            self._gather_next()
        self._collect()
        return self.done == len(self.frames)

    def run(self) -> None:
        while not self.step():
            if self._queue_full() and self.pending:
                # Nothing to gather until a frame finishes: sleep on the workers, not spin.
                wait(list(self.pending.values()), return_when=FIRST_COMPLETED)

    def cancel(self) -> None:
        """Stops: frames not started are dropped, running ones finish; nothing is written."""
        for future in self.pending.values():
            future.cancel()
        self.pool.shutdown(wait=True)
        self.scene.frame_set(self.original_frame)
        for owner, attribute, value in self.suspended:
            setattr(owner, attribute, value)
        if self.live_was_on:
            live.enable(self.scene)

    def finish(self) -> dict:
        """Writes the results to Blender and returns the report."""
        self.pool.shutdown(wait=True)
        self.scene.frame_set(self.original_frame)
        for obj in self.objects:
            remove_bake(obj)
        if self.target == "SHAPE_KEYS":
            self._write_shape_keys()
        else:
            self._write_point_caches()
        report = self.report()
        text = bpy.data.texts.get(REPORT_TEXT) or bpy.data.texts.new(REPORT_TEXT)
        text.from_string(json.dumps(report, indent=2))
        # Live mode stays off: the objects now show the bake, which live mode would take as input.
        return report

    def _write_shape_keys(self) -> None:
        for obj in self.objects:
            if obj.data.shape_keys is None:
                obj.shape_key_add(name="Basis", from_mix=False)
                obj["squish_added_basis"] = True
            for frame in self.frames:
                result = self.results.get(frame)
                if result is None:
                    continue
                block = obj.shape_key_add(name=_shape_key_name(frame), from_mix=False)
                block.data.foreach_set("co", result.local_positions[obj.name].astype(np.float32).ravel())
                # Shown at its own frame only: 0 one frame before and after, 1 at the frame.
                for key_frame, value in ((frame - 1, 0.0), (frame, 1.0), (frame + 1, 0.0)):
                    block.value = value
                    block.keyframe_insert("value", frame=key_frame)
                block.value = 0.0
            obj.data.update()

    def _write_point_caches(self) -> None:
        os.makedirs(self.directory, exist_ok=True)
        for obj in self.objects:
            samples = []
            for frame in self.frames:
                result = self.results.get(frame)
                if result is not None:
                    samples.append(result.local_positions[obj.name])
                else:
                    # A failed frame shows the input: the evaluated mesh, as if not baked.
                    samples.append(self._input_local(obj, frame))
            path = os.path.join(self.directory, f"{bpy.path.clean_name(obj.name)}.pc2")
            write_pc2(path, self.frames[0], samples)
            modifier = obj.modifiers.new(CACHE_MODIFIER, "MESH_CACHE")
            modifier.cache_format = "PC2"
            modifier.filepath = path
            modifier.deform_mode = "OVERWRITE"
            modifier.play_mode = "SCENE"
            modifier.time_mode = "FRAME"
            modifier.interpolation = "NONE"
            modifier.forward_axis, modifier.up_axis = "POS_Y", "POS_Z"
            modifier.frame_start = float(self.frames[0])

    def _input_local(self, obj, frame: int) -> np.ndarray:
        """An object's evaluated mesh at a frame (object space): what a failed frame shows."""
        self.scene.frame_set(frame)
        obj_eval = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
        mesh = obj_eval.to_mesh()
        local = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
        stored = mesh.attributes.get(evaluate.INPUT_ATTRIBUTE)
        if stored is None:
            mesh.vertices.foreach_get("co", local)
        else:
            stored.data.foreach_get("vector", local)
        obj_eval.to_mesh_clear()
        self.scene.frame_set(self.original_frame)
        return local.reshape(-1, 3).astype(np.float64)

    def report(self) -> dict:
        failed = {f: fig.error for f, fig in sorted(self.figures.items()) if fig.error}
        return {
            "frames": [self.frames[0], self.frames[-1]],
            "target": self.target,
            "failed_frames": failed,
            "per_frame": [
                {"frame": fig.frame, "seconds": fig.seconds, "volumes": fig.volumes, "penetration": fig.penetration,
                 "self_intersecting_faces": fig.self_intersections, "warnings": fig.warnings,
                 **({"error": fig.error} if fig.error else {})}
                for _, fig in sorted(self.figures.items())
            ],
            "squish_version": squish.__version__,
        }

    def summary(self) -> str:
        failed = [f for f, fig in self.figures.items() if fig.error]
        text = f"Squish: baked frames {self.frames[0]}–{self.frames[-1]} to "
        text += "shape keys" if self.target == "SHAPE_KEYS" else f"point caches in {self.directory}"
        if self.live_was_on:
            text += "; live mode was switched off (the objects show the bake)"
        if failed:
            first = self.figures[min(failed)].error
            text += f"; {len(failed)} frames failed ({min(failed)}: {first})"
        warned = sorted(f for f, fig in self.figures.items() if fig.warnings)
        if warned:
            text += f"; {len(warned)} frames with warnings ({warned[0]}: {self.figures[warned[0]].warnings[0]})"
        return text + f"; details in the text \"{REPORT_TEXT}\""
