"""One frame of the Blender scene as a `squish.Frame`, and its result back in object space.

The input of every object is its evaluated mesh (armature and other modifiers applied) in world
space, read at the scene's current frame with the add-on's properties as animated at that
frame. The properties are read from the original data: the active depsgraph writes animated and
driven values back to it at each frame change, and a user's edit is there at once (an evaluated
copy would still hold the value of its last evaluation). The deformer needs
triangles: Blender's loop triangles of each mesh are passed, so the vertices, their count and
their order are the mesh's own.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import bpy
import numpy as np
from mathutils import Matrix

import squish

from . import schema_props

# The attribute the live-mode modifier stores its input positions in (the evaluated mesh before
# the add-on's own Set Position), so that live mode reads the modifier stack's result without
# switching its own modifier off.
INPUT_ATTRIBUTE = "squish_input"
LIVE_MODIFIER = "Squish live"
CACHE_MODIFIER = "Squish cache"
# Baked shape keys are named "squish 00012" (the frame).
BAKED_KEY_PREFIX = "squish "


class SetupError(Exception):
    """A problem with the user's setup, as one line: the object, the problem, the fix."""


def _world(matrix: Matrix) -> np.ndarray:
    return np.array(matrix, dtype=np.float64)


@dataclass
class ObjectInput:
    name: str
    matrix_world: np.ndarray  # (4, 4)
    positions: np.ndarray  # world space, float64 (n, 3)
    triangles: np.ndarray  # int64 (m, 3)
    params: dict
    closed: bool
    rest: np.ndarray | None = None  # world space: the mesh's own positions (bind pose), for articulations
    uvs: np.ndarray | None = None  # (m, 3, 2) per loop-triangle corner, for the shared parametrization
    skin: squish.Skin | None = None  # with self-contact "Auto": the skin, analysed once
    joint_matrices: np.ndarray | None = None  # with self-contact "Auto": the bones' world matrices (J, 4, 4)


@dataclass
class FrameInput:
    """Everything one frame's deformation needs, gathered on Blender's main thread; `deform` can
    then run on any thread (it touches no Blender data)."""

    frame: int
    objects: list[ObjectInput]
    pairs: list[tuple[str, str, dict]]
    articulations: list[tuple[str, str, tuple[np.ndarray, np.ndarray], np.ndarray | None, dict]]
    fingerprint: int = 0

    def build(self) -> squish.Frame:
        frame = squish.Frame()
        for obj in self.objects:
            mesh = squish.Mesh(obj.positions, obj.triangles, uvs=obj.uvs)
            if obj.skin is not None:
                frame.add_object(obj.name, mesh, obj.params, self_contact="auto", skin=obj.skin,
                                 joint_matrices=obj.joint_matrices)
            else:
                frame.add_object(obj.name, mesh, obj.params)
            if obj.rest is not None:
                frame.set_rest_positions(obj.name, obj.rest)
        for a, b, params in self.pairs:
            frame.add_pair(a, b, params)
        for name, articulation, regions, joints, params in self.articulations:
            frame.add_articulation(name, articulation, regions, joints, params)
        return frame


@dataclass
class FrameResult:
    frame: int
    local_positions: dict[str, np.ndarray] = field(default_factory=dict)  # object space, float64
    world_positions: dict[str, np.ndarray] = field(default_factory=dict)
    report: dict = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def warnings(self) -> list[str]:
        """squish's warnings for the frame (a contact left unresolved, a clamped τ…): what
        happened and what to change, one line each."""
        return [w["message"] for w in self.report.get("stats", {}).get("warnings", [])]


def participants(scene) -> list[bpy.types.Object]:
    """The objects of the enabled setup, in a stable order: pairs' objects, then articulated ones."""
    ordered = []
    for pair in scene.squish.pairs:
        for obj in (pair.object_a, pair.object_b):
            if obj is not None and obj not in ordered:
                ordered.append(obj)
    for obj in scene.objects:
        articulated = len(obj.squish.articulations) or obj.squish.self_contact == "AUTO"
        if obj.type == "MESH" and articulated and obj not in ordered:
            ordered.append(obj)
    return ordered


def check_setup(scene) -> list[bpy.types.Object]:
    """The objects to deform; raises SetupError for a setup that cannot be evaluated."""
    for index, pair in enumerate(scene.squish.pairs, start=1):
        if pair.object_a is None or pair.object_b is None:
            raise SetupError(f"Pair {index}: has no {'first' if pair.object_a is None else 'second'} object; "
                             "pick two mesh objects or remove the pair")
        if pair.object_a == pair.object_b:
            raise SetupError(f"{pair.object_a.name}: is both objects of pair {index}; pick two different "
                             "objects (self-contact is set up as an articulation)")
    objects = participants(scene)
    if not objects:
        raise SetupError("Scene: no contact pair or articulation; add a pair of two mesh objects in the Squish tab")
    owners = {}
    for obj in objects:
        if obj.type != "MESH":
            raise SetupError(f"{obj.name}: is an object of type {obj.type.lower()}, not a mesh; pick a mesh object "
                             "(or convert it to a mesh)")
        # Results are stored on the mesh data (live attribute, shape keys): one mesh, one result.
        other = owners.setdefault(obj.data.name, obj)
        if other != obj:
            raise SetupError(f"{obj.name}: shares its mesh data with {other.name}; make it single-user (Object > "
                             "Relations > Make Single User) so each can deform on its own")
    return objects


class GroupWeights:
    """Vertex-group weights per object. Blender has no bulk access to them, so each object's
    vertices are read once, for all its groups, and kept for one gather (live mode: a brush
    stroke changes them) or for a whole bake."""

    def __init__(self):
        self._objects: dict[str, dict[int, np.ndarray]] = {}

    def weights(self, obj: bpy.types.Object, key: str, group_name: str) -> np.ndarray:
        """Per-vertex weights of a group (0 outside it); `key` names the setting in the error."""
        group = obj.vertex_groups.get(group_name)
        if group is None:
            names = ", ".join(g.name for g in obj.vertex_groups) or "none"
            raise SetupError(f"{obj.name}: vertex group \"{group_name}\" ({key}) does not exist; pick one of its "
                             f"groups ({names}) or clear the field")
        table = self._objects.get(obj.name)
        if table is None:
            table = self._objects[obj.name] = self._read(obj.data)
        column = table.get(group.index)
        return column if column is not None else np.zeros(len(obj.data.vertices), dtype=np.float64)

    @staticmethod
    def _read(mesh) -> dict[int, np.ndarray]:
        count = len(mesh.vertices)
        table: dict[int, np.ndarray] = {}
        for vertex in mesh.vertices:
            for element in vertex.groups:
                column = table.get(element.group)
                if column is None:
                    column = table[element.group] = np.zeros(count, dtype=np.float64)
                column[vertex.index] = element.weight
        return table


def _is_closed(triangles: np.ndarray) -> bool:
    """Every edge of the triangulated surface has exactly two faces (a quad's diagonal too)."""
    if len(triangles) == 0:
        return False
    edges = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    # One integer per undirected edge: a 1-D unique is far faster than a row-wise one.
    keys = edges[:, 0] * (int(triangles.max()) + 1) + edges[:, 1]
    _, counts = np.unique(keys, return_counts=True)
    return bool(np.all(counts == 2))


def _corner_uvs(obj, mesh, uv_map: str) -> np.ndarray:
    """The UVs of each loop triangle's corners, (m, 3, 2) float64, from the UV map `uv_map` (empty:
    the active render one): per corner, so that seams keep one UV per side."""
    layers = mesh.uv_layers
    layer = layers.get(uv_map) if uv_map else next((u for u in layers if u.active_render), None)
    if layer is None:
        names = ", ".join(u.name for u in layers) or "none"
        what = f"no UV map \"{uv_map}\"" if uv_map else "no UV map"
        raise SetupError(f"{obj.name}: has {what}, which the shared-parametrization mapping matches the meshes in; "
                         f"pick one of its UV maps ({names}) or use the unique direction")
    loop_uvs = np.empty(len(layer.uv) * 2, dtype=np.float32)
    layer.uv.foreach_get("vector", loop_uvs)
    loops = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int64)
    mesh.loop_triangles.foreach_get("loops", loops)
    return loop_uvs.reshape(-1, 2).astype(np.float64)[loops].reshape(-1, 3, 2)


def _mesh_arrays(obj_eval, original_count: int, name: str) -> tuple[np.ndarray, np.ndarray, bool, object]:
    """Positions (object space) and loop triangles of an evaluated object."""
    mesh = obj_eval.to_mesh()
    count = len(mesh.vertices)
    if count != original_count:
        obj_eval.to_mesh_clear()
        raise SetupError(f"{name}: its modifiers change the vertex count ({original_count} → {count}); apply them, "
                         "or keep only modifiers that move vertices (armature, shape keys)")
    positions = np.empty(count * 3, dtype=np.float32)
    stored = mesh.attributes.get(INPUT_ATTRIBUTE)
    if stored is not None and stored.domain == "POINT" and stored.data_type == "FLOAT_VECTOR":
        stored.data.foreach_get("vector", positions)
    else:
        mesh.vertices.foreach_get("co", positions)
    mesh.calc_loop_triangles()
    triangles = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int64)
    mesh.loop_triangles.foreach_get("vertices", triangles)
    triangles = triangles.reshape(-1, 3)
    return positions.reshape(-1, 3).astype(np.float64), triangles, _is_closed(triangles), mesh


def _pair_direction(pair, name: str):
    """The pair's mapping direction: None (auto), the vector, or an object's world axis."""
    if not pair.use_direction:
        return None
    if pair.direction_object is not None:
        axis = {"X": 0, "Y": 1, "Z": 2}[pair.direction_axis.lstrip("-")]
        vector = np.array(pair.direction_object.matrix_world.to_3x3().col[axis], dtype=np.float64)
        if pair.direction_axis.startswith("-"):
            vector = -vector
    else:
        vector = np.array(pair.direction, dtype=np.float64)
    if not np.all(np.isfinite(vector)) or np.linalg.norm(vector) == 0.0:
        raise SetupError(f"{name}: the mapping direction is zero; give a non-zero vector or an object whose axis "
                         "is not scaled to zero")
    return [float(v) for v in vector]


def baked_by_squish(obj) -> bool:
    """Whether an object shows a bake of the add-on (its input would then be a result)."""
    modifier = obj.modifiers.get(CACHE_MODIFIER)
    if modifier is not None and modifier.type == "MESH_CACHE" and modifier.show_viewport:
        return True
    keys = obj.data.shape_keys if obj.type == "MESH" else None
    return keys is not None and any(b.name.startswith(BAKED_KEY_PREFIX) for b in keys.key_blocks)


def object_armature(obj):
    """The armature of an object's first Armature modifier that has one (None without)."""
    return next((m.object for m in obj.modifiers if m.type == "ARMATURE" and m.object is not None), None)


def _articulation_regions(obj, articulation, depsgraph, groups: GroupWeights):
    """The two regions (vertex indices) and the joints (3 world points, or None) of an articulation."""
    label = f"{obj.name}, articulation \"{articulation.name}\""
    if articulation.source == "GROUPS":
        masks = []
        for key in ("group_1", "group_2"):
            group = getattr(articulation, key)
            if not group:
                raise SetupError(f"{label}: has no vertex group for region {key[-1]}; pick one")
            weights = groups.weights(obj, f"region {key[-1]}", group)
            masks.append(np.flatnonzero(weights >= 0.5).astype(np.uint32))
        return (masks[0], masks[1]), None
    armature = articulation.armature or object_armature(obj)
    if armature is None or armature.type != "ARMATURE":
        raise SetupError(f"{label}: no armature; pick the armature whose bones bend here (or use vertex groups)")
    bones = armature.data.bones
    parent, child = bones.get(articulation.parent_bone), bones.get(articulation.child_bone)
    for role, bone, name in (("parent", parent, articulation.parent_bone), ("child", child, articulation.child_bone)):
        if bone is None:
            raise SetupError(f"{label}: {armature.name} has no bone \"{name}\" ({role}); pick one of its bones")
    if child.parent != parent:
        children = ", ".join(b.name for b in parent.children) or "none"
        raise SetupError(f"{label}: \"{child.name}\" is not a child of \"{parent.name}\"; pick one of its children "
                         f"({children})")
    min_weight = articulation.min_weight
    region_1 = groups.weights(obj, "parent bone's group", parent.name)
    region_2 = np.zeros_like(region_1)
    for bone in [child, *child.children_recursive]:
        if obj.vertex_groups.get(bone.name) is not None:
            region_2 += groups.weights(obj, "child bone's group", bone.name)
    regions = (np.flatnonzero(region_1 >= min_weight).astype(np.uint32),
               np.flatnonzero(region_2 >= min_weight).astype(np.uint32))
    posed = armature.evaluated_get(depsgraph)
    to_world = posed.matrix_world
    parent_pose, child_pose = posed.pose.bones[parent.name], posed.pose.bones[child.name]
    # The end of the child bone, by the scene file's rule for skins (not the bone's tail, whose
    # direction an importer chooses): the child's first child joint, or for a leaf the point
    # continuing the parent bone beyond the joint at rest, carried by the child bone's pose.
    if child.children:
        end = posed.pose.bones[child.children[0].name].head
    else:
        rest_end = child.head_local + (child.head_local - parent.head_local)
        end = child_pose.matrix @ child.matrix_local.inverted() @ rest_end
    joints = np.array([to_world @ parent_pose.head, to_world @ child_pose.head, to_world @ end], dtype=np.float64)
    return regions, joints


# Skins analysed for self-contact "Auto", by object name: (what they were built from, the Skin).
_skins: dict[str, tuple[int, squish.Skin]] = {}


def _skin(obj, rest: np.ndarray, triangles: np.ndarray, groups: GroupWeights) -> tuple[squish.Skin, object]:
    """The `squish.Skin` of an object with self-contact "Auto" (bind pose in world space, the
    weights of the bones' vertex groups, the armature's hierarchy and rest matrices), built once
    for as long as those stay the same; and the armature."""
    armature = object_armature(obj)
    if armature is None or armature.type != "ARMATURE":
        raise SetupError(f"{obj.name}: self-contact \"Auto\" reads the skeleton from an Armature modifier, and the "
                         "object has none with an armature; add one or set self-contact to Off")
    bones = list(armature.data.bones)
    names = [bone.name for bone in bones]
    index = {name: j for j, name in enumerate(names)}
    parents = [index[b.parent.name] if b.parent is not None else None for b in bones]
    to_world = _world(armature.matrix_world)
    bind = np.stack([to_world @ _world(bone.matrix_local) for bone in bones])
    columns = [(index[g.name], groups.weights(obj, "skin", g.name)) for g in obj.vertex_groups if g.name in index]
    if not columns:
        raise SetupError(f"{obj.name}: self-contact \"Auto\" needs the skin's weights: none of its vertex groups is "
                         f"named after a bone of {armature.name}")
    weights = np.stack([w for _, w in columns], axis=1)
    joints = np.tile([j for j, _ in columns], (len(weights), 1))
    key = hash((rest.tobytes(), triangles.tobytes(), weights.tobytes(), bind.tobytes(), tuple(names), tuple(parents)))
    cached = _skins.get(obj.name)
    if cached is None or cached[0] != key:
        try:
            skin = squish.Skin((rest, triangles), joints, weights, parents, bind, names=names)
        except squish.SquishError as error:
            raise SetupError(f"{obj.name}: self-contact \"Auto\": {error}") from None
        cached = _skins[obj.name] = (key, skin)
    return cached[1], armature


def _joint_matrices(armature, depsgraph) -> np.ndarray:
    """The bones' world matrices at this frame, in the armature's bone order."""
    posed = armature.evaluated_get(depsgraph)
    to_world = _world(posed.matrix_world)
    return np.stack([to_world @ _world(posed.pose.bones[bone.name].matrix) for bone in armature.data.bones])


def _shared_parametrization(scene) -> set:
    """The objects of the pairs that match the meshes through their UVs (method A)."""
    return {obj for pair in scene.squish.pairs if pair.mapping == "shared_parametrization"
            for obj in (pair.object_a, pair.object_b)}


def gather(scene, depsgraph, groups: GroupWeights | None = None) -> FrameInput:
    """The current frame's input (raises SetupError). `groups`: vertex-group weights read before
    (a bake's frames share them); by default they are read anew."""
    groups = groups if groups is not None else GroupWeights()
    objects = check_setup(scene)
    with_uvs = _shared_parametrization(scene)
    inputs, meshes = [], []
    try:
        for obj in objects:
            obj_eval = obj.evaluated_get(depsgraph)
            local, triangles, closed, evaluated_mesh = _mesh_arrays(obj_eval, len(obj.data.vertices), obj.name)
            meshes.append(obj_eval)
            # Vertex groups are read from the original mesh: the vertex order is the same (checked).
            matrix = _world(obj_eval.matrix_world)
            world = local @ matrix[:3, :3].T + matrix[:3, 3]
            settings = obj.squish

            def weights(key, group, obj=obj):
                return groups.weights(obj, key, group)

            params = schema_props.parameters_from(settings, "object", weights)
            if params.get("preserve_volume") is True and not closed:
                raise SetupError(f"{obj.name}: is an open mesh, so its volume cannot be preserved; switch "
                                 "\"Preserve volume\" off (or close the mesh)")
            rest = None
            auto = obj.squish.self_contact == "AUTO"
            if len(obj.squish.articulations) or auto:
                # The articulations' partition of unity is computed on the rest pose: the mesh's
                # own positions before its modifiers (a skin's bind pose), placed like the frame.
                own = np.empty(len(obj.data.vertices) * 3, dtype=np.float32)
                obj.data.vertices.foreach_get("co", own)
                rest = own.reshape(-1, 3).astype(np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
            uvs = _corner_uvs(obj, evaluated_mesh, obj.squish.uv_map) if obj in with_uvs else None
            item = ObjectInput(obj.name, matrix, world, triangles, params, closed, rest, uvs)
            if auto:
                item.skin, armature = _skin(obj, rest, triangles, groups)
                item.joint_matrices = _joint_matrices(armature, depsgraph)
            inputs.append(item)
        pairs = []
        for pair in scene.squish.pairs:
            params = schema_props.parameters_from(pair, "pair")
            if "direction" in params:
                params["direction"] = _pair_direction(pair, f"Pair {pair.object_a.name}/{pair.object_b.name}")
            pairs.append((pair.object_a.name, pair.object_b.name, params))
        articulations = []
        for obj in objects:
            for articulation in obj.squish.articulations:
                regions, joints = _articulation_regions(obj, articulation, depsgraph, groups)
                params = schema_props.parameters_from(articulation, "articulation")
                articulations.append((obj.name, articulation.name, regions, joints, params))
    finally:
        for obj_eval in meshes:
            obj_eval.to_mesh_clear()
    frame_input = FrameInput(scene.frame_current, inputs, pairs, articulations)
    frame_input.fingerprint = fingerprint(frame_input)
    return frame_input


def fingerprint(frame_input: FrameInput) -> int:
    """A hash of everything the result depends on: live mode evaluates once per change."""
    parts = []
    for obj in frame_input.objects:
        parts += [obj.name, obj.positions.tobytes(), obj.triangles.tobytes(), repr(_hashable(obj.params)),
                  b"" if obj.rest is None else obj.rest.tobytes(), b"" if obj.uvs is None else obj.uvs.tobytes(),
                  id(obj.skin), b"" if obj.joint_matrices is None else obj.joint_matrices.tobytes()]
    parts.append(repr(_hashable(frame_input.pairs)))
    for name, articulation, regions, joints, params in frame_input.articulations:
        parts += [name, articulation, regions[0].tobytes(), regions[1].tobytes(),
                  b"" if joints is None else joints.tobytes(), repr(_hashable(params))]
    return hash(tuple(parts))


def _hashable(value):
    if isinstance(value, np.ndarray):
        return value.tobytes()
    if isinstance(value, dict):
        return tuple(sorted((k, _hashable(v)) for k, v in value.items()))
    if isinstance(value, (list, tuple)):
        return tuple(_hashable(v) for v in value)
    return value


def deform(frame_input: FrameInput, threads: int | None = None) -> FrameResult:
    """Deforms one frame (any thread; the GIL is released while squish computes). Raises
    SetupError with squish's one-line message."""
    start = time.perf_counter()
    try:
        vertices, report = frame_input.build().deform(threads=threads)
    except squish.SquishError as error:
        raise SetupError(str(error)) from None
    result = FrameResult(frame_input.frame, report=report)
    for obj, world in zip(frame_input.objects, vertices):
        result.world_positions[obj.name] = world
        inverse = np.linalg.inv(obj.matrix_world)
        result.local_positions[obj.name] = world @ inverse[:3, :3].T + inverse[:3, 3]
    result.seconds = time.perf_counter() - start
    return result
