"""A closed input's topology against its remesh's: kept, or where it is not (issue 30).

A closed mesh that does not intersect itself has a known topology: each of its
components is one closed surface with the Euler characteristic ``V - E + F``.
The remesh keeps it when each input component is covered by exactly one
output component with the same Euler characteristic, and no output component
lies on two input components. Each output vertex is a point of the input, so
the input component under it (its closest face's) says which it covers.
"""

from __future__ import annotations

import numpy as np

from .._mesh_components import component_euler, labelled_components
from .._regions import describe_regions, regions
from .._tol import REGION_LINK
from ._mesh_input import directed_once


def topology_against_input(
    surface, vertices: np.ndarray, faces: np.ndarray, euler: list | None = None
) -> dict | None:
    """Whether the mesh ``(vertices, faces)`` has the topology of ``surface``'s
    input (a :class:`~rdmesh.MeshSurface` with ``topology_known``), or None
    when that topology is not known. ``euler``: the mesh's components' Euler
    characteristics, if known (the topology report's, numbered by first face).

    Returns
    -------
    dict or None
        ``kept``; ``input`` and ``output``: the components and their Euler
        characteristics (the output's by the input component each covers);
        ``oriented`` (no edge run twice the same way, None where not ``kept``: with a
        closed manifold output that keeps the input's topology, each output
        component is then homeomorphic to the input component it covers);
        where ``kept`` is False, ``regions`` (the input components whose
        topology differs, as the output's vertices on them) and a
        ``statement``.
    """
    if not getattr(surface, "topology_known", False):
        return None
    in_chi = surface.input_euler
    n_in = len(in_chi)
    faces = np.asarray(faces, np.int64)
    count, face_label, label = labelled_components(faces, len(vertices))
    if euler is None:
        out_chi = component_euler(faces, face_label, count, len(vertices))
    else:
        out_chi = np.asarray(euler, np.int64)
    used = np.flatnonzero(label >= 0)
    on = surface.input_components(vertices[used])
    comp = label[used]
    # The input component most of each output component's vertices lie on.
    pairs, count = np.unique(comp * np.int64(n_in) + on, return_counts=True)
    out_c, in_c = pairs // n_in, pairs % n_in
    best = np.lexsort((-count, out_c))
    first = np.r_[True, out_c[best][1:] != out_c[best][:-1]]
    owner = np.empty(len(out_chi), np.int64)
    owner[out_c[best][first]] = in_c[best][first]
    spans = np.bincount(out_c, minlength=len(out_chi)) > 1  # on two input components
    covers = np.bincount(owner, minlength=n_in)
    chi = np.bincount(owner, out_chi, minlength=n_in).astype(np.int64)
    wrong = (covers != 1) | (chi != in_chi)
    wrong[np.unique(in_c[spans[out_c]])] = True
    kept = not wrong.any()
    out = {
        "kept": kept,
        "input": {"components": n_in, "euler": in_chi.tolist()},
        "output": {"components": len(out_chi), "euler": chi.tolist()},
        "oriented": directed_once(faces) if kept else None,
    }
    if kept:
        return out
    where = regions(vertices[used][wrong[on]], REGION_LINK * surface.radius)
    bad = np.flatnonzero(wrong)
    said = ", ".join(
        f"input component {i} (Euler {in_chi[i]}) is covered by {covers[i]} output "
        f"component{'s' if covers[i] != 1 else ''} (Euler sum {chi[i]})"
        for i in bad[:3]
    )
    if len(bad) > 3:
        said += f", and {len(bad) - 3} more"
    if spans.any():
        said += f"; {int(spans.sum())} output components lie on two input components"
    out["regions"] = where
    out["statement"] = (
        f"the remesh does not have the input's topology: {said} ({describe_regions(where)}); "
        "parts of the input thinner than the radius bound, or closer together than it, "
        "are not resolved there (lower radius_bound)"
    )
    return out
