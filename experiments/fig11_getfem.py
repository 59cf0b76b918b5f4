#!/usr/bin/python3
"""The twisted bar in linear elasticity with GetFEM (Debian's python3-getfem), for fig11.

Usage: fig11_getfem.py DIR L B E NU THETA ELEMENTS_ACROSS
A bar [0, L] x [0, B]², clamped at x = 0, its x = L face turned by THETA about the bar's axis
(u = θ e_x × (p − c), no warping at either end, as the lattice's anchored layers); Q2 hexahedra.
Writes DIR/getfem.csv (elements_across, dofs, torque = 2 U / θ) and, for the points of
DIR/lattice_displacement.csv (columns x,y,z,...), the FEM displacement there:
DIR/getfem_at_sites.csv (x,y,z,ux,uy,uz).
"""
import csv
import os
import sys

import numpy as np
import getfem as gf

d = sys.argv[1]
L, B, E, NU, TH = (float(v) for v in sys.argv[2:7])
NE = int(sys.argv[7])
gf.util_trace_level(0)
gf.util_warning_level(0)
lam, mu = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))

rows = []
for ne in range(max(1, NE - 2), NE + 1):
    m = gf.Mesh("cartesian", np.linspace(0, L, round(L / B * ne) + 1), np.linspace(0, B, ne + 1),
                np.linspace(0, B, ne + 1))
    mfu = gf.MeshFem(m, 3)
    mfu.set_fem(gf.Fem("FEM_QK(3,2)"))
    mim = gf.MeshIm(m, gf.Integ("IM_HEXAHEDRON(5)"))
    m.set_region(1, m.outer_faces_with_direction([-1.0, 0.0, 0.0], 0.01))
    m.set_region(2, m.outer_faces_with_direction([1.0, 0.0, 0.0], 0.01))
    md = gf.Model("real")
    md.add_fem_variable("u", mfu)
    md.add_initialized_data("lambda", [lam])
    md.add_initialized_data("mu", [mu])
    md.add_isotropic_linearized_elasticity_brick(mim, "u", "lambda", "mu")
    md.add_Dirichlet_condition_with_multipliers(mim, "u", mfu, 1)
    P = mfu.basic_dof_nodes()
    D = np.zeros(mfu.nbdof())
    c = B / 2
    D[1::3] = -TH * (P[2, 1::3] - c)
    D[2::3] = TH * (P[1, 2::3] - c)
    md.add_initialized_fem_data("Dr", mfu, D)
    md.add_Dirichlet_condition_with_multipliers(mim, "u", mfu, 2, "Dr")
    md.solve()
    U = gf.asm("generic", mim, 0, "lambda*sqr(Trace(Grad_u))/2 + mu*Norm_sqr(Sym(Grad_u))", -1, md)
    rows.append((ne, mfu.nbdof(), 2 * U / TH))

with open(os.path.join(d, "getfem.csv"), "w") as f:
    f.write("elements_across,dofs,torque\n")
    for r in rows:
        f.write(f"{r[0]},{r[1]},{r[2]:.17g}\n")

sites = os.path.join(d, "lattice_displacement.csv")
if os.path.exists(sites):
    with open(sites) as f:
        pts = np.array([[float(r["x"]), float(r["y"]), float(r["z"])] for r in csv.DictReader(f)]).T
    u = gf.compute_interpolate_on(mfu, md.variable("u"), pts)
    with open(os.path.join(d, "getfem_at_sites.csv"), "w") as f:
        f.write("x,y,z,ux,uy,uz\n")
        for k in range(pts.shape[1]):
            f.write(",".join(f"{v:.17g}" for v in (*pts[:, k], *u[:, k])) + "\n")
