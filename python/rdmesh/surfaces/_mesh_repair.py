"""Repairs of a mesh input that leave its solid unchanged: faces listed twice,
faces turned against their neighbours, and the check that each closed
component encloses a volume.

A face listed twice with the same orientation counts twice in the winding
number (a jump of 2 across it), so one copy goes; a face listed once each way
cancels out of the winding number, so both go. Faces turned against the
neighbours across an edge of two faces are turned back, in each orientable
patch the smaller share; both leave the solid the winding number bounds as
the mesh's author meant it where that meaning is clear.
"""

from __future__ import annotations

import logging

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from .._errors import MeshInputError
from .._mesh_components import labelled_components
from .._vectors import unique_rows
from ..features.sharp_edges import two_face_edges

log = logging.getLogger("rdmesh")

#: A closed component enclosing less than this share of the volume of a ball
#: of its area (``36 pi V^2 / A^3``) is flat: a doubled sheet, no solid (a
#: plate 1000 times wider than thick: 1.4e-5).
FLAT = 1e-6


def is_flat(volume, area):
    """Whether a closed surface of ``area`` enclosing ``volume`` (numbers or
    arrays) is flat (:data:`FLAT`)."""
    return 36.0 * np.pi * np.square(volume) <= FLAT * np.power(area, 3)


def without_duplicates(f: np.ndarray) -> np.ndarray:
    """``f`` without repeated faces: of faces on the same three vertices, the
    first of the orientation left once opposite pairs cancel (in the winding
    number) is kept, or none when they all cancel."""
    key = np.sort(f, axis=1)
    groups, group = unique_rows(key)
    if len(groups) == len(f):
        return f
    # +1 where the face lists its sorted vertices in cyclic order, else -1.
    sign = np.where(_even(f, key), 1.0, -1.0)
    net = np.sign(np.bincount(group, weights=sign, minlength=len(groups)))
    majority = np.flatnonzero(sign == net[group])
    keep = np.sort(majority[np.unique(group[majority], return_index=True)[1]])
    log.warning(
        "MeshSurface: %d repeated faces dropped (%d pairs of opposite faces, which "
        "cancel, both dropped)",
        len(f) - len(keep), int(np.count_nonzero(net == 0)),
    )  # fmt: skip
    return f[keep]


def _even(f: np.ndarray, key: np.ndarray) -> np.ndarray:
    """Whether each face ``f`` lists its sorted vertices ``key`` in cyclic order."""
    return (
        (f[:, 0] == key[:, 0]) & (f[:, 1] == key[:, 1])
        | (f[:, 1] == key[:, 0]) & (f[:, 2] == key[:, 1])
        | (f[:, 2] == key[:, 0]) & (f[:, 0] == key[:, 1])
    )


def coherently_oriented(f: np.ndarray) -> np.ndarray:
    """``f`` with faces turned to agree with their neighbours across edges of
    two faces: in each orientable patch the smaller share of faces turns (of
    two equal shares, the one without the patch's first face). Non-orientable
    patches (a Moebius strip) are left as they are."""
    m = len(f)
    if m == 0:
        return f
    _, pair, forward = two_face_edges(f)
    # Neighbours agree when they run along the shared edge in opposite directions.
    agree = forward[:, 0] != forward[:, 1]
    if agree.all():
        return f
    fa, fb = pair[:, 0], pair[:, 1]
    # Two copies of each face, kept (i) and turned (i + m): agreeing
    # neighbours join copies of the same kind, disagreeing ones across.
    rows = np.r_[fa, fa + m]
    cols = np.r_[np.where(agree, fb, fb + m), np.where(agree, fb + m, fb)]
    graph = coo_matrix((np.ones(len(rows), bool), (rows, cols)), shape=(2 * m, 2 * m))
    _, label = connected_components(graph, directed=False)
    as_is, turned = label[:m], label[m:]
    size = np.bincount(as_is, minlength=int(label.max()) + 1)
    own, other = size[as_is], size[turned]
    turn = (as_is != turned) & ((own < other) | ((own == other) & (as_is > turned)))
    if not turn.any():
        return f
    log.warning(
        "MeshSurface: %d faces turned to agree with their neighbours (the faces were not "
        "consistently oriented)",
        int(turn.sum()),
    )  # fmt: skip
    out = f.copy()
    out[turn] = out[turn][:, ::-1]
    return out


def check_volumes(v: np.ndarray, f: np.ndarray, norms: np.ndarray) -> None:
    """Refuse a closed mesh with a component that encloses no volume.

    ``norms``: twice each face's area.

    Raises
    ------
    rdmesh.MeshInputError
        A component is flat (:data:`FLAT`): a sheet listed both ways, or a
        solid squashed far below any size the mesher can resolve.
    """
    count, face_label, _ = labelled_components(f, len(v))
    # The ratio does not depend on scale: measured at unit size (no overflow).
    lo, hi = v.min(axis=0), v.max(axis=0)
    size = float(np.max(hi - lo)) or 1.0
    u = (v - 0.5 * (lo + hi)) / size
    det = np.einsum("ij,ij->i", u[f[:, 0]], np.cross(u[f[:, 1]], u[f[:, 2]])) / 6.0
    volume = np.bincount(face_label, weights=det, minlength=count)
    area = 0.5 * np.bincount(face_label, weights=norms, minlength=count) / size**2
    flat = is_flat(volume, area)
    if flat.any():
        c = int(np.argmax(flat))
        where = v[f[face_label == c]].reshape(-1, 3).mean(axis=0)
        raise MeshInputError(
            f"mesh component {c} (of {count}, around {np.round(where, 6).tolist()}) encloses "
            f"almost no volume ({abs(volume[c]) * size**3:.3g} for an area of "
            f"{area[c] * size**2:.3g}): a sheet "
            "listed both ways or a solid flattened below any size rdmesh can mesh"
        )
