"""Where the blocks of a volume are: their boxes, their faces, and who traces each face.

The block boundaries are sample planes: along an axis of ``n`` samples cut
into ``m = ceil((n - 1) / block)`` blocks, block ``k`` runs from sample
``k (n - 1) // m`` to sample ``(k + 1) (n - 1) // m``, so neighbouring blocks
share the plane of samples between them and no block has more than
``block`` cells along an axis. A face is one rectangle of a boundary plane
between two neighbouring blocks (or on the volume's own box), keyed
``(axis, plane, j, k)``: its normal axis, the index of its plane along that
axis (0 .. m), and the block indices along the two other axes in increasing
order. Every physical coordinate of a plane comes from one formula
(:meth:`Layout.coord`), so two tasks computing the same point get the same
bits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

Face = tuple[int, int, int, int]
Block = tuple[int, int, int]


def _others(axis: int) -> tuple[int, int]:
    """The two other axes, in increasing order."""
    b, c = (k for k in range(3) if k != axis)
    return b, c


@dataclass(frozen=True)
class Layout:
    """The blocks of a volume.

    Attributes
    ----------
    shape : (3,) samples per axis.
    planes : three tuples of sample indices: the block boundaries along each
        axis, from 0 to ``n - 1``.
    spacing, origin : (3,) float64, as for :class:`rdmesh.VolumeSurface`.
    """

    shape: tuple[int, int, int]
    planes: tuple[tuple[int, ...], tuple[int, ...], tuple[int, ...]]
    spacing: tuple[float, float, float]
    origin: tuple[float, float, float]

    @classmethod
    def of(cls, shape, block: int, spacing, origin) -> Layout:
        """Blocks of at most ``block`` cells along each axis, as equal as can be."""
        planes = []
        for n in shape:
            m = max(1, -(-(n - 1) // block))
            planes.append(tuple((k * (n - 1)) // m for k in range(m + 1)))
        return cls(
            tuple(int(n) for n in shape),
            tuple(planes),  # type: ignore[arg-type]
            tuple(float(s) for s in spacing),  # type: ignore[arg-type]
            tuple(float(o) for o in origin),  # type: ignore[arg-type]
        )

    @property
    def counts(self) -> tuple[int, int, int]:
        """Blocks along each axis."""
        return tuple(len(p) - 1 for p in self.planes)  # type: ignore[return-value]

    def blocks(self) -> list[Block]:
        """Every block, in C order (the order of the weld and of the results)."""
        n0, n1, n2 = self.counts
        return [(i, j, k) for i in range(n0) for j in range(n1) for k in range(n2)]

    def coord(self, axis: int, index) -> np.ndarray:
        """The physical coordinate of (fractional) sample ``index`` along ``axis``."""
        return self.origin[axis] + self.spacing[axis] * np.asarray(index, dtype=np.float64)

    def index_box(self, block: Block) -> tuple[np.ndarray, np.ndarray]:
        """The first and last sample of a block along each axis, ``(3,)`` each."""
        lo = np.array([self.planes[a][block[a]] for a in range(3)], np.int64)
        hi = np.array([self.planes[a][block[a] + 1] for a in range(3)], np.int64)
        return lo, hi

    def box(self, block: Block) -> np.ndarray:
        """The block's box ``(2, 3)``: its lowest and highest corner."""
        lo, hi = self.index_box(block)
        return np.array([[float(self.coord(a, i[a])) for a in range(3)] for i in (lo, hi)])

    @property
    def whole_box(self) -> np.ndarray:
        """The volume's box ``(2, 3)``."""
        return np.array(
            [[float(self.coord(a, 0)) for a in range(3)],
             [float(self.coord(a, self.shape[a] - 1)) for a in range(3)]]
        )  # fmt: skip

    # -- faces ----------------------------------------------------------------------

    def faces_of(self, block: Block) -> list[Face]:
        """The six faces of a block: low and high along each axis."""
        out = []
        for a in range(3):
            b, c = _others(a)
            for side in (0, 1):
                out.append((a, block[a] + side, block[b], block[c]))
        return out

    def owned_faces(self, block: Block) -> list[Face]:
        """The faces a block traces: its low face along each axis, and its high
        face where it is the last block along that axis."""
        out = []
        for a in range(3):
            b, c = _others(a)
            out.append((a, block[a], block[b], block[c]))
            if block[a] == self.counts[a] - 1:
                out.append((a, block[a] + 1, block[b], block[c]))
        return out

    def owner(self, face: Face) -> Block:
        """The block that traces a face."""
        a, p, j, k = face
        b, c = _others(a)
        out = [0, 0, 0]
        out[a], out[b], out[c] = min(p, self.counts[a] - 1), j, k
        return tuple(out)  # type: ignore[return-value]

    def all_faces(self) -> list[Face]:
        """Every face, in the order of the blocks that trace them."""
        return [f for blk in self.blocks() for f in self.owned_faces(blk)]

    def is_outer(self, face: Face) -> bool:
        """The face lies on the volume's own box."""
        return face[1] in (0, self.counts[face[0]])

    def rect(self, face: Face) -> tuple[int, int, tuple[int, int], tuple[int, int]]:
        """``(axis, plane sample index, (b0, b1), (c0, c1))``: the face's plane and
        its sample range along the two other axes (in increasing axis order)."""
        a, p, j, k = face
        b, c = _others(a)
        pb, pc = self.planes[b], self.planes[c]
        return a, self.planes[a][p], (pb[j], pb[j + 1]), (pc[k], pc[k + 1])


def others(axis: int) -> tuple[int, int]:
    """The two axes other than ``axis``, in increasing order."""
    return _others(axis)
