//! Blending a curved boundary into the elements behind it, as Gmsh's
//! `setOrder` does: once the new nodes of the curved facets are on the
//! shape, the nodes inside each element that touches them follow by
//! transfinite interpolation of the displacement of its edges and faces
//! (Gordon–Hall on quads and hexes: faces from their edges, the inside
//! from the faces; on triangles and tetrahedra the linear blend of the
//! edges). Why: leaving those nodes straight inverts an element as soon
//! as the sagitta of its wall face passes its first row of nodes (the
//! extruded 1e-3 layer at p = 3: 320 of 1,096 elements), where the blend
//! spreads the bend over the element's height and keeps it valid while
//! the sagitta is under the height (Gmsh's `setOrder` on the same mesh:
//! valid, and deformesh's snap with the blend too).
//!
//! The blend is linear in the displacement, so each kind gets a recipe
//! once: for each node it recomputes, the weights of the nodes it is
//! blended from. Edge nodes are never recomputed (they are on the shape
//! or straight), nor are the nodes of a boundary face that is not planar
//! (a face on a curved wall, already on its shape). A planar boundary
//! face (a slip plane, a flat held side) is blended like an inner face:
//! its edges are in its plane, so its nodes stay in it. Prisms and
//! pyramids have no recipe: their nodes stay where they are.

use super::{nodes_1d, HighOrderError, Spacing};
use crate::mesh::element::{simplex, Shape};
use crate::mesh::CurvedMesh;
use std::collections::BTreeMap;

/// One blended node: its position in the cell and the cell positions
/// (with weights) its displacement is blended from.
type Rule = (usize, Vec<(usize, f64)>);

/// A kind's blend at one order and spacing: the face nodes first (from
/// their edges), then the nodes inside (on quads and hexes from the
/// faces, blended first; on triangles and tetrahedra from the edges).
#[derive(Debug, Default)]
struct Recipe {
    faces: Vec<Rule>,
    inside: Vec<Rule>,
}

/// Moves the nodes inside the elements of `mesh` that the boundary snap
/// moved (`nodes` against `before`) by the blend of their element's
/// edges and faces (module docs); returns those elements, in order (the
/// blend moves no node outside them). `mesh`'s own nodes are not read.
pub fn blend_into_elements<const D: usize>(mesh: &CurvedMesh<D>, before: &[[f64; D]], nodes: &mut [[f64; D]]) -> Result<Vec<usize>, HighOrderError> {
    let touched: Vec<usize> = (0..mesh.cells.len()).filter(|&c| mesh.cells[c].iter().any(|&n| nodes[n] != before[n])).collect();
    if touched.is_empty() {
        return Ok(touched);
    }
    let kept = kept_nodes(mesh, nodes);
    let mut recipes = BTreeMap::new();
    for shape in mesh.shapes() {
        recipes.insert(shape, recipe(shape, mesh.p, mesh.spacing)?);
    }
    // faces first everywhere: the inside of an element reads the faces it
    // shares with its neighbours, which depend on their edges alone
    for stage in [0, 1] {
        for &c in &touched {
            let cell = &mesh.cells[c];
            let recipe = &recipes[&mesh.cell_shape(c)];
            for (a, from) in if stage == 0 { &recipe.faces } else { &recipe.inside } {
                let n = cell[*a];
                if kept[n] {
                    continue;
                }
                let d: [f64; D] = std::array::from_fn(|k| from.iter().map(|&(b, w)| w * (nodes[cell[b]][k] - before[cell[b]][k])).sum());
                nodes[n] = std::array::from_fn(|k| before[n][k] + d[k]);
            }
        }
    }
    Ok(touched)
}

/// The nodes of boundary facets that are not planar in `nodes` (3D): on a
/// curved wall, where the snap put them. In 2D none: no boundary node is
/// inside an element's face.
fn kept_nodes<const D: usize>(mesh: &CurvedMesh<D>, nodes: &[[f64; D]]) -> Vec<bool> {
    let mut kept = vec![false; nodes.len()];
    if D < 3 {
        return kept;
    }
    for facet in &mesh.boundary {
        let points: Vec<[f64; 3]> = facet.nodes.iter().map(|&n| std::array::from_fn(|k| nodes[n][k])).collect();
        if !planar(&points) {
            for &n in facet.nodes {
                kept[n] = true;
            }
        }
    }
    kept
}

/// Whether `points` lie in one plane, to rounding of their spread (the
/// normal of a thin facet's widest triangle carries rounding of order
/// 1e-16 times its aspect: 1e-9 holds to aspects of 1e7, far under the
/// sagitta of any curved facet).
fn planar(points: &[[f64; 3]]) -> bool {
    use crate::numeric::{cross3 as cross, dot, sub};
    let o = points[0];
    let size = points.iter().map(|&x| dot(sub(x, o), sub(x, o))).fold(0.0, f64::max).sqrt();
    // the normal of the widest triangle through the first point
    let mut normal = [0.0; 3];
    for &a in points {
        for &b in points {
            let n = cross(sub(a, o), sub(b, o));
            if dot(n, n) > dot(normal, normal) {
                normal = n;
            }
        }
    }
    let len = dot(normal, normal).sqrt();
    len == 0.0 || points.iter().all(|&x| (dot(sub(x, o), normal) / len).abs() <= 1e-9 * size)
}

/// The blend of `shape` at order `p` on `spacing`'s nodes.
fn recipe(shape: Shape, p: usize, spacing: Spacing) -> Result<Recipe, HighOrderError> {
    match shape {
        Shape::Quadrilateral | Shape::Hexahedron => tensor_recipe(shape.dim(), p, spacing),
        Shape::Triangle | Shape::Tetrahedron => simplex_recipe(shape, p, spacing),
        _ => Ok(Recipe::default()),
    }
}

/// Gordon–Hall on the `(p+1)^dim` tensor lattice: a node with one index
/// at an end (3D) is on a face and is blended over the face's two free
/// axes; a node with none is inside and is blended over every axis.
fn tensor_recipe(dim: usize, p: usize, spacing: Spacing) -> Result<Recipe, HighOrderError> {
    let t = nodes_1d(p, spacing)?;
    let n = p + 1;
    let mut recipe = Recipe::default();
    for a in 0..n.pow(dim as u32) {
        let m: Vec<usize> = (0..dim).map(|s| a / n.pow(s as u32) % n).collect();
        let free: Vec<usize> = (0..dim).filter(|&s| m[s] != 0 && m[s] != p).collect();
        let rule = (a, transfinite(&m, &free, &t, n));
        match dim - free.len() {
            0 => recipe.inside.push(rule),
            1 if dim == 3 => recipe.faces.push(rule),
            _ => {}
        }
    }
    Ok(recipe)
}

/// The weights of the transfinite interpolation at lattice point `m` over
/// the axes `free`: the inclusion–exclusion sum, over each nonempty set
/// S of them, of `(−1)^{|S|+1}` times the multilinear blend of the
/// points with the axes of S moved to their ends.
fn transfinite(m: &[usize], free: &[usize], t: &[f64], n: usize) -> Vec<(usize, f64)> {
    let p = n - 1;
    let mut weights: BTreeMap<usize, f64> = BTreeMap::new();
    for set in 1..1usize << free.len() {
        let axes: Vec<usize> = (0..free.len()).filter(|&b| set >> b & 1 == 1).map(|b| free[b]).collect();
        let sign = if axes.len() % 2 == 1 { 1.0 } else { -1.0 };
        for ends in 0..1usize << axes.len() {
            let mut point = m.to_vec();
            let mut w = sign;
            for (b, &s) in axes.iter().enumerate() {
                let hi = ends >> b & 1 == 1;
                point[s] = if hi { p } else { 0 };
                w *= if hi { t[m[s]] } else { 1.0 - t[m[s]] };
            }
            let index = point.iter().rev().fold(0, |acc, &i| acc * n + i);
            *weights.entry(index).or_insert(0.0) += w;
        }
    }
    weights.into_iter().filter(|&(_, w)| w != 0.0).collect()
}

/// The linear blend of the edges on a triangle or tetrahedron: at a node
/// with barycentric coordinates λ, the sum over the edges (i, j) of
/// `(λ_i + λ_j) d_e(λ_j / (λ_i + λ_j))`, `d_e` the edge's displacement
/// interpolated on its nodes. The vertices do not move, so on each edge
/// it is that edge's own, and on each face the blend of the face's edges.
fn simplex_recipe(shape: Shape, p: usize, spacing: Spacing) -> Result<Recipe, HighOrderError> {
    let dim = shape.dim();
    let refs = simplex::simplex_nodes(shape, p, spacing)?;
    let bary = |x: [f64; 3]| -> [f64; 4] { [1.0 - x[0] - x[1] - x[2], x[0], x[1], x[2]] };
    let edges: Vec<(usize, usize, Vec<usize>)> = shape.edges().iter().enumerate().map(|(e, &[i, j])| (i, j, simplex::edge_nodes(shape, p, e))).collect();
    let mut recipe = Recipe::default();
    for (a, m) in simplex::lattice(shape, p).into_iter().enumerate() {
        let b = [p - m[0] - m[1] - m[2], m[0], m[1], m[2]];
        let nonzero = b[..=dim].iter().filter(|&&x| x != 0).count();
        if nonzero <= 2 {
            continue; // a vertex or an edge node
        }
        let l = bary(refs[a]);
        let mut weights: BTreeMap<usize, f64> = BTreeMap::new();
        for (i, j, on_edge) in &edges {
            let s = l[*i] + l[*j];
            if s <= 0.0 {
                continue;
            }
            let params: Vec<f64> = on_edge.iter().map(|&k| bary(refs[k])[*j]).collect();
            for (k, w) in lagrange_weights(&params, l[*j] / s).into_iter().enumerate() {
                *weights.entry(on_edge[k]).or_insert(0.0) += s * w;
            }
        }
        let rule = (a, weights.into_iter().filter(|&(_, w)| w != 0.0).collect());
        if nonzero == dim + 1 {
            recipe.inside.push(rule);
        } else {
            recipe.faces.push(rule);
        }
    }
    Ok(recipe)
}

/// The Lagrange basis on the points `params` at `t`.
fn lagrange_weights(params: &[f64], t: f64) -> Vec<f64> {
    (0..params.len())
        .map(|k| params.iter().enumerate().filter(|&(q, _)| q != k).map(|(_, &x)| (t - x) / (params[k] - x)).product())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Gordon–Hall reproduces a displacement that is linear in two of the
    /// three axes (whatever it does along the third) from its values on
    /// the edges: here `x²(1 − x)(1 + y/2)(1 − z)` along z, on two cells
    /// that share a face, every node but the blended ones put at it.
    #[test]
    fn hex_blend_reproduces_a_displacement_linear_in_two_axes() {
        for spacing in [Spacing::Equispaced, Spacing::GaussLobatto] {
            for p in 2..=4 {
                let bend = |x: [f64; 3]| [0.0, 0.05 * x[0], 0.3 * x[0] * x[0] * (1.0 - x[0]) * (1.0 + 0.5 * x[1]) * (1.0 - x[2])];
                let mut mesh = CurvedMesh::<3>::structured(p, spacing, [2, 1, 1], |x| x).unwrap();
                mesh.boundary = crate::mesh::Facets::new();
                let before = mesh.nodes.clone();
                let expected: Vec<[f64; 3]> = before.iter().map(|&x| std::array::from_fn(|k| x[k] + bend(x)[k])).collect();
                // the nodes the blend computes (on no cell edge) straight
                let n = p + 1;
                let mut nodes = expected.clone();
                for cell in &mesh.cells {
                    for (a, &v) in cell.iter().enumerate() {
                        let ends = (0..3).filter(|&s| [0, p].contains(&(a / n.pow(s as u32) % n))).count();
                        if ends < 2 {
                            nodes[v] = before[v];
                        }
                    }
                }
                blend_into_elements(&mesh, &before, &mut nodes).unwrap();
                for (v, x) in nodes.iter().enumerate() {
                    let err = (0..3).map(|k| (x[k] - expected[v][k]).abs()).fold(0.0, f64::max);
                    assert!(err < 1e-15, "p = {p} {spacing:?} node {v}: {x:?} against {:?}", expected[v]);
                }
            }
        }
    }

    /// On a triangle or tetrahedron with one edge bent by `d(t) = t²(1 − t)`
    /// (t from its first vertex; zero at its ends), every blended node
    /// moves by `(λ_0 + λ_1) d(λ_1 / (λ_0 + λ_1))`: the formula written out,
    /// at p = 3 and 4 on both spacings (d is exact in the edge's
    /// interpolant).
    #[test]
    fn simplex_nodes_follow_a_bent_edge_by_the_linear_blend() {
        for shape in [Shape::Triangle, Shape::Tetrahedron] {
            for spacing in [Spacing::Equispaced, Spacing::GaussLobatto] {
                for p in 3..=4 {
                    let recipe = simplex_recipe(shape, p, spacing).unwrap();
                    let refs = simplex::simplex_nodes(shape, p, spacing).unwrap();
                    // edge 0 runs from vertex 0 to vertex 1, along the x axis
                    assert_eq!(shape.edges()[0], [0, 1]);
                    let d = |x: [f64; 3]| if x[1] == 0.0 && x[2] == 0.0 { x[0] * x[0] * (1.0 - x[0]) } else { 0.0 };
                    let blended = recipe.faces.len() + recipe.inside.len();
                    assert_eq!(blended, shape.num_nodes(p) - shape.edges().len() * (p - 1) - shape.vertices().len(), "{shape:?} p = {p}");
                    for (a, from) in recipe.faces.iter().chain(&recipe.inside) {
                        let got: f64 = from.iter().map(|&(b, w)| w * d(refs[b])).sum();
                        let x = refs[*a];
                        let (l0, l1) = (1.0 - x[0] - x[1] - x[2], x[0]);
                        let s = l0 + l1;
                        let want = if s > 0.0 { s * (l1 / s).powi(2) * (1.0 - l1 / s) } else { 0.0 };
                        assert!((got - want).abs() < 1e-14, "{shape:?} p = {p} {spacing:?} node {a} at {x:?}: {got} against {want}");
                    }
                }
            }
        }
    }

    #[test]
    fn planar_tells_a_plane_from_a_bend() {
        let flat = [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0], [0.5, 0.5, 1.0]];
        assert!(planar(&flat));
        let bent = [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0], [0.5, 0.5, 1.0 + 1e-7]];
        assert!(!planar(&bent));
    }
}
