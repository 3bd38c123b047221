#!/usr/bin/env python3
"""How close `tracemesh nanoshaper` comes to NanoShaper on the files a BEM solver writes (docs/nanoshaper.md).

Both programs are run the way TABI-PB runs NanoShaper: molecule.xyzr and surfaceConfiguration.prm (the keys TABI-PB
writes) in an empty working directory, the program run there with no argument, triangulatedSurf.vert/.face read
back. Area (sum of triangle areas) and volume (divergence theorem) are computed from the files alone, so both
programs are measured by the same code. Three tables, in Markdown:

  surfaces   Surface = ses and skin at one Grid_scale: NanoShaper's surface against the Gaussian surface tracemesh
             meshes in its place (area, volume, their ratios), per molecule.
  vertices   Surface = ses at several Grid_scale values: NanoShaper's vertex count against tracemesh's (the
             Grid_scale → density rule of cli/nanoshaper/nanoshaper_job.hpp).
  fit        tracemesh's plain command on (d, t0) candidates against NanoShaper's SES and skin: how the substitutes
             were chosen (the mean and worst |area ratio − 1| and |volume ratio − 1| over the molecules).

Environment:
  NANOSHAPER               the NanoShaper binary (required)
  TRACEMESH                the tracemesh binary (default: build/bin/tracemesh of the repository)
  TRACEMESH_MOLECULES_DIR  where the molecules are (default: tests/data/molecules of the repository)
  GRID_SCALES              Grid_scale values of the vertices table (default "1 1.5 2 3")
  THREADS                  threads of both programs (default 2)
Usage: python3 bench/nanoshaper_equivalence.py surfaces|vertices|fit [MOLECULE ...]
       (default molecules: gly adp villin_1vii fas2 mache 2buk_12asu, .pqr or .pqr.gz)
"""
import gzip
import itertools
import math
import os
import subprocess
import sys
import tempfile

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_MOLECULES = ["gly", "adp", "villin_1vii", "fas2", "mache", "2buk_12asu"]
# The Grid_scale of the surfaces and fit tables: NanoShaper's own default, at which its SES is accurate enough to
# be the reference.
REFERENCE_GRID_SCALE = 2.0
# The density of tracemesh's runs in the fit table (the surface, not its sampling, is what is compared).
FIT_DENSITY = 2.0
# The candidates (FIT_D and FIT_T0 in the environment override them, blank-separated).
FIT_D = [-1.0, -1.5, -2.0, -2.5, -3.0]
FIT_T0 = [1.0, 1.5, 2.0]
# (r·√(1 + ln t0 / d) is the radius of a lone atom's own surface, parameter_ranges::min_atom_surface_radius_per_edge.)
MIN_LONE_ATOM_FACTOR = 0.25

# The .prm TABI-PB writes (its NanoShaper branch), with Grid_scale and Surface filled in.
TABI_PRM = """\
Grid_scale = {grid_scale:f}
Grid_perfil = 90.000000
XYZR_FileName = molecule.xyzr
Build_epsilon_maps = false
Build_status_map = false
Save_Mesh_MSMS_Format = true
Compute_Vertex_Normals = true
Surface = {surface}
Smooth_Mesh = true
Skin_Surface_Parameter = 0.450000
Cavity_Detection_Filling = false
Conditional_Volume_Filling_Value = 11.400000
Keep_Water_Shaped_Cavities = false
Probe_Radius = 1.400000
Accurate_Triangulation = true
Triangulation = true
Check_duplicated_vertices = true
Save_Status_map = false
Save_PovRay = false
Number_thread = {threads}
"""


def molecule_path(name):
    directory = os.environ.get("TRACEMESH_MOLECULES_DIR", os.path.join(REPO, "tests", "data", "molecules"))
    for candidate in (name, name + ".pqr", name + ".pqr.gz"):
        path = os.path.join(directory, candidate)
        if os.path.exists(path):
            return path
    raise SystemExit(f"nanoshaper_equivalence.py: no molecule {name} in {directory}")


def write_xyzr(pqr_path, xyzr_path):
    """The atoms of radius > 0 as x y z r lines (a radius-0 atom has no surface in either program)."""
    opener = gzip.open if pqr_path.endswith(".gz") else open
    with opener(pqr_path, "rt", encoding="ascii") as source, open(xyzr_path, "w", encoding="ascii") as out:
        for line in source:
            if line.startswith(("ATOM", "HETATM")):
                fields = line.split()
                if float(fields[-1]) > 0:
                    out.write(f"{fields[-5]} {fields[-4]} {fields[-3]} {fields[-1]}\n")


def read_msms_pair(work):
    """(vertices, triangles) of triangulatedSurf.vert/.face: three header lines, the count first on line 3."""
    def body(name):
        with open(os.path.join(work, name), encoding="ascii") as f:
            lines = f.read().splitlines()
        count = int(lines[2].split()[0])
        return [line.split() for line in lines[3:3 + count]]
    vertices = [tuple(float(v) for v in fields[:3]) for fields in body("triangulatedSurf.vert")]
    triangles = [tuple(int(i) - 1 for i in fields[:3]) for fields in body("triangulatedSurf.face")]
    return vertices, triangles


def area_and_volume(vertices, triangles):
    area = volume = 0.0
    for a, b, c in triangles:
        p, q, r = vertices[a], vertices[b], vertices[c]
        u = (q[0] - p[0], q[1] - p[1], q[2] - p[2])
        v = (r[0] - p[0], r[1] - p[1], r[2] - p[2])
        n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
        area += 0.5 * math.sqrt(n[0] ** 2 + n[1] ** 2 + n[2] ** 2)
        volume += (p[0] * (q[1] * r[2] - q[2] * r[1]) - p[1] * (q[0] * r[2] - q[2] * r[0]) +
                   p[2] * (q[0] * r[1] - q[1] * r[0])) / 6.0
    return area, volume


def run_as_tabi(command, molecule, surface, grid_scale, threads):
    """One run the way TABI-PB makes it: {vertices, area, volume}, or raises with the program's output."""
    with tempfile.TemporaryDirectory(prefix="ns_equivalence_") as work:
        write_xyzr(molecule, os.path.join(work, "molecule.xyzr"))
        with open(os.path.join(work, "surfaceConfiguration.prm"), "w", encoding="ascii") as f:
            f.write(TABI_PRM.format(grid_scale=grid_scale, surface=surface, threads=threads))
        done = subprocess.run(command, cwd=work, capture_output=True, text=True, check=False)
        if done.returncode != 0 or not os.path.exists(os.path.join(work, "triangulatedSurf.vert")):
            raise RuntimeError(f"{command[0]} exited with {done.returncode}: {(done.stdout + done.stderr)[-400:]}")
        vertices, triangles = read_msms_pair(work)
        area, volume = area_and_volume(vertices, triangles)
        return {"vertices": len(vertices), "area": area, "volume": volume}


def run_tracemesh_surface(binary, molecule, d, t0, threads):
    """tracemesh's plain command on (d, t0): {area, volume} of its mesh, from its .vert/.face."""
    with tempfile.TemporaryDirectory(prefix="ns_equivalence_") as work:
        out = os.path.join(work, "triangulatedSurf.vert")
        subprocess.run([binary, molecule, "-o", out, "--d", str(d), "--t0", str(t0), "--density", str(FIT_DENSITY),
                        "--threads", str(threads)], check=True, capture_output=True)
        vertices, triangles = read_msms_pair(work)
        area, volume = area_and_volume(vertices, triangles)
        return {"area": area, "volume": volume}


def name_of(molecule):
    return os.path.basename(molecule).split(".")[0]


def surfaces_table(nanoshaper, tracemesh, molecules, threads):
    print(f"Grid_scale = {REFERENCE_GRID_SCALE}; area Å², volume Å³; ratio = tracemesh / NanoShaper\n")
    print("| molecule | Surface | NanoShaper area | tracemesh area | ratio | NanoShaper volume | tracemesh volume "
          "| ratio |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for molecule, surface in itertools.product(molecules, ("ses", "skin")):
        ns = run_as_tabi([nanoshaper], molecule, surface, REFERENCE_GRID_SCALE, threads)
        tm = run_as_tabi(tracemesh, molecule, surface, REFERENCE_GRID_SCALE, threads)
        print(f"| {name_of(molecule)} | {surface} | {ns['area']:.0f} | {tm['area']:.0f} | "
              f"{tm['area'] / ns['area']:.3f} | {ns['volume']:.0f} | {tm['volume']:.0f} | "
              f"{tm['volume'] / ns['volume']:.3f} |", flush=True)


def vertices_table(nanoshaper, tracemesh, molecules, threads):
    scales = [float(s) for s in os.environ.get("GRID_SCALES", "1 1.5 2 3").split()]
    print("Surface = ses; vertex counts of triangulatedSurf.vert; ratio = tracemesh / NanoShaper\n")
    print("| molecule | Grid_scale | NanoShaper | tracemesh | ratio |")
    print("|---|---:|---:|---:|---:|")
    for molecule, scale in itertools.product(molecules, scales):
        ns = run_as_tabi([nanoshaper], molecule, "ses", scale, threads)
        tm = run_as_tabi(tracemesh, molecule, "ses", scale, threads)
        print(f"| {name_of(molecule)} | {scale:g} | {ns['vertices']} | {tm['vertices']} | "
              f"{tm['vertices'] / ns['vertices']:.2f} |", flush=True)


def fit_table(nanoshaper, tracemesh_binary, molecules, threads):
    references = {}
    for molecule, surface in itertools.product(molecules, ("ses", "skin")):
        references[molecule, surface] = run_as_tabi([nanoshaper], molecule, surface, REFERENCE_GRID_SCALE, threads)
    print(f"tracemesh at density {FIT_DENSITY} against NanoShaper at Grid_scale {REFERENCE_GRID_SCALE} over "
          f"{len(molecules)} molecules: mean ratio (tracemesh / NanoShaper) and, in brackets, the worst |ratio − 1|. "
          f"Candidates whose lone atom keeps less than half its radius (1 + ln t0 / d < {MIN_LONE_ATOM_FACTOR}) "
          "are left out: they leave exposed atoms without a surface of their own, which tracemesh refuses.\n")
    print("| d | t0 | SES area | SES volume | skin area | skin volume |")
    print("|---:|---:|---:|---:|---:|---:|")
    candidates_d = [float(v) for v in os.environ.get("FIT_D", " ".join(map(str, FIT_D))).split()]
    candidates_t0 = [float(v) for v in os.environ.get("FIT_T0", " ".join(map(str, FIT_T0))).split()]
    for d, t0 in itertools.product(candidates_d, candidates_t0):
        if 1 + math.log(t0) / d < MIN_LONE_ATOM_FACTOR:
            continue
        ratios = {key: [] for key in itertools.product(("ses", "skin"), ("area", "volume"))}
        for molecule in molecules:
            tm = run_tracemesh_surface(tracemesh_binary, molecule, d, t0, threads)
            for surface, quantity in ratios:
                ratios[surface, quantity].append(tm[quantity] / references[molecule, surface][quantity])
        cells = [f"{sum(r) / len(r):.3f} ({max(abs(x - 1) for x in r):.3f})" for r in ratios.values()]
        print(f"| {d:g} | {t0:g} | " + " | ".join(cells) + " |", flush=True)


def main():
    if len(sys.argv) < 2 or sys.argv[1] not in ("surfaces", "vertices", "fit"):
        raise SystemExit(__doc__)
    nanoshaper = os.environ.get("NANOSHAPER")
    if not nanoshaper:
        raise SystemExit("nanoshaper_equivalence.py: set NANOSHAPER to the NanoShaper binary")
    tracemesh = os.environ.get("TRACEMESH", os.path.join(REPO, "build", "bin", "tracemesh"))
    threads = int(os.environ.get("THREADS", "2"))
    molecules = [molecule_path(name) for name in (sys.argv[2:] or DEFAULT_MOLECULES)]
    if sys.argv[1] == "surfaces":
        surfaces_table(nanoshaper, [tracemesh, "nanoshaper"], molecules, threads)
    elif sys.argv[1] == "vertices":
        vertices_table(nanoshaper, [tracemesh, "nanoshaper"], molecules, threads)
    else:
        fit_table(nanoshaper, tracemesh, molecules, threads)
    return 0


if __name__ == "__main__":
    sys.exit(main())
