"""Volumes meshed in blocks on a Dask cluster, with seams that match.

:func:`mesh_volume_blocks` cuts a volume into blocks, traces the curves where
the isosurface meets the faces between blocks once (:mod:`.trace`), protects
the whole network of those curves once (:mod:`.network`), meshes each block
on a worker with exactly the balls of its faces (:mod:`.tasks`), and welds
the blocks' meshes by their equal vertices (:mod:`.weld`). Modules:
:mod:`.layout` (where the blocks and faces are), :mod:`.field` (the
interpolant every task evaluates the same way), :mod:`.options` (checked
before anything runs), :mod:`.source` (the windows the tasks read),
:mod:`.passes` (the passes over the blocks), :mod:`.run` (tasks on the
cluster), :mod:`.report` and :mod:`.volume_blocks` (the entry point).
"""

from .volume_blocks import mesh_volume_blocks

__all__ = ["mesh_volume_blocks"]
