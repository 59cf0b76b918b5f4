"""The canonical workload (docs/performance.md) as the peers read it: the n^3 simple-cubic
lattice, spacing A, quanta of MASS, bonds to nearest and face-diagonal neighbours of stiffness K,
the x = 0 face anchored, gravity -G along z."""
import math
import os

A, MASS, K, G = 0.01, 1e-3, 1000.0, 9.81


def lattice(n):
    """Sites, bonds (i, j, type 1 = axis, 2 = diagonal) of the canonical lattice, 0-based."""
    def idx(i, j, k):
        return (k * n + j) * n + i
    sites = [(i * A, j * A, k * A) for k in range(n) for j in range(n) for i in range(n)]
    bonds = []
    for k in range(n):
        for j in range(n):
            for i in range(n):
                p = idx(i, j, k)
                if i + 1 < n: bonds.append((p, idx(i + 1, j, k), 1))
                if j + 1 < n: bonds.append((p, idx(i, j + 1, k), 1))
                if k + 1 < n: bonds.append((p, idx(i, j, k + 1), 1))
                if i + 1 < n and j + 1 < n:
                    bonds += [(p, idx(i + 1, j + 1, k), 2), (idx(i + 1, j, k), idx(i, j + 1, k), 2)]
                if i + 1 < n and k + 1 < n:
                    bonds += [(p, idx(i + 1, j, k + 1), 2), (idx(i + 1, j, k), idx(i, j, k + 1), 2)]
                if j + 1 < n and k + 1 < n:
                    bonds += [(p, idx(i, j + 1, k + 1), 2), (idx(i, j + 1, k), idx(i, j, k + 1), 2)]
    return sites, bonds


def bond_count(n):
    return 3 * n * n * (n - 1) + 6 * n * (n - 1) ** 2


def lammps_data(n, work):
    """The workload as a LAMMPS data file in `work` (written once per n); its path."""
    data = os.path.join(work, f"canonical_{n}.data")
    if not os.path.exists(data):
        sites, bonds = lattice(n)
        hi = (n - 1) * A
        with open(data, "w") as f:
            f.write(f"canonical lattice n = {n}\n\n{len(sites)} atoms\n{len(bonds)} bonds\n1 atom types\n2 bond types\n\n")
            f.write(f"-0.005 {hi + 0.005} xlo xhi\n-0.005 {hi + 0.005} ylo yhi\n-0.005 {hi + 0.005} zlo zhi\n\n")
            f.write(f"Masses\n\n1 {MASS}\n\nAtoms # bond\n\n")
            f.writelines(f"{q + 1} 1 1 {x} {y} {z}\n" for q, (x, y, z) in enumerate(sites))
            f.write("\nBonds\n\n")
            f.writelines(f"{b + 1} {t} {i + 1} {j + 1}\n" for b, (i, j, t) in enumerate(bonds))
    return data


def lammps_header(n, work):
    """The LAMMPS input common to every run: data, harmonic bonds (K = k/2: LAMMPS's energy is
    K (r - r0)^2), the anchored face and the free quanta."""
    return f"""units si
atom_style bond
boundary s s s
read_data {lammps_data(n, work)}
pair_style none
bond_style harmonic
bond_coeff 1 {K / 2} {A}
bond_coeff 2 {K / 2} {A * math.sqrt(2)}
comm_modify cutoff {3 * A}
region face block INF {0.5 * A} INF INF INF INF
group face region face
group free subtract all face
"""
