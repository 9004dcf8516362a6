"""`deformesh.gmsh.curve`: the live Gmsh model's mesh curved in place."""

from __future__ import annotations

import _thread
import threading

import gmsh
import numpy as np
import pytest

import deformesh
from conftest import check_curved, element_tags, fillet_part, groups, prism_layer, quad_layer, snapshot
from models import periodic_channel


def curve_and_check(order, tmp_path, **options):
    before = groups()
    linear = element_tags()
    report = deformesh.gmsh.curve(order=order, progress=False, **options)
    # every element of every entity is there, of the same tag
    assert element_tags() == linear
    assert sum(len(v) for (d, _), v in linear.items() if d == gmsh.model.getDimension()) == report["cells"]
    return report, check_curved(order, report, before, tmp_path)


def test_a_filleted_part_with_a_hole_is_curved_in_place_at_order_3(session, tmp_path):
    fillet_part()
    report, figures = curve_and_check(3, tmp_path)
    assert report["written_back"]["elements"] > 1000
    # the fillet's and the hole's nodes are off the straight faces: curved
    assert report["quality"]["boundary_node_distance"] < 1e-12


def test_a_quad_boundary_layer_is_curved_in_place(session, tmp_path):
    quad_layer()
    types = gmsh.model.mesh.getElementTypes(2)
    assert 3 in types, "the layer has quads"
    curve_and_check(3, tmp_path)
    assert 36 in gmsh.model.mesh.getElementTypes(2), "QUA_16"


def test_a_prism_layer_is_curved_in_place(session, tmp_path):
    prism_layer()
    assert gmsh.model.mesh.getElementTypes(3) == [6]
    # p = 2: Gmsh 4.15's minDetJac of a prism of order 3 raises
    # "FaceClosureFull not implemented for prisms of order 3" (measured)
    curve_and_check(2, tmp_path)
    assert list(gmsh.model.mesh.getElementTypes(3)) == [13], "PRI_18"


def test_a_periodic_channel_keeps_its_periodic_nodes_at_order_3(session, tmp_path):
    periodic_channel()
    right = [c for _, c in gmsh.model.getEntities(1) if abs(gmsh.model.occ.getCenterOfMass(1, c)[0] - 3) < 1e-9]
    curve_and_check(3, tmp_path)
    for c in right:
        master, slaves, masters, _ = gmsh.model.mesh.getPeriodicNodes(1, c, includeHighOrderNodes=True)
        # the inlet's edges have 2 new nodes each: the links hold them too
        assert len(slaves) == 3 * (len(gmsh.model.mesh.getElements(1, c)[1][0])) + 1
        xs = np.asarray([gmsh.model.mesh.getNode(n)[0] for n in slaves])
        xm = np.asarray([gmsh.model.mesh.getNode(n)[0] for n in masters])
        # every slave node is the image of a master node (Gmsh pairs the
        # new nodes of an edge in reverse where the two edges run opposite
        # ways, after its own setOrder too: measured, its links are its own)
        image = np.sort((xs - [3, 0, 0])[:, 1])
        assert np.abs(image - np.sort(xm[:, 1])).max() < 1e-12 and np.abs(xs[:, 0] - 3).max() < 1e-12


def test_ctrl_c_leaves_the_model_as_it_was(session):
    fillet_part(0.12)
    nodes, xyz, elements = snapshot()
    timer = threading.Timer(0.2, _thread.interrupt_main)
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        deformesh.gmsh.curve(order=3, progress=False)
    timer.cancel()
    n2, x2, e2 = snapshot()
    assert np.array_equal(nodes, n2) and np.array_equal(xyz, x2)
    for (t1, k1, v1), (t2, k2, v2) in zip(elements, e2):
        assert t1 == t2 and all(np.array_equal(a, b) for a, b in zip(k1, k2)) and all(np.array_equal(a, b) for a, b in zip(v1, v2))
    # and the next run, uninterrupted, curves it
    report = deformesh.gmsh.curve(order=2, progress=False)
    assert report["quality"]["invalid_elements"] == []


def test_a_mesh_of_order_2_is_refused_and_left_as_it_was(session):
    fillet_part(0.4)
    gmsh.model.mesh.setOrder(2)
    nodes, xyz, _ = snapshot()
    with pytest.raises(deformesh.InputError, match="linear mesh"):
        deformesh.gmsh.curve(order=3, progress=False)
    n2, x2, _ = snapshot()
    assert np.array_equal(nodes, n2) and np.array_equal(xyz, x2)


def test_a_wrong_option_is_a_usage_error_naming_it(session):
    fillet_part(0.4)
    with pytest.raises(deformesh.UsageError, match="--order"):
        deformesh.gmsh.curve(order=7, progress=False)
    with pytest.raises(TypeError, match="unknown option"):
        deformesh.gmsh.curve(order=2, smoothness=3)
