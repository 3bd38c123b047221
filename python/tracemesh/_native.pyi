"""Type hints of the extension module tracemesh._native (python/src/native.cpp); use the functions of tracemesh."""

from typing import Callable, Dict, List, Optional

import numpy as np

engine_version: str
mesh_parameter_fields: List[str]
structure_option_names: List[str]
max_threads: int
output_formats: List[str]

class InputSummary:
    """What read_molecule read, for the report's input."""

    @property
    def format(self) -> str: ...
    @property
    def radii(self) -> str: ...
    @property
    def json(self) -> str: ...

def read_molecule(path: str, options: Dict[str, str]) -> Dict[str, object]: ...
def mesh(positions: np.ndarray, radii: np.ndarray, fields: Dict[str, str], threads: int,
         input: Optional[InputSummary], on_progress: Optional[Callable[[str, float], None]],
         hold_until_cancelled: bool) -> Dict[str, object]: ...
def encode(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray, atom_index: np.ndarray,
           format: str) -> List[bytes]: ...
def save(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray, atom_index: np.ndarray, path: str,
         format: Optional[str]) -> List[str]: ...
