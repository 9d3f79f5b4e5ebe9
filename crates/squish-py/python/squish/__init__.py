"""Squish: a time-independent deformer for elastic contacts (Brunel, Bénard, Guennebaud, Barla).

Meshes that intersect at one frame go in; meshes in clean contact come out, squashed where they
touch and bulging around it with their volume preserved. Every frame is computed from scratch.

>>> import squish
>>> ball, ground = squish.read_mesh("ball.obj"), squish.read_mesh("ground.obj")
>>> (ball_out, ground_out), report = squish.deform(ball, ground, b_params={"rigid": True})
>>> squish.write_mesh("out/ball.obj", ball.with_vertices(ball_out), like="ball.obj")

- ``Mesh(vertices, faces, uvs=None)``: float64 (n, 3) vertices, integer (m, 3) faces, UVs per
  vertex or per face corner; ``read_mesh`` and ``write_mesh`` for OBJ, PLY and glTF files
  (``like=`` keeps every attribute of a source file). Wherever a mesh goes, a ``(vertices,
  faces)`` pair of arrays or lists, or an object with ``vertices`` and ``faces``, does too.
- ``deform`` and ``contact``: two meshes, one frame (``squish deform`` / ``squish contact``).
- ``Frame``: any number of objects, pairs and self-contact articulations for one frame;
  ``Skin`` gives an object ``self_contact="auto"`` (its skeleton's articulations and parts).
- ``Scene.load(path)``: a scene file; ``scene.frame(i)``; ``scene.run(output, frames=, threads=)``
  writes the same files and report as ``squish run``. Frames follow Python: ``range(1, 25)`` is
  frames 1 to 24, ``[3, 4, 5]`` those frames; the text ``"1:24"`` is ``--frames``' (inclusive).
- ``params_schema()``: every parameter with its default, range, thesis symbol and meaning.
- ``squish.usd.write_shot`` (extra ``squish[usd]``) and ``squish.distributed.run_shot`` (extra
  ``squish[ray]``).

Parameters are dicts or keyword arguments whose keys are the schema's; a bad value raises
``ParameterError`` (a ``ValueError``) naming the key, mesh and file problems ``InputError``. The
GIL is released while computing.
"""

from . import _squish
from ._errors import InputError, ParameterError, SquishError
from ._squish import Mesh, Scene, ShotResult, Skin, merge_reports, params_schema, read_mesh, write_mesh

__all__ = [
    "Frame",
    "InputError",
    "Mesh",
    "ParameterError",
    "Scene",
    "ShotResult",
    "Skin",
    "SquishError",
    "contact",
    "deform",
    "merge_reports",
    "params_schema",
    "read_mesh",
    "write_mesh",
]

__version__ = _squish.version()


def deform(a, b, a_params=None, b_params=None, pair=None, **params):
    return _squish.deform(a, b, a_params, b_params, pair, **params)


def contact(a, b, a_params=None, b_params=None, pair=None, **params):
    return _squish.contact(a, b, a_params, b_params, pair, **params)


class Frame(_squish.Frame):
    def add_object(self, name, mesh, params=None, *, self_contact=None, skin=None, joint_matrices=None, **kwargs):
        return super().add_object(
            name, mesh, params, self_contact=self_contact, skin=skin, joint_matrices=joint_matrices, **kwargs
        )

    def set_articulation(self, object, name, params=None, **kwargs):
        return super().set_articulation(object, name, params, **kwargs)

    def add_pair(self, a, b, params=None, **kwargs):
        return super().add_pair(a, b, params, **kwargs)

    def add_articulation(self, object, name, regions, joints=None, params=None, **kwargs):
        return super().add_articulation(object, name, regions, joints, params, **kwargs)


def _describe(level: str) -> str:
    """The parameters of one level of the schema, one entry each, for docstrings."""
    lines = []
    for row in params_schema():
        if row["level"] != level:
            continue
        default = row["default"]
        head = f"{row['key']} ({row['kind']}, default {default!r})"
        details = [part for part in (row["symbol"], row["section"]) if part]
        if "range" in row:
            details.append(f"valid: {row['range']['text']}")
        if row.get("choices"):
            details.append("one of " + ", ".join(repr(c) for c in row["choices"]))
        if row["unit"]:
            details.append(row["unit"])
        lines.append(f"    {head}: {row['summary']}" + (f" [{'; '.join(details)}]" if details else ""))
        if row["optional"] and row.get("auto"):
            lines.append(f"        {row['word']!r}: {row['auto']}")
    return "\n".join(lines)


def _set_docs() -> None:
    objects, pairs, articulations = (_describe(level) for level in ("object", "pair", "articulation"))
    deform.__doc__ = f"""Deforms two intersecting meshes into clean contact (one frame), as ``squish deform``.

    deform(a, b, a_params=None, b_params=None, pair=None, **params)
        -> ((a_vertices, b_vertices), report)

    ``a`` and ``b`` are ``squish.Mesh``es; the mapping direction is oriented along b's normals
    (a is pushed along +d, b along -d). Returns the deformed vertices of each mesh (float64
    arrays, same count and order as the input) and a report dict: the parameters used, the deepest
    penetration before and after (closed meshes), and the frame's figures (per-stage times in ms,
    per object volumes before/after, contact and deformable region sizes, extent; per pair the
    mapping direction, contact threshold and area), as ``report.json`` of ``squish deform``.

    Parameters are dicts (``a_params``, ``b_params``: object parameters; ``pair``: pair
    parameters) or keyword arguments ``a_KEY=``, ``b_KEY=``, ``pair_KEY=``. Errors raise
    ``squish.ParameterError`` naming the key (``a.stiffness = -1: must be > 0 (k, default 1)``);
    unusable meshes raise ``squish.InputError``.

    Object parameters (a_params, b_params):
{objects}

    Pair parameters (pair):
{pairs}
"""
    contact.__doc__ = f"""The contact definition of two meshes (thesis ch. 4), without deforming them, as
    ``squish contact``.

    contact(a, b, a_params=None, b_params=None, pair=None, **params) -> dict

    The dict holds the figures of contact.json (mapping direction, threshold ε_c = m + τσ, depth
    statistics, intersection points, per side the sizes and areas of the intersection, mapping
    and contact regions, timings), ``labels`` (per mesh, a uint8 array per vertex: 0 outside,
    1 intersection, 2 mapping region, 3 contact zone) and ``boundary_points`` (``positions``,
    ``kind`` 1-3 and ``side`` 0-1 of the regions' exact boundary points). Parameters as for
    ``deform``.

    Object parameters (a_params, b_params):
{objects}

    Pair parameters (pair):
{pairs}
"""
    Frame.__doc__ = """One frame of any number of objects, pairs and self-contact articulations.

    frame = squish.Frame()
    ball = frame.add_object("ball", ball_mesh, stiffness=1.0)
    ground = frame.add_object("ground", ground_mesh, rigid=True)
    frame.add_pair(ball, ground, contact_tau=0.5)
    vertices, report = frame.deform(threads=2)

    ``Scene.frame(i)`` gives a scene's frame as a ``Frame``. ``deform(threads=None)`` returns every
    object's vertices and the figures of a report.json frame entry.
    """
    Frame.add_object.__doc__ = f"""Adds an object; returns its index.

    add_object(name, mesh, params=None, *, self_contact=None, skin=None, joint_matrices=None,
               **kwargs) -> int

    ``mesh``: a ``squish.Mesh``, a ``(vertices, faces)`` pair or an object with ``vertices`` and
    ``faces``; its UVs, if any, serve the shared-parametrization mapping. A key given both in
    ``params`` and as a keyword argument is an error.

    ``self_contact="auto"`` (thesis ch. 6, issue 27): the articulations of the mesh's skeleton
    and the contacts between its parts, as a scene file's ``self_contact = "auto"``. ``skin``:
    a ``squish.Skin`` of this mesh (bind pose, joints, weights, parents, bind matrices), built
    once; ``joint_matrices``: the joints' world matrices at this frame, ``(J, 4, 4)``. The
    object keys apply to the part contacts (``untangle``, ``extent``, ``bulge`` …); one
    articulation's keys: ``set_articulation(object, name, **keys)`` (names: ``articulations``).

    Object parameters (a dict and/or keyword arguments):
{objects}
"""
    Frame.set_articulation.__doc__ = f"""Sets parameters of an object's articulation by name (one given with
    ``add_articulation`` or found by ``self_contact="auto"``), over its current ones.

    set_articulation(object, name, params=None, **kwargs)

    Articulation parameters (a dict and/or keyword arguments):
{articulations}
"""
    Frame.add_pair.__doc__ = f"""Adds a pair of objects (indices or names) that may be in contact;
    the mapping direction is oriented along the second object's normals. Returns its index.

    add_pair(a, b, params=None, **kwargs) -> int

    Pair parameters (a dict and/or keyword arguments):
{pairs}
"""
    Frame.add_articulation.__doc__ = f"""Adds a self-contact articulation (thesis ch. 6) to an object.

    add_articulation(object, name, regions, joints=None, params=None, **kwargs)

    ``regions``: the two overlapping working regions as vertex indices (parent side, child side);
    ``joints``: the world positions (3, 3) of the parent bone's start, the articulation and the
    child bone's end (needed unless ``direction`` is given).

    Articulation parameters (a dict and/or keyword arguments):
{articulations}
"""


_set_docs()
