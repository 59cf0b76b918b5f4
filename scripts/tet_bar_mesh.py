#!/usr/bin/python3
"""Writes a tetrahedral mesh of a box bar (nx × ny × nz cubes of side h, each cut into the six
Kuhn tetrahedra around its main diagonal, so that neighbouring cubes share their faces' cuts) as
Gmsh 2.2 ASCII, Gmsh 4.1 ASCII and VTK XML (.vtu, ASCII): the example meshes of scenes/meshes.

Usage: scripts/tet_bar_mesh.py NX NY NZ H OUT_STEM  (writes OUT_STEM.msh, OUT_STEM_v41.msh, OUT_STEM.vtu)
"""
import itertools
import sys


def bar(nx, ny, nz, h):
    def node(i, j, k):
        return i + (nx + 1) * (j + (ny + 1) * k)

    nodes = [(i * h, j * h, k * h) for k in range(nz + 1) for j in range(ny + 1) for i in range(nx + 1)]
    tets = []
    for k, j, i in itertools.product(range(nz), range(ny), range(nx)):
        for perm in itertools.permutations(range(3)):
            corner = [0, 0, 0]
            path = [node(i, j, k)]
            for axis in perm:
                corner[axis] += 1
                path.append(node(i + corner[0], j + corner[1], k + corner[2]))
            tets.append(path)
    return nodes, tets


def fmt(v):
    return repr(float(v))


def gmsh22(nodes, tets):
    out = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat", "$Nodes", str(len(nodes))]
    out += [f"{n + 1} {fmt(x)} {fmt(y)} {fmt(z)}" for n, (x, y, z) in enumerate(nodes)]
    out += ["$EndNodes", "$Elements", str(len(tets))]
    out += [f"{e + 1} 4 2 1 1 " + " ".join(str(v + 1) for v in t) for e, t in enumerate(tets)]
    out += ["$EndElements"]
    return "\n".join(out) + "\n"


def gmsh41(nodes, tets):
    n, m = len(nodes), len(tets)
    out = ["$MeshFormat", "4.1 0 8", "$EndMeshFormat", "$Nodes", f"1 {n} 1 {n}", f"3 1 0 {n}"]
    out += [str(k + 1) for k in range(n)]
    out += [f"{fmt(x)} {fmt(y)} {fmt(z)}" for x, y, z in nodes]
    out += ["$EndNodes", "$Elements", f"1 {m} 1 {m}", f"3 1 4 {m}"]
    out += [f"{e + 1} " + " ".join(str(v + 1) for v in t) for e, t in enumerate(tets)]
    out += ["$EndElements"]
    return "\n".join(out) + "\n"


def vtu(nodes, tets):
    pts = "\n".join(f"{fmt(x)} {fmt(y)} {fmt(z)}" for x, y, z in nodes)
    conn = "\n".join(" ".join(str(v) for v in t) for t in tets)
    offsets = " ".join(str(4 * (e + 1)) for e in range(len(tets)))
    types = " ".join("10" for _ in tets)
    return f"""<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian">
  <UnstructuredGrid>
    <Piece NumberOfPoints="{len(nodes)}" NumberOfCells="{len(tets)}">
      <Points>
        <DataArray type="Float64" NumberOfComponents="3" format="ascii">
{pts}
        </DataArray>
      </Points>
      <Cells>
        <DataArray type="Int64" Name="connectivity" format="ascii">
{conn}
        </DataArray>
        <DataArray type="Int64" Name="offsets" format="ascii">
{offsets}
        </DataArray>
        <DataArray type="UInt8" Name="types" format="ascii">
{types}
        </DataArray>
      </Cells>
    </Piece>
  </UnstructuredGrid>
</VTKFile>
"""


def main():
    nx, ny, nz, h, stem = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4]), sys.argv[5]
    nodes, tets = bar(nx, ny, nz, h)
    for suffix, text in ((".msh", gmsh22(nodes, tets)), ("_v41.msh", gmsh41(nodes, tets)), (".vtu", vtu(nodes, tets))):
        with open(stem + suffix, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
