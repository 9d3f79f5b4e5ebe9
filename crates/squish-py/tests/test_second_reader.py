"""glTF outputs opened by a second, independent reader (pygltflib, pure Python): the document's
structure and every attribute but positions and normals unchanged, positions and their accessor
bounds consistent (issue 23). The rigged characters come from ../shared/data and are skipped
when it is absent; the procedural case always runs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pygltflib
import pytest

import squish

REPOSITORY = Path(__file__).resolve().parents[3]
RIGGED = REPOSITORY.parent / "shared" / "data" / "rigged"

COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}
DTYPES = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}


def accessor_array(document: pygltflib.GLTF2, index: int) -> np.ndarray:
    """An accessor's values, decoded from the GLB's binary chunk by this reader alone."""
    accessor = document.accessors[index]
    view = document.bufferViews[accessor.bufferView]
    assert view.buffer == 0, "GLB assets keep their data in the binary chunk"
    blob = document.binary_blob()
    dtype = np.dtype(DTYPES[accessor.componentType])
    width = COMPONENTS[accessor.type]
    stride = view.byteStride or dtype.itemsize * width
    start = (view.byteOffset or 0) + (accessor.byteOffset or 0)
    assert start + stride * (accessor.count - 1) + dtype.itemsize * width <= (view.byteOffset or 0) + view.byteLength
    rows = [
        np.frombuffer(blob, dtype=dtype, count=width, offset=start + i * stride) for i in range(accessor.count)
    ]
    return np.array(rows).reshape(accessor.count, width)


def single(values: list[float] | None) -> tuple | None:
    """Numbers as the 32-bit floats glTF's transforms are: a writer may print the same float
    with other decimals than the input's JSON."""
    return None if values is None else tuple(np.float32(values).tolist())


def structure(document: pygltflib.GLTF2) -> dict:
    """What a deformation must not change: the scene graph, rig, materials, animations, and each
    primitive's attribute names, indices and mode."""
    return {
        "nodes": [
            (n.name, n.mesh, n.skin, n.children, single(n.matrix), single(n.translation), single(n.rotation), single(n.scale))
            for n in document.nodes
        ],
        "skins": [(s.joints, s.inverseBindMatrices, s.skeleton) for s in document.skins],
        "materials": [m.name for m in document.materials],
        "textures": len(document.textures),
        "images": [(i.name, i.mimeType, i.uri) for i in document.images],
        "samplers": len(document.samplers),
        "animations": [(a.name, len(a.channels), len(a.samplers)) for a in document.animations],
        "primitives": [
            [(sorted(k for k, v in vars(p.attributes).items() if v is not None), p.mode, p.material) for p in m.primitives]
            for m in document.meshes
        ],
    }


def kept_attributes(document: pygltflib.GLTF2) -> list[np.ndarray]:
    """Every primitive's indices and attributes other than POSITION and NORMAL, decoded."""
    arrays = []
    for mesh in document.meshes:
        for primitive in mesh.primitives:
            if primitive.indices is not None:
                arrays.append(accessor_array(document, primitive.indices))
            for name, index in sorted(vars(primitive.attributes).items()):
                if index is not None and name not in ("POSITION", "NORMAL"):
                    arrays.append(accessor_array(document, index))
    return arrays


def check_positions(document: pygltflib.GLTF2) -> int:
    """POSITION accessors hold finite values within their declared min/max (glTF requires the
    bounds); returns the vertex count over every primitive."""
    count = 0
    for mesh in document.meshes:
        for primitive in mesh.primitives:
            accessor = document.accessors[primitive.attributes.POSITION]
            values = accessor_array(document, primitive.attributes.POSITION)
            assert np.isfinite(values).all()
            assert np.all(values >= np.array(accessor.min, dtype=np.float32))
            assert np.all(values <= np.array(accessor.max, dtype=np.float32))
            count += accessor.count
    return count


@pytest.mark.parametrize("asset", ["CesiumMan.glb", "Fox.glb", "RiggedSimple.glb"])
def test_a_rigged_character_comes_back_whole(asset, tmp_path):
    source = RIGGED / asset
    if not source.is_file():
        pytest.skip(f"{source} absent (../shared/data is not beside the repository)")
    mesh = squish.read_mesh(source)
    # A smooth, non-rigid change of every position: a deformation as the output writer sees it.
    v = mesh.vertices
    centre = v.mean(axis=0)
    moved = v + 0.05 * np.sin(3.0 * (v - centre)) * np.ptp(v, axis=0)
    output = tmp_path / asset
    squish.write_mesh(output, mesh.with_vertices(moved), like=source)

    before, after = pygltflib.GLTF2().load(str(source)), pygltflib.GLTF2().load(str(output))
    assert structure(after) == structure(before)
    kept_before, kept_after = kept_attributes(before), kept_attributes(after)
    assert len(kept_after) == len(kept_before) > 0
    for a, b in zip(kept_before, kept_after):
        assert a.dtype == b.dtype and np.array_equal(a, b)
    assert check_positions(after) == check_positions(before)
    # The positions did change, and squish reads back what it wrote (f32 in the file).
    assert not np.array_equal(squish.read_mesh(output).vertices, v)
    np.testing.assert_allclose(squish.read_mesh(output).vertices, moved, rtol=0, atol=1e-5 * np.ptp(v))


def test_a_procedural_mesh_written_as_glb_reads_back(tmp_path):
    mesh = squish.Mesh.icosphere(1.0, 3)
    output = tmp_path / "ball.glb"
    squish.write_mesh(output, mesh)
    document = pygltflib.GLTF2().load(str(output))
    assert check_positions(document) == len(mesh.vertices)
    primitive = document.meshes[0].primitives[0]
    positions = accessor_array(document, primitive.attributes.POSITION)
    np.testing.assert_allclose(positions, mesh.vertices, rtol=0, atol=1e-6)
    faces = accessor_array(document, primitive.indices).reshape(-1, 3)
    assert np.array_equal(faces, mesh.faces)
