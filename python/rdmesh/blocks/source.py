"""The volume as the tasks read it: numpy windows sliced here, or lazy dask slices."""

from __future__ import annotations

from typing import Any

import numpy as np

from .field import raw_range
from .layout import Layout, others
from .tasks import Piece


class HDF5Dataset:
    """An HDF5 dataset that travels as its file's name and its own, and is
    opened again where it is read (``h5py``'s datasets cannot be pickled).

    Parameters
    ----------
    dataset : h5py.Dataset
        An open dataset; its file must be at the same path on the workers.
    """

    def __init__(self, dataset: Any) -> None:
        self.filename = str(dataset.file.filename)
        self.name = str(dataset.name)
        self.shape = tuple(int(n) for n in dataset.shape)
        self.dtype = np.dtype(dataset.dtype)
        self.ndim = len(self.shape)

    def __getitem__(self, key: Any) -> np.ndarray:
        import h5py

        with h5py.File(self.filename, "r") as fh:
            return fh[self.name][key]


def _reopened(volume: Any) -> Any:
    """An h5py dataset as an :class:`HDF5Dataset`; anything else as it is."""
    if type(volume).__module__.startswith("h5py") and hasattr(volume, "file"):
        return HDF5Dataset(volume)
    return volume


class Source:
    """The volume as tasks read it: numpy windows, or lazy dask slices."""

    def __init__(self, volume: Any, interpolation: str) -> None:
        self.lazy = not isinstance(volume, np.ndarray)
        if self.lazy:
            try:
                import dask.array as da
            except ImportError as exc:
                raise ImportError(
                    "mesh_volume_blocks needs Dask: pip install 'rdmesh[dask]'"
                ) from exc
            if not isinstance(volume, da.Array):
                if not hasattr(volume, "shape") or not hasattr(volume, "dtype"):
                    volume = np.asarray(volume)
                    self.lazy = False
                else:
                    volume = da.from_array(_reopened(volume))
        self.data = volume
        self.shape = tuple(int(n) for n in volume.shape)
        dtype = np.dtype(volume.dtype)
        if len(self.shape) != 3:
            raise ValueError(f"volume must be a 3-D array, got {len(self.shape)}-D with shape "
                             f"{self.shape}")  # fmt: skip
        real = np.issubdtype(dtype, np.integer) or np.issubdtype(dtype, np.floating)
        if not (real or dtype == np.bool_):
            raise ValueError(
                f"volume must hold real numbers (integers, floats or booleans), got dtype {dtype}"
            )
        least = 4 if interpolation == "cubic" else 2
        if min(self.shape) < least:
            raise ValueError(
                f"volume must have at least {least} samples along each axis for "
                f"{interpolation} interpolation, got shape {self.shape}"
            )

    def piece(self, lo: np.ndarray, hi: np.ndarray, degree: int | None) -> Piece:
        """The window a region ``[lo, hi]`` of samples needs (``degree`` None:
        the region itself)."""
        a, b = (lo, hi) if degree is None else raw_range(lo, hi, degree)
        sl, pads = [], []
        for k in range(3):
            n = self.shape[k]
            s0, s1 = max(int(a[k]), 0), min(int(b[k]), n - 1)
            sl.append(slice(s0, s1 + 1))
            pads.append((s0 - int(a[k]), int(b[k]) - s1))
        data = self.data[tuple(sl)]
        if self.lazy:
            import dask

            (data,) = dask.optimize(data)
        else:
            data = np.array(data)
        return Piece(data, np.asarray(a, np.int64), pads)


def face_box(layout: Layout, face) -> tuple[np.ndarray, np.ndarray]:
    a, p, (b0, b1), (c0, c1) = layout.rect(face)
    b, c = others(a)
    lo, hi = np.zeros(3, np.int64), np.zeros(3, np.int64)
    lo[a] = hi[a] = p
    lo[b], hi[b], lo[c], hi[c] = b0, b1, c0, c1
    return lo, hi
