"""Mesh bytes back into arrays: OFF (ASCII) and binary little-endian PLY, the formats proto/mesh_encoders.cpp writes.

The client downloads one of them from tracemeshd; OFF carries positions and triangles only (1e-6 Å resolution),
PLY also float32 normals, the atom index and the component of each vertex.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Dict, List, Optional, Tuple

import numpy as np

from ._errors import Error, ParameterError

if TYPE_CHECKING:
    from . import Mesh

__all__ = ["decode_mesh"]

# PLY scalar types (PLY 1.0 names and their sized aliases) as little-endian numpy types.
_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "<i2", "int16": "<i2", "ushort": "<u2",
    "uint16": "<u2", "int": "<i4", "int32": "<i4", "uint": "<u4", "uint32": "<u4", "float": "<f4",
    "float32": "<f4", "double": "<f8", "float64": "<f8",
}


def _malformed(format: str, why: str) -> Error:
    return Error(f"not a {format} mesh: {why}", "invalid_input")


def _decode_off(data: bytes) -> Tuple[np.ndarray, np.ndarray]:
    words: List[bytes] = []
    for line in data.split(b"\n"):
        words.extend(line.split(b"#", 1)[0].split())
    if not words or words[0] != b"OFF" or len(words) < 4:
        raise _malformed("OFF", "no 'OFF' header with vertex, face and edge counts")
    try:
        vertex_count, face_count = int(words[1]), int(words[2])
        body = words[4:]
        vertices = np.array(body[: 3 * vertex_count], dtype=np.float64).reshape(vertex_count, 3)
        faces = np.array(body[3 * vertex_count:], dtype=np.int64).reshape(face_count, 4)
    except ValueError as error:
        raise _malformed("OFF", str(error)) from None
    if face_count and not np.all(faces[:, 0] == 3):
        raise _malformed("OFF", "a face that is not a triangle")
    return vertices, faces[:, 1:].astype(np.int32)


def _ply_header(data: bytes) -> Tuple[List[Tuple[str, int, List[Tuple[str, ...]]]], int]:
    """The elements [(name, count, properties)] of a binary little-endian PLY header, and where its body starts."""
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply\n") or end < 0:
        raise _malformed("PLY", "no 'ply' ... 'end_header' header")
    elements: List[Tuple[str, int, List[Tuple[str, ...]]]] = []
    for line in data[:end].decode("ascii", "replace").splitlines()[1:]:
        words = line.split()
        if not words or words[0] == "comment":
            continue
        if words[0] == "format" and words[1:2] != ["binary_little_endian"]:
            raise _malformed("PLY", f"format {' '.join(words[1:])} (binary_little_endian is read)")
        elif words[0] == "element":
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property" and elements:
            elements[-1][2].append(tuple(words[1:]))
    return elements, end + len(b"end_header\n")


def _decode_ply(data: bytes) -> Dict[str, np.ndarray]:
    elements, offset = _ply_header(data)
    out: Dict[str, np.ndarray] = {}
    for name, count, properties in elements:
        if properties and properties[0][0] == "list":
            # Triangles: a list count then three indices, fixed-size since every face here is a triangle.
            _, count_type, index_type, _ = properties[0]
            dtype = np.dtype([("n", _PLY_TYPES[count_type]), ("v", _PLY_TYPES[index_type], (3,))])
        else:
            dtype = np.dtype([(prop[1], _PLY_TYPES[prop[0]]) for prop in properties])
        size = dtype.itemsize * count
        if offset + size > len(data):
            raise _malformed("PLY", f"element {name} runs past the end of the data")
        records = np.frombuffer(data, dtype=dtype, count=count, offset=offset)
        offset += size
        if name == "face":
            if count and not np.all(records["n"] == 3):
                raise _malformed("PLY", "a face that is not a triangle")
            out["faces"] = records["v"].astype(np.int32)
        elif name == "vertex":
            out.update({prop[1]: records[prop[1]] for prop in properties})
    if "faces" not in out or "x" not in out:
        raise _malformed("PLY", "no vertex or face element")
    return out


def decode_mesh(data: bytes, format: str, report: Optional[Dict[str, Any]] = None) -> "Mesh":
    """The Mesh that OFF or PLY bytes (as tracemesh writes them) hold. OFF has neither normals nor atom indices
    (0×3 and empty arrays); PLY's float32 values are widened to float64. Raises Error (code "invalid_input") for
    malformed bytes, ParameterError for another format."""
    from . import Mesh

    if format == "off":
        vertices, faces = _decode_off(data)
        return Mesh(vertices, faces, np.zeros((0, 3)), np.zeros(0, dtype=np.int32), report or {})
    if format == "ply":
        ply = _decode_ply(data)
        column = lambda *names: np.column_stack([ply[n].astype(np.float64) for n in names])  # noqa: E731
        normals = column("nx", "ny", "nz") if "nx" in ply else np.zeros((0, 3))
        atom_index = ply["atom_index"].astype(np.int32) if "atom_index" in ply else np.zeros(0, dtype=np.int32)
        components = ply["component"].astype(np.int32) if "component" in ply else None
        return Mesh(column("x", "y", "z"), ply["faces"], normals, atom_index, report or {}, components)
    raise ParameterError(f"decode_mesh reads off or ply, not {format!r}", "invalid_argument")
