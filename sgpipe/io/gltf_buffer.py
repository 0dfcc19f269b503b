"""Buffer views and accessors of a pygltflib document over one binary buffer: the glTF writers'
(export, the sample and validation assets, the experiments' generated planes) shared layout."""

from __future__ import annotations

import numpy as np
import pygltflib as gl

_COMPONENT = {np.dtype(np.uint32): gl.UNSIGNED_INT, np.dtype(np.uint16): gl.UNSIGNED_SHORT,
              np.dtype(np.uint8): gl.UNSIGNED_BYTE}


class GltfBuffer:
    """Appends buffer views (each 4-byte aligned) and accessors to `doc`; `blob` holds the
    buffer's bytes."""

    def __init__(self, doc: gl.GLTF2):
        self.doc = doc
        self.blob = bytearray()

    def view(self, data: bytes, target: int | None = None) -> int:
        """A buffer view of `data` (an image's bytes, an accessor's); its index."""
        self.blob += b"\0" * (-len(self.blob) % 4)
        self.doc.bufferViews.append(gl.BufferView(buffer=0, byteOffset=len(self.blob),
                                                  byteLength=len(data), target=target))
        self.blob += data
        return len(self.doc.bufferViews) - 1

    def accessor(self, data: np.ndarray, kind: str, target: int | None,
                 minmax: bool = False) -> int:
        """An accessor of the rows of `data` (uint32 / uint16 / uint8, else float) of type
        `kind` (VEC3, SCALAR …), with min / max when asked; its index."""
        data = np.ascontiguousarray(data)
        acc = gl.Accessor(bufferView=self.view(data.tobytes(), target),
                          componentType=_COMPONENT.get(data.dtype, gl.FLOAT),
                          count=int(data.shape[0]), type=kind)
        if minmax:
            acc.min = [float(v) for v in data.min(0)]
            acc.max = [float(v) for v in data.max(0)]
        self.doc.accessors.append(acc)
        return len(self.doc.accessors) - 1

    def embed(self) -> None:
        """The blob as the document's one GLB binary buffer."""
        self.doc.buffers = [gl.Buffer(byteLength=len(self.blob))]
        self.doc.set_binary_blob(bytes(self.blob))
