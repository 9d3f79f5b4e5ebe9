"""One frame from NumPy arrays: squish.deform, squish.contact, squish.Frame."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ball_and_slab

import squish


def test_a_sphere_pressed_into_a_slab_keeps_its_volume_and_leaves_the_slab():
    ball, slab = ball_and_slab(depth=0.3)
    (ball_out, slab_out), report = squish.deform(ball, slab, b_params={"stiffness": 2.0})

    # Same count and order: float64 (n, 3). The automatic extent reaches over the whole unit
    # ball (a pressed sphere deforms whole), so the vertices untouched beyond the extent are
    # checked with an extent of 0.8: those more than 1.2 above the slab are outside 𝒟.
    assert ball_out.shape == ball.vertices.shape and ball_out.dtype == np.float64
    assert slab_out.shape == slab.vertices.shape
    (short_ball, _), _ = squish.deform(ball, slab, a_params={"extent": 0.8}, b_params={"stiffness": 2.0})
    far = ball.vertices[:, 2] > 1.2
    assert far.any() and np.array_equal(short_ball[far], ball.vertices[far])
    assert not np.array_equal(ball_out[far], ball.vertices[far])

    # Volume preserved (γ = 1, closed meshes) to 1e-9.
    for mesh, out in ((ball, ball_out), (slab, slab_out)):
        before, after = mesh.volume(), mesh.with_vertices(out).volume()
        assert abs(after - before) <= 1e-9 * abs(before), (before, after)
    for obj in report["frame"]["objects"]:
        assert obj["deformed"] and abs(obj["relative_volume_change"]) <= 1e-9

    # Penetration resolved: the deepest vertex inside the other mesh goes from 0.3 to 2.2% of it
    # (each mesh's vertices sample the contact surface, and the facets between them cut across
    # the other mesh's: docs/decisions.md, "Known limitations").
    assert report["penetration_before"] == pytest.approx(0.3, abs=1e-9)
    assert report["penetration_after"] < 0.03 * report["penetration_before"]
    # The stiffer slab moves less than the ball.
    assert np.abs(slab_out - slab.vertices).max() < np.abs(ball_out - ball.vertices).max()
    assert report["parameters"]["b"]["stiffness"] == 2.0


def test_keyword_arguments_and_dicts_are_the_same_parameters():
    ball, slab = ball_and_slab(subdivisions=2, cells=8)
    (a1, b1), _ = squish.deform(ball, slab, a_params={"extent": 0.8}, pair={"contact_tau": 0.5})
    (a2, b2), _ = squish.deform(ball, slab, a_extent=0.8, pair_contact_tau=0.5)
    assert np.array_equal(a1, a2) and np.array_equal(b1, b2)
    (a3, _), _ = squish.deform(ball, slab)
    assert not np.array_equal(a1, a3)


def test_a_frame_of_two_objects_is_the_two_mesh_call():
    ball, slab = ball_and_slab(subdivisions=2, cells=8)
    (a, b), _ = squish.deform(ball, slab, b_rigid=True)
    frame = squish.Frame()
    frame.add_object("ball", ball)
    frame.add_object("slab", slab, {"rigid": True})
    frame.add_pair("ball", "slab")
    for threads in (1, 2):
        vertices, report = frame.deform(threads=threads)
        assert np.array_equal(vertices[0], a) and np.array_equal(vertices[1], b)
    assert [o["name"] for o in report["objects"]] == ["ball", "slab"]
    assert report["pairs"][0]["penetration_after"] < report["pairs"][0]["penetration_before"]
    assert np.array_equal(vertices[1], slab.vertices)  # rigid


def test_a_frame_of_three_objects_deforms_the_middle_one_from_both_sides():
    ball, slab = ball_and_slab(subdivisions=2, cells=8)  # ball centred at z = 0.7, slab z ∈ [-1, 0]
    bottom = ball.with_vertices(ball.vertices - [0, 0, 2.4])  # centred at z = -1.7: 0.3 into the slab
    frame = squish.Frame()
    frame.add_object("top", ball)
    frame.add_object("slab", slab)
    frame.add_object("bottom", bottom)
    frame.add_pair("top", "slab")
    frame.add_pair(2, 1)
    vertices, report = frame.deform()
    assert frame.objects == ["top", "slab", "bottom"] and len(vertices) == 3
    assert all(p["in_contact"] for p in report["pairs"])
    moved = np.abs(vertices[1] - slab.vertices).max(axis=1) > 0
    assert (slab.vertices[moved][:, 2] > -0.5).any() and (slab.vertices[moved][:, 2] < -0.5).any()


def test_contact_labels_the_regions_of_chapter_4():
    ball, slab = ball_and_slab(subdivisions=2, cells=8)
    result = squish.contact(ball, slab)
    labels_ball, labels_slab = result["labels"]
    assert labels_ball.shape == (ball.num_vertices,) and labels_slab.shape == (slab.num_vertices,)
    assert set(np.unique(labels_ball)) <= {0, 1, 2, 3} and (labels_ball == 3).any()
    # The contact zone lies in the ball's lower cap, below the slab's top.
    assert (ball.vertices[labels_ball == 3][:, 2] < 0.0).all()
    assert np.allclose(np.abs(result["mapping_direction"]), [0, 0, 1], atol=1e-6)
    points = result["boundary_points"]
    assert points["positions"].shape == (len(points["kind"]), 3) and set(points["side"]) == {0, 1}
