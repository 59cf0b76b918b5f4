#!/usr/bin/python3
"""How many CG iterations an aggregation multigrid preconditioner would save (docs/performance.md).

Usage: bench/studies/multigrid_iterations.py [--n 10,20,40]
Needs Debian's python3-numpy and python3-scipy (not a build dependency: a study, not part of the
suite). Assembles the linearised backward-Euler system A = M + h C + h^2 K of the canonical
lattice at rest (src/integrators/backward_euler.hpp: B_b = (h D + h^2 k) u u^T per bond, the x = 0 face
eliminated) at h = 1/60 s, the system `qbond bench --solve` times, and counts preconditioned CG
iterations to a relative residual of 1e-6 with
  - block Jacobi (A's 3x3 diagonal blocks): what qbond's CG uses;
  - a V(1,1)-cycle of plain aggregation (piecewise-constant prolongation) and of smoothed
    aggregation (P = (I - w D^-1 A) P0, w = 2/3), block-Jacobi smoothing (w = 2/3), aggregates
    grown greedily over the quanta graph, coarsened until 300 unknowns, then Cholesky.
`work`: the iterations times the stored entries each touches, in units of A's (CG's product 1; a
V(1,1) cycle adds two products with each level's matrix and one with each P and P^T), a proxy for
the time when every matrix is streamed from memory.
"""
import argparse

import numpy as np
import scipy.sparse as sp

H, K, D, MASS, A = 1 / 60, 1000.0, 0.01, 1e-3, 0.01
OFFSETS = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, -1, 0), (1, 0, 1), (1, 0, -1), (0, 1, 1), (0, 1, -1)]


def system(n):
    """A and b over the free quanta (x > 0) of the n^3 lattice at rest, under gravity."""
    idx = np.arange(n**3).reshape(n, n, n)
    pos = np.stack(np.meshgrid(*(np.arange(n) * A,) * 3, indexing='ij'), -1).reshape(-1, 3)
    ends = []
    for o in OFFSETS:
        lo = tuple(slice(max(0, -d), n - max(0, d)) for d in o)
        hi = tuple(slice(max(0, d), n - max(0, -d)) for d in o)
        ends.append((idx[lo].ravel(), idx[hi].ravel()))
    i = np.concatenate([e[0] for e in ends])
    j = np.concatenate([e[1] for e in ends])
    u = pos[j] - pos[i]
    u /= np.linalg.norm(u, axis=1)[:, None]
    blocks = (H * D + H * H * K) * u[:, :, None] * u[:, None, :]
    rows, cols, vals = [], [], []
    for r, c, s in ((i, i, 1), (j, j, 1), (i, j, -1), (j, i, -1)):
        for p in range(3):
            for q in range(3):
                rows.append(3 * r + p)
                cols.append(3 * c + q)
                vals.append(s * blocks[:, p, q])
    N = n**3
    M = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(3 * N, 3 * N))
    M = M + MASS * sp.identity(3 * N)
    free = np.where(pos[:, 0] > 0)[0]
    dof = (3 * free[:, None] + np.arange(3)).ravel()
    b = np.zeros(len(dof))
    b[2::3] = -H * MASS * 9.81
    return M[dof][:, dof].tocsr(), b


def block_diagonal_inverse(M, bs):
    C = M.tocoo()
    same = (C.row // bs) == (C.col // bs)
    blocks = np.zeros((M.shape[0] // bs, bs, bs))
    blocks[C.row[same] // bs, C.row[same] % bs, C.col[same] % bs] = C.data[same]
    return np.linalg.inv(blocks)


def apply_blocks(inv, r):
    return np.einsum('nij,nj->ni', inv, r.reshape(len(inv), -1)).ravel()


def aggregates(M, bs):
    """Greedy aggregation: a node whose neighbours are all free takes them; leftovers join a neighbour's."""
    C = M.tocoo()
    G = sp.csr_matrix((np.ones(C.nnz), (C.row // bs, C.col // bs)), shape=(M.shape[0] // bs,) * 2)
    agg = -np.ones(G.shape[0], int)
    count = 0
    for k in range(G.shape[0]):
        nb = G.indices[G.indptr[k]:G.indptr[k + 1]]
        if agg[k] < 0 and np.all(agg[nb] < 0):
            agg[nb] = count
            agg[k] = count
            count += 1
    for k in np.where(agg < 0)[0]:
        nb = G.indices[G.indptr[k]:G.indptr[k + 1]]
        taken = agg[nb][agg[nb] >= 0]
        agg[k] = taken[0]
    return agg, count


def hierarchy(M, smoothed, coarsest=300):
    levels = []
    while M.shape[0] > coarsest:
        agg, count = aggregates(M, 3)
        r = np.arange(M.shape[0])
        P = sp.csr_matrix((np.ones(len(r)), (r, 3 * agg[r // 3] + r % 3)), shape=(M.shape[0], 3 * count))
        inv = block_diagonal_inverse(M, 3)
        if smoothed:
            P = (P - (2 / 3) * sp.block_diag(list(inv), format='csr') @ M @ P).tocsr()
        levels.append((M, inv, P))
        M = (P.T @ M @ P).tocsr()
    return levels, np.linalg.cholesky(M.toarray())


def v_cycle(levels, L, w=2 / 3):
    def cycle(k, r):
        if k == len(levels):
            return np.linalg.solve(L.T, np.linalg.solve(L, r))
        M, inv, P = levels[k]
        x = w * apply_blocks(inv, r)
        x += P @ cycle(k + 1, P.T @ (r - M @ x))
        return x + w * apply_blocks(inv, r - M @ x)
    return lambda r: cycle(0, r)


def pcg(M, b, precondition, tol=1e-6, cap=10000):
    x = np.zeros_like(b)
    r = b.copy()
    z = precondition(r)
    p = z.copy()
    rz = r @ z
    for it in range(cap):
        if np.linalg.norm(r) <= tol * np.linalg.norm(b):
            return it
        Mp = M @ p
        alpha = rz / (p @ Mp)
        x += alpha * p
        r -= alpha * Mp
        z = precondition(r)
        rz, rz_old = r @ z, rz
        p = z + (rz / rz_old) * p
    return cap


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--n', default='10,20,40')
    args = ap.parse_args()
    print(f"{'n':>4} {'preconditioner':<28} {'iterations':>10} {'work':>7}  levels (unknowns)")
    for n in (int(s) for s in args.n.split(',')):
        M, b = system(n)
        its = pcg(M, b, lambda r, inv=block_diagonal_inverse(M, 3): apply_blocks(inv, r))
        print(f"{n:>4} {'block Jacobi':<28} {its:>10} {its:>7.0f}")
        for name, smoothed in (('plain aggregation', False), ('smoothed aggregation', True)):
            levels, L = hierarchy(M, smoothed)
            its = pcg(M, b, v_cycle(levels, L))
            sizes = [lv[0].shape[0] for lv in levels] + [L.shape[0]]
            cycle = sum(2 * lv[0].nnz + 2 * lv[2].nnz for lv in levels) / M.nnz
            print(f"{n:>4} {name + ' V(1,1)':<28} {its:>10} {its * (1 + cycle):>7.0f}  {sizes}")


if __name__ == '__main__':
    main()
