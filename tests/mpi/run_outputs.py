"""Reading a qbond run's outputs, for the tests under mpiexec: raw files, frames, diagnostics rows
and ParaView frames, and the bond breaks of a run over ranks against the run alone's."""
import argparse
import csv
import os
import re
import sys

from vtkmodules.vtkIOXML import vtkXMLPolyDataReader


def ranks_arguments():
    """The arguments every test over ranks takes: QBOND SCENE WORKDIR --ranks N --mpiexec MPIEXEC
    [--mpiexec-flag F ...]; the caller adds its own and parses."""
    p = argparse.ArgumentParser()
    p.add_argument("qbond")
    p.add_argument("scene")
    p.add_argument("work")
    p.add_argument("--ranks", type=int, required=True)
    p.add_argument("--mpiexec", required=True)
    p.add_argument("--mpiexec-flag", action="append", default=[])
    return p


def read(path):
    with open(path, "rb") as f:
        return f.read()


def frames(out):
    return sorted(os.listdir(os.path.join(out, "frames")))


def rows(out):
    with open(os.path.join(out, "diagnostics.csv")) as f:
        return list(csv.reader(f))


def same_bytes(first, second, what):
    """Exits unless two runs' outputs (diagnostics.csv and every frame) are the same bytes."""
    if frames(first) != frames(second):
        sys.exit(f"{what} wrote different frames")
    for name in ["diagnostics.csv"] + [os.path.join("frames", f) for f in frames(first)]:
        if read(os.path.join(first, name)) != read(os.path.join(second, name)):
            sys.exit(f"{name}: {what} wrote different bytes")


def poly(path):
    r = vtkXMLPolyDataReader()
    r.SetFileName(path)
    r.Update()
    return r.GetOutput()


def events(out):
    with open(os.path.join(out, "events.csv")) as f:
        return list(csv.reader(f))


# The columns of events.csv that are measured, not counted: compared within a bound.
MEASURED = ("time", "strain", "tension")


def same_events(alone, many, ranks, bound, kind):
    """events.csv of the run over ranks in `many` against the run alone's in `alone`: the same
    rows in the same order, every column but time, strain and tension exactly, those within
    bound(column, scale) (scale: the column's largest magnitude alone), and rows of `kind`
    (broken, formed) among them. Returns the rows of `many`; exits with a message otherwise."""
    e1, en = events(alone), events(many)
    if not any(r[e1[0].index("event")] == kind for r in e1[1:]):
        sys.exit(f"no bond {kind} in the run alone")
    if len(e1) != len(en) or e1[0] != en[0]:
        sys.exit(f"events.csv: {len(e1) - 1} rows alone, {len(en) - 1} over {ranks} ranks")
    header = e1[0]
    scale = {h: max(abs(float(r[header.index(h)])) for r in e1[1:]) for h in MEASURED}
    for r1, rn in zip(e1[1:], en[1:]):
        for k, h in enumerate(header):
            if h not in MEASURED and r1[k] != rn[k]:
                sys.exit(f"events.csv: {h} {r1[k]} alone, {rn[k]} over {ranks} ranks ({r1})")
            if h in MEASURED and abs(float(r1[k]) - float(rn[k])) > bound(h, scale[h]):
                sys.exit(f"events.csv: {h} {r1[k]} alone, {rn[k]} over {ranks} ranks ({r1}; "
                         f"bound {bound(h, scale[h]):g})")
    return en


def same_breaks(alone, many, ranks, bound):
    """The breaks of the run over ranks in `many` against the run alone's in `alone`: the same
    events (same_events), and in every frame over ranks the bonds shown plus those broken before
    it are every bond of the scene and those formed before it, none lost, none twice. Returns the
    breaks' count; exits with a message otherwise."""
    en = same_events(alone, many, ranks, bound, "broken")
    diag = rows(alone)
    total = int(diag[1][diag[0].index("bonds_alive")]) + int(diag[1][diag[0].index("bonds_broken")])
    kind = en[0].index("event")
    broken_at = [int(r[0]) for r in en[1:] if r[kind] == "broken"]
    formed_at = [int(r[0]) for r in en[1:] if r[kind] == "formed"]
    for name in frames(many):
        step = int(re.search(r"(\d+)", name).group(1))
        shown = poly(os.path.join(many, "frames", name)).GetNumberOfLines()
        broken = sum(1 for s in broken_at if s < step)
        formed = sum(1 for s in formed_at if s < step)
        if shown + broken != total + formed:
            sys.exit(f"{name}: {shown} bonds shown, {broken} broken and {formed} formed before step {step}, "
                     f"of {total}")
    return len(broken_at)


def restored(tables, bound):
    """Exits unless every diagnostics row of each (label, rows) table keeps |numerical| within
    `bound` [J]: restore_energy closes the ledger each step."""
    for label, table in tables:
        at = table[0].index("numerical")
        for r in table[1:]:
            if abs(float(r[at])) > bound:
                sys.exit(f"diagnostics step {r[0]}: numerical {r[at]} {label}, restore_energy should keep it "
                         f"within {bound:g}")
