//! Tests of the MSH 2.2 reader and writer.

use super::*;
use crate::io::layout::tests::mixed2;
use crate::io::layout::{Layout, Periodic};
use crate::mesh::element::Shape;
use crate::mesh::curved::tests::{bend2, bend3};
use crate::mesh::element::Spacing;
use crate::mesh::BoundaryEdge;

/// A 2×1 quad mesh of [0, 2] × [0, 1] in MSH 2.2 as Gmsh and other
/// writers spell it: a point element, curve 2 in two groups (Gmsh's
/// renumbered copy on the next line), a line with partition tags, a quad
/// repeated under its own tag, and node 9 in no element.
const SQUARES: &str = "$MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
3
1 1 \"bottom\"
1 2 \"sides\"
2 3 \"fluid\"
$EndPhysicalNames
$Nodes
7
1 0 0 0
2 1 0 0
3 2 0 0
4 0 1 0
5 1 1 0
6 2 1 0
9 5 5 0
$EndNodes
$Elements
9
1 15 2 0 1 1
2 1 2 1 1 1 2
3 1 2 1 1 2 3
4 1 2 2 2 3 6
5 1 2 1 2 3 6
6 1 4 2 4 1 3 4 1
7 3 2 3 1 1 2 5 4
8 3 2 3 1 2 3 6 5
7 3 2 3 1 1 2 5 4
$EndElements
$NodeData
1
\"ignored\"
$EndNodeData
";

/// The error message of `text`, which must fail to parse.
fn error_of(text: &str) -> String {
    parse_msh(text).expect_err("bad input must be rejected").to_string()
}

/// The 1-based line of the first occurrence of `needle` in `text`.
fn line_of(text: &str, needle: &str) -> usize {
    text[..text.find(needle).unwrap_or_else(|| panic!("{needle:?} not in the text"))].matches('\n').count() + 1
}

#[test]
fn reads_a_hand_written_file() {
    let m = parse_msh(SQUARES).unwrap();
    assert_eq!(m.nodes, vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [0.0, 1.0], [1.0, 1.0], [2.0, 1.0], [5.0, 5.0]]);
    assert_eq!(m.cells, vec![[0, 1, 4, 3], [1, 2, 5, 4]], "the repeated quad is one cell");
    assert_eq!(m.part_names, vec!["bottom".to_string(), "sides".to_string()]);
    // curve 2 in both groups (first seen in `sides`), its two lines one
    // element in both parts
    let edge = |nodes, part| BoundaryEdge { nodes, part };
    assert_eq!(m.edges, vec![edge([0, 1], 0), edge([1, 2], 0), edge([2, 5], 1), edge([2, 5], 0), edge([3, 0], 1)]);
    let tagged = parse_any(SQUARES.as_bytes(), true).unwrap();
    assert_eq!(tagged.cell_tags, vec![7, 8]);
    assert_eq!(tagged.node_tags, vec![1, 2, 3, 4, 5, 6, 9]);

    let raw = read::parse(SQUARES.as_bytes(), CURVED[1]).unwrap();
    let blocks: Vec<(usize, i64, i64, Vec<u64>)> = raw.blocks.iter().map(|b| (b.kind.dim, b.entity, b.element_type, b.tags.clone())).collect();
    assert_eq!(blocks, vec![(0, 1, 15, vec![1]), (1, 1, 1, vec![2, 3]), (1, 2, 1, vec![4]), (1, 4, 1, vec![6]), (2, 1, 3, vec![7, 8])]);
    assert_eq!(raw.blocks[2].at, Pos::Line(line_of(SQUARES, "4 1 2 2 2")));
    assert_eq!(raw.entity_physicals[&(1, 2)], vec![2, 1]);
    assert_eq!(raw.entity_physicals[&(0, 1)], Vec::<i64>::new());
    assert_eq!(raw.entity_physicals[&(2, 1)], vec![3]);
    // the lowest-dimensional element's entity; node 9 on point entity 0
    assert_eq!(raw.node_entity, vec![(0, 1), (1, 1), (1, 1), (1, 4), (2, 1), (1, 2), (0, 0)]);
    let entities: Vec<((usize, i64), [f64; 6], Vec<i64>)> = raw.entities.iter().map(|e| ((e.dim, e.tag), e.bbox, e.physicals.clone())).collect();
    assert_eq!(
        entities,
        vec![
            ((0, 0), [5.0, 5.0, 0.0, 5.0, 5.0, 0.0], vec![]),
            ((0, 1), [0.0, 0.0, 0.0, 0.0, 0.0, 0.0], vec![]),
            ((1, 1), [0.0, 0.0, 0.0, 2.0, 0.0, 0.0], vec![1]),
            ((1, 2), [2.0, 0.0, 0.0, 2.0, 1.0, 0.0], vec![2, 1]),
            ((1, 4), [0.0, 0.0, 0.0, 0.0, 1.0, 0.0], vec![2]),
            ((2, 1), [0.0, 0.0, 0.0, 2.0, 1.0, 0.0], vec![3]),
        ]
    );
    assert!(raw.entities.iter().all(|e| e.bounding.is_empty()));
    assert_eq!(raw.skipped, vec!["NodeData".to_string()]);
    assert_eq!(raw.elements_at, Some(Pos::Line(line_of(SQUARES, "$Elements") + 1)));
    // the layout the writers get: one element per distinct line
    assert_eq!(raw.layout().elements.len(), 7);
}

#[test]
fn elements_of_one_entity_in_different_groups_get_entities_of_their_own() {
    // quad 8 in group 4 instead of 3: surface 1 keeps group 3, quad 8 goes
    // on a new surface 2 in group 4
    let text = SQUARES.replace("2 3 \"fluid\"", "2 3 \"fluid\"\n2 4 \"solid\"").replace("3\n1 1 \"bottom\"", "4\n1 1 \"bottom\"").replace("8 3 2 3 1", "8 3 2 4 1");
    let raw = read::parse(text.as_bytes(), CURVED[1]).unwrap();
    let quads: Vec<(i64, Vec<u64>)> = raw.blocks.iter().filter(|b| b.kind.dim == 2).map(|b| (b.entity, b.tags.clone())).collect();
    assert_eq!(quads, vec![(1, vec![7]), (2, vec![8])]);
    assert_eq!((raw.entity_physicals[&(2, 1)].clone(), raw.entity_physicals[&(2, 2)].clone()), (vec![3], vec![4]));
    // node 6 on curve 2, node 5 on the surface of the first quad holding it
    assert_eq!((raw.node_entity[5], raw.node_entity[4]), ((1, 2), (2, 1)));
    // nothing else moves
    assert_eq!(parse_msh(&text).unwrap(), parse_msh(SQUARES).unwrap());
}

#[test]
fn every_msh2_version_is_read_and_others_are_refused() {
    let m = parse_msh(SQUARES).unwrap();
    for v in ["2", "2.0", "2.1"] {
        assert_eq!(parse_msh(SQUARES.replacen("2.2 0 8", &format!("{v} 0 8"), 1)).unwrap(), m, "version {v}");
    }
    let msg = error_of(&SQUARES.replacen("2.2 0 8", "3.0 0 8", 1));
    assert!(msg.starts_with("line 2: MSH version 3.0 is not supported") && msg.contains("-format msh41"), "{msg}");
}

#[test]
fn refuses_binary_msh2() {
    let e = parse_msh(SQUARES.replacen("2.2 0 8", "2.2 1 8", 1)).unwrap_err();
    assert!(matches!(e, MshError::BinaryV2 { at: Pos::Line(2), .. }), "{e:?}");
    let msg = e.to_string();
    assert!(msg.starts_with("line 2: binary MSH 2.2 is not supported") && msg.contains("-format msh22") && msg.contains("MSH 4.1"), "{msg}");
    let msg = error_of(&SQUARES.replacen("2.2 0 8", "2.2 7 8", 1));
    assert!(msg.starts_with("line 2: expected file type 0 (ASCII) or 1 (binary), found `7`"), "{msg}");
}

#[test]
fn refuses_one_tag_on_two_elements() {
    // tag 7 again, on the other quad
    let text = SQUARES.replacen("9\n1 15", "10\n1 15", 1).replacen("$EndElements", "7 3 2 3 1 2 3 6 5\n$EndElements", 1);
    let e = parse_msh(&text).unwrap_err();
    let (first, second) = (line_of(&text, "7 3 2 3 1 1 2 5 4"), line_of(&text, "7 3 2 3 1 2 3 6 5"));
    assert!(matches!(e, MshError::DuplicateElement { tag: 7, .. }), "{e:?}");
    assert_eq!(e.to_string(), format!("line {second}: element tag 7 is used by two different elements (the first at line {first}): element tags must be unique"));
    // the same tag on the same nodes of another entity is another element
    let text = SQUARES.replacen("\n7 3 2 3 1 1 2 5 4\n$End", "\n7 3 2 3 5 1 2 5 4\n$End", 1);
    assert!(error_of(&text).contains("element tag 7 is used by two different elements"));
}

#[test]
fn reader_errors_name_the_line() {
    let cases: [(&str, &str, &str, &str); 8] = [
        ("8 3 2 3 1 2 3 6 5", "8 3 2 3 1 2 3 77 5", "8 3 2 3 1 2 3 77", "element 8 refers to unknown node tag 77"),
        ("8 3 2 3 1 2 3 6 5", "8 2 2 3 1 2 3 6", "8 2 2", "element block of Triangles in a mesh whose cells are Quadrilaterals"),
        ("5 1 1 0\n", "5 nan 1 0\n", "5 nan", "node 5 has a non-finite coordinate `nan`"),
        ("6 2 1 0\n", "5 2 1 0\n", "5 2 1 0", "node tag 5 is defined twice"),
        ("6 2 1 0\n", "6 2 1 0.5\n", "6 2 1 0.5", "node 6 has z = 0.5"),
        ("3 2 0 0\n", "3 2 x 0\n", "3 2 x", "expected a coordinate of node 3, found `x`"),
        ("6 1 4 2 4 1 3 4 1", "6 1 4 2 4 1 3 4 8", "6 1 4", "element 6 refers to unknown node tag 8"),
        ("1 15 2 0 1 1", "1 15 two 0 1 1", "1 15 two", "expected the number of element tags, found `two`"),
    ];
    for (from, to, at, words) in cases {
        assert!(SQUARES.contains(from), "{from:?}");
        let text = SQUARES.replacen(from, to, 1);
        let msg = error_of(&text);
        let line = line_of(&text, at);
        assert!(msg.starts_with(&format!("line {line}: ")) && msg.contains(words), "{to:?}: expected line {line} and {words:?}: {msg}");
    }
    assert!(error_of(&SQUARES.replacen("8 3 2 3 1 2 3 6 5", "8 2 2 3 1 2 3 6", 1)).contains("one kind of cell"));
    // truncated in an element: at the last line
    let cut = &SQUARES[..SQUARES.find("8 3 2 3 1 2 3").unwrap() + 12];
    assert_eq!(error_of(cut), format!("line {}: file truncated: expected a node tag of an element", cut.lines().count()));
    // a count too large: the next section header is no element tag
    let msg = error_of(&SQUARES.replacen("$Elements\n9", "$Elements\n10", 1));
    assert!(msg.starts_with(&format!("line {}: expected an element tag, found `$EndElements`", line_of(SQUARES, "$EndElements"))), "{msg}");
    let elements_first = SQUARES.replacen("$Nodes", "$Elements\n0\n$EndElements\n$Nodes", 1);
    assert!(error_of(&elements_first).contains("expected $Nodes before $Elements"));
    let no_elements = &SQUARES[..SQUARES.find("$Elements").unwrap()];
    assert_eq!(error_of(no_elements), "missing section $Elements");
    assert_eq!(error_of(&SQUARES[..SQUARES.find("$Nodes").unwrap()]), "missing section $Nodes");
    let msg = error_of(&SQUARES.replacen("2 3 \"fluid\"", "2 3 fluid", 1));
    assert!(msg.starts_with(&format!("line {}: expected a quoted physical group name", line_of(SQUARES, "2 3 \"fluid\""))), "{msg}");
}

#[test]
fn reads_periodic_links_with_and_without_affine_maps() {
    let periodic = "$Periodic\n2\n1 4 2\nAffine 1 0 0 -2 0 1 0 0 0 0 1 0 0 0 0 1\n2\n1 3\n4 6\n0 1 3\n1\n1 3\n$EndPeriodic\n";
    let text = format!("{SQUARES}{periodic}");
    let raw = read::parse(text.as_bytes(), CURVED[1]).unwrap();
    let links: Vec<(usize, i64, i64, usize, Vec<(u64, u64)>)> = raw.periodic.iter().map(|l| (l.dim, l.slave, l.master, l.affine.len(), l.pairs.clone())).collect();
    assert_eq!(links, vec![(1, 4, 2, 16, vec![(1, 3), (4, 6)]), (0, 1, 3, 0, vec![(1, 3)])]);
    assert_eq!(raw.periodic[0].affine[3], -2.0);
    let layout = raw.layout();
    assert_eq!(layout.periodic[0].pairs, vec![(0, 2), (3, 5)]);
    let bad = text.replacen("4 6\n0 1 3", "4 66\n0 1 3", 1);
    let msg = error_of(&bad);
    assert!(msg.starts_with(&format!("line {}: expected the tag of a node of $Nodes", line_of(&bad, "4 66"))), "{msg}");
    let msg = error_of(&text.replacen("Affine 1 0 0 -2", "Affine 1 0 x -2", 1));
    assert!(msg.starts_with(&format!("line {}: expected an affine value, found `x`", line_of(&text, "Affine"))), "{msg}");
}

/// What MSH 2 keeps of a layout: all but the entities' boxes and
/// bounding entities and the nodes' entities.
fn kept(l: &Layout) -> Layout {
    let mut l = l.clone();
    for e in &mut l.entities {
        e.bbox = [0.0; 6];
        e.bounding.clear();
    }
    l.entities.sort_by_key(|e| (e.dim, e.tag));
    l.node_entity.clear();
    l
}

/// Writes `layout` as 2.2 and reads it back; the second round trip must
/// give the first's layout exactly.
fn round_trip(layout: &Layout) -> Layout {
    let text = layout_text_22(layout);
    let back = read::parse(text.as_bytes(), CURVED[1]).unwrap().layout();
    let again = read::parse(layout_text_22(&back).as_bytes(), CURVED[1]).unwrap().layout();
    assert_eq!(again, back, "a second round trip changes the layout");
    back
}

#[test]
fn layouts_survive_a_round_trip() {
    for p in 1..=4 {
        let m = CurvedMesh::<2>::structured(p, Spacing::Equispaced, [3, 2], bend2).unwrap();
        let layout = Layout::generated(&m);
        let text = layout_text_22(&layout);
        assert!(text.starts_with("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n5\n1 1 \"xmin\"\n"), "{}", &text[..200]);
        // boundary element 1 on part 1's curve, in its group; nodes in Gmsh's order
        let first = &layout.elements[0];
        let gmsh: Vec<String> = crate::mesh::element::to_format(&super::types::gmsh_perm(crate::mesh::element::Shape::Line, p), &first.nodes).iter().map(|&n| (n + 1).to_string()).collect();
        assert!(text.contains(&format!("\n1 {} 2 {} {} {}\n", MSH_LINE_TYPES[p - 1], first.entity, first.entity, gmsh.join(" "))));
        let back = round_trip(&layout);
        assert_eq!(kept(&back), kept(&layout), "p = {p}");
        // boundary nodes move to their curves; the box comes from the nodes
        assert_eq!(back.node_entity[0].0, 1);
        assert_eq!(CurvedMesh::<2>::parse_msh(&text).unwrap(), m, "p = {p}");
        for (a, b) in back.coords.iter().zip(&layout.coords) {
            assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits));
        }
        let h = CurvedMesh::<3>::structured(p, Spacing::Equispaced, [1, 2, 1], bend3).unwrap();
        let layout = Layout::generated(&h);
        assert_eq!(kept(&round_trip(&layout)), kept(&layout), "hex p = {p}");
        assert_eq!(CurvedMesh::<3>::parse_msh(layout_text_22(&layout)).unwrap(), h, "hex p = {p}");
    }
}

/// MSH 2.2 writes every element with its own type and node order: the
/// quads and triangles of one entity come back as they were.
#[test]
fn a_mixed_layout_survives_a_round_trip() {
    for p in [2, 3] {
        let layout = Layout::generated(&mixed2(p));
        let back = round_trip(&layout);
        assert_eq!(kept(&back), kept(&layout), "p = {p}");
        let text = layout_text_22(&layout);
        let elements = text.split("$Elements\n").nth(1).unwrap().lines().skip(1).take(12);
        let types: Vec<i64> = elements.map(|l| l.split(' ').nth(1).unwrap().parse().unwrap()).collect();
        let cells = [Shape::Quadrilateral, Shape::Quadrilateral, Shape::Triangle, Shape::Triangle].map(|s| msh_type(s, p));
        assert_eq!(types[8..], cells, "p = {p}: each cell with its own type");
    }
}

#[test]
fn an_entity_in_two_groups_is_written_once_per_group_and_read_once() {
    let m = CurvedMesh::<2>::structured(2, Spacing::Equispaced, [2, 2], bend2).unwrap();
    let mut layout = Layout::generated(&m);
    // curve 1 (part `xmin`, 2 lines) also in group 2; a periodic link
    layout.entities.iter_mut().find(|e| (e.dim, e.tag) == (1, 1)).unwrap().physicals.push(2);
    let pairs: Vec<(usize, usize)> = vec![(3, 0), (7, 4)];
    let affine: Vec<f64> = vec![1.0, 0.0, 0.0, 0.5, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0];
    layout.periodic.push(Periodic { dim: 1, slave: 2, master: 1, affine: affine.clone(), pairs: pairs.clone() });
    let text = layout_text_22(&layout);
    let n = layout.elements.len();
    let doubled = layout.elements.iter().filter(|e| (e.shape.dim(), e.entity) == (1, 1)).count();
    assert_eq!(doubled, 2);
    assert!(text.contains(&format!("$Elements\n{}\n", n + doubled)));
    // as Gmsh: every line numbered in order, the copy next to its element
    let lines: Vec<&str> = text[text.find("$Elements").unwrap()..].lines().skip(2).take(n + doubled).collect();
    for (k, l) in lines.iter().enumerate() {
        assert!(l.starts_with(&format!("{} ", k + 1)), "line {k}: {l}");
    }
    let k = layout.elements.iter().position(|e| (e.shape.dim(), e.entity) == (1, 1)).unwrap();
    let rest = |l: &str| l.split_once(' ').unwrap().1.split(' ').skip(3).collect::<Vec<_>>().join(" ");
    assert_eq!((rest(lines[k]), lines[k].split(' ').nth(3), lines[k + 1].split(' ').nth(3)), (rest(lines[k + 1]), Some("1"), Some("2")));
    assert!(text.contains("$Periodic\n1\n1 2 1\nAffine 1 0 0 0.5 0 1 0 0 0 0 1 0 0 0 0 1\n2\n4 1\n8 5\n$EndPeriodic\n"), "{}", &text[text.find("$Periodic").unwrap()..]);
    let back = round_trip(&layout);
    assert_eq!(back.elements.len(), n);
    assert_eq!(back.entities.iter().find(|e| (e.dim, e.tag) == (1, 1)).unwrap().physicals, vec![1, 2]);
    assert_eq!(back.periodic, vec![Periodic { dim: 1, slave: 2, master: 1, affine, pairs }]);
    // tags: each element has the number of its first line
    let mut line = 0;
    for (a, b) in back.elements.iter().zip(&layout.elements) {
        line += 1;
        assert_eq!((a.tag, &a.nodes, a.entity), (line, &b.nodes, b.entity));
        if (b.shape.dim(), b.entity) == (1, 1) {
            line += 1;
        }
    }
    // the mesh keeps both parts of the curve's lines
    let back_mesh = CurvedMesh::<2>::parse_msh(&text).unwrap();
    assert_eq!(back_mesh.boundary.len(), m.boundary.len() + doubled);
    assert_eq!(back_mesh.cells, m.cells);
}
