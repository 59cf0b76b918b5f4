#!/usr/bin/python3
"""Writes the project's own small closed meshes into scenes/meshes/ (run from anywhere):

  torus.obj        a torus, R = 40 mm, r = 15 mm, in millimetres (scenes use "scale": 0.001);
                   32 x 16 quads, so it also exercises the OBJ polygon fan-triangulation
  tetrahedron.stl  a regular tetrahedron of edge 50 mm, in metres, ASCII STL
  blob.stl         a lumpy "bunny-like" blob about 60 mm across: an icosphere (320 triangles)
                   pushed out radially by smooth bumps, two of them ears; binary STL

Every mesh is closed (each edge shared by two triangles) with outward, counter-clockwise faces.
Pure Python (math and struct only) and deterministic: rerunning rewrites identical bytes.
"""
import math
import os
import struct

OUT = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "scenes", "meshes")


def torus(R=40.0, r=15.0, nu=32, nv=16):
    verts, quads = [], []
    for i in range(nu):
        u = 2 * math.pi * i / nu
        for j in range(nv):
            v = 2 * math.pi * j / nv
            verts.append(((R + r * math.cos(v)) * math.cos(u), (R + r * math.cos(v)) * math.sin(u), r * math.sin(v)))
    for i in range(nu):
        for j in range(nv):
            a = i * nv + j
            b = ((i + 1) % nu) * nv + j
            c = ((i + 1) % nu) * nv + (j + 1) % nv
            d = i * nv + (j + 1) % nv
            quads.append((a, b, c, d))  # outward: u then v is counter-clockwise seen from outside
    return verts, quads


def write_obj(path, verts, faces, comment):
    with open(path, "w", newline="\n") as f:
        f.write(f"# {comment}\n# written by scripts/make_meshes.py\no mesh\n")
        for x, y, z in verts:
            f.write(f"v {x:.6f} {y:.6f} {z:.6f}\n")
        for face in faces:
            f.write("f " + " ".join(str(k + 1) for k in face) + "\n")


def normal(a, b, c):
    u = [b[k] - a[k] for k in range(3)]
    v = [c[k] - a[k] for k in range(3)]
    n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
    length = math.sqrt(sum(x * x for x in n)) or 1.0
    return tuple(x / length for x in n)


def write_ascii_stl(path, verts, tris, name):
    with open(path, "w", newline="\n") as f:
        f.write(f"solid {name}\n")
        for t in tris:
            a, b, c = (verts[k] for k in t)
            f.write("  facet normal {:.6e} {:.6e} {:.6e}\n    outer loop\n".format(*normal(a, b, c)))
            for p in (a, b, c):
                f.write("      vertex {:.6e} {:.6e} {:.6e}\n".format(*p))
            f.write("    endloop\n  endfacet\n")
        f.write(f"endsolid {name}\n")


def write_binary_stl(path, verts, tris, header):
    with open(path, "wb") as f:
        f.write(header.encode("ascii").ljust(80, b" ")[:80])
        f.write(struct.pack("<I", len(tris)))
        for t in tris:
            a, b, c = (verts[k] for k in t)
            f.write(struct.pack("<12fH", *normal(a, b, c), *a, *b, *c, 0))


def tetrahedron(edge=0.05):
    # Corners of a regular tetrahedron: alternate corners of a cube of side edge/√2.
    h = edge / math.sqrt(2) / 2
    verts = [(h, h, h), (h, -h, -h), (-h, h, -h), (-h, -h, h)]
    tris = [(0, 1, 2), (0, 3, 1), (0, 2, 3), (1, 3, 2)]
    return verts, tris


def icosphere(levels):
    t = (1 + math.sqrt(5)) / 2
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
             (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    verts = [tuple(x / math.sqrt(sum(c * c for c in v)) for x in v) for v in verts]
    tris = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
            (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11),
            (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(levels):
        mid = {}

        def midpoint(i, j):
            key = (min(i, j), max(i, j))
            if key not in mid:
                p = [(verts[i][k] + verts[j][k]) / 2 for k in range(3)]
                n = math.sqrt(sum(c * c for c in p))
                mid[key] = len(verts)
                verts.append(tuple(c / n for c in p))
            return mid[key]

        new = []
        for a, b, c in tris:
            ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        tris = new
    return verts, tris


def blob(radius=0.025):
    verts, tris = icosphere(2)
    # Bumps exp(-(1 − cos θ)/w) about a few directions; the two upward ones make "ears".
    bumps = [((0.35, 0.25, 0.9), 0.55, 0.04), ((-0.35, 0.25, 0.9), 0.55, 0.04), ((0.9, 0.0, -0.3), 0.3, 0.15),
             ((-0.5, -0.8, -0.2), 0.25, 0.2), ((0.0, 0.9, -0.4), 0.2, 0.25)]
    out = []
    for v in verts:
        s = 1.0
        for d, height, width in bumps:
            n = math.sqrt(sum(c * c for c in d))
            cos = sum(v[k] * d[k] / n for k in range(3))
            s += height * math.exp(-(1 - cos) / width)
        out.append(tuple(radius * s * c for c in v))
    return out, tris


def main():
    os.makedirs(OUT, exist_ok=True)
    verts, quads = torus()
    write_obj(os.path.join(OUT, "torus.obj"), verts, quads, "torus R = 40 mm, r = 15 mm (millimetres), 32 x 16 quads")
    verts, tris = tetrahedron()
    write_ascii_stl(os.path.join(OUT, "tetrahedron.stl"), verts, tris, "tetrahedron")
    verts, tris = blob()
    write_binary_stl(os.path.join(OUT, "blob.stl"), verts, tris, "qbond blob (scripts/make_meshes.py), metres")
    for name in sorted(os.listdir(OUT)):
        print(os.path.join(OUT, name), os.path.getsize(os.path.join(OUT, name)), "bytes")


if __name__ == "__main__":
    main()
