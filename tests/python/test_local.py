"""The package meshing locally: the same bytes and report as the tracemesh command, its readers' arrays, its errors
as Python exceptions with the command's messages, and Ctrl-C."""

import inspect
import json
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import tracemesh

THREADS = 2


def run_cli(cli: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(cli), *map(str, args)], capture_output=True, text=True, check=False)


def cli_message(completed: subprocess.CompletedProcess) -> str:
    """The one line `tracemesh: <message>[ (see tracemesh --help)]` without its prefix and usage hint."""
    line = completed.stderr.strip()
    assert line.startswith("tracemesh: "), completed.stderr
    return line[len("tracemesh: "):].removesuffix(" (see tracemesh --help)")


def without_timings(report: dict) -> dict:
    return {key: value for key, value in report.items() if key not in ("timings", "encodings")}


def cli_options(params: dict) -> list:
    return [word for name, value in params.items() for word in (f"--{name.replace('_', '-')}", value)]


@pytest.fixture(scope="module")
def fas2(molecules: Path) -> tracemesh.Molecule:
    return tracemesh.read_molecule(molecules / "fas2.pqr")


@pytest.mark.parametrize("params", [{}, {"density": 2, "method": "lattice"}, {"refine": "none", "d": -2, "t0": 0.5},
                                    {"trace_degree": 8, "trace_step": 0.4, "cavities": "drop"}])
def test_the_off_bytes_and_the_report_are_the_commands(cli, molecules, fas2, tmp_path, params):
    off, report = tmp_path / "cli.off", tmp_path / "cli.json"
    completed = run_cli(cli, molecules / "fas2.pqr", "-o", off, "--threads", THREADS, "--report", report,
                        *cli_options(params))
    assert completed.returncode == 0, completed.stderr
    mesh = tracemesh.mesh(fas2, threads=THREADS, **params)
    assert mesh.save(tmp_path / "module.off") == [str(tmp_path / "module.off")]
    assert (tmp_path / "module.off").read_bytes() == off.read_bytes()
    assert without_timings(mesh.report) == without_timings(json.loads(report.read_text()))
    assert mesh.vertices.shape == (mesh.report["vertices"], 3) and mesh.vertices.dtype == np.float64
    assert mesh.faces.shape == (mesh.report["triangles"], 3) and mesh.faces.dtype == np.int32
    assert mesh.normals.shape == mesh.vertices.shape
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1.0, rtol=1e-9)
    assert mesh.atom_index.shape == (len(mesh.vertices),) and mesh.atom_index.max() < len(fas2)


def test_every_format_is_the_commands(cli, molecules, fas2, tmp_path):
    mesh = tracemesh.mesh(fas2, threads=1)  # one thread: the bytes never depend on the count
    for name in ("a.drc", "a.glb", "a.ply", "a.vert"):
        assert run_cli(cli, molecules / "fas2.pqr", "-o", tmp_path / f"cli_{name}").returncode == 0
        written = mesh.save(tmp_path / f"py_{name}")
        for path in written:
            suffix = Path(path).suffix
            assert Path(path).read_bytes() == (tmp_path / f"cli_a{suffix}").read_bytes(), path
    assert mesh.save(tmp_path / "raw.bin", format="glb-raw") == [str(tmp_path / "raw.bin")]
    assert run_cli(cli, molecules / "fas2.pqr", "-o", tmp_path / "raw_cli.bin", "--format", "glb-raw").returncode == 0
    assert (tmp_path / "raw.bin").read_bytes() == (tmp_path / "raw_cli.bin").read_bytes()
    assert mesh.encode("draco") == (tmp_path / "cli_a.drc").read_bytes()
    vert, face = mesh.encode_msms()
    assert vert == (tmp_path / "cli_a.vert").read_bytes() and face == (tmp_path / "cli_a.face").read_bytes()


def test_decoding_ply_and_off_gives_the_arrays_back(fas2):
    mesh = tracemesh.mesh(fas2, threads=THREADS)
    ply = tracemesh.decode_mesh(mesh.encode("ply"), "ply")
    np.testing.assert_array_equal(ply.vertices, mesh.vertices.astype(np.float32))
    np.testing.assert_array_equal(ply.normals, mesh.normals.astype(np.float32))
    np.testing.assert_array_equal(ply.faces, mesh.faces)
    np.testing.assert_array_equal(ply.atom_index, mesh.atom_index)
    assert ply.components.shape == (len(mesh.vertices),) and ply.components.max() == len(mesh.report["components"]) - 1
    off = tracemesh.decode_mesh(mesh.encode("off"), "off")
    np.testing.assert_array_equal(off.faces, mesh.faces)
    np.testing.assert_allclose(off.vertices, mesh.vertices, atol=1e-6)
    assert off.encode("off") == mesh.encode("off")  # 9 significant digits read back to the same text
    with pytest.raises(tracemesh.Error, match="not a PLY mesh"):
        tracemesh.decode_mesh(b"ply\nformat ascii 1.0\nend_header\n", "ply")


def pqr_atoms(path: Path) -> np.ndarray:
    """x, y, z, charge, radius of every ATOM/HETATM record: the last five fields of a PQR line."""
    rows = [line.split()[-5:] for line in path.read_text().splitlines() if line.startswith(("ATOM", "HETATM"))]
    return np.array(rows, dtype=np.float64)


def test_a_molecule_holds_the_files_atoms(molecules, fas2):
    expected = pqr_atoms(molecules / "fas2.pqr")
    assert len(fas2) == len(expected) == 906
    assert fas2.positions.shape == (906, 3) and fas2.positions.dtype == np.float64
    np.testing.assert_array_equal(fas2.positions, expected[:, :3])
    np.testing.assert_array_equal(fas2.charges, expected[:, 3])
    np.testing.assert_array_equal(fas2.radii, expected[:, 4])
    np.testing.assert_array_equal(fas2.as_array(), expected[:, [0, 1, 2, 4]])
    assert (fas2.format, fas2.radii_source) == ("pqr", "file")


def pdb_record(record, serial, name, residue, sequence, xyz, element):
    x, y, z = xyz
    return (f"{record:<6}{serial:>5} {name:<4} {residue:>3} A{sequence:>4}    {x:>8.3f}{y:>8.3f}{z:>8.3f}"
            f"{1.0:>6.2f}{0.0:>6.2f}          {element:>2}")


def test_the_readers_options_are_the_commands(tmp_path):
    pdb = tmp_path / "two.pdb"
    pdb.write_text("\n".join([
        pdb_record("ATOM", 1, " N", "GLY", 1, (0.0, 0.0, 0.0), "N"),
        pdb_record("ATOM", 2, " CA", "GLY", 1, (1.4, 0.0, 0.0), "C"),
        pdb_record("HETATM", 3, " O", "HOH", 2, (5.0, 0.0, 0.0), "O"),
        "END", ""]))
    default = tracemesh.read_molecule(pdb)
    assert len(default) == 2 and (default.format, default.radii_source) == ("pdb", "bondi")
    np.testing.assert_array_equal(default.positions, [[0, 0, 0], [1.4, 0, 0]])
    np.testing.assert_array_equal(default.radii, [1.55, 1.70])  # Bondi's N and C
    with_water = tracemesh.read_molecule(pdb, waters="keep", radii="mantina")
    assert len(with_water) == 3 and with_water.radii_source == "mantina"
    assert tracemesh.mesh(with_water).report["input"] == {"format": "pdb", "radii": "mantina"}



def test_reading_errors_are_the_commands(cli, molecules, tmp_path):
    pdb = tmp_path / "one.pdb"
    pdb.write_text(pdb_record("ATOM", 1, " N", "GLY", 1, (0.0, 0.0, 0.0), "N") + "\nEND\n")
    cases = [  # (path, options, the CLI's options, the error code)
        (pdb, {"format_in": "pqr"}, ["--format-in", "pqr"], "invalid_input"),  # PDB records declared PQR
        (tmp_path / "missing.pqr", {}, [], "io_error"),
        (molecules / "fas2.pqr", {"format_in": "cif"}, ["--format-in", "cif"], "invalid_argument"),
    ]
    for path, options, cli_args, code in cases:
        completed = run_cli(cli, path, "-o", tmp_path / "x.off", *cli_args)
        assert completed.returncode != 0
        with pytest.raises(tracemesh.Error) as raised:
            tracemesh.read_molecule(path, **options)
        assert raised.value.code == code
        assert isinstance(raised.value, ValueError) == (code == "invalid_argument")
        # A bad option's message names it as the command spells it (--format-in), the package's as the keyword.
        message = str(raised.value)
        assert cli_message(completed) == (message.replace("format_in", "--format-in", 1) if code == "invalid_argument"
                                          else message), path
    assert not (tmp_path / "x.off").exists()
    with pytest.raises(ValueError, match="^waters "):
        tracemesh.read_molecule(pdb, waters="maybe")
    with pytest.raises(TypeError, match="unknown parameter 'water'"):
        tracemesh.read_molecule(pdb, water="keep")


@pytest.mark.parametrize("params, cli_args", [
    ({"density": 50}, ["--density", "50"]),
    ({"density": "abc"}, ["--density", "abc"]),
    ({"t0": float("nan")}, ["--t0", "nan"]),
    ({"method": "marching"}, ["--method", "marching"]),
    ({"d": 1}, ["--d", "1"]),
])
def test_a_bad_parameter_is_a_value_error_with_the_commands_message(cli, molecules, fas2, tmp_path, params, cli_args):
    completed = run_cli(cli, molecules / "fas2.pqr", "-o", tmp_path / "x.off", *cli_args)
    assert completed.returncode == 2
    with pytest.raises(ValueError) as raised:
        tracemesh.mesh(fas2, **params)
    assert isinstance(raised.value, tracemesh.ParameterError) and raised.value.code == "invalid_argument"
    assert str(raised.value) == cli_message(completed)


def test_the_trace_parameters_are_named_as_keywords(fas2):
    with pytest.raises(ValueError, match=r"^trace_step must be .*got 0$"):
        tracemesh.mesh(fas2, trace_step=0)
    with pytest.raises(TypeError, match="unexpected keyword argument 'trace-step'"):
        tracemesh.mesh(fas2, **{"trace-step": 0.5})
    with pytest.raises(TypeError, match="density must be a number or a string"):
        tracemesh.mesh(fas2, density=[1])
    with pytest.raises(ValueError, match=r"^threads must be an integer in \[0, 1024\]"):
        tracemesh.mesh(fas2, threads=-1)


def test_the_keywords_are_the_engines_parameters():
    keywords = [name for name, parameter in inspect.signature(tracemesh.mesh).parameters.items()
                if parameter.kind is inspect.Parameter.KEYWORD_ONLY]
    assert keywords[:len(tracemesh.MESH_PARAMETERS)] == list(tracemesh.MESH_PARAMETERS)
    assert keywords[len(tracemesh.MESH_PARAMETERS):] == ["threads", "progress", "_hold_until_cancelled"]


def test_an_array_is_meshed_as_the_file(molecules, fas2):
    from_file = tracemesh.mesh(fas2, threads=THREADS)
    from_array = tracemesh.mesh(fas2.as_array(), threads=THREADS)
    np.testing.assert_array_equal(from_array.vertices, from_file.vertices)
    np.testing.assert_array_equal(from_array.faces, from_file.faces)
    assert "input" not in from_array.report and from_file.report["input"] == {"format": "pqr", "radii": "file"}
    from_path = tracemesh.mesh(molecules / "fas2.pqr", threads=THREADS)
    np.testing.assert_array_equal(from_path.vertices, from_file.vertices)
    assert without_timings(from_path.report) == without_timings(from_file.report)


def test_bad_atoms_are_value_errors():
    with pytest.raises(ValueError, match=r"^atom 1: radius -1 is negative$"):
        tracemesh.mesh([[0, 0, 0, 1.5], [1, 0, 0, -1]])
    with pytest.raises(ValueError, match=r"shape \(N, 4\)"):
        tracemesh.mesh(np.zeros((3, 3)))
    with pytest.raises(tracemesh.Error) as raised:
        tracemesh.mesh(np.zeros((2, 4)))
    assert raised.value.code == "nothing_to_mesh" and not isinstance(raised.value, ValueError)


def test_progress_is_reported_on_the_calling_thread_and_a_raise_cancels(fas2):
    import threading

    stages = []
    caller = threading.get_ident()

    def progress(stage, fraction):
        assert threading.get_ident() == caller
        stages.append((stage, fraction))

    tracemesh.mesh(fas2, progress=progress)
    # Reports that come faster than the caller looks are passed on as the latest one: stages in pipeline order,
    # the last one always.
    pipeline = ["reading", "culling", "sampling", "roots", "tracing", "triangulating", "refining", "certifying",
                "encoding", "done"]
    order = [pipeline.index(stage) for stage, _ in stages]
    assert order == sorted(order) and stages[-1] == ("done", 1.0), stages
    assert all(0 <= fraction <= 1 for _, fraction in stages)

    class Stop(Exception):
        pass

    def stop(stage, fraction):
        raise Stop(stage)

    with pytest.raises(Stop):  # held at its first report, the run can only end by being cancelled
        tracemesh.mesh(fas2, progress=stop, _hold_until_cancelled=True)


INTERRUPTED_SCRIPT = """
import sys
import tracemesh

molecule = tracemesh.read_molecule(sys.argv[1])

def progress(stage, fraction):
    print("started", flush=True)  # the run is held at its first report: only a cancel ends it

try:
    tracemesh.mesh(molecule, progress=progress, _hold_until_cancelled=True)
except KeyboardInterrupt:
    print("interrupted", flush=True)
    sys.exit(0)
print("finished", flush=True)
sys.exit(1)
"""


def test_ctrl_c_cancels_the_mesher_and_raises_keyboard_interrupt(molecules, tmp_path):
    script = tmp_path / "interrupted.py"
    script.write_text(INTERRUPTED_SCRIPT)
    child = subprocess.Popen([sys.executable, str(script), str(molecules / "2buk_12asu.pqr")],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert child.stdout.readline() == "started\n"
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=300)  # bounds only a failing run, which never ends otherwise
    finally:
        child.kill()
    assert (child.returncode, out) == (0, "interrupted\n"), err
