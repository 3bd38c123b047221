"""tracemesh: the Gaussian molecular surface (TMSmesh, Chen & Lu 2011) of a molecule as a certified triangle mesh.

Locally, through the same readers, mesher and encoders as the ``tracemesh`` command::

    import tracemesh
    molecule = tracemesh.read_molecule("fas2.pqr")
    mesh = tracemesh.mesh(molecule, density=2)
    mesh.vertices, mesh.faces, mesh.normals, mesh.atom_index, mesh.report["area"]
    mesh.save("fas2.off")

or through a tracemeshd service: ``tracemesh.Client("http://127.0.0.1:8080").mesh("fas2.pqr", density=2)``.
docs/python.md is the guide and the reference.
"""

from __future__ import annotations

import json
import os
import warnings
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional, Tuple, Union

import numpy as np

from . import _native
from ._errors import Error, ParameterError, ServiceError
from ._fields import field_texts

__all__ = [
    "Client",
    "Error",
    "Mesh",
    "Molecule",
    "ParameterError",
    "ServiceError",
    "decode_mesh",
    "engine_version",
    "mesh",
    "read_molecule",
]

#: The engine's version, as every report names it ("tracemesh-engine-N").
engine_version: str = _native.engine_version
#: The mesh parameters of :func:`mesh` (the service's field names; the CLI's options with '-' for '_').
MESH_PARAMETERS: Tuple[str, ...] = tuple(_native.mesh_parameter_fields)
#: The input options of :func:`read_molecule` (the service's fields; the CLI's --format-in, --radii, ...).
INPUT_OPTIONS: Tuple[str, ...] = tuple(_native.structure_option_names)
#: What :meth:`Mesh.save` writes: the CLI's --format names.
OUTPUT_FORMATS: Tuple[str, ...] = tuple(_native.output_formats)

PathLike = Union[str, "os.PathLike[str]"]
Parameter = Union[int, float, str, None]
#: Called as progress(stage, fraction) on the calling thread while :func:`mesh` runs.
ProgressCallback = Callable[[str, float], None]


@dataclass(eq=False)
class Molecule:
    """Atoms: ``positions`` (N×3 float64, Å), ``radii`` (N, Å; 0 for atoms that do not contribute) and
    ``charges`` (N, e; 0 for PDB, mmCIF and xyzr input). ``input`` is what :func:`read_molecule` read (None for
    atoms made from arrays): the report's ``input`` section, whose format and radii source ``format`` and
    ``radii_source`` give."""

    positions: np.ndarray
    radii: np.ndarray
    charges: np.ndarray
    input: Optional[_native.InputSummary] = None

    @property
    def format(self) -> Optional[str]:
        """The format read: "pqr", "pdb", "mmcif" or "xyzr" (None for arrays)."""
        return None if self.input is None else self.input.format

    @property
    def radii_source(self) -> Optional[str]:
        """Where the radii came from: "file" (PQR, xyzr) or the table's name, "bondi" or "mantina"."""
        return None if self.input is None else self.input.radii

    def __len__(self) -> int:
        return int(self.radii.shape[0])

    def __repr__(self) -> str:
        return f"Molecule({len(self)} atoms, format={self.format!r}, radii_source={self.radii_source!r})"

    @classmethod
    def from_array(cls, xyzr: Any) -> "Molecule":
        """Atoms from an N×4 array of x, y, z, radius (Å); charges 0."""
        array = np.ascontiguousarray(xyzr, dtype=np.float64)
        if array.ndim != 2 or array.shape[1] != 4:
            raise ParameterError(f"atoms must be an array of shape (N, 4) (x, y, z, radius), got shape "
                                 f"{array.shape}", "invalid_argument")
        return cls(array[:, :3].copy(), array[:, 3].copy(), np.zeros(array.shape[0]))

    def as_array(self) -> np.ndarray:
        """The N×4 array of x, y, z, radius."""
        return np.column_stack([self.positions, self.radii])


@dataclass(eq=False)
class Mesh:
    """A surface mesh: ``vertices`` (V×3 float64, Å), ``faces`` (F×3 int32, counter-clockwise seen from outside),
    ``normals`` (V×3, outward unit normals), ``atom_index`` (V int32: the atom contributing most to the field at
    each vertex, an index into the molecule) and ``report`` (the JSON report of ``tracemesh --report`` as a dict:
    area, volume, components, certificate, quality, timings, ...). A mesh decoded from PLY also has
    ``components`` (V int32: each vertex's connected component, an index into report["components"])."""

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    atom_index: np.ndarray
    report: Dict[str, Any] = field(default_factory=dict)
    components: Optional[np.ndarray] = None

    def __repr__(self) -> str:
        return f"Mesh({len(self.vertices)} vertices, {len(self.faces)} faces)"

    def _arrays(self) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        return (self.vertices, np.asarray(self.faces, dtype=np.int64), self.normals,
                np.asarray(self.atom_index, dtype=np.int64))

    def save(self, path: PathLike, format: Optional[str] = None) -> List[str]:
        """Writes the mesh as ``tracemesh -o path`` does: the format from the extension (.off, .drc, .glb, .ply,
        .vert/.face for the MSMS pair) or ``format`` (one of OUTPUT_FORMATS), the file replaced atomically.
        Returns the paths written (two for msms)."""
        return _native.save(*self._arrays(), os.fspath(path), format)

    def encode(self, format: str = "off") -> bytes:
        """The bytes of the mesh in ``format`` (off, draco, glb, glb-raw, ply), as the CLI and the service encode."""
        if format == "msms":
            raise ParameterError("encode() gives one buffer: use encode_msms() for the .vert/.face pair",
                                 "invalid_argument")
        return _native.encode(*self._arrays(), format)[0]

    def encode_msms(self) -> Tuple[bytes, bytes]:
        """The MSMS .vert and .face files (1-based indices), as ``tracemesh --format msms`` writes them."""
        vert, face = _native.encode(*self._arrays(), "msms")
        return vert, face


def read_molecule(path: PathLike, **options: Optional[str]) -> Molecule:
    """Reads a PQR, PDB, mmCIF or xyzr file, plain or gzip-compressed, as the ``tracemesh`` command does.

    ``options`` are the input options of the CLI and the service, by the service's names (INPUT_OPTIONS):
    ``format_in`` "pqr", "pdb", "mmcif" or "xyzr" (default: the format the file's extension declares, .pqr,
    .pdb/.ent, .cif/.mmcif, .xyzr, each also .gz, else detected from the content); for PDB and mmCIF ``radii``
    "bondi" (default) or "mantina", ``hydrogens`` "keep" (default) or "drop", ``waters`` "drop" (default) or
    "keep", ``ligands`` "keep" (default) or "drop", and ``assembly`` (docs/formats.md). None keeps the default.

    Raises TypeError for an unknown option, ParameterError (a ValueError) for a bad value, Error otherwise (code
    "io_error" for a file that cannot be read, "invalid_input" naming the damaged line, "nothing_to_mesh",
    "limit_exceeded").
    """
    read = _native.read_molecule(os.fspath(path), field_texts(options, INPUT_OPTIONS))
    return Molecule(read["positions"], read["radii"], read["charges"], read["input"])


def mesh(molecule: Union[Molecule, PathLike, Any], *, density: Parameter = None, d: Parameter = None,
         t0: Parameter = None, method: Optional[str] = None, refine: Optional[str] = None,
         cavities: Optional[str] = None, trace_degree: Parameter = None, trace_step: Parameter = None,
         trace_cos_bound: Parameter = None, trace_extreme_tolerance: Parameter = None, threads: int = 0,
         progress: Optional[ProgressCallback] = None, _hold_until_cancelled: bool = False) -> Mesh:
    """Meshes the Gaussian surface φ = t0 of ``molecule`` (a Molecule, an N×4 array of x, y, z, radius, or a file
    path read with :func:`read_molecule`'s defaults), as ``tracemesh`` does with the same parameters.

    Parameters (None: the engine's default; docs/api.md gives each range): ``density`` vertices per Å² (1), ``d``
    kernel decay rate (-1), ``t0`` isovalue (1), ``method`` "trace" or "lattice" ("trace"), ``refine`` "full" or
    "none" ("full"), ``cavities`` "keep" or "drop" ("keep"), ``trace_degree`` (10), ``trace_step`` (0.5),
    ``trace_cos_bound`` (0.9397), ``trace_extreme_tolerance`` (0.02). Numbers may be given as strings, read as the
    CLI reads them. ``threads``: worker threads, 0 = all cores (never changes the mesh). ``progress``: called as
    progress(stage, fraction) from this thread while the mesher runs (a raise cancels it).

    The mesher runs without the GIL; Ctrl-C (SIGINT) cancels it and raises KeyboardInterrupt. Raises
    ParameterError (a ValueError) for a bad parameter, with the CLI's message ("density must be a number in
    [0.05, 20], got 50"), Error otherwise (its code as the service's: "nothing_to_mesh", "unresolvable_input",
    "limit_exceeded", "internal_error"). ``_hold_until_cancelled`` is the test suite's seam: the run stops at its
    first progress report until it is cancelled.
    """
    if isinstance(molecule, (str, os.PathLike)):
        molecule = read_molecule(molecule)
    elif not isinstance(molecule, Molecule):
        molecule = Molecule.from_array(molecule)
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)):
        raise TypeError(f"threads must be an int, got {type(threads).__name__}")
    if not 0 <= threads <= _native.max_threads:
        raise ParameterError(f"threads must be an integer in [0, {_native.max_threads}] (0 = all cores), got "
                             f"{threads}", "invalid_argument")
    fields = field_texts({"density": density, "d": d, "t0": t0, "method": method, "refine": refine,
                          "cavities": cavities, "trace_degree": trace_degree, "trace_step": trace_step,
                          "trace_cos_bound": trace_cos_bound, "trace_extreme_tolerance": trace_extreme_tolerance},
                         MESH_PARAMETERS)
    out = _native.mesh(molecule.positions, molecule.radii, fields, int(threads), molecule.input, progress,
                       _hold_until_cancelled)
    if out["fallback_reason"]:
        # As the CLI warns: the mesh is certified, but of the lattice path (report["method_used"]).
        warnings.warn(f"the trace path failed ({out['fallback_reason']}); the lattice path made this mesh",
                      RuntimeWarning, stacklevel=2)
    return Mesh(out["vertices"], out["faces"], out["normals"], out["atom_index"], json.loads(out["report"]))


from ._client import Client  # noqa: E402  (the client builds Mesh objects)
from ._decode import decode_mesh  # noqa: E402
