"""The ``o``/``g`` and ``usemtl`` groups of a Wavefront OBJ file, per triangle.

trimesh reads an OBJ as one mesh per material and forgets its ``o`` (object)
and ``g`` (group) statements, which name a map's objects. This reader keeps
them: one pass over the file's lines (linear in its size, the file's size
bounded and its memory checked before it is read), every polygon fanned into
triangles as the loaders do, and each triangle labelled with the ``o``/``g``
group and the material in force where its ``f`` line stands (Wavefront OBJ
format [1]_, "Grouping" and "Display/render attributes"). :func:`label_faces`
carries those labels onto the faces of the mesh :func:`viscore.load_mesh`
made of the same file, by nearest triangle centroid.

References
----------
.. [1] Wavefront Technologies. "Object Files (.obj)", Advanced Visualizer
   manual, Appendix B1 (Grouping: ``g``, ``o``; Display/render attributes:
   ``usemtl``). https://paulbourke.net/dataformats/obj/
"""

from __future__ import annotations

import os
import stat
from dataclasses import dataclass

import numpy as np

from .._validate import InputError, check_memory

__all__ = ["ObjGroups", "obj_groups", "label_faces", "MAX_OBJ_BYTES"]

#: Largest OBJ file whose groups are read, bytes (a map of tens of millions of
#: triangles; the mesh loader refuses larger ones by memory first).
MAX_OBJ_BYTES = 2 << 30

#: Peak bytes of memory per byte of file while its lines are split and parsed
#: (the bytes, the list of lines, Python integers per triangle in five lists: about
#: 180 bytes a triangle of some 20 bytes of text, and the arrays made of them).
_BYTES_PER_FILE_BYTE = 40


@dataclass(frozen=True, eq=False)
class ObjGroups:
    """The triangles of an OBJ file with their group and material.

    Attributes
    ----------
    centroids : (n, 3) float64
        Centroid of each triangle (polygons fanned from their first vertex), in
        the file's coordinates.
    group : (n,) int64
        Index into ``group_names`` of the ``o``/``g`` group in force at the
        triangle's ``f`` line (0, ``''``, before any).
    material : (n,) int64
        Index into ``material_names`` of the ``usemtl`` in force (0, ``''``,
        before any).
    group_names, material_names : tuple of str
        The names, in order of first use; ``o`` and ``g`` names are joined as
        ``'o/g'`` when both are in force.
    """

    centroids: np.ndarray
    group: np.ndarray
    material: np.ndarray
    group_names: tuple
    material_names: tuple

    @property
    def groups_used(self) -> int:
        """Distinct ``o``/``g`` groups holding triangles."""
        return len(np.unique(self.group))

    @property
    def materials_used(self) -> int:
        """Distinct materials holding triangles."""
        return len(np.unique(self.material))


def _read(path: str | os.PathLike) -> bytes:
    label = str(path)
    try:
        st = os.stat(path)
        if not stat.S_ISREG(st.st_mode):
            raise InputError(f"{label}: not a regular file")
        if st.st_size > MAX_OBJ_BYTES:
            raise InputError(f"{label}: {st.st_size:,} bytes, more than the {MAX_OBJ_BYTES:,} "
                             "whose groups are read")
        check_memory(float(st.st_size) * _BYTES_PER_FILE_BYTE, f"{label}: its OBJ groups")
        with open(path, "rb") as fh:
            return fh.read(MAX_OBJ_BYTES + 1)
    except FileNotFoundError:
        raise InputError(f"{label}: no such file") from None
    except OSError as exc:
        raise InputError(f"{label}: cannot read ({exc.strerror or exc})") from None


def _index(token: bytes, count: int) -> int:
    """A face vertex token (``v``, ``v/t``, ``v//n``, ``v/t/n``) as a 0-based index."""
    k = int(token.split(b"/", 1)[0])
    return k - 1 if k > 0 else count + k


def obj_groups(path: str | os.PathLike) -> ObjGroups:
    """Read the triangles of an OBJ file with their ``o``/``g`` group and material.

    Parameters
    ----------
    path : str or path-like
        The OBJ file.

    Returns
    -------
    ObjGroups

    Raises
    ------
    InputError
        A file that is missing, not regular, over :data:`MAX_OBJ_BYTES` or whose
        parse would not fit in memory; a vertex or face line that is not numbers;
        a face index outside the vertices read so far. One line naming the file
        and the line.

    Notes
    -----
    One pass, linear in the file's size; no line is read twice. Lines other
    than ``v``, ``f``, ``o``, ``g`` and ``usemtl`` are skipped, as are faces of
    fewer than three vertices. Continuation lines (a trailing backslash) are
    joined first.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> text = b"v 0 0 0\\nv 1 0 0\\nv 0 1 0\\nv 1 1 0\\no a\\nf 1 2 3\\no b\\nf 2 4 3\\n"
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "two.obj"
    >>> _ = p.write_bytes(text)
    >>> g = obj_groups(p)
    >>> g.group.tolist(), g.group_names
    ([1, 2], ('', 'a', 'b'))
    """
    label = str(path)
    data = _read(path).replace(b"\\\r\n", b" ").replace(b"\\\n", b" ")
    coords: list[bytes] = []
    tri_a: list[int] = []
    tri_b: list[int] = []
    tri_c: list[int] = []
    tri_group: list[int] = []
    tri_mat: list[int] = []
    groups = {"": 0}
    materials = {"": 0}
    o_name = g_name = ""
    group = material = 0
    count = 0
    for number, line in enumerate(data.split(b"\n"), 1):
        parts = line.split()
        if not parts:
            continue
        key = parts[0]
        try:
            if key == b"v":
                if len(parts) < 4:
                    raise ValueError
                coords.append(b" ".join(parts[1:4]))
                count += 1
            elif key == b"f":
                idx = [_index(t, count) for t in parts[1:]]
                if len(idx) < 3:
                    continue
                if min(idx) < 0 or max(idx) >= count:
                    raise InputError(f"{label}: line {number}: a face index outside the "
                                     f"{count:,} vertices read so far")
                first = idx[0]
                for b, c in zip(idx[1:-1], idx[2:], strict=True):
                    tri_a.append(first)
                    tri_b.append(b)
                    tri_c.append(c)
                    tri_group.append(group)
                    tri_mat.append(material)
            elif key in (b"o", b"g"):
                name = b" ".join(parts[1:]).decode("utf-8", "replace")
                if key == b"o":
                    o_name, g_name = name, ""
                else:
                    g_name = name
                full = "/".join(n for n in (o_name, g_name) if n)
                group = groups.setdefault(full, len(groups))
            elif key == b"usemtl":
                name = b" ".join(parts[1:]).decode("utf-8", "replace")
                material = materials.setdefault(name, len(materials))
        except ValueError:
            raise InputError(f"{label}: line {number}: expected numbers after "
                             f"{key.decode('ascii', 'replace')!r}") from None
    try:
        vertices = (np.array(b" ".join(coords).split(), dtype=np.float64).reshape(-1, 3)
                    if coords else np.zeros((0, 3)))
    except ValueError:
        raise InputError(f"{label}: a vertex line holds something other than numbers"
                         ) from None
    faces = np.stack([np.asarray(tri_a, np.int64), np.asarray(tri_b, np.int64),
                      np.asarray(tri_c, np.int64)], axis=1) if tri_a else np.zeros((0, 3),
                                                                                   np.int64)
    centroids = vertices[faces].mean(axis=1) if len(faces) else np.zeros((0, 3))
    return ObjGroups(centroids=centroids, group=np.asarray(tri_group, np.int64),
                     material=np.asarray(tri_mat, np.int64),
                     group_names=tuple(groups), material_names=tuple(materials))


def label_faces(groups: ObjGroups, mesh_vertices: np.ndarray, mesh_faces: np.ndarray,
                labels: np.ndarray) -> np.ndarray:
    """Carry per-triangle labels of an OBJ file onto a mesh loaded from it.

    Parameters
    ----------
    groups : ObjGroups
    mesh_vertices : (v, 3) float
    mesh_faces : (m, 3) int
        The mesh :func:`viscore.load_mesh` made of the same file (its faces may be
        reordered, split by material, or fewer: degenerate ones dropped).
    labels : (n,) int
        One label per triangle of ``groups`` (``groups.group`` or ``groups.material``).

    Returns
    -------
    (m,) int64
        The label of the file's triangle whose centroid is nearest each face's.

    Notes
    -----
    A k-d tree over the file's centroids (:class:`scipy.spatial.cKDTree`):
    ``O(m log n)``.
    """
    from scipy.spatial import cKDTree

    if not len(groups.centroids) or not len(mesh_faces):
        return np.zeros(len(mesh_faces), np.int64)
    centre = np.asarray(mesh_vertices, np.float64)[np.asarray(mesh_faces)].mean(axis=1)
    _, nearest = cKDTree(groups.centroids).query(centre)
    return np.asarray(labels, np.int64)[nearest]
