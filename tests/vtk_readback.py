#!/usr/bin/python3
"""Reads a qbond .pvd series back with VTK itself (Debian's python3-vtk9) and checks it.

Usage: vtk_readback.py SERIES.pvd --frames N --points N --lines N
                       --point-arrays a,b,... --cell-arrays a,b,...
Exits non-zero with a message naming the frame and what differs.
"""
import argparse
import os
import sys
import xml.etree.ElementTree as ET

from vtkmodules.vtkIOXML import vtkXMLPolyDataReader

p = argparse.ArgumentParser()
p.add_argument("pvd")
p.add_argument("--frames", type=int, required=True)
p.add_argument("--points", type=int, required=True)
p.add_argument("--lines", type=int, required=True)
p.add_argument("--point-arrays", required=True)
p.add_argument("--cell-arrays", required=True)
a = p.parse_args()

datasets = ET.parse(a.pvd).getroot().findall("./Collection/DataSet")
if len(datasets) != a.frames:
    sys.exit(f"{a.pvd}: {len(datasets)} frames, expected {a.frames}")
times = [float(d.get("timestep")) for d in datasets]
if times != sorted(times):
    sys.exit(f"{a.pvd}: frame times not increasing: {times}")
for d in datasets:
    path = os.path.join(os.path.dirname(a.pvd), d.get("file"))
    r = vtkXMLPolyDataReader()
    r.SetFileName(path)
    r.Update()
    if r.GetErrorCode() != 0:
        sys.exit(f"{path}: VTK reader error {r.GetErrorCode()}")
    poly = r.GetOutput()
    got = (poly.GetNumberOfPoints(), poly.GetNumberOfVerts(), poly.GetNumberOfLines())
    if got != (a.points, a.points, a.lines):
        sys.exit(f"{path}: points, verts, lines = {got}, expected {(a.points, a.points, a.lines)}")
    for kind, data, names, size in (("point", poly.GetPointData(), a.point_arrays, a.points),
                                    ("cell", poly.GetCellData(), a.cell_arrays, a.points + a.lines)):
        for name in names.split(","):
            arr = data.GetArray(name)
            if arr is None:
                sys.exit(f"{path}: no {kind} array '{name}'")
            if arr.GetNumberOfTuples() != size:
                sys.exit(f"{path}: {kind} array '{name}' has {arr.GetNumberOfTuples()} tuples, expected {size}")
    # The bond ids of the line cells follow the vertex cells' -1 (VTK orders verts, then lines).
    bond = poly.GetCellData().GetArray("bond")
    if a.lines and (bond.GetValue(a.points - 1) != -1 or bond.GetValue(a.points) < 0):
        sys.exit(f"{path}: cell array 'bond' is not aligned with the cells")
print(f"ok: {len(datasets)} frames, {a.points} points, {a.lines} lines")
