"""What the real Gmsh finds in a mesh file: its physical groups, its
entities with their groups, boundaries and element types, the node tags on
each entity, its periodic links with how far each pair is from the affine
image of its master (every node of the slave's elements, high-order ones
included, must have a pair), and minDetJac of every element of the top
dimension. Prints JSON.

Usage: python check_kept.py MESH.msh"""
import json
import sys

import gmsh
import numpy as np

gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.open(sys.argv[1])
m = gmsh.model
out = {"groups": sorted([d, t, m.getPhysicalName(d, t)] for d, t in m.getPhysicalGroups())}
entities = []
for d, t in m.getEntities():
    types, tags, _ = m.mesh.getElements(d, t)
    entities.append({
        "dim": d, "tag": t,
        "physicals": sorted(int(p) for p in m.getPhysicalGroupsForEntity(d, t)),
        "boundary": sorted(int(b) for _, b in m.getBoundary([(d, t)], oriented=False)) if d > 0 else [],
        "types": sorted(int(x) for x in types),
        "elements": sorted(int(e) for ts in tags for e in ts),
        "nodes": sorted(int(n) for n in m.mesh.getNodes(d, t)[0]),
    })
out["entities"] = sorted(entities, key=lambda e: (e["dim"], e["tag"]))
tags_all, coords, _ = m.mesh.getNodes()
xyz = dict(zip((int(t) for t in tags_all), np.reshape(coords, (-1, 3))))
links = []
for d, t in m.getEntities():
    master, slave_nodes, master_nodes, affine = m.mesh.getPeriodicNodes(d, t, includeHighOrderNodes=True)
    if master == t and len(slave_nodes) == 0:
        continue
    a = np.reshape(affine, (4, 4)) if len(affine) == 16 else None
    worst = 0.0
    for s, mn in zip(slave_nodes, master_nodes):
        x = np.append(xyz[int(mn)], 1.0)
        worst = max(worst, float(np.linalg.norm((a @ x)[:3] - xyz[int(s)])))
    # every node of the slave's elements (its closure) must be paired
    _, _, enodes = m.mesh.getElements(d, t)
    closure = {int(n) for ns in enodes for n in ns}
    unpaired = sorted(closure - {int(s) for s in slave_nodes})
    links.append({"dim": d, "slave": t, "master": int(master), "pairs": len(slave_nodes), "worst": worst, "unpaired": unpaired[:10], "unpaired_count": len(unpaired)})
out["periodic"] = links
top = max(d for d, _ in m.getEntities())
_, tags, _ = m.mesh.getElements(top)
tags = [int(x) for ts in tags for x in ts]
dj = m.mesh.getElementQualities(tags, "minDetJac") if tags else []
out["elements"] = len(tags)
out["invalid"] = int(sum(1 for v in dj if v <= 0))
out["min_det_jac"] = float(min(dj)) if len(dj) else None
print(json.dumps(out))
gmsh.finalize()
