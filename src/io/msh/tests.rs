//! Tests of the MSH reader and writer, ASCII and binary, all orders.

use super::*;
use crate::io::layout::tests::mixed2;
use crate::io::vtu::VtuError;
use crate::mesh::curved::tests::{bend2, bend3};
use crate::mesh::element::{Shape, Spacing};
use crate::mesh::{BoundaryEdge, BoundaryFace};

/// A 5×4 box with interior and boundary nodes moved by a smooth
/// non-affine map, and coordinates that stress round-trip printing.
fn perturbed_box() -> QuadMesh {
    let mut m = QuadMesh::structured_box([0.0, 0.0], [2.0, 1.0], 5, 4);
    for p in &mut m.nodes {
        let [x, y] = *p;
        *p = [
            x + 0.05 * (3.0 * y).sin() * x / 3.0,
            y + 0.04 * (2.0 * x).cos() * y + 1e-17 * x,
        ];
    }
    m.nodes[0] = [-0.0, 5e-324];
    m
}

fn written(mesh: &QuadMesh) -> String {
    msh_string(mesh)
}

/// The error message for `text`, which must fail to parse.
fn error_of(text: &str) -> String {
    parse_msh(text)
        .expect_err("bad input must be rejected")
        .to_string()
}

#[test]
fn round_trip_is_identical() {
    let m = perturbed_box();
    let back = parse_msh(written(&m)).unwrap();
    assert_eq!(back, m);
    for (a, b) in back.nodes.iter().zip(&m.nodes) {
        assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits));
    }
}

#[test]
fn file_round_trip_and_layout() {
    let m = perturbed_box();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("box.msh");
    write_msh(&path, &m).unwrap();
    assert_eq!(read_msh(&path).unwrap(), m);
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.starts_with(
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n5\n1 1 \"left\"\n"
    ));
    assert!(text.contains("2 5 \"domain\"\n$EndPhysicalNames\n$Entities\n0 4 1 0\n"));
    // 18 edges and 20 quads: 5 blocks, tags 1..38
    assert!(text.contains("$Elements\n5 38 1 38\n1 1 1 4\n"));
}

#[test]
fn write_rejects_invalid_meshes() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.msh");
    let mut m = perturbed_box();
    m.nodes[3][1] = f64::NAN;
    assert!(write_msh(&path, &m)
        .unwrap_err()
        .to_string()
        .contains("node 3"));
    let mut m = perturbed_box();
    m.edges[0].part = 9;
    assert!(matches!(
        write_msh(&path, &m),
        Err(MshError::InvalidMesh(_))
    ));
    let mut m = perturbed_box();
    m.part_names[1] = "left".into();
    assert!(write_msh(&path, &m)
        .unwrap_err()
        .to_string()
        .contains("twice"));
    assert!(!path.exists());
}

#[test]
fn reads_parametric_blocks_gaps_points_and_unnamed_curves() {
    let text = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n\
        $PhysicalNames\n1\n1 7 \"wall side\"\n$EndPhysicalNames\n\
        $Entities\n1 2 1 0\n1 0 0 0 0\n\
        3 0 0 0 1 0 0 1 7 2 1 -1\n4 0 0 0 0 1 0 0 0\n\
        1 0 0 0 1 1 0 0 2 3 4\n$EndEntities\n\
        $Nodes\n3 4 2 40\n0 1 0 1\n2\n0 0 0\n\
        1 3 1 1\n10\n1 0 0 0.5\n\
        2 1 1 2\n20\n40\n1 1 0 0.1 0.2\n0 1 0 0.3 0.4\n$EndNodes\n\
        $Elements\n4 5 1 9\n0 1 15 1\n9 2\n1 3 1 1\n5 2 10\n\
        1 4 1 1\n4 40 2\n2 1 3 2\n2 2 10 20 40\n1 40 20 10 2\n$EndElements\n";
    let m = parse_msh(text).unwrap();
    assert_eq!(
        m.nodes,
        vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
    );
    // ordered by element tag, orientation as in the file
    assert_eq!(m.cells, vec![[3, 2, 1, 0], [0, 1, 2, 3]]);
    assert_eq!(
        m.part_names,
        vec!["wall side".to_string(), "curve4".to_string()]
    );
    assert_eq!(
        m.edges,
        vec![
            BoundaryEdge {
                nodes: [3, 0],
                part: 1
            },
            BoundaryEdge {
                nodes: [0, 1],
                part: 0
            }
        ]
    );
}

#[test]
fn reads_the_real_gmsh_file() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/cylinder_bl_coarse.msh");
    let text = std::fs::read_to_string(&path).unwrap();
    let header = |section: &str| -> Vec<usize> {
        let at = text.find(section).unwrap() + section.len();
        text[at..]
            .lines()
            .nth(1)
            .unwrap()
            .split_whitespace()
            .map(|t| t.parse().unwrap())
            .collect()
    };
    let m = read_msh(&path).unwrap();
    assert_eq!(m.num_nodes(), header("$Nodes")[1]);
    assert_eq!(m.num_cells() + m.edges.len(), header("$Elements")[1]);
    assert_eq!(
        m.part_names,
        vec!["wall".to_string(), "farfield".to_string()]
    );
    let count = |p: usize| m.edges.iter().filter(|e| e.part == p).count();
    assert_eq!((count(0), count(1)), (12, 56));
    assert!(
        (0..m.num_cells()).all(|c| m.cell_area(c) > 0.0),
        "Gmsh quads are counter-clockwise"
    );
    // the square [-2,2]² minus the 12-gon inscribed in the r = 0.5 circle
    let expected = 16.0 - 0.5 * 12.0 * 0.25 * (std::f64::consts::PI / 6.0).sin();
    assert!((m.area() - expected).abs() < 1e-12, "area {}", m.area());
}

/// A valid 1×1 box file with the first occurrence of `from` replaced
/// by `to`, and the 1-based line where `to` starts.
fn corrupted(from: &str, to: &str) -> (String, usize) {
    let text = written(&QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 1, 1));
    let at = text
        .find(from)
        .unwrap_or_else(|| panic!("{from:?} not in {text}"));
    let line = text[..at].matches('\n').count() + 1 + usize::from(from.starts_with('\n'));
    (text.replacen(from, to, 1), line)
}

/// Asserts that the corrupted file fails with a message naming the line
/// and containing every one of `words`.
fn assert_rejected(from: &str, to: &str, words: &[&str]) {
    let (text, line) = corrupted(from, to);
    let msg = error_of(&text);
    assert!(
        msg.starts_with(&format!("line {line}:")),
        "expected line {line}: {msg}"
    );
    for w in words {
        assert!(msg.contains(w), "{w:?} missing from: {msg}");
    }
}

#[test]
fn rejects_old_formats_and_bad_binary_data() {
    assert_rejected("4.1 0 8", "3.0 0 8", &["version 3.0", "-format msh41"]);
    assert_rejected("4.1 0 8", "4 0 8", &["version 4 "]);
    assert_rejected("4.1 0 8", "4.1 1 4", &["data size 8"]);
    assert_rejected("4.1 0 8", "4.1 2 8", &["file type 0 (ASCII) or 1 (binary)"]);
    // a text file claiming to be binary: its text read as binary numbers
    // fails cleanly, at a byte offset
    let (text, _) = corrupted("4.1 0 8", "4.1 1 8\n\u{1}\0\0\0");
    let msg = error_of(&text);
    assert!(msg.starts_with("byte "), "{msg}");
    assert_eq!(error_of(""), "line 1: file truncated: expected $MeshFormat");
}

#[test]
fn rejects_truncated_files() {
    let text = written(&QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 2, 2));
    let cut = &text[..text.find("$EndNodes").unwrap() - 20];
    let msg = error_of(cut);
    let last_line = cut.lines().count();
    assert!(
        msg.starts_with(&format!("line {last_line}: file truncated"))
            && msg.contains("coordinate"),
        "{msg}"
    );
    // Every prefix fails cleanly, never panics.
    for end in 0..text.len() - 1 {
        assert!(
            parse_msh(&text[..end]).is_err(),
            "prefix of length {end} accepted"
        );
    }
}

#[test]
fn rejects_wrong_counts() {
    // the header claims 5 nodes, the one block holds 4
    assert_rejected(
        "\n1 4 1 4\n",
        "\n1 5 1 4\n",
        &["number of nodes", "says 5", "hold 4"],
    );
    assert_rejected(
        "\n5 5 1 5\n",
        "\n5 6 1 5\n",
        &["number of elements", "says 6", "hold 5"],
    );
    // a block claiming one element too many runs into the section end
    let (text, _) = corrupted("\n2 1 3 1\n", "\n2 1 3 2\n");
    let end_line = text.lines().position(|l| l == "$EndElements").unwrap() + 1;
    let msg = error_of(&text);
    assert!(
        msg.starts_with(&format!(
            "line {end_line}: expected an element tag, found `$EndElements`"
        )),
        "{msg}"
    );
    // a block claiming one node too few no longer adds up to the header
    let (text, block_line) = corrupted("\n2 1 0 4\n", "\n2 1 0 3\n");
    let msg = error_of(&text);
    assert!(
        msg.starts_with(&format!("line {}: number of nodes", block_line - 1)),
        "{msg}"
    );
}

#[test]
fn rejects_unknown_element_types() {
    // a 13-node (serendipity) pyramid block (type 19: no row of the table)
    assert_rejected("\n2 1 3 1\n", "\n2 1 19 1\n", &["element type 19", "13-node (serendipity) pyramid", "linear mesh (type 7)"]);
}

#[test]
fn rejects_non_finite_coordinates() {
    for bad in ["NaN", "inf", "-inf", "infinity"] {
        assert_rejected(
            "\n1 0 0\n",
            &format!("\n1 {bad} 0\n"),
            &["non-finite", "node 2", bad],
        );
    }
}

#[test]
fn rejects_a_2d_node_off_the_plane() {
    // node 2 at (1, 0) given z = 0.25: not dropped silently
    assert_rejected("\n1 0 0\n", "\n1 0 0.25\n", &["node 2", "z = 0.25", "z = 0"]);
    let (text, _) = corrupted("\n1 0 0\n", "\n1 0 0.25\n");
    let e = CurvedMesh::<2>::parse_msh(&text).err().expect("off the plane").to_string();
    assert!(e.contains("node 2 has z = 0.25"), "{e}");
}

/// The cylinder's wall curve also in a second group `ring` (listed
/// first on the entity): its lines belong to both groups.
#[test]
fn an_entity_in_two_groups_belongs_to_both() {
    let text = include_str!("../../../tests/data/cylinder_bl_coarse.msh")
        .replacen("3\n1 1 \"wall\"", "4\n1 4 \"ring\"\n1 1 \"wall\"", 1)
        .replacen("1e-07 1 1 2 5 -5", "1e-07 2 4 1 2 5 -5", 1);
    let m = parse_msh(&text).unwrap();
    assert_eq!(m.part_names, ["wall", "farfield", "ring"]);
    let count = |part: usize| m.edges.iter().filter(|e| e.part == part).count();
    assert_eq!((count(0), count(2)), (12, 12));
    let wall: Vec<[usize; 2]> = m.edges.iter().filter(|e| e.part == 0).map(|e| e.nodes).collect();
    let ring: Vec<[usize; 2]> = m.edges.iter().filter(|e| e.part == 2).map(|e| e.nodes).collect();
    assert_eq!(wall, ring);
}

#[test]
fn rejects_unknown_node_tags_and_garbage() {
    assert_rejected(
        "\n5 1 2 4 3\n",
        "\n5 1 2 44 3\n",
        &["element 5", "unknown node tag 44"],
    );
    assert_rejected("\n2 1 0 4\n", "\n2 1 x 4\n", &["parametric flag", "`x`"]);
    assert_rejected("\"left\"", "left", &["quoted", "`left`"]);
    assert_rejected("\"left\"", "\"left", &["closing quote"]);
    assert_rejected("$EndNodes", "$EndNode", &["expected $EndNodes"]);
    assert_rejected("$Elements", "Elements", &["section header"]);
}

// ------------------------------------------------------------ hex meshes

/// A 3×2×2 brick moved by a smooth non-affine map, with coordinates
/// that stress round-trip printing.
fn perturbed_brick() -> HexMesh {
    let mut m = HexMesh::structured_box([0.0; 3], [1.5, 1.0, 1.0], [3, 2, 2]);
    for p in &mut m.nodes {
        let [x, y, z] = *p;
        *p = [
            x + 0.04 * (2.0 * y).sin() * z,
            y + 0.03 * (3.0 * z).cos() * x + 1e-17 * x,
            z + 0.05 * x * y,
        ];
    }
    m.nodes[0] = [-0.0, 5e-324, 1e300];
    m
}

#[test]
fn hex_round_trip_is_identical() {
    let m = perturbed_brick();
    let back = parse_hex_msh(hex_msh_string(&m)).unwrap();
    assert_eq!(back, m);
    for (a, b) in back.nodes.iter().zip(&m.nodes) {
        assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits));
    }
}

#[test]
fn hex_file_round_trip_and_layout() {
    let m = perturbed_brick();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("brick.msh");
    write_hex_msh(&path, &m).unwrap();
    assert_eq!(read_hex_msh(&path).unwrap(), m);
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.starts_with(
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n7\n2 1 \"xmin\"\n"
    ));
    assert!(text.contains("3 7 \"domain\"\n$EndPhysicalNames\n$Entities\n0 0 6 1\n"));
    // the volume is bounded by the six surfaces
    assert!(text.contains(" 1 7 6 1 2 3 4 5 6\n$EndEntities\n"));
    assert!(text.contains("$Nodes\n1 36 1 36\n3 1 0 36\n1\n"));
    // 2·(2·2 + 3·2 + 3·2) = 32 faces in 6 blocks, 12 hexes: tags 1..44
    assert!(text.contains("$Elements\n7 44 1 44\n2 1 3 4\n1 "));
    assert!(text.contains("\n3 1 5 12\n33 1 2 6 5 13 14 18 17\n"));
    // the 2D reader refuses the hexes, naming what it accepts
    let msg = parse_msh(&text).unwrap_err().to_string();
    assert!(
        msg.contains("element type 5 (only linear meshes: 1 = 2-node line"),
        "{msg}"
    );
}

#[test]
fn hex_write_rejects_invalid_meshes() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.msh");
    let mut m = perturbed_brick();
    m.nodes[5][2] = f64::INFINITY;
    let msg = write_hex_msh(&path, &m).unwrap_err().to_string();
    assert!(msg.contains("node 5") && msg.contains("inf"), "{msg}");
    let mut m = perturbed_brick();
    m.faces[3].part = 6;
    let msg = write_hex_msh(&path, &m).unwrap_err().to_string();
    assert!(msg.contains("boundary face 3"), "{msg}");
    let mut m = perturbed_brick();
    m.cells[2][7] = 36;
    let msg = write_hex_msh(&path, &m).unwrap_err().to_string();
    assert!(msg.contains("cell 2 refers to a node >= 36"), "{msg}");
    let mut m = perturbed_brick();
    m.part_names[4] = "xmax".into();
    assert!(write_hex_msh(&path, &m)
        .unwrap_err()
        .to_string()
        .contains("twice"));
    m.part_names[4] = "a\"b".into();
    assert!(matches!(
        write_hex_msh(&path, &m),
        Err(MshError::InvalidMesh(_))
    ));
    assert!(!path.exists());
}

#[test]
fn hex_reader_names_unnamed_surfaces_and_skips_lines() {
    // one hex; a named surface (physical 4 "wall") with one face, an
    // unnamed surface 9 with one face, a line block and a point block
    let text = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n\
        $PhysicalNames\n2\n2 4 \"wall\"\n3 1 \"solid\"\n$EndPhysicalNames\n\
        $Entities\n0 1 2 1\n5 0 0 0 1 0 0 0 0\n\
        3 0 0 0 1 1 0 1 4 0\n9 0 0 1 1 1 1 0 0\n\
        1 0 0 0 1 1 1 1 1 2 3 9\n$EndEntities\n\
        $Nodes\n1 8 11 18\n3 1 0 8\n11\n12\n13\n14\n15\n16\n17\n18\n\
        0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n$EndNodes\n\
        $Elements\n5 5 1 20\n0 1 15 1\n20 11\n1 5 1 1\n19 11 12\n\
        3 1 5 1\n3 11 12 13 14 15 16 17 18\n\
        2 9 3 1\n2 15 16 17 18\n2 3 3 1\n7 11 14 13 12\n$EndElements\n";
    let m = parse_hex_msh(text).unwrap();
    assert_eq!(m.cells, vec![[0, 1, 2, 3, 4, 5, 6, 7]]);
    assert_eq!(m.nodes[6], [1.0, 1.0, 1.0]);
    assert_eq!(
        m.part_names,
        vec!["wall".to_string(), "surface9".to_string()]
    );
    // ordered by element tag: 2 (surface 9) before 7 (surface 3)
    assert_eq!(
        m.faces,
        vec![
            BoundaryFace {
                nodes: [4, 5, 6, 7],
                part: 1
            },
            BoundaryFace {
                nodes: [0, 3, 2, 1],
                part: 0
            }
        ]
    );
}

#[test]
fn hex_reader_errors() {
    let text = hex_msh_string(&HexMesh::structured_box([0.0; 3], [1.0; 3], [1, 1, 1]));
    // serendipity pyramids cannot be stored
    let bad = text.replacen("\n2 1 3 1\n", "\n2 1 19 1\n", 1);
    let line = bad.lines().position(|l| l == "2 1 19 1").unwrap() + 1;
    let msg = parse_hex_msh(&bad).unwrap_err().to_string();
    let start = format!(
        "line {line}: unsupported element type 19 (only linear meshes: 1 = 2-node \
         line, 2 = 3-node triangle, 3 = 4-node quad, 4 = 4-node tetrahedron, 5 = 8-node hexahedron, 6 = 6-node prism, 7 = 5-node pyramid, 15 = point). \
         Type 19 is the 13-node (serendipity) pyramid"
    );
    assert!(msg.starts_with(&start), "{msg}");
    // a hex naming a node that does not exist
    let bad = text.replacen("\n7 1 2 4 3 5 6 8 7\n", "\n7 1 2 4 3 5 6 8 70\n", 1);
    let msg = parse_hex_msh(&bad).unwrap_err().to_string();
    assert!(
        msg.ends_with("element 7 refers to unknown node tag 70"),
        "{msg}"
    );
    // every prefix fails cleanly
    for end in 0..text.len() - 1 {
        assert!(
            parse_hex_msh(&text[..end]).is_err(),
            "prefix {end} accepted"
        );
    }
}

// ------------------------------------------------------------ any order




#[test]
fn msh_round_trip_keeps_tensor_order_and_parts() {
    for p in 1..=4 {
        let m = CurvedMesh::<2>::structured(p, Spacing::Equispaced, [2, 1], bend2).unwrap();
        let back = CurvedMesh::<2>::parse_msh(m.msh_string().unwrap()).unwrap();
        assert_eq!(back, m, "p={p}");
        let h = CurvedMesh::<3>::structured(p, Spacing::Equispaced, [1, 2, 1], bend3).unwrap();
        let back = CurvedMesh::<3>::parse_msh(h.msh_string().unwrap()).unwrap();
        assert_eq!(back, h, "p={p}");
    }
}


#[test]
fn bad_meshes_and_files_are_rejected() {
    let mut m = CurvedMesh::<2>::structured(2, Spacing::Equispaced, [1, 1], bend2).unwrap();
    let mut cells = m.cells.to_vecs();
    cells[0].pop();
    m.cells = crate::mesh::Cells::from_cells(2, 2, m.shape, cells);
    assert!(matches!(m.msh_string(), Err(MshError::InvalidMesh(_))));
    let mut m = CurvedMesh::<2>::structured(2, Spacing::Equispaced, [1, 1], bend2).unwrap();
    m.part_names[1] = "xmin".into();
    assert!(m.vtu_string(&[]).is_err());
    let m = CurvedMesh::<2>::structured(2, Spacing::Equispaced, [1, 1], bend2).unwrap();
    assert!(matches!(
        m.vtu_string(&[("q", &[1.0, 2.0])]),
        Err(VtuError::Length { .. })
    ));
    // a hex file is not a 2D mesh; mixed orders are refused
    let h = CurvedMesh::<3>::structured(2, Spacing::Equispaced, [1, 1, 1], bend3).unwrap();
    assert!(matches!(
        CurvedMesh::<2>::parse_msh(h.msh_string().unwrap()),
        Err(MshError::UnknownElementType {
            element_type: 12,
            ..
        })
    ));
    let text = m.msh_string().unwrap().replace("\n1 1 8 ", "\n1 1 1 ");
    assert!(CurvedMesh::<2>::parse_msh(&text).is_err());
    let text = m.msh_string().unwrap().replace("4.1 0 8", "3.0 0 8");
    assert!(matches!(
        CurvedMesh::<2>::parse_msh(&text),
        Err(MshError::UnsupportedVersion { .. })
    ));
}

/// The mixed test mesh's cells as a file gives them back: each cell's
/// shape, order and nodes (crate order), by element tag.
fn cells_read_back(text: &str) -> Vec<(Shape, usize, Vec<usize>)> {
    let layout = read::parse(text.as_bytes(), CURVED[1]).unwrap().layout();
    let mut cells: Vec<_> = layout.elements.into_iter().filter(|e| e.shape.dim() == 2).collect();
    cells.sort_by_key(|e| e.tag);
    cells.into_iter().map(|e| (e.shape, e.order, e.nodes)).collect()
}

/// The mixed test mesh's cells as they should come back.
fn cells_of(m: &CurvedMesh<2>) -> Vec<(Shape, usize, Vec<usize>)> {
    (0..m.cells.len()).map(|c| (m.cell_shape(c), m.p, m.cells[c].to_vec())).collect()
}

/// One entity holding quads and triangles: one block of each kind, each
/// with its own type and Gmsh node order, read back to the same cells.
#[test]
fn a_mixed_mesh_is_written_in_one_block_per_kind() {
    for p in [2, 3] {
        let m = mixed2(p);
        let text = m.msh_string().unwrap();
        // 8 boundary lines, then triangles and quads on surface 1
        assert!(text.contains("$Elements\n3 12 1 12\n"), "p = {p}");
        for shape in [Shape::Triangle, Shape::Quadrilateral] {
            assert!(text.contains(&format!("\n2 1 {} 2\n", msh_type(shape, p))), "p = {p}: {shape:?} block");
        }
        assert_eq!(cells_read_back(&text), cells_of(&m), "p = {p}");
    }
}

/// `parse_any` gives the mixed mesh back whole.
#[test]
fn a_mixed_mesh_reads_back_through_parse_any() {
    for p in [2, 3] {
        let m = mixed2(p);
        let tagged = parse_any(m.msh_string().unwrap().as_bytes(), false).unwrap();
        let AnyMesh::Plane(back) = tagged.mesh else { panic!("p = {p}: not a 2D mesh") };
        assert_eq!(cells_of(&back), cells_of(&m), "p = {p}");
        assert_eq!((back.nodes, back.boundary), (m.nodes, m.boundary), "p = {p}");
    }
}

/// The file holds the equispaced nodes of a Gauss–Lobatto mesh.
#[test]
fn gauss_lobatto_mesh_is_written_equispaced() {
    let g = CurvedMesh::<2>::structured(4, Spacing::GaussLobatto, [2, 2], bend2).unwrap();
    let back = CurvedMesh::<2>::parse_msh(g.msh_string().unwrap()).unwrap();
    assert_eq!(back.nodes, g.to_equispaced().nodes);
}

// ------------------------------------------------------------ binary

/// A binary MSH 4.1 file of one unit quad (nodes 1..4) with its bottom
/// edge in the group `wall`, in either byte order.
fn binary_square(big: bool) -> Vec<u8> {
    let mut b: Vec<u8> = b"$MeshFormat\n4.1 1 8\n".to_vec();
    let int = |b: &mut Vec<u8>, v: i32| b.extend(if big { v.to_be_bytes() } else { v.to_le_bytes() });
    let size = |b: &mut Vec<u8>, v: u64| b.extend(if big { v.to_be_bytes() } else { v.to_le_bytes() });
    let double = |b: &mut Vec<u8>, v: f64| b.extend(if big { v.to_be_bytes() } else { v.to_le_bytes() });
    int(&mut b, 1);
    b.extend(b"\n$EndMeshFormat\n$PhysicalNames\n1\n1 1 \"wall\"\n$EndPhysicalNames\n$Entities\n");
    [0, 1, 1, 0].into_iter().for_each(|n| size(&mut b, n));
    // curve 1 in group 1, no bounding points; surface 1 bounded by it
    for (physical, bounding) in [(Some(1), None), (None, Some(1))] {
        int(&mut b, 1);
        [0.0, 0.0, 0.0, 1.0, 1.0, 0.0].into_iter().for_each(|x| double(&mut b, x));
        size(&mut b, u64::from(physical.is_some()));
        physical.into_iter().for_each(|t| int(&mut b, t));
        size(&mut b, u64::from(bounding.is_some()));
        bounding.into_iter().for_each(|t| int(&mut b, t));
    }
    b.extend(b"\n$EndEntities\n$Nodes\n");
    [1, 4, 1, 4].into_iter().for_each(|n| size(&mut b, n));
    [2, 1, 0].into_iter().for_each(|n| int(&mut b, n));
    (4..=4).chain(1..=4).for_each(|n| size(&mut b, n)); // count, then the tags
    [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0].into_iter().for_each(|x| double(&mut b, x));
    b.extend(b"\n$EndNodes\n$Elements\n");
    [2, 2, 1, 2].into_iter().for_each(|n| size(&mut b, n));
    for (dim, element_type, nodes) in [(1, 1, &[1u64, 2][..]), (2, 3, &[1, 2, 3, 4][..])] {
        [dim, 1, element_type].into_iter().for_each(|n| int(&mut b, n));
        size(&mut b, 1);
        size(&mut b, dim as u64);
        nodes.iter().for_each(|&n| size(&mut b, n));
    }
    b.extend(b"\n$EndElements\n");
    b
}

#[test]
fn binary_files_of_either_byte_order_read_like_text() {
    let text = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n1\n1 1 \"wall\"\n$EndPhysicalNames\n\
        $Nodes\n1 4 1 4\n2 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n$EndNodes\n\
        $Elements\n2 2 1 2\n1 1 1 1\n1 1 2\n2 1 3 1\n2 1 2 3 4\n$EndElements\n";
    let ascii = parse_msh(text).unwrap();
    // without $Entities no line is in `wall`: it gets its curve's name
    assert_eq!(ascii.part_names, ["wall", "curve1"]);
    for big in [false, true] {
        let bytes = binary_square(big);
        assert!(is_binary(&bytes));
        let m = parse_msh(&bytes).unwrap();
        assert_eq!((&m.nodes, &m.cells), (&ascii.nodes, &ascii.cells));
        assert_eq!(m.edges, [BoundaryEdge { nodes: [0, 1], part: 0 }]);
        assert_eq!(m.part_names, ["wall"]);
        // every prefix fails cleanly, at a byte offset once in the data
        for end in 0..bytes.len() - 1 {
            let e = parse_msh(&bytes[..end]).expect_err("prefix accepted").to_string();
            assert!(end < 40 || e.starts_with("byte ") || e.starts_with("missing"), "{e}");
        }
    }
    // an element naming a node that does not exist, at its byte offset
    let mut bytes = binary_square(false);
    let last = bytes.len() - "\n$EndElements\n".len() - 8;
    bytes[last] = 9;
    let e = parse_msh(&bytes).unwrap_err().to_string();
    assert!(e.starts_with(&format!("byte {}: element 2 refers to unknown node tag 9", last - 32)), "{e}");
}
