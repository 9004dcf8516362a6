#!/usr/bin/env python3
"""The real Gmsh judges a curved mesh against the CAD model it was made
from: it opens MODEL (STEP, BREP, ...), merges MESH (MSH 4.1, whose
entities carry the model's tags) and prints JSON:

  dim              the mesh's dimension
  elements         its elements of that dimension
  invalid          those with Gmsh's minDetJac <= 0
  min_det_jac      the least minDetJac, min_sj the least minSJ
  node_distance    {entity dimension: the largest distance of a node Gmsh
                   classifies on an entity of that dimension (below the
                   mesh's) to the entity: gmshModelGetClosestPoint on
                   curves and surfaces, the point itself on points}
  worst            {entity dimension: {"node", "entity", "distance"}}
  entities         [{"dim", "tag", "type", "nodes"}] of those entities
  sample_distance  {entity dimension: the largest distance to its entity
                   of the boundary elements (of dimension dim - 1) sampled
                   at 17 points per edge (a line: 17 points; a quadrangle
                   17 x 17; a triangle the lattice of 17 per edge), the
                   points deformesh samples for its own figure}

judge() does the same for the mesh already in Gmsh's current model (used
by cad_models.py for Gmsh's own curving); write_quietly(path) is
gmsh.write without OpenCASCADE's STEP banner on standard output.

judge_by_geometry(MODEL, MESH) (--by-geometry) judges a mesh whose
entities need not carry the model's tags (a mesh made in the session
that built the model, or by another mesher): the mesh and the model are
read into two models, each boundary element is found on the model's
entity of its dimension nearest to its centre (of those whose trimmed
face holds the centre's foot), and each boundary node is measured
against the entity nearest to it: the face of its elements, the curve
where elements on two faces meet (3D), the point where two curves meet
(2D). Prints the same keys; "entities" lists {"dim", "tag", "nodes"}
per model entity found nearest to some node.

Usage: check_cad.py [--by-geometry] MODEL MESH"""
import json
import os
import sys

import gmsh

M = 16


def write_quietly(path):
    """gmsh.write(path), OpenCASCADE's STEP writer's talk on standard
    output (which the tests read) sent to /dev/null."""
    sys.stdout.flush()
    saved = os.dup(1)
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    try:
        gmsh.write(path)
    finally:
        os.dup2(saved, 1)
        os.close(null)
        os.close(saved)


def _elements(dim):
    import numpy as np

    types, per_type, _ = gmsh.model.mesh.getElements(dim)
    if len(types) == 0:
        return np.array([], dtype=np.int64)
    return np.concatenate(per_type)


def _nodes():
    import numpy as np

    nt, xyz, _ = gmsh.model.mesh.getNodes()
    x = np.zeros((int(nt.max()) + 1, 3))
    x[nt] = np.reshape(xyz, (-1, 3))
    return x


def _samples(etype):
    """The sample points of a boundary element type, as Gmsh's
    reference coordinates (lines and quads on [-1, 1], triangles on the
    unit right triangle)."""
    name = gmsh.model.mesh.getElementProperties(etype)[0]
    if name.startswith("Line"):
        return [c for k in range(M + 1) for c in (-1 + 2 * k / M, 0, 0)]
    if name.startswith("Quadrilateral"):
        return [c for j in range(M + 1) for i in range(M + 1) for c in (-1 + 2 * i / M, -1 + 2 * j / M, 0)]
    return [c for j in range(M + 1) for i in range(M + 1 - j) for c in (i / M, j / M, 0)]


def _distance(dim, tag, pts):
    """Distances of points (n x 3) to entity (dim, tag)."""
    import numpy as np

    if len(pts) == 0:
        return np.zeros(0)
    if dim == 0:
        return np.linalg.norm(pts - np.array(gmsh.model.getValue(0, tag, [])), axis=1)
    foot = np.reshape(gmsh.model.getClosestPoint(dim, tag, np.ravel(pts))[0], (-1, 3))
    return np.linalg.norm(pts - foot, axis=1)


def judge():
    import numpy as np

    dim = max(d for d, _ in gmsh.model.getEntities() if len(_elements(d)) > 0)
    tags = _elements(dim)
    dj = np.array(gmsh.model.mesh.getElementQualities(tags, "minDetJac"))
    sj = np.array(gmsh.model.mesh.getElementQualities(tags, "minSJ"))
    x = _nodes()
    node_distance, worst, entities, sample = {}, {}, [], {}
    for d in range(dim):
        node_distance[str(d)] = 0.0
        for _, t in gmsh.model.getEntities(d):
            nt, xyz, _ = gmsh.model.mesh.getNodes(d, t)
            dist = _distance(d, t, np.reshape(xyz, (-1, 3)))
            entities.append({"dim": d, "tag": t, "type": gmsh.model.getType(d, t), "nodes": len(nt)})
            if len(dist) and dist.max() >= node_distance[str(d)]:
                k = int(dist.argmax())
                node_distance[str(d)] = float(dist[k])
                worst[str(d)] = {"node": int(nt[k]), "entity": t, "distance": float(dist[k])}
    d = dim - 1
    sample[str(d)] = 0.0
    for _, t in gmsh.model.getEntities(d):
        types, _, enodes = gmsh.model.mesh.getElements(d, t)
        for et, en in zip(types, enodes):
            uvw = _samples(et)
            bf = np.reshape(gmsh.model.mesh.getBasisFunctions(et, uvw, "Lagrange")[1], (len(uvw) // 3, -1))
            nodes = np.reshape(en, (-1, bf.shape[1]))
            pts = np.einsum("qn,enc->eqc", bf, x[nodes]).reshape(-1, 3)
            dist = _distance(d, t, pts)
            if len(dist):
                sample[str(d)] = max(sample[str(d)], float(dist.max()))
    return {"dim": dim, "elements": int(len(tags)), "invalid": int((dj <= 0).sum()), "min_det_jac": float(dj.min()),
            "min_sj": float(sj.min()), "node_distance": node_distance, "worst": worst, "entities": entities,
            "sample_distance": sample}


def _nearest(dim, tags, pts, inside=False):
    """Per point (n x 3), the nearest of entities (dim, tags) and the
    distance; with `inside`, only entities whose trimming holds the foot
    count, where any does."""
    import numpy as np

    d = np.full((len(tags), len(pts)), np.inf)
    held = np.zeros((len(tags), len(pts)), dtype=bool)
    for i, t in enumerate(tags):
        if dim == 0:
            foot = np.tile(gmsh.model.getValue(0, t, []), (len(pts), 1))
        else:
            foot = np.reshape(gmsh.model.getClosestPoint(dim, t, np.ravel(pts))[0], (-1, 3))
        d[i] = np.linalg.norm(pts - foot, axis=1)
        if inside:
            # the candidates near enough to matter
            for k in np.nonzero(d[i] <= 1e-6)[0]:
                held[i, k] = gmsh.model.isInside(dim, t, list(foot[k])) > 0
    if inside:
        d = np.where(held | ~held.any(axis=0), d, np.inf)
    k = d.argmin(axis=0)
    return [tags[j] for j in k], d[k, np.arange(len(pts))]


def judge_by_geometry(model_file, mesh_file):
    import numpy as np

    gmsh.open(mesh_file)
    mesh_model = gmsh.model.getCurrent()
    dim = max(d for d, _ in gmsh.model.getEntities() if len(_elements(d)) > 0)
    tags = _elements(dim)
    dj = np.array(gmsh.model.mesh.getElementQualities(tags, "minDetJac"))
    sj = np.array(gmsh.model.mesh.getElementQualities(tags, "minSJ"))
    x = _nodes()
    # the boundary elements: their nodes, centres and sample points
    facets, samples = [], []
    types, _, enodes = gmsh.model.mesh.getElements(dim - 1)
    for et, en in zip(types, enodes):
        uvw = _samples(et)
        bf = np.reshape(gmsh.model.mesh.getBasisFunctions(et, uvw, "Lagrange")[1], (len(uvw) // 3, -1))
        nodes = np.reshape(en, (-1, bf.shape[1]))
        centre = np.reshape(gmsh.model.mesh.getBasisFunctions(et, [0, 0, 0] if et in (1, 8, 26, 27, 28, 3, 10, 16, 36, 37) else [1 / 3, 1 / 3, 0], "Lagrange")[1], (1, -1))
        for e in nodes:
            facets.append((e, (centre @ x[e])[0]))
        samples.append(np.einsum("qn,enc->eqc", bf, x[nodes]))
    samples = np.concatenate(samples) if samples else np.zeros((0, 1, 3))
    gmsh.model.add("cad")
    gmsh.merge(model_file)
    faces = [t for _, t in gmsh.model.getEntities(dim - 1)]
    face, _ = _nearest(dim - 1, faces, np.array([c for _, c in facets]), inside=True)
    on = {}
    for (e, _), f in zip(facets, face):
        for n in e:
            on.setdefault(int(n), set()).add(f)
    node_distance, worst, entities = {}, {}, {}
    groups = {}
    for n, fs in on.items():
        key = (dim - 1, tuple(sorted(fs))[0]) if len(fs) == 1 else (dim - 2, None)
        groups.setdefault(key, []).append(n)
    for (d, f), ns in sorted(groups.items(), key=lambda g: (g[0][0], g[0][1] or 0)):
        pts = x[ns]
        if f is not None:
            near, dist = [f] * len(ns), _distance(d, f, pts)
        else:
            near, dist = _nearest(d, [t for _, t in gmsh.model.getEntities(d)], pts)
        for t in near:
            entities[(d, t)] = entities.get((d, t), 0) + 1
        k = int(np.argmax(dist))
        if dist[k] >= node_distance.get(str(d), 0.0):
            node_distance[str(d)] = float(dist[k])
            worst[str(d)] = {"node": int(ns[k]), "entity": int(near[k]), "distance": float(dist[k])}
    sample = 0.0
    for f in set(face):
        idx = [i for i, g in enumerate(face) if g == f]
        if idx:
            sample = max(sample, float(_distance(dim - 1, f, samples[idx].reshape(-1, 3)).max()))
    gmsh.model.setCurrent(mesh_model)
    return {"dim": dim, "elements": int(len(tags)), "invalid": int((dj <= 0).sum()), "min_det_jac": float(dj.min()),
            "min_sj": float(sj.min()), "node_distance": node_distance, "worst": worst,
            "entities": [{"dim": d, "tag": int(t), "nodes": c} for (d, t), c in sorted(entities.items())],
            "sample_distance": {str(dim - 1): sample}}


if __name__ == "__main__":
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    args = [a for a in sys.argv[1:] if a != "--by-geometry"]
    if "--by-geometry" in sys.argv:
        print(json.dumps(judge_by_geometry(args[0], args[1])))
    else:
        gmsh.open(args[0])
        gmsh.merge(args[1])
        print(json.dumps(judge()))
    gmsh.finalize()
