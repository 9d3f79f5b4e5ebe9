"""``self_contact="auto"`` from Python: a ``squish.Skin`` (bind pose, weights, skeleton) gives an
object the articulations of its skeleton and the contacts between its parts, as a scene file's
``self_contact = "auto"`` (thesis ch. 6, issue 27), on a procedural limb bent past its fold."""

import numpy as np
import pytest

import squish

RADIUS, LENGTH, JOINT = 0.3, 3.0, 1.5


def limb(segments=24, rings=40):
    """A closed cylinder along z from 0 to LENGTH, with its skin: joint 0 at the base, joint 1 (the
    knee) at z = JOINT, joint 2 at the top (a leaf); weights blend over 0.6 around the knee."""
    vertices = [[0.0, 0.0, 0.0]]
    for r in range(rings + 1):
        z = LENGTH * r / rings
        for s in range(segments):
            phi = 2 * np.pi * s / segments
            vertices.append([RADIUS * np.cos(phi), RADIUS * np.sin(phi), z])
    vertices.append([0.0, 0.0, LENGTH])
    ring = lambda r, s: 1 + r * segments + s % segments  # noqa: E731
    faces = [[0, ring(0, s + 1), ring(0, s)] for s in range(segments)]
    for r in range(rings):
        for s in range(segments):
            a, b, c, d = ring(r, s), ring(r, s + 1), ring(r + 1, s), ring(r + 1, s + 1)
            faces += [[a, b, d], [a, d, c]]
    top = len(vertices) - 1
    faces += [[top, ring(rings, s), ring(rings, s + 1)] for s in range(segments)]
    vertices = np.array(vertices)
    t = np.clip((vertices[:, 2] - (JOINT - 0.3)) / 0.6, 0.0, 1.0)
    knee = t * t * (3 - 2 * t)
    joints = np.tile([0, 1], (len(vertices), 1))
    weights = np.stack([1 - knee, knee], axis=1)
    return squish.Mesh(vertices, np.array(faces)), joints, weights


def translation(z):
    m = np.eye(4)
    m[2, 3] = z
    return m


def bend(degrees):
    """World matrices of the three joints with the knee bent by `degrees` about x."""
    a = np.radians(degrees)
    rotation = np.eye(4)
    rotation[1:3, 1:3] = [[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]
    knee = translation(JOINT) @ rotation
    return np.stack([np.eye(4), knee, knee @ translation(LENGTH - JOINT)])


BIND = np.stack([np.eye(4), translation(JOINT), translation(LENGTH)])
PARENTS = [None, 0, 1]


def posed(mesh, joints, weights, world):
    """Linear blend skinning of the bind pose by the joints' world matrices."""
    skinning = world @ np.linalg.inv(BIND)
    homogeneous = np.c_[mesh.vertices, np.ones(mesh.num_vertices)]
    out = np.zeros_like(mesh.vertices)
    for k in range(joints.shape[1]):
        moved = np.einsum("nij,nj->ni", skinning[joints[:, k]], homogeneous)[:, :3]
        out += weights[:, k : k + 1] * moved
    return mesh.with_vertices(out)


def test_auto_self_contact_resolves_a_bent_limb_and_its_keys_take_effect():
    rest, joints, weights = limb()
    skin = squish.Skin(rest, joints, weights, PARENTS, BIND, names=["thigh", "knee", "ankle"])
    assert skin.articulations == ["thigh / knee"]
    assert skin.parts == ["thigh", "knee"]
    world = bend(150)
    bent = posed(rest, joints, weights, world)
    before = bent.self_intersecting_faces()

    def run(**options):
        frame = squish.Frame()
        frame.add_object("leg", bent, self_contact="auto", skin=skin, joint_matrices=world, **options.pop("object", {}))
        for name, keys in options.items():
            frame.set_articulation("leg", name, **keys)
        (vertices,), report = frame.deform(threads=1)
        return vertices, report, frame

    vertices, report, frame = run()
    assert frame.articulations("leg") == ["thigh / knee"]
    after = bent.with_vertices(vertices).self_intersecting_faces()
    volume_change = bent.with_vertices(vertices).volume() / bent.volume() - 1
    articulation = report["articulations"][0]
    print(f"bent limb: {before} self-intersecting faces → {after}; ΔV/V {volume_change:.1e}; articulation in contact {articulation['in_contact']}")
    assert before > 40, before
    assert after <= 0.05 * before, (before, after)
    assert abs(volume_change) < 1e-9
    assert articulation["in_contact"] and articulation["name"] == "thigh / knee"

    # Its keys: an articulation's stiffness, and the object's untangling.
    stiffer, *_ = run(**{"thigh / knee": {"stiffness": [1.0, 4.0]}})
    assert np.abs(stiffer - vertices).max() > 1e-3
    # Without the untangling, the contacts' own result keeps a few faces crossing (a fold within
    # the knee's part); with it (the default) none.
    assert report["self_intersecting_faces"] == [["leg", [before, after]]]
    _, raw_report, _ = run(object={"untangle": False})
    (_, [_, raw_after]), = raw_report["self_intersecting_faces"]
    print(f"untangle = false: {raw_after} faces left")
    assert raw_after > after

    # The same frame from the explicit articulation plus the parts equals it bit for bit.
    explicit = squish.Frame()
    explicit.add_object("leg", bent, self_contact="auto", skin=skin, joint_matrices=world)
    again, _ = explicit.deform(threads=2)
    assert np.array_equal(again[0], vertices), "thread count changed the result"


def test_auto_self_contact_errors_name_the_fix():
    rest, joints, weights = limb()
    skin = squish.Skin(rest, joints, weights, PARENTS, BIND)
    frame = squish.Frame()
    with pytest.raises(squish.ParameterError, match=r"leg\.self_contact: .*needs skin=squish\.Skin"):
        frame.add_object("leg", rest, self_contact="auto")
    with pytest.raises(squish.ParameterError, match="needs joint_matrices"):
        frame.add_object("leg", rest, self_contact="auto", skin=skin)
    with pytest.raises(squish.ParameterError, match=r"give \"auto\""):
        frame.add_object("leg", rest, self_contact="yes")
    with pytest.raises(squish.ParameterError, match="the skin's mesh has"):
        frame.add_object("leg", squish.Mesh.icosphere(1.0, 1), self_contact="auto", skin=skin, joint_matrices=BIND)
    with pytest.raises(squish.InputError, match=r"joint_matrices: give one 4 × 4 world matrix per joint, an array of shape \(3, 4, 4\)"):
        frame.add_object("leg", rest, self_contact="auto", skin=skin, joint_matrices=BIND[:2])
    with pytest.raises(squish.InputError, match="parents: joint 1 has parent 7"):
        squish.Skin(rest, joints, weights, [None, 7, 1], BIND)
    with pytest.raises(squish.InputError, match="weights: shape"):
        squish.Skin(rest, joints, weights[:5], PARENTS, BIND)
    frame.add_object("leg", rest, self_contact="auto", skin=skin, joint_matrices=BIND)
    with pytest.raises(squish.InputError, match=r'no articulation is named "knee"; its articulations are "joint 0 / joint 1"'):
        frame.set_articulation("leg", "knee", stiffness=2)
    with pytest.raises(squish.ParameterError, match="stiffness"):
        frame.set_articulation("leg", "joint 0 / joint 1", stiffness=-1)
