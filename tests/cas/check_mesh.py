#!/usr/bin/env python3
"""An independent check of `lgc mesh`: each mesh is read back with trimesh and
manifold3d, which must find it watertight, consistently wound, outward
(positive volume), manifold, and of the surface's known Euler characteristic
and number of components. Its triangles are tested pairwise for intersections
(exact orientation predicates, with a floating-point filter), and every vertex
is checked to lie within its summary's reach of f = 0 by mpmath at 150 bits
(the formula parser is the ray oracle's, shared with no lgc code). In certified
cells, triangle centres must lie within the summary's `mesh_to_surface` of
f = 0, and points of f = 0 traced by `lgc trace` within its `surface_to_mesh`
of the mesh.

Usage: check_mesh.py LGC [DEPTH]
"""

import itertools
import json
import os
import subprocess
import sys
import tempfile

import manifold3d
import numpy as np
import trimesh
from mpmath import iv

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from check_rays import INTERVAL, Parser, evaluate  # noqa: E402

# name, formula, box, Euler characteristic, components
CASES = [
    ("sphere", "x^2+y^2+z^2-1", "-2,-2,-2,2,2,2", 2, 1),
    ("torus", "(sqrt(x^2+y^2)-1)^2+z^2-0.25^2", "-2,-2,-2,2,2,2", 0, 1),
    # A tube around a figure eight: genus 2.
    ("genus two", "(x^2*(1-x^2)-y^2)^2+z^2-0.01", "-1.5,-1.5,-1.5,1.5,1.5,1.5", -2, 1),
    # Genus 5.
    ("tangle cube", "x^4-5*x^2+y^4-5*y^2+z^4-5*z^2+11.8", "-3,-3,-3,3,3,3", -8, 1),
    ("two spheres", "min((x-0.6)^2+y^2+z^2-0.25, (x+0.6)^2+y^2+z^2-0.25)", "-2,-2,-2,2,2,2", 4, 2),
    # A cube with three orthogonal holes through it, meeting in the middle:
    # two spheres with six holes each, glued along the six circles, genus 5.
    (
        "drilled cube",
        "max(max(max(abs(x),abs(y)),abs(z))-1, -min(min(sqrt(x^2+y^2)-0.5, sqrt(y^2+z^2)-0.5), sqrt(x^2+z^2)-0.5))",
        "-1.3,-1.3,-1.3,1.3,1.3,1.3",
        -8,
        1,
    ),
    # The gyroid cut by a ball of radius 0.9, where the ball meets the
    # gyroid's sheets transversally: one body of genus 2, as scikit-image's
    # marching cubes also finds on 240^3 and 360^3 grids. (At radius 1 the
    # sphere nearly touches the sheets at a few points, and the count of
    # tiny pieces there changes with the grid.)
    (
        "gyroid ball",
        "max(sin(4*x)*cos(4*y)+sin(4*y)*cos(4*z)+sin(4*z)*cos(4*x), x^2+y^2+z^2-0.81)",
        "-1.3,-1.3,-1.3,1.3,1.3,1.3",
        -2,
        1,
    ),
    # A scene of two spheres, each meshed in its own box and coordinates and
    # placed in the scene's: the formula is the scene's surface, written out.
    (
        "scene",
        "min((x-0.9)^2+(y-0.2)^2+(z+0.1)^2-0.36, (x+0.8)^2+y^2+(z-0.3)^2-0.1225)",
        "-2,-2,-2,2,2,2",
        4,
        2,
    ),
]

# The scene file meshed for the case of that name, instead of its formula.
SCENES = {
    "scene": "sphere { center = (0.9, 0.2, -0.1); radius = 0.6; }\n"
    "sphere { center = (-0.8, 0, 0.3); radius = 0.35; }\n",
}


# ------------------------------------------------------------- predicates ---

def exact_rows(*arrays):
    """Arrays of coordinates as numpy arrays of exact Python integers, every
    coordinate times a common power of two."""
    pts = np.stack(arrays)
    values, inverse = np.unique(pts, return_inverse=True)
    ratios = [float(x).as_integer_ratio() for x in values]
    shift = max(den.bit_length() - 1 for _, den in ratios)
    ints = np.array([num << (shift - (den.bit_length() - 1)) for num, den in ratios] + [0], dtype=object)[:-1]
    return ints[inverse.reshape(pts.shape)]


def orient_exact_rows(a, b, c, d):
    """Signs of det[b-a, c-a, d-a] for rows, in exact integer arithmetic."""
    P = exact_rows(a, b, c, d)
    u, v, w = P[1] - P[0], P[2] - P[0], P[3] - P[0]
    det = (
        u[:, 0] * (v[:, 1] * w[:, 2] - v[:, 2] * w[:, 1])
        - u[:, 1] * (v[:, 0] * w[:, 2] - v[:, 2] * w[:, 0])
        + u[:, 2] * (v[:, 0] * w[:, 1] - v[:, 1] * w[:, 0])
    )
    return (det > 0).astype(int) - (det < 0).astype(int)


def orient(a, b, c, d):
    """Signs of det[b-a, c-a, d-a] for rows of (N,3) arrays: in floating
    point where the value is far from its rounding error, exactly elsewhere."""
    u, v, w = b - a, c - a, d - a
    det = (
        u[:, 0] * (v[:, 1] * w[:, 2] - v[:, 2] * w[:, 1])
        - u[:, 1] * (v[:, 0] * w[:, 2] - v[:, 2] * w[:, 0])
        + u[:, 2] * (v[:, 0] * w[:, 1] - v[:, 1] * w[:, 0])
    )
    # A generous bound of the rounding error of the differences and the
    # determinant: 1e-12 of the product of the three lengths.
    scale = np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1) * np.linalg.norm(w, axis=1)
    sign = np.sign(det).astype(int)
    # Four points with one coordinate equal lie in a plane: det is 0 exactly.
    flat = np.any((a == b) & (a == c) & (a == d), axis=1)
    sign[flat] = 0
    unsure = np.nonzero((np.abs(det) <= 1e-12 * scale) & ~flat)[0]
    if len(unsure):
        sign[unsure] = orient_exact_rows(a[unsure], b[unsure], c[unsure], d[unsure])
    return sign


def orient2_rows(a, b, c):
    """Signs of the 2-D orientation of rows of (m,2) arrays: in floating
    point where far from its rounding error, exactly elsewhere."""
    u, w = b - a, c - a
    det = u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]
    scale = np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1)
    sign = np.sign(det).astype(int)
    unsure = np.nonzero(np.abs(det) <= 1e-12 * scale)[0]
    if len(unsure):
        A, B, C = exact_rows(a[unsure], b[unsure], c[unsure])
        u, w = B - A, C - A
        det = u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]
        sign[unsure] = (det > 0).astype(int) - (det < 0).astype(int)
    return sign


def project(a, b, c, *more):
    """Rows of triangles abc (and more points in their planes) in 2-D: each
    row in the coordinate plane its triangle projects onto best (dropping
    the axis of its normal's largest component). Returns a, b, c, *more."""
    n = np.cross(b - a, c - a)
    keep = np.array([[1, 2], [0, 2], [0, 1]])[np.argmax(np.abs(n), axis=1)]
    rows = np.arange(len(a))[:, None]
    return [x[rows, keep] for x in (a, b, c, *more)]


def coplanar_segments_meet_triangles(p, q, a, b, c):
    """Whether segments pq, each in the plane of its triangle abc, meet it
    (rows): in the coordinate plane each triangle projects onto best."""
    a, b, c, p, q = project(a, b, c, p, q)
    flip = orient2_rows(a, b, c) < 0
    b, c = np.where(flip[:, None], c, b), np.where(flip[:, None], b, c)

    def inside(x):
        return (orient2_rows(a, b, x) >= 0) & (orient2_rows(b, c, x) >= 0) & (orient2_rows(c, a, x) >= 0)

    def between(x, y, z):
        lo, hi = np.minimum(x, y), np.maximum(x, y)
        return np.all((lo <= z) & (z <= hi), axis=1)

    def cross(p, q, r, s):
        d1, d2 = orient2_rows(p, q, r), orient2_rows(p, q, s)
        d3, d4 = orient2_rows(r, s, p), orient2_rows(r, s, q)
        proper = (d1 * d2 < 0) & (d3 * d4 < 0)
        touch = (
            ((d1 == 0) & between(p, q, r))
            | ((d2 == 0) & between(p, q, s))
            | ((d3 == 0) & between(r, s, p))
            | ((d4 == 0) & between(r, s, q))
        )
        return proper | touch

    meets = inside(p) | inside(q)
    for x, y in ((a, b), (b, c), (c, a)):
        meets |= cross(p, q, x, y)
    return meets


def in_cone(s, a, b, x):
    """Whether each x, in the plane of its triangle s a b, lies in the
    triangle's angle at s, edges included (rows)."""
    s, a, b, x = project(s, a, b, x)
    flip = orient2_rows(s, a, b) < 0
    a, b = np.where(flip[:, None], b, a), np.where(flip[:, None], a, b)
    return (orient2_rows(s, a, x) >= 0) & (orient2_rows(s, x, b) >= 0)


def segments_cross(p, q, a, b, c):
    """Whether closed segments pq meet closed triangles abc (rows)."""
    s1, s2 = orient(a, b, c, p), orient(a, b, c, q)
    coplanar = (s1 == 0) & (s2 == 0)
    straddle = (s1 * s2 <= 0) & ~coplanar
    t1, t2, t3 = orient(p, q, a, b), orient(p, q, b, c), orient(p, q, c, a)
    inside = ((t1 >= 0) & (t2 >= 0) & (t3 >= 0)) | ((t1 <= 0) & (t2 <= 0) & (t3 <= 0))
    meets = straddle & inside
    rows = np.nonzero(coplanar)[0]
    if len(rows):
        meets[rows] = coplanar_segments_meet_triangles(p[rows], q[rows], a[rows], b[rows], c[rows])
    return meets


def candidate_pairs(v, f):
    """Pairs of triangles whose bounding boxes overlap, found through a grid."""
    lo = v[f].min(axis=1)
    hi = v[f].max(axis=1)
    cell = max(float(np.max(hi - lo)), 1e-300)
    origin = lo.min(axis=0)
    buckets = {}
    glo = np.floor((lo - origin) / cell).astype(int)
    ghi = np.floor((hi - origin) / cell).astype(int)
    for t in range(len(f)):
        for key in itertools.product(*(range(glo[t][k], ghi[t][k] + 1) for k in range(3))):
            buckets.setdefault(key, []).append(t)
    pairs = set()
    for members in buckets.values():
        for i, j in itertools.combinations(members, 2):
            pairs.add((min(i, j), max(i, j)))
    pairs = np.array(sorted(pairs), dtype=np.int64).reshape(-1, 2)
    keep = np.all(lo[pairs[:, 0]] <= hi[pairs[:, 1]], axis=1) & np.all(lo[pairs[:, 1]] <= hi[pairs[:, 0]], axis=1)
    return pairs[keep]


def self_intersections(v, f):
    """Pairs of triangles that meet other than in their shared vertices or
    edge. Triangles sharing an edge may not fold onto each other; those
    sharing one vertex may meet only there; others may not meet."""
    pairs = candidate_pairs(v, f)
    A, B = f[pairs[:, 0]], f[pairs[:, 1]]
    shared = (A[:, :, None] == B[:, None, :]).sum(axis=(1, 2))
    bad = []
    # Disjoint triangles: an edge of one must not meet the other.
    idx = np.nonzero(shared == 0)[0]
    if len(idx):
        hit = np.zeros(len(idx), dtype=bool)
        for X, Y in ((A, B), (B, A)):
            for e in range(3):
                p, q = v[X[idx, e]], v[X[idx, (e + 1) % 3]]
                a, b, c = v[Y[idx, 0]], v[Y[idx, 1]], v[Y[idx, 2]]
                hit |= segments_cross(p, q, a, b, c)
        bad += [tuple(pairs[i]) for i in idx[hit]]
    # One shared vertex s: the edge of each opposite s must miss the other,
    # and an edge from s lying in the other's plane must point out of it.
    idx = np.nonzero(shared == 1)[0]
    if len(idx):
        X, Y = A[idx], B[idx]
        match = X[:, :, None] == Y[:, None, :]
        ix = np.argmax(match.any(axis=2), axis=1)
        iy = np.argmax(match.any(axis=1), axis=1)
        rows = np.arange(len(idx))
        s = X[rows, ix]
        ox = [X[rows, (ix + k) % 3] for k in (1, 2)]
        oy = [Y[rows, (iy + k) % 3] for k in (1, 2)]
        meets = np.zeros(len(idx), dtype=bool)
        for mine, other in ((ox, oy), (oy, ox)):
            meets |= segments_cross(v[mine[0]], v[mine[1]], v[s], v[other[0]], v[other[1]])
            for x in mine:
                flat = np.nonzero(orient(v[s], v[other[0]], v[other[1]], v[x]) == 0)[0]
                if len(flat):
                    meets[flat] |= in_cone(v[s[flat]], v[other[0][flat]], v[other[1][flat]], v[x[flat]])
        bad += [tuple(pairs[i]) for i in idx[meets]]
    # A shared edge: the two triangles may not be coplanar on the same side.
    idx = np.nonzero(shared == 2)[0]
    if len(idx):
        X, Y = A[idx], B[idx]
        in_y = (X[:, :, None] == Y[:, None, :]).any(axis=2)
        in_x = (Y[:, :, None] == X[:, None, :]).any(axis=2)
        rows = np.arange(len(idx))
        c = X[rows, np.argmin(in_y, axis=1)]
        d = Y[rows, np.argmin(in_x, axis=1)]
        # The shared edge, in X's winding order.
        k = np.argmin(in_y, axis=1)
        e0, e1 = X[rows, (k + 1) % 3], X[rows, (k + 2) % 3]
        flat = orient(v[e0], v[e1], v[c], v[d]) == 0
        for r in np.nonzero(flat)[0]:
            n1 = np.cross(v[e1[r]] - v[e0[r]], v[c[r]] - v[e0[r]])
            n2 = np.cross(v[e1[r]] - v[e0[r]], v[d[r]] - v[e0[r]])
            if np.dot(n1, n2) > 0:
                bad.append(tuple(pairs[idx[r]]))
    bad += [tuple(pairs[i]) for i in np.nonzero(shared == 3)[0]]
    return bad


def self_test():
    """The intersection test must catch each kind of crossing it looks for."""
    v = np.array(
        [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.2, 0.2, -1], [0.2, 0.2, 1], [1, 1, 0],
         [0.5, 0.1, 0], [0.1, 0.5, 0], [5, 5, 5], [6, 5, 5], [5, 6, 5]],
        dtype=np.float64,
    )
    cases = [
        ([[0, 1, 2], [3, 4, 5]], 1),  # an edge through the other
        ([[0, 1, 2], [0, 6, 7]], 1),  # coplanar, one shared vertex, overlapping
        ([[0, 1, 2], [1, 2, 6]], 1),  # coplanar, shared edge, folded over
        ([[0, 1, 2], [1, 5, 2]], 0),  # coplanar neighbours
        ([[0, 1, 2], [8, 9, 10]], 0),  # apart
    ]
    for faces, expected in cases:
        found = len(self_intersections(v, np.array(faces, dtype=np.int64)))
        assert found == expected, f"self-test {faces}: found {found}, expected {expected}"


# --------------------------------------------------------------- vertices ---

def far_vertices(tree, v, eps):
    """Vertices with no point of f = 0 within eps: those where f's enclosure
    over the cube of half-width eps around them excludes 0."""
    far = []
    for k, p in enumerate(v):
        x = [(iv.mpf([float(p[i]) - eps, float(p[i]) + eps]), iv.mpf(0)) for i in range(3)]
        f = evaluate(tree, x, INTERVAL)[0]
        if f.a > 0 or f.b < 0:
            far.append(k)
    return far


# ------------------------------------------------------------------- main ---

def mesh(lgc, source, box, depth, path):
    """Meshes a formula in `box`, or a scene file (`box` None) object by
    object, to the default tolerance; a scene's summaries are merged into
    one."""
    where = [] if box is None else ["--box=" + box]
    out = subprocess.run(
        [lgc, "mesh", source, *where, "--depth", str(depth), "-o", path, "--json"],
        capture_output=True,
        text=True,
    )
    if out.returncode != 0:
        raise RuntimeError(f"lgc mesh failed: {out.stderr}")
    summary = json.loads(out.stdout)
    if "objects" not in summary:
        return summary
    objects = summary["objects"]
    return {
        "certified": sum(o["certified"] for o in objects),
        "cells": sum(o["cells"] for o in objects),
        "hausdorff": max(o["hausdorff"] for o in objects),
        "mesh_to_surface": max(o["mesh_to_surface"] for o in objects),
        "surface_to_mesh": max(o["surface_to_mesh"] for o in objects),
        "reach": max(o["reach"] for o in objects),
        "tolerance": max(o["tolerance"] for o in objects),
        "uncertified": [u for o in objects for u in o["uncertified"]],
    }


# --------------------------------------------------- surface samples ---

def point_triangle_distances(p, a, b, c):
    """Distances from the point p to each triangle (a[i], b[i], c[i])."""
    def segment(a, b):
        ab = b - a
        t = np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
        q = a + np.clip(t, 0.0, 1.0)[:, None] * ab
        return np.linalg.norm(p - q, axis=1)

    d = np.minimum(np.minimum(segment(a, b), segment(b, c)), segment(c, a))
    n = np.cross(b - a, c - a)
    nn = np.einsum("ij,ij->i", n, n)
    ok = nn > 0
    h = np.einsum("ij,ij->i", p - a, n) / np.where(ok, nn, 1.0)
    q = p - h[:, None] * n
    inside = ok.copy()
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(v - u, q - u), n) >= 0
    plane = np.abs(h) * np.sqrt(nn)
    return np.where(inside, np.minimum(d, plane), d)


def surface_samples_far_from_mesh(lgc, formula, box, summary, v, f, rays=1000):
    """Points of f = 0 found by `lgc trace` (first hits, each proved) that lie
    in no uncertified cell must be within the certificate's `surface_to_mesh`
    of the mesh. Returns the count checked and the points farther than it."""
    lo = np.array([float(x) for x in box.split(",")[:3]])
    hi = np.array([float(x) for x in box.split(",")[3:]])
    rng = np.random.default_rng(7)
    centre, size = 0.5 * (lo + hi), np.linalg.norm(hi - lo)
    starts = rng.normal(size=(rays, 3))
    starts = centre + 2 * size * starts / np.linalg.norm(starts, axis=1)[:, None]
    targets = lo + (hi - lo) * rng.random((rays, 3))
    directions = targets - starts
    text = "".join(" ".join(repr(float(x)) for x in (*o, *d)) + "\n" for o, d in zip(starts, directions))
    out = subprocess.run([lgc, "trace", formula, "--box=" + box], input=text, capture_output=True, text=True, check=True)
    boxes = [(np.array(u["lo"]), np.array(u["hi"])) for u in summary["uncertified"]]
    bound = summary["surface_to_mesh"] + 1e-9 * size
    checked, far = 0, []
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    tri_lo = np.minimum(np.minimum(a, b), c)
    tri_hi = np.maximum(np.maximum(a, b), c)
    for line, o, d in zip(out.stdout.splitlines(), starts, directions):
        try:
            t = float(line)
        except ValueError:
            continue  # none, touch or undecided
        p = o + t * d
        if any(np.all(p >= l) and np.all(p <= h) for l, h in boxes):
            continue
        near = np.all((tri_lo <= p + bound) & (tri_hi >= p - bound), axis=1)
        distance = point_triangle_distances(np.broadcast_to(p, (near.sum(), 3)), a[near], b[near], c[near]).min(initial=np.inf)
        checked += 1
        if distance > bound:
            far.append((p.tolist(), distance))
    return checked, far


def check(lgc, name, formula, box, euler, components, depth, workdir):
    problems = []
    path = os.path.join(workdir, "mesh.ply")
    if name in SCENES:
        scene = os.path.join(workdir, "scene.lgc")
        with open(scene, "w") as out:
            out.write(SCENES[name])
        summary = mesh(lgc, scene, None, depth, path)
    else:
        summary = mesh(lgc, formula, box, depth, path)
    m = trimesh.load(path, process=False)
    v = np.asarray(m.vertices, dtype=np.float64)
    f = np.asarray(m.faces, dtype=np.int64)
    if not m.is_watertight:
        problems.append("not watertight")
    if not m.is_winding_consistent:
        problems.append("winding inconsistent")
    if not m.volume > 0:
        problems.append(f"volume {m.volume} is not positive (not wound outward)")
    if m.euler_number != euler:
        problems.append(f"Euler characteristic {m.euler_number}, expected {euler}")
    if m.body_count != components:
        problems.append(f"{m.body_count} components, expected {components}")
    solid = manifold3d.Manifold(
        manifold3d.Mesh(vert_properties=v.astype(np.float32), tri_verts=f.astype(np.uint32))
    )
    if solid.status() != manifold3d.Error.NoError:
        problems.append(f"manifold3d: {solid.status()}")
    crossing = self_intersections(v, f)
    if crossing:
        problems.append(f"{len(crossing)} pairs of triangles intersect, such as {crossing[:3]}")
    # STL, OBJ and glTF store each vertex rounded to the nearest float32, as
    # numpy rounds: rounded, the mesh must still not cross itself, and no
    # two vertices may round to one point (readers would merge them).
    v32 = v.astype(np.float32).astype(np.float64)
    if len(np.unique(v32, axis=0)) != len(v32):
        problems.append("two vertices round to one float32 point")
    crossing = self_intersections(v32, f)
    if crossing:
        problems.append(f"rounded to float32, {len(crossing)} pairs of triangles intersect, such as {crossing[:3]}")
    reach = summary["reach"]
    far = far_vertices(Parser(formula).parse(), v, reach)
    if far:
        problems.append(f"{len(far)} vertices farther than {reach} from f = 0, such as {v[far[0]].tolist()}")
    if summary["hausdorff"] > summary["tolerance"]:
        problems.append(f"certified within {summary['hausdorff']}, past the tolerance {summary['tolerance']}")
    # The centres of triangles outside the uncertified cells must have a
    # root of f within the certificate's `mesh_to_surface`: f's enclosure
    # over the cube of that half-width must hold 0.
    if summary["certified"] > 0:
        centres = v[f].mean(axis=1)
        boxes = [(np.array(u["lo"]), np.array(u["hi"])) for u in summary["uncertified"]]
        outside = np.ones(len(f), dtype=bool)
        for lo, hi in boxes:
            outside &= ~np.all((v[f] >= lo) & (v[f] <= hi), axis=2).any(axis=1)
        centres = centres[outside]
        # At most 2,000 of them, chosen at random (mpmath is slow).
        pick = np.random.default_rng(11).permutation(len(centres))[:2000]
        far_centres = far_vertices(Parser(formula).parse(), centres[pick], summary["mesh_to_surface"])
        if far_centres:
            problems.append(
                f"{len(far_centres)} triangle centres in certified cells farther than "
                f"{summary['mesh_to_surface']} from f = 0"
            )
    checked, far_samples = surface_samples_far_from_mesh(lgc, formula, box, summary, v, f)
    if summary["certified"] > 0 and checked == 0:
        problems.append("no traced surface point fell in a certified cell")
    if far_samples:
        problems.append(
            f"{len(far_samples)} traced surface points in certified cells farther than {summary['surface_to_mesh']} "
            f"from the mesh, such as {far_samples[0]}"
        )
    print(
        f"{name:<13} {len(v)} vertices, {len(f)} triangles, Euler {m.euler_number}, "
        f"{summary['certified']} of {summary['cells']} cells certified, {checked} traced points within "
        f"{summary['surface_to_mesh']:.3g} of the mesh, mesh within {summary['mesh_to_surface']:.3g} of f = 0, "
        f"{m.body_count} component(s): {'ok' if not problems else '; '.join(problems)}"
    )
    return problems


def main():
    lgc = sys.argv[1]
    depth = int(sys.argv[2]) if len(sys.argv) > 2 else 5
    self_test()
    failures = 0
    with tempfile.TemporaryDirectory() as workdir:
        for name, formula, box, euler, components in CASES:
            failures += bool(check(lgc, name, formula, box, euler, components, depth, workdir))
    if failures:
        print(f"FAIL: {failures} of {len(CASES)} meshes")
        sys.exit(1)
    print(f"all {len(CASES)} meshes pass")


if __name__ == "__main__":
    main()
