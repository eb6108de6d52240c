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

log = logging.getLogger("rdmesh")

#: A closed component enclosing less than this share of the volume of a ball
#: of its area (``36 pi V^2 / A^3``) is flat: a doubled sheet, no solid (a
#: plate 1000 times wider than thick: 1.4e-5).
FLAT = 1e-6


def without_duplicates(f: np.ndarray) -> np.ndarray:
    """``f`` without repeated faces: of faces on the same three vertices, one
    copy of each orientation is kept, and a pair of opposite orientations
    (which cancel in the winding number) goes."""
    key = np.sort(f, axis=1)
    order = np.lexsort(key.T[::-1])
    k = key[order]
    start = np.r_[True, np.any(k[1:] != k[:-1], axis=1)]
    if start.all():
        return f
    group = np.cumsum(start) - 1
    # The orientation: whether the face is an even permutation of its sorted vertices.
    even = _even(f[order], k)
    n_groups = int(group[-1]) + 1
    n_even = np.bincount(group, weights=even, minlength=n_groups)
    n_odd = np.bincount(group, minlength=n_groups) - n_even
    # One face per group, of the orientation left once opposite pairs cancel.
    first_even = np.full(n_groups, -1, np.int64)
    first_odd = np.full(n_groups, -1, np.int64)
    idx = np.arange(len(order))
    first_even[group[even][::-1]] = idx[even][::-1]
    first_odd[group[~even][::-1]] = idx[~even][::-1]
    pick = np.where(n_even > n_odd, first_even, np.where(n_odd > n_even, first_odd, -1))
    cancelled = int(np.count_nonzero(pick < 0))
    keep = np.sort(order[pick[pick >= 0]])
    log.warning(
        "MeshSurface: %d repeated faces dropped (%d pairs of opposite faces, which "
        "cancel, both dropped)",
        len(f) - len(keep), cancelled,
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
    heads = f.reshape(-1)
    tails = f[:, [1, 2, 0]].reshape(-1)
    face = np.repeat(np.arange(m), 3)
    n = int(f.max()) + 1
    key = np.minimum(heads, tails) * n + np.maximum(heads, tails)
    order = np.argsort(key, kind="stable")
    k = key[order]
    start = np.r_[True, k[1:] != k[:-1]]
    count = np.diff(np.r_[np.flatnonzero(start), len(k)])
    pair = np.flatnonzero(start)[count == 2]
    a, b = order[pair], order[pair + 1]
    # Neighbours agree when they run along the shared edge in opposite directions.
    agree = heads[a] != heads[b]
    if agree.all():
        return f
    fa, fb = face[a], face[b]
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
    flat = 36.0 * np.pi * volume**2 <= FLAT * area**3
    if flat.any():
        c = int(np.argmax(flat))
        where = v[f[face_label == c]].reshape(-1, 3).mean(axis=0)
        raise MeshInputError(
            f"mesh component {c} (of {count}, around {np.round(where, 6).tolist()}) encloses "
            f"almost no volume ({abs(volume[c]) * size**3:.3g} for an area of "
            f"{area[c] * size**2:.3g}): a sheet "
            "listed both ways or a solid flattened below any size rdmesh can mesh"
        )
