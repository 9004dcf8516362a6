"""Issue 46's overhead benchmark: `deformesh.gmsh.curve` on the live model
against the command line on the same mesh, both release builds.

The filleted block with a bored hole (an OCC cut and fillet:
python/tests/models.py) meshed in about 10^5 tets, written as
MSH and STEP; then, REPEAT times alternately:
- the command line as a whole process: `deformesh curve part.msh --cad
  part.step --order P` (reads, binds, curves, certifies, writes MSH, VTU,
  PNG and the report);
- `deformesh.gmsh.curve(order=P)` on the model in this session (reads the
  mesh through the C API, curves, writes it back with setOrder and
  setNode), the model put back to order 1 between runs (not timed);
- Gmsh's own `setOrder(P)` on it, for scale.
Prints one line per run and the medians.

Run with a Python that has the package installed (`pip install .`) and
gmsh:  python benches/python_overhead.py --cli target/release/deformesh
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import sys

import gmsh

import deformesh

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python" / "tests"))
from models import fillet_part  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--cli", required=True, help="the deformesh binary (a release build)")
    ap.add_argument("--size", type=float, default=0.045, help="Mesh.MeshSizeMax (0.045: about 10^5 tets)")
    ap.add_argument("--order", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    fillet_part(a.size, groups=False)
    tets = len(gmsh.model.mesh.getElementsByType(4)[0])
    work = Path(tempfile.mkdtemp(prefix="deformesh-overhead-"))
    gmsh.write(str(work / "part.msh"))
    gmsh.write(str(work / "part.step"))
    env = dict(os.environ, DEFORMESH_GMSH_LIB=gmsh.libpath)
    print(f"{tets} tets, order {a.order}, files in {work}")
    cli, live, setorder, inside = [], [], [], []
    for r in range(a.repeat):
        t = time.perf_counter()
        subprocess.run([a.cli, "curve", str(work / "part.msh"), "--cad", str(work / "part.step"), "--order", str(a.order), "-o", str(work / "cli.msh"), "--force"], check=True, env=env, capture_output=True)
        cli.append(time.perf_counter() - t)
        theirs = json.loads((work / "cli.report.json").read_text())
        inside.append(theirs["total_s"])
        t = time.perf_counter()
        report = deformesh.gmsh.curve(order=a.order, progress=False)
        live.append(time.perf_counter() - t)
        # the file holds Gmsh's %.16g coordinates, the live model the doubles
        assert abs(report["quality"]["min_det_j"] / theirs["quality"]["min_det_j"] - 1) < 1e-6, (report["quality"]["min_det_j"], theirs["quality"]["min_det_j"])
        gmsh.model.mesh.setOrder(1)
        t = time.perf_counter()
        gmsh.model.mesh.setOrder(a.order)
        setorder.append(time.perf_counter() - t)
        gmsh.model.mesh.setOrder(1)
        print(f"run {r + 1}: command line {cli[-1]:.2f} s (its report's total {inside[-1]:.2f} s)  deformesh.gmsh.curve {live[-1]:.2f} s  Gmsh setOrder {setorder[-1]:.2f} s", flush=True)
    m = statistics.median
    print(f"median: command line {m(cli):.2f} s (report total {m(inside):.2f} s)  deformesh.gmsh.curve {m(live):.2f} s ({100 * (m(live) / m(cli) - 1):+.1f} % of the command line)  Gmsh setOrder {m(setorder):.2f} s")
    gmsh.finalize()


if __name__ == "__main__":
    main()
