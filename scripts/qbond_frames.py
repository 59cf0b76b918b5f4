"""Reads a `qbond run`'s ParaView output back with VTK (Debian's python3-vtk9): the frames
listed in series.pvd, and each frame's quanta, bonds and bond strains as numpy arrays."""
import os
import xml.etree.ElementTree as ET

from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOXML import vtkXMLPolyDataReader


def frames(run):
    """[(time, path of the frame's .vtp)] of the run directory `run`."""
    pvd = ET.parse(os.path.join(run, "series.pvd")).getroot()
    return [(float(d.get("timestep")), os.path.join(run, d.get("file"))) for d in pvd.iter("DataSet")]


def read(path):
    """A frame's positions (N x 3), bonds (B x 2 quanta indices) and bond strains (B)."""
    r = vtkXMLPolyDataReader()
    r.SetFileName(path)
    r.Update()
    poly = r.GetOutput()
    x = vtk_to_numpy(poly.GetPoints().GetData())
    lines = vtk_to_numpy(poly.GetLines().GetConnectivityArray()).reshape(-1, 2)
    # Cell data covers the quanta's vertex cells first, then the bonds' lines.
    strain = vtk_to_numpy(poly.GetCellData().GetArray("strain"))[poly.GetNumberOfVerts():]
    return x, lines, strain


def pieces(n, lines):
    """Number of connected pieces of n quanta joined by the bonds `lines` (union-find)."""
    parent = list(range(n))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for a, b in lines:
        parent[find(a)] = find(b)
    return len({find(i) for i in range(n)})
