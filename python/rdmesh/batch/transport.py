"""Sending jobs to workers: cloudpickle, plus what rdmesh's surfaces need.

An :class:`~rdmesh.ImplicitSurface` holds a lock (for its evaluation count)
and a :class:`~rdmesh.MeshSurface` a C++ distance structure; neither pickles
as is. This pickler gives a lock as a new lock and a mesh surface as its
(cleaned) triangles, from which the worker builds the same surface, with the
rest of its attributes restored. A class that defines its own pickling
(``__reduce__``, ``__getstate__``) is left to it. A
:class:`~rdmesh.VolumeSurface` keeps its samples only in C++: it is refused
with a message that says what to send instead.
"""

from __future__ import annotations

import functools
import io
import pickle
import threading
from typing import Any

from ..surfaces.mesh import MeshSurface
from ..surfaces.volume import VolumeSurface

_LOCKS = (type(threading.Lock()), type(threading.RLock()))

#: Attributes of a MeshSurface that are its constructor's arguments or that the
#: constructor rebuilds on the worker (the C++ structure, the lock, the k-d tree,
#: the table of its crossings' faces).
_REBUILT = ("vertices", "faces", "_core", "_lock", "_kdtree", "_on_face")


class NotSendable(TypeError):
    """A job that cannot be pickled, so cannot be sent to a worker."""


def _own_pickling(cls: type) -> bool:
    """True if ``cls`` (or a base other than ``object``) defines how it pickles."""
    hooks = ("__reduce__", "__reduce_ex__", "__getstate__", "__setstate__")
    return any(hook in vars(base) for base in cls.__mro__[:-1] for hook in hooks)


def _mesh_surface(vertices: Any, faces: Any, name: str) -> MeshSurface:
    # Its sharp edges, feature settings and holes come back with the pickled
    # state; ``faces`` already holds the caps over its holes, if any.
    return MeshSurface((vertices, faces), name=name, feature_angle=None, holes="fill")


def _volume_refusal(surface: VolumeSurface) -> NotSendable:
    return NotSendable(
        f"a VolumeSurface ({surface.name!r}) keeps its samples in C++ and cannot be sent "
        "to a worker; give the job a function that makes it there instead, such as "
        "Job(functools.partial(make_volume, path)) with make_volume(path) returning "
        "rdmesh.VolumeSurface(numpy.load(path), ...)"
    )


@functools.cache
def _pickler() -> type:
    """The pickler class (cloudpickle comes with Dask, so it is imported late)."""
    import cloudpickle

    class Pickler(cloudpickle.Pickler):
        def reducer_override(self, obj: Any) -> Any:
            return _reduce(obj) or super().reducer_override(obj)

    return Pickler


def _reduce(obj: Any) -> Any:
    """How to pickle ``obj`` if it is one of ours that needs help, else None."""
    kind = type(obj)
    if kind in _LOCKS:  # a new, unlocked lock of the same kind
        return (threading.RLock if kind is _LOCKS[1] else threading.Lock), ()
    if isinstance(obj, MeshSurface) and not _own_pickling(kind):
        if kind is not MeshSurface:
            raise NotSendable(
                f"{kind.__name__}, a subclass of MeshSurface, cannot be sent to a worker "
                "unless it defines its own pickling (__reduce__); give the job a function "
                "that makes it on the worker instead"
            )
        state = {k: v for k, v in vars(obj).items() if k not in _REBUILT}
        return _mesh_surface, (obj.vertices, obj.faces, obj.name), state
    if isinstance(obj, VolumeSurface) and not _own_pickling(kind):
        raise _volume_refusal(obj)
    return None


def dumps(obj: Any) -> bytes:
    """``obj`` pickled for a worker.

    Raises
    ------
    NotSendable
        It cannot be pickled; the message says what could not and what to do.
    """
    buffer = io.BytesIO()
    try:
        _pickler()(buffer, protocol=pickle.HIGHEST_PROTOCOL).dump(obj)
    except NotSendable:
        raise
    except Exception as exc:  # noqa: BLE001 - pickling user objects raises anything
        raise NotSendable(
            f"the job cannot be sent to a worker, it does not pickle: "
            f"{type(exc).__name__}: {exc}. Surfaces, their functions and the options must "
            "pickle (cloudpickle handles lambdas and closures, not open files, locks or "
            "C++ objects); a surface that holds such things can be made on the worker by "
            "a function given as the job's surface"
        ) from exc
    return buffer.getvalue()


def loads(data: bytes) -> Any:
    """The object :func:`dumps` pickled."""
    return pickle.loads(data)
