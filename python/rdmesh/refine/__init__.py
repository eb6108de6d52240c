"""Refinement: from the surface and the core to a mesh.

- :mod:`~rdmesh.refine.facets`: the crossings of each changed facet's dual;
- :mod:`~rdmesh.refine.criteria`: angle, size and distance bounds;
- :mod:`~rdmesh.refine.pipeline`: changed facets -> evaluation -> flags in the core;
- :mod:`~rdmesh.refine.stages`: what each stage refines, and where;
- :mod:`~rdmesh.refine.methods`: the two methods as seeds plus ordered stages;
- :mod:`~rdmesh.refine.floor`: the spacing floor;
- :mod:`~rdmesh.refine.mesher`: the loop.

Submodules are imported where used.
"""
