"""Reading a qbond run's outputs, for the tests under mpiexec: raw files, frames, diagnostics rows
and ParaView frames."""
import csv
import os

import vtk


def read(path):
    with open(path, "rb") as f:
        return f.read()


def frames(out):
    return sorted(os.listdir(os.path.join(out, "frames")))


def rows(out):
    with open(os.path.join(out, "diagnostics.csv")) as f:
        return list(csv.reader(f))


def poly(path):
    r = vtk.vtkXMLPolyDataReader()
    r.SetFileName(path)
    r.Update()
    return r.GetOutput()
