#!/usr/bin/env python3
"""Where the trace path's topology differs from the lattice path's: yz cross-sections of the Gaussian surface.

For each feature (a seed point near a thin void or tunnel neck), the seed is refined by Newton's method to the
nearby critical point of phi (phi(x) = sum exp(d(|x - c|^2 / r^2 - 1)), d = -1, t0 = 1), which locates the
feature exactly: a minimum of phi below t0 is a void, a saddle with two positive Hessian eigenvalues is the
narrowest point of a tunnel. Lattice cavities that have no trace cavity within 1 A are added as seeds by themselves.
Each panel is the plane x = x_c through the critical point: the solid {phi >= t0} in grey, the feature's own
region {phi < t0} in red, the trace lines (y, z) = (J h, K h) as dots (h from the trace report's
trace.line_spacing; lines are anchored at the origin, core/lattice/lattice.cpp), and both meshes cut by the plane.

Usage: topology_figure.py --pqr MOL.pqr --trace T.off --trace-report T.json --lattice L.off -o OUT.png
                          [--seed LABEL:X,Y,Z ...] [--title TEXT]
Needs numpy and matplotlib (Debian: python3-numpy, python3-matplotlib).
"""
import argparse
import json

import numpy as np

D, T0, CUTOFF = -1.0, 1.0, 6.0  # kernel decay, isovalue, neglected beyond |x - c| > CUTOFF * r (e^-35 per atom)


def read_pqr(path):
    rows = []
    with open(path) as f:
        for line in f:
            if line.startswith(("ATOM", "HETATM")):
                t = line.split()
                rows.append([float(t[-5]), float(t[-4]), float(t[-3]), float(t[-1])])
    a = np.array(rows)
    a = a[a[:, 3] > 0]  # radius 0: no contribution
    return a[:, :3], a[:, 3]


def read_off(path):
    with open(path) as f:
        assert f.readline().strip() == "OFF", path
        nv, nf, _ = map(int, f.readline().split())
        verts = np.array([f.readline().split() for _ in range(nv)], dtype=float)
        faces = np.array([f.readline().split()[1:4] for _ in range(nf)], dtype=np.int64)
    return verts, faces


class Field:
    def __init__(self, centres, radii):
        self.c, self.r = centres, radii

    def near(self, lo, hi):
        reach = CUTOFF * self.r.max()
        m = np.all((self.c >= lo - reach) & (self.c <= hi + reach), axis=1)
        return self.c[m], self.r[m]

    def value(self, pts, chunk=4000):
        pts = np.atleast_2d(pts)
        c, r = self.near(pts.min(0), pts.max(0))
        out = np.empty(len(pts))
        for i in range(0, len(pts), chunk):
            s2 = ((pts[i:i + chunk, None, :] - c[None]) ** 2).sum(2) / r**2
            out[i:i + chunk] = np.where(s2 < CUTOFF**2, np.exp(D * (s2 - 1)), 0).sum(1)
        return out

    def derivatives(self, x):
        c, r = self.near(x, x)
        diff = x - c
        s2 = (diff**2).sum(1) / r**2
        e = np.where(s2 < CUTOFF**2, np.exp(D * (s2 - 1)), 0)
        k = 2 * D / r**2
        grad = (e * k) @ diff
        hess = np.einsum("j,jk,jl->kl", e * k * k, diff, diff) + np.eye(3) * (e * k).sum()
        return e.sum(), grad, hess


def critical_point(field, seed):
    """Newton on grad phi = 0 from seed, steps capped at 0.1 A; returns (point, phi, Hessian eigenvalues)."""
    x = np.array(seed, dtype=float)
    for _ in range(300):
        _, g, h = field.derivatives(x)
        w, u = np.linalg.eigh(h)
        w = np.where(np.abs(w) < 1e-6, 1e-6, w)
        step = -u @ ((u.T @ g) / w)
        x += step * min(1.0, 0.1 / max(np.linalg.norm(step), 1e-30))
        if np.linalg.norm(g) < 1e-11:
            break
    phi, g, h = field.derivatives(x)
    if np.linalg.norm(g) > 1e-8:
        raise SystemExit(f"topology_figure: no critical point of phi near {seed}")
    return x, phi, np.linalg.eigvalsh(h)


def describe(phi, ev):
    positive = int((ev > 0).sum())
    depth = T0 - phi
    kind = {3: "void (minimum of φ)", 2: "tunnel neck (saddle)"}.get(positive, "bridge neck (saddle)")
    if positive >= 2 and depth > 0:
        widths = 2 * np.sqrt(2 * depth / ev[ev > 0])  # quadratic model: width of {phi < t0} across the feature
        return kind, f"{kind}, t0 − φ = {depth:.3f}, width {' × '.join(f'{w:.2f}' for w in sorted(widths))} Å"
    return kind, f"{kind}, φ − t0 = {-depth:.3f}"


def components(verts, faces):
    """Connected components of a triangle mesh: a label per vertex (union-find over triangle edges)."""
    parent = np.arange(len(verts))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for f in faces:
        ra, rb, rc = find(f[0]), find(f[1]), find(f[2])
        parent[rb] = ra
        parent[rc] = ra
    return np.array([find(v) for v in range(len(verts))])


def cavity_centroids(verts, faces):
    """Centroids of every component but the one of largest extent (the cavities and any small separate piece)."""
    label = components(verts, faces)
    groups = [np.where(label == l)[0] for l in np.unique(label)]
    groups.sort(key=lambda g: -np.ptp(verts[g], axis=0).max())
    return [verts[g].mean(0) for g in groups[1:]]


def plane_section(verts, faces, x0, lo, hi):
    """Segments where the mesh meets the plane x = x0, in (y, z), for triangles inside the window."""
    tri = verts[faces]
    keep = (tri[:, :, 0].min(1) <= x0) & (tri[:, :, 0].max(1) >= x0)
    keep &= np.all(tri[:, :, 1:].min(1) <= hi, axis=1) & np.all(tri[:, :, 1:].max(1) >= lo, axis=1)
    segs = []
    for t in tri[keep]:
        pts = []
        for a, b in ((0, 1), (1, 2), (2, 0)):
            xa, xb = t[a, 0] - x0, t[b, 0] - x0
            if (xa < 0) != (xb < 0):
                s = xa / (xa - xb)
                pts.append(t[a, 1:] + s * (t[b, 1:] - t[a, 1:]))
        if len(pts) == 2:
            segs.append(pts)
    return np.array(segs).reshape(-1, 2, 2)


def feature_region(phi_grid, i, j):
    """Mask of the connected part of {phi < t0} in the slice that contains grid point (i, j) (4-connected)."""
    inside = phi_grid < T0
    mask = np.zeros_like(inside)
    if not inside[i, j]:
        return mask
    stack = [(i, j)]
    while stack:
        a, b = stack.pop()
        if 0 <= a < inside.shape[0] and 0 <= b < inside.shape[1] and inside[a, b] and not mask[a, b]:
            mask[a, b] = True
            stack += [(a + 1, b), (a - 1, b), (a, b + 1), (a, b - 1)]
    return mask


def lines_through(field, point, h, kind, reach=1.0):
    """For a void: how many trace lines within `reach` of it in yz pass through {phi < t0} within `reach` in x."""
    x0, y0, z0 = point
    xs = np.arange(x0 - reach, x0 + reach, 0.002)
    best = None
    for j in np.arange(np.ceil((y0 - reach) / h), np.floor((y0 + reach) / h) + 1):
        for k in np.arange(np.ceil((z0 - reach) / h), np.floor((z0 + reach) / h) + 1):
            line = np.stack([xs, np.full_like(xs, j * h), np.full_like(xs, k * h)], 1)
            low = field.value(line).min()
            if best is None or low < best[0]:
                best = (low, j, k)
    if not kind.startswith("void"):
        return f"x-parallel lines are {h:.2f} Å apart"
    meets = "a line meets it" if best[0] < T0 else "no line meets it"
    return f"lowest φ on any line near it: {best[0]:.4f} (line J={best[1]:.0f}, K={best[2]:.0f}); {meets}"


def panel(ax, field, meshes, h, label, point, phi, ev, half=1.6, n=321):
    import matplotlib.patches as mpatches
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D

    x0, y0, z0 = point
    ys, zs = np.linspace(y0 - half, y0 + half, n), np.linspace(z0 - half, z0 + half, n)
    yy, zz = np.meshgrid(ys, zs, indexing="ij")
    grid = field.value(np.stack([np.full(yy.size, x0), yy.ravel(), zz.ravel()], 1)).reshape(yy.shape)
    ax.contourf(ys, zs, (grid >= T0).T.astype(float), levels=[0.5, 1.5], colors=["0.82"])
    ax.contour(ys, zs, grid.T, levels=[T0], colors="k", linewidths=0.8)
    region = feature_region(grid, n // 2, n // 2)
    if region.any():
        ax.contourf(ys, zs, region.T.astype(float), levels=[0.5, 1.5], colors=["tab:red"], alpha=0.6)
    lo, hi = np.array([y0 - half, z0 - half]), np.array([y0 + half, z0 + half])
    styles = {"trace": dict(colors="tab:blue", linewidths=1.6), "lattice": dict(colors="tab:orange", linewidths=1.2,
                                                                                  linestyles="--")}
    for name, (verts, faces) in meshes.items():
        ax.add_collection(LineCollection(plane_section(verts, faces, x0, lo, hi), **styles[name]))
    js = np.arange(np.ceil(lo[0] / h), np.floor(hi[0] / h) + 1) * h
    ks = np.arange(np.ceil(lo[1] / h), np.floor(hi[1] / h) + 1) * h
    jj, kk = np.meshgrid(js, ks)
    ax.plot(jj.ravel(), kk.ravel(), "o", color="tab:green", ms=5, zorder=5)
    kind, text = describe(phi, ev)
    ax.plot([y0], [z0], "x", color="k", ms=7, zorder=6)
    ax.set_title(f"{label} at ({x0:.2f}, {y0:.2f}, {z0:.2f})\n{text}\n{lines_through(field, point, h, kind)}",
                 fontsize=8.5)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel("y (Å)")
    ax.set_ylabel("z (Å)")
    handles = [mpatches.Patch(color="0.82", label="solid φ ≥ t0 in the plane x = x of the ×"),
               mpatches.Patch(color="tab:red", alpha=0.6, label="the feature's φ < t0 in this plane"),
               Line2D([], [], color="tab:blue", lw=1.6, label="trace mesh, 2 v/Å², cut by the plane"),
               Line2D([], [], color="tab:orange", lw=1.2, ls="--", label="lattice mesh, 8 v/Å², cut by the plane"),
               Line2D([], [], color="tab:green", marker="o", lw=0, label=f"trace lines (J·h̃, K·h̃), h̃ = {h:.3f} Å")]
    return handles


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--pqr", required=True)
    p.add_argument("--trace", required=True, help="OFF mesh of the trace path")
    p.add_argument("--trace-report", required=True, help="JSON report of the trace run (for trace.line_spacing)")
    p.add_argument("--lattice", required=True, help="OFF mesh of the lattice path (the reference)")
    p.add_argument("--seed", action="append", default=[], help="LABEL:X,Y,Z, a point near a feature to show")
    p.add_argument("--title", default="")
    p.add_argument("-o", "--output", required=True)
    a = p.parse_args()

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    h = json.load(open(a.trace_report))["trace"]["parameters"]["line_spacing"]
    field = Field(*read_pqr(a.pqr))
    meshes = {"trace": read_off(a.trace), "lattice": read_off(a.lattice)}
    seeds = [(s.split(":")[0], [float(v) for v in s.split(":")[1].split(",")]) for s in a.seed]
    trace_cavities = cavity_centroids(*meshes["trace"])
    for c in cavity_centroids(*meshes["lattice"]):
        if all(np.linalg.norm(c - t) > 1.0 for t in trace_cavities):
            seeds.append(("lattice cavity the trace lacks", list(c)))
    if not seeds:
        raise SystemExit("topology_figure: nothing to show (no seed and no unmatched lattice cavity)")
    # At least 8.5 in wide: the title and the legend's three columns must fit above and below a single panel.
    fig, axes = plt.subplots(1, len(seeds), figsize=(max(5.2 * len(seeds), 8.5), 6.4), squeeze=False)
    for ax, (label, seed) in zip(axes[0], seeds):
        point, phi, ev = critical_point(field, seed)
        handles = panel(ax, field, meshes, h, label, point, phi, ev)
        print(f"{label}: {describe(phi, ev)[1]} at {np.round(point, 3).tolist()}")
    fig.legend(handles=handles, loc="lower center", ncol=3, fontsize=8, frameon=False)
    fig.suptitle(a.title, fontsize=10)
    fig.tight_layout(rect=(0, 0.1, 1, 0.93))
    fig.savefig(a.output, dpi=130)


if __name__ == "__main__":
    main()
