#!/usr/bin/python3
"""How many CG iterations a block SSOR preconditioner would save (docs/performance.md).

Usage: bench/studies/ssor_iterations.py [--n 10,20]
Needs Debian's python3-numpy and python3-scipy (a study, not part of the suite). On the system of
multigrid_iterations.py (the canonical lattice at rest, h = 1/60 s, the x = 0 face eliminated),
counts preconditioned CG iterations to a relative residual of 1e-6 with
  - block Jacobi (A's 3x3 diagonal blocks): what qbond's CG uses;
  - block SSOR, M = (D/w + L) (D/w)^-1 (D/w + U) w / (2 - w) with L, U A's strictly lower and
    upper block triangles, in the quanta's natural (lattice) order: a sequential sweep;
  - the same in a multicolour order (8 colours by the parity of x, y and z, which separates every
    offset of the stencil): each colour's quanta can be swept in parallel, deterministically.
Each SSOR iteration costs two triangular sweeps besides CG's product (Eisenstat's trick folds the
product into them), so it pays only where it takes well under half of block Jacobi's iterations.
"""
import argparse
import importlib.util
import pathlib

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

_spec = importlib.util.spec_from_file_location(
    "multigrid_iterations", pathlib.Path(__file__).with_name("multigrid_iterations.py"))
_mg = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_mg)


def split(A):
    """A's block diagonal D and strictly lower block triangle L (3x3 blocks)."""
    C = A.tocoo()
    same, lower = (C.row // 3) == (C.col // 3), (C.row // 3) > (C.col // 3)
    D = sp.csr_matrix((C.data[same], (C.row[same], C.col[same])), shape=A.shape)
    L = sp.csr_matrix((C.data[lower], (C.row[lower], C.col[lower])), shape=A.shape)
    return D, L


def ssor(A, w):
    D, L = split(A)
    # Block triangular: LU in the natural order fills nothing outside the diagonal blocks.
    lower = sla.splu((D / w + L).tocsc(), permc_spec='NATURAL', diag_pivot_thresh=0)
    upper = sla.splu((D / w + L.T).tocsc(), permc_spec='NATURAL', diag_pivot_thresh=0)
    Dw = (D / w).tocsr()
    return lambda r: (2 - w) * upper.solve(Dw @ lower.solve(r))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--n', default='10,20')
    args = ap.parse_args()
    print('| n | preconditioner | w | iterations |\n|---|---|---|---|')
    for n in (int(v) for v in args.n.split(',')):
        A, b = _mg.system(n)
        q = np.arange(n**3)
        X, Y, Z = q // (n * n), (q // n) % n, q % n
        free = np.where(X > 0)[0]  # the unknowns of system(n), in its order
        colour = (X[free] % 2) + 2 * (Y[free] % 2) + 4 * (Z[free] % 2)
        order = np.argsort(colour, kind='stable')
        dof = (3 * order[:, None] + np.arange(3)).ravel()
        Ac, bc = A[dof][:, dof].tocsr(), b[dof]
        inv = _mg.block_diagonal_inverse(A, 3)
        print(f'| {n} | block Jacobi | | {_mg.pcg(A, b, lambda r: _mg.apply_blocks(inv, r))} |', flush=True)
        for w in (1.0, 1.3, 1.5, 1.7):
            print(f'| {n} | block SSOR, natural order | {w} | {_mg.pcg(A, b, ssor(A, w))} |', flush=True)
            print(f'| {n} | block SSOR, 8 colours | {w} | {_mg.pcg(Ac, bc, ssor(Ac, w))} |', flush=True)


if __name__ == '__main__':
    main()
