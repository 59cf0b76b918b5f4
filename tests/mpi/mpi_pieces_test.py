#!/usr/bin/python3
"""Frames written in pieces over MPI ranks hold, together, the frames of the run alone.

Usage: mpi_pieces_test.py QBOND SCENE WORKDIR --ranks N --mpiexec MPIEXEC [--mpiexec-flag F ...]

Runs SCENE alone (whole-world .vtp frames) and over N ranks with --frame-pieces, and checks:
  - series.pvd lists one .pvtp per frame of the run alone, at the same times;
  - each .pvtp is a ParaView parallel PolyData file: a VTKFile of type PPolyData holding one
    PPolyData with PPointData, PCellData and PPoints (one 3-component PDataArray) declaring the
    arrays every piece holds (name, type, components, in order), and one Piece per rank whose
    Source names a file beside it; VTK's own parallel reader reads it;
  - the pieces' owned points (vtkGhostType 0) are every quanta of the run alone's frame exactly
    once, at its positions and velocities to 1e-12 of their scale, and their lines every bond
    exactly once, between the same quanta.
Exits non-zero with a message naming the frame and what differs.
"""
import os
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOXML import vtkXMLPPolyDataReader, vtkXMLPolyDataReader

from run_outputs import ranks_arguments

p = ranks_arguments()
a = p.parse_args()
REL = 1e-12


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {r.returncode}\n{r.stdout}\n{r.stderr}")


shutil.rmtree(a.work, ignore_errors=True)
alone, split = os.path.join(a.work, "alone"), os.path.join(a.work, "pieces")
run([a.qbond, "run", a.scene, "-o", alone, "--quiet"])
run([a.mpiexec] + a.mpiexec_flag + ["-n", str(a.ranks), a.qbond, "run", a.scene, "-o", split, "--quiet",
     "--frame-pieces"])


def series(out):
    root = ET.parse(os.path.join(out, "series.pvd")).getroot()
    return [(d.get("timestep"), d.get("file")) for d in root.iter("DataSet")]


one, many = series(alone), series(split)
if [t for t, _ in one] != [t for t, _ in many] or not one:
    sys.exit("series.pvd: the frames' times differ from the run alone's")
if [f[:-4] + ".pvtp" for _, f in one] != [f for _, f in many]:
    sys.exit(f"series.pvd does not list a .pvtp per frame: {many[:3]}...")


def declared(text, section):
    """(Name, type, components) of the DataArrays of a piece's section, from its XML header."""
    body = re.search(rf"<{section}[^>]*>(.*?)</{section}>", text, re.S).group(1)
    return [(d.get("Name"), d.get("type"), d.get("NumberOfComponents"))
            for d in (ET.fromstring(m) for m in re.findall(r"<DataArray[^>]*/>", body))]


def poly(path, reader):
    r = reader()
    r.SetFileName(path)
    r.Update()
    return r.GetOutput()


def lines_of(d):
    conn = vtk_to_numpy(d.GetLines().GetConnectivityArray()) if d.GetNumberOfLines() else np.zeros(0, int)
    return conn.reshape(-1, 2)


def cell_bonds(d):
    """The bond id of each line (the cell array covers the vertex cells first)."""
    b = vtk_to_numpy(d.GetCellData().GetArray("bond"))
    return b[d.GetNumberOfVerts():]


worst = 0.0
for (_, whole), (_, parallel) in zip(one, many):
    ref = poly(os.path.join(alone, whole), vtkXMLPolyDataReader)
    ids = vtk_to_numpy(ref.GetPointData().GetArray("id"))
    x_ref = vtk_to_numpy(ref.GetPoints().GetData())[np.argsort(ids)]
    v_ref = vtk_to_numpy(ref.GetPointData().GetArray("velocity"))[np.argsort(ids)]
    ends_ref = {int(b): tuple(ids[e]) for b, e in zip(cell_bonds(ref), lines_of(ref))}

    # The parallel file's schema.
    path = os.path.join(split, parallel)
    root = ET.parse(path).getroot()
    if root.tag != "VTKFile" or root.get("type") != "PPolyData":
        sys.exit(f"{parallel}: not a VTKFile of type PPolyData")
    pp = root.findall("PPolyData")
    if len(pp) != 1:
        sys.exit(f"{parallel}: {len(pp)} PPolyData elements")
    pp = pp[0]
    sections = {s: pp.findall(s) for s in ("PPointData", "PCellData", "PPoints")}
    if any(len(v) != 1 for v in sections.values()):
        sys.exit(f"{parallel}: needs one PPointData, PCellData and PPoints")
    points = sections["PPoints"][0].findall("PDataArray")
    if len(points) != 1 or points[0].get("NumberOfComponents") != "3":
        sys.exit(f"{parallel}: PPoints must hold one 3-component PDataArray")
    pieces = [e.get("Source") for e in pp.findall("Piece")]
    if len(pieces) != a.ranks:
        sys.exit(f"{parallel}: {len(pieces)} pieces over {a.ranks} ranks")
    want = {s: [(d.get("Name"), d.get("type"), d.get("NumberOfComponents")) for d in sections[s][0].findall("PDataArray")]
            for s in ("PPointData", "PCellData")}
    want["PPoints"] = [(None, points[0].get("type"), "3")]

    seen_points, seen_bonds = {}, {}
    for src in pieces:
        piece = os.path.join(os.path.dirname(path), src)
        if not os.path.isfile(piece):
            sys.exit(f"{parallel}: piece {src} is missing")
        with open(piece, "rb") as f:
            head = f.read().split(b"<AppendedData")[0].decode()
        for s, t in (("PPointData", "PointData"), ("PCellData", "CellData"), ("PPoints", "Points")):
            if declared(head, t) != want[s]:
                sys.exit(f"{src}: its {t} arrays {declared(head, t)} are not those {parallel} declares {want[s]}")
        d = poly(piece, vtkXMLPolyDataReader)
        pid = vtk_to_numpy(d.GetPointData().GetArray("id"))
        ghost = vtk_to_numpy(d.GetPointData().GetArray("vtkGhostType"))
        x = vtk_to_numpy(d.GetPoints().GetData())
        v = vtk_to_numpy(d.GetPointData().GetArray("velocity"))
        for k in np.nonzero(ghost == 0)[0]:
            q = int(pid[k])
            if q in seen_points:
                sys.exit(f"{parallel}: quanta {q} is owned by two pieces")
            seen_points[q] = (x[k], v[k])
        for b, e in zip(cell_bonds(d), lines_of(d)):
            if int(b) in seen_bonds:
                sys.exit(f"{parallel}: bond {b} is in two pieces")
            seen_bonds[int(b)] = (int(pid[e[0]]), int(pid[e[1]]))
    if sorted(seen_points) != list(range(len(ids))):
        sys.exit(f"{parallel}: the pieces own {len(seen_points)} quanta, the run alone has {len(ids)}")
    if seen_bonds != ends_ref:
        sys.exit(f"{parallel}: the pieces hold {len(seen_bonds)} bonds, the run alone's frame {len(ends_ref)} "
                 "(or other ends)")
    x = np.array([seen_points[q][0] for q in range(len(ids))])
    v = np.array([seen_points[q][1] for q in range(len(ids))])
    for what, got, ref_ in (("position", x, x_ref), ("velocity", v, v_ref)):
        s = max(abs(ref_).max(), 1e-300)
        diff = abs(got - ref_).max()
        if diff > REL * s:
            sys.exit(f"{parallel}: {what}s differ from the run alone's by {diff:g} (scale {s:g})")
        worst = max(worst, diff / s)
    # ParaView's reader (VTK's) reads the whole: every piece's points and lines.
    whole_file = poly(path, vtkXMLPPolyDataReader)
    if whole_file.GetNumberOfLines() != len(ends_ref):
        sys.exit(f"{parallel}: VTK's parallel reader reads {whole_file.GetNumberOfLines()} lines of {len(ends_ref)}")
print(f"{len(many)} frames in {a.ranks} pieces each hold the run alone's quanta and bonds once; "
      f"largest difference {worst:.3g} of scale")
