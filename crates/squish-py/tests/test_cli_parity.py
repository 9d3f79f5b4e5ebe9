"""The Python calls give the command line's results, bit for bit, and its reports' figures."""

from __future__ import annotations

import json

import numpy as np
from conftest import assert_same_files, ball_and_slab

import squish


def test_deform_is_bit_for_bit_the_cli_on_the_same_files(cli, tmp_path):
    ball, slab = ball_and_slab(depth=0.25, subdivisions=3, cells=12)
    # Binary PLY stores float64 exactly, so the files hold the arrays bit for bit.
    squish.write_mesh(tmp_path / "ball.ply", ball)
    squish.write_mesh(tmp_path / "slab.ply", slab)
    ball, slab = squish.read_mesh(tmp_path / "ball.ply"), squish.read_mesh(tmp_path / "slab.ply")
    sets = {"b.stiffness": 2.5, "a.bulge": 1.5, "pair.contact_tau": 0.25}
    args = [arg for key, value in sets.items() for arg in ("--set", f"{key}={value}")]
    cli("deform", tmp_path / "ball.ply", tmp_path / "slab.ply", "-o", tmp_path / "out", *args)

    (ball_out, slab_out), report = squish.deform(
        ball, slab, a_params={"bulge": 1.5}, b_params={"stiffness": 2.5}, pair={"contact_tau": 0.25}
    )
    assert np.array_equal(ball_out, squish.read_mesh(tmp_path / "out" / "ball.ply").vertices)
    assert np.array_equal(slab_out, squish.read_mesh(tmp_path / "out" / "slab.ply").vertices)

    # The report holds the figures of the command's report.json (times aside).
    cli_report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert set(cli_report) - {"inputs", "outputs"} == set(report)
    assert report["parameters"] == cli_report["parameters"]
    assert report["penetration_after"] == cli_report["penetration_after"]
    for ours, theirs in zip(report["frame"]["objects"], cli_report["frame"]["objects"]):
        assert ours["relative_volume_change"] == theirs["relative_volume_change"]
        assert ours["contact_vertices"] == theirs["contact_vertices"]

    # write_mesh(like=) writes what the command writes: a copy of the input with new positions.
    squish.write_mesh(tmp_path / "ball_py.ply", ball.with_vertices(ball_out), like=tmp_path / "ball.ply")
    assert (tmp_path / "ball_py.ply").read_bytes() == (tmp_path / "out" / "ball.ply").read_bytes()


def test_obj_attributes_pass_through_write_mesh_like(cli, tmp_path):
    source = tmp_path / "quad.obj"
    source.write_text(
        "# a pyramid with texture coordinates\nmtllib pyramid.mtl\no pyramid\n"
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 1\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0.5 0.5\n"
        "usemtl stone\ng base\nf 4/4 3/3 2/2 1/1\ng sides\nf 1/1 2/2 5/5\nf 2/2 3/3 5/5\nf 3/3 4/4 5/5\nf 4/4 1/1 5/5\n"
    )
    mesh = squish.read_mesh(source)
    moved = mesh.with_vertices(mesh.vertices * 2.0)
    squish.write_mesh(tmp_path / "out.obj", moved, like=source)
    text = (tmp_path / "out.obj").read_text()
    for line in ("mtllib pyramid.mtl", "usemtl stone", "g sides", "vt 0.5 0.5", "f 4/4 3/3 2/2 1/1"):
        assert line in text
    assert np.array_equal(squish.read_mesh(tmp_path / "out.obj").vertices, mesh.vertices * 2.0)


def test_a_scene_run_writes_the_files_of_squish_run(cli, example_scene, tmp_path):
    cli("run", example_scene, "-o", tmp_path / "cli", "--frames", "20:25", "--threads", "2")
    scene = squish.Scene.load(example_scene)
    assert scene.objects == ["ball", "ground"] and scene.frame_range == (1, 48) and scene.fps == 24
    result = scene.run(tmp_path / "py", frames=range(20, 26), threads=1)
    assert result.frames == list(range(20, 26))
    assert_same_files(tmp_path / "cli", tmp_path / "py")

    # The report: the command's, with the missing frames of the shot listed.
    report = result.report
    assert report["run"]["status"] == "complete"
    assert report["missing_frames"] == ["1:19", "26:48"]
    assert [f["frame"] for f in report["per_frame"]] == list(range(20, 26))
    assert (tmp_path / "py" / "report.20-25.json").is_file() and result.part_report_path.name == "report.20-25.json"
    cli_report = json.loads((tmp_path / "cli" / "report.json").read_text())
    assert set(report) == set(cli_report)

    # A frame of the scene deformed alone is the run's frame.
    vertices, figures = scene.frame(22).deform(threads=2)
    assert np.array_equal(vertices[0], squish.read_mesh(tmp_path / "py" / "ball" / "0022.obj").vertices)
    assert figures["objects"][0]["relative_volume_change"] == report["per_frame"][2]["objects"][0]["relative_volume_change"]

    # completed_frames sees what is on disk.
    assert scene.completed_frames(tmp_path / "py") == list(range(20, 26))
    (tmp_path / "py" / "ground" / "0021.obj").unlink()
    assert scene.completed_frames(tmp_path / "py") == [20, 22, 23, 24, 25]


def test_params_schema_is_the_cli_schema(cli):
    schema = json.loads(cli("params", "--json").stdout)
    assert squish.params_schema() == schema["parameters"]


def test_self_intersecting_faces_counts_as_squish_info(cli, tmp_path):
    # Two spheres overlapping in one mesh: faces crossing the other sphere's intersect.
    ball = squish.Mesh.icosphere(1.0, 3)
    vertices = np.vstack([ball.vertices, ball.vertices + [1.2, 0.1, 0.0]])
    faces = np.vstack([ball.faces, ball.faces + ball.num_vertices])
    both = squish.Mesh(vertices, faces)
    squish.write_mesh(tmp_path / "both.ply", both)
    info = json.loads(cli("info", tmp_path / "both.ply", "--json", "--weld", "never").stdout)
    count = both.self_intersecting_faces()
    assert count == info["self_intersecting_faces"] > 0
    assert ball.self_intersecting_faces() == 0


def test_the_shared_parametrization_reads_uvs_as_the_cli(cli, tmp_path):
    """Method A's mapping from the files' UVs (OBJ vt, planar here, with a seam cut into the slab's):
    ``squish.deform`` on meshes read with ``read_mesh`` gives ``squish deform``'s files bit for bit."""
    ball, slab = ball_and_slab(depth=0.25, subdivisions=3, cells=12)
    for name, mesh in (("ball", ball), ("slab", slab)):
        v, f = mesh.vertices, mesh.faces
        lines = [f"v {float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in v]
        corners = v[f][:, :, :2].copy()
        if name == "slab":  # the faces right of x = 0.1 in another chart (rotated, scaled, moved)
            right = v[f][:, :, 0].mean(axis=1) > 0.1
            c, s = np.cos(1.1), np.sin(1.1)
            corners[right] = corners[right] @ np.array([[c, s], [-s, c]]) * 0.6 + [4.0, 2.0]
        lines += [f"vt {float(x)!r} {float(y)!r}" for x, y in corners.reshape(-1, 2)]
        lines += [" ".join(["f"] + [f"{vi + 1}/{3 * k + i + 1}" for i, vi in enumerate(t)]) for k, t in enumerate(f)]
        (tmp_path / f"{name}.obj").write_text("\n".join(lines) + "\n")
    a, b = squish.read_mesh(tmp_path / "ball.obj"), squish.read_mesh(tmp_path / "slab.obj")
    assert a.uvs.shape == (a.num_faces, 3, 2)
    cli("deform", tmp_path / "ball.obj", tmp_path / "slab.obj", "-o", tmp_path / "out", "--set", "pair.mapping=shared_parametrization")
    (ball_out, slab_out), report = squish.deform(a, b, pair_mapping="shared_parametrization")
    assert report["frame"]["pairs"][0]["in_contact"]
    assert np.array_equal(ball_out, squish.read_mesh(tmp_path / "out" / "ball.obj").vertices)
    assert np.array_equal(slab_out, squish.read_mesh(tmp_path / "out" / "slab.obj").vertices)
    # The UVs matter: the unique direction gives another result.
    (other, _), _ = squish.deform(a, b)
    assert not np.array_equal(other, ball_out)
