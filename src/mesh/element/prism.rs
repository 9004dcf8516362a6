//! The order-`p` Lagrange prism (wedge): the triangle's space `P_p` times
//! the line's, on the reference prism `{(x, y) in the unit triangle} ×
//! [0, 1]` of [`Shape::Prism`].
//!
//! **The lattice order** (fixed: the crate keeps prism nodes in it). A node
//! is `(i, j, k)`: `(i, j)` a node of the order-`p` triangle lattice of
//! [`super::simplex`] (`j` outer, `i` inner), `k = 0..=p` its layer along
//! z. Layers are outermost: position `k · T + t` with `t` the triangle
//! position and `T = (p+1)(p+2)/2`. So the bottom triangle (vertices 0, 1,
//! 2) is layer 0 and the top one (vertices 3, 4, 5) layer `p`.
//!
//! **Nodes.** The triangle's node set (equispaced or warp-blend) times the
//! 1-D set of [`super::nodes_1d`] on the same spacing: a quad face carries
//! the tensor nodes of a quad, a triangle face a triangle's, so a prism
//! shares its faces with hexes and tetrahedra node for node.
//!
//! **Basis.** `ℓ_{(t, k)}(x, y, z) = ℓ_t^{tri}(x, y) · l_k(z)`.

use std::sync::OnceLock;

use super::simplex::{self, SimplexSpace};
use super::{check_order, nodes_1d, HighOrderError, Shape, Spacing, MAX_ORDER};

/// The number of nodes of the order-`p` triangle.
fn triangle_count(p: usize) -> usize {
    (p + 1) * (p + 2) / 2
}

/// The multi-indices `(i, j, k)` of the order-`p` prism in lattice order.
pub fn lattice(p: usize) -> Vec<[usize; 3]> {
    let tri = simplex::lattice(Shape::Triangle, p);
    (0..=p).flat_map(|k| tri.iter().map(move |&[i, j, _]| [i, j, k])).collect()
}

/// The position of `(i, j, k)` in [`lattice`]`(p)`.
///
/// # Panics
/// If it is not in the lattice.
pub fn lattice_index(p: usize, [i, j, k]: [usize; 3]) -> usize {
    assert!(k <= p, "layer {k} of an order-{p} prism");
    k * triangle_count(p) + simplex::lattice_index(Shape::Triangle, p, [i, j, 0])
}

/// The positions of the six vertices in [`lattice`] order, in
/// [`Shape::Prism`]'s vertex order.
pub fn vertex_nodes(p: usize) -> [usize; 6] {
    let tri = [[0, 0], [p, 0], [0, p]];
    std::array::from_fn(|v| lattice_index(p, [tri[v % 3][0], tri[v % 3][1], if v < 3 { 0 } else { p }]))
}

/// The `p³` sub-prisms of the order-`p` lattice (layer by layer, the
/// triangle's `p²` sub-triangles of [`simplex::sub_simplices`]), corners in
/// [`Shape::Prism`]'s vertex order, each oriented like the reference
/// prism.
pub fn sub_prisms(p: usize) -> Vec<[usize; 6]> {
    let tri = simplex::sub_simplices(Shape::Triangle, p);
    let lat = simplex::lattice(Shape::Triangle, p);
    let mut out = Vec::with_capacity(p * tri.len());
    for k in 0..p {
        for s in &tri {
            out.push(std::array::from_fn(|a| {
                let [i, j, _] = lat[s[a % 3]];
                lattice_index(p, [i, j, k + a / 3])
            }));
        }
    }
    out
}

/// The reference coordinates of the order-`p` nodes in lattice order.
pub fn prism_nodes(p: usize, spacing: Spacing) -> Result<Vec<[f64; 3]>, HighOrderError> {
    let tri = simplex::simplex_nodes(Shape::Triangle, p, spacing)?;
    let t = nodes_1d(p, spacing)?;
    Ok(t.iter().flat_map(|&z| tri.iter().map(move |x| [x[0], x[1], z])).collect())
}

/// The Lagrange space on the prism, on one node set. Get the shared
/// instances from [`space`].
#[derive(Clone, Debug)]
pub struct PrismSpace {
    /// Element order.
    pub p: usize,
    /// The node set.
    pub spacing: Spacing,
    /// Reference coordinates of the nodes, lattice order.
    pub nodes: Vec<[f64; 3]>,
    /// The triangle's space.
    tri: &'static SimplexSpace,
    /// The 1-D nodes.
    t: Vec<f64>,
    /// `1 / Π_{m≠k} (t_k − t_m)`.
    scale: Vec<f64>,
}

impl PrismSpace {
    /// The order-`p` space on `spacing`'s nodes.
    pub fn new(p: usize, spacing: Spacing) -> Result<Self, HighOrderError> {
        let t = nodes_1d(p, spacing)?;
        let scale = (0..=p).map(|k| 1.0 / (0..=p).filter(|&m| m != k).map(|m| t[k] - t[m]).product::<f64>()).collect();
        Ok(PrismSpace { p, spacing, nodes: prism_nodes(p, spacing)?, tri: simplex::space(Shape::Triangle, p, spacing)?, t, scale })
    }

    /// The number of nodes (basis functions).
    pub fn num_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// The basis values and reference gradients at `ξ` into the caller's
    /// slices (each of [`PrismSpace::num_nodes`]); allocates nothing.
    ///
    /// # Panics
    /// If a slice has another length.
    pub fn eval(&self, xi: [f64; 3], values: &mut [f64], grads: &mut [[f64; 3]]) {
        let nt = triangle_count(self.p);
        assert!(values.len() == nt * (self.p + 1) && grads.len() == values.len(), "{} basis functions", nt * (self.p + 1));
        let (mut tv, mut tg) = ([0.0; 15], [[0.0; 3]; 15]);
        self.tri.eval([xi[0], xi[1], 0.0], &mut tv[..nt], &mut tg[..nt]);
        let (mut lv, mut ld) = ([0.0; MAX_ORDER + 1], [0.0; MAX_ORDER + 1]);
        for k in 0..=self.p {
            let (mut v, mut dv) = (1.0, 0.0);
            for m in (0..=self.p).filter(|&m| m != k) {
                let d = xi[2] - self.t[m];
                dv = dv * d + v;
                v *= d;
            }
            lv[k] = v * self.scale[k];
            ld[k] = dv * self.scale[k];
        }
        for k in 0..=self.p {
            for t in 0..nt {
                let n = k * nt + t;
                values[n] = tv[t] * lv[k];
                grads[n] = [tg[t][0] * lv[k], tg[t][1] * lv[k], tv[t] * ld[k]];
            }
        }
    }
}

/// The shared space of order `p` and `spacing`, built on first use
/// (Gmsh's `BasisFactory`).
pub fn space(p: usize, spacing: Spacing) -> Result<&'static PrismSpace, HighOrderError> {
    static SPACES: [OnceLock<PrismSpace>; MAX_ORDER * 2] = [const { OnceLock::new() }; MAX_ORDER * 2];
    check_order(p)?;
    let slot = (p - 1) * 2 + usize::from(spacing == Spacing::GaussLobatto);
    Ok(SPACES[slot].get_or_init(|| PrismSpace::new(p, spacing).expect("the order was checked")))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The basis interpolates: `ℓ_n(x_m) = δ_nm`, the values sum to 1 and
    /// the gradients to 0 anywhere, and it reproduces `x y² z^p`-type
    /// members of `P_p ⊗ P_p` through its nodes (here the map ξ itself
    /// and a product of the two factors' top degrees).
    #[test]
    fn the_basis_interpolates_and_reproduces_its_space() {
        for p in 1..=MAX_ORDER {
            for spacing in [Spacing::Equispaced, Spacing::GaussLobatto] {
                let s = space(p, spacing).unwrap();
                let n = s.num_nodes();
                assert_eq!(n, Shape::Prism.num_nodes(p));
                let (mut v, mut g) = (vec![0.0; n], vec![[0.0; 3]; n]);
                for (m, &x) in s.nodes.iter().enumerate() {
                    s.eval(x, &mut v, &mut g);
                    for (k, &val) in v.iter().enumerate() {
                        assert!((val - f64::from(u8::from(k == m))).abs() < 1e-12, "p = {p}, ℓ_{k}(x_{m}) = {val}");
                    }
                }
                let f = |x: [f64; 3]| x[0].powi(p as i32 - 1) * x[1] * x[2].powi(p as i32) + 0.3 * x[2];
                let df = |x: [f64; 3]| {
                    let a = p as i32 - 1;
                    [
                        if a > 0 { f64::from(a) * x[0].powi(a - 1) * x[1] * x[2].powi(p as i32) } else { 0.0 },
                        x[0].powi(a) * x[2].powi(p as i32),
                        x[0].powi(a) * x[1] * p as f64 * x[2].powi(p as i32 - 1) + 0.3,
                    ]
                };
                let at = [0.21, 0.33, 0.71];
                s.eval(at, &mut v, &mut g);
                let value: f64 = v.iter().zip(&s.nodes).map(|(l, &x)| l * f(x)).sum();
                assert!((value - f(at)).abs() < 1e-12, "p = {p}: {value} vs {}", f(at));
                for d in 0..3 {
                    let grad: f64 = g.iter().zip(&s.nodes).map(|(l, &x)| l[d] * f(x)).sum();
                    assert!((grad - df(at)[d]).abs() < 1e-11, "p = {p}, ∂{d}: {grad} vs {}", df(at)[d]);
                }
            }
        }
    }

    /// The sub-prisms tile the reference prism: p³ of them, each of
    /// volume 1/(2p³) and positive orientation, and every lattice node is
    /// a corner of one.
    #[test]
    fn the_sub_prisms_tile_the_lattice() {
        for p in 1..=MAX_ORDER {
            let x = prism_nodes(p, Spacing::Equispaced).unwrap();
            let subs = sub_prisms(p);
            assert_eq!(subs.len(), p * p * p);
            let mut seen = vec![false; x.len()];
            for s in &subs {
                let c = s.map(|n| x[n]);
                // base triangle area (signed) times height
                let area = 0.5 * ((c[1][0] - c[0][0]) * (c[2][1] - c[0][1]) - (c[1][1] - c[0][1]) * (c[2][0] - c[0][0]));
                let h = c[3][2] - c[0][2];
                assert!((area * h - 0.5 / (p * p * p) as f64).abs() < 1e-14, "p = {p}: {s:?}");
                assert!((0..3).all(|a| c[a + 3][0] == c[a][0] && c[a + 3][1] == c[a][1]), "upright");
                s.iter().for_each(|&n| seen[n] = true);
            }
            assert!(seen.iter().all(|&b| b));
            let v = vertex_nodes(p);
            for (a, &n) in v.iter().enumerate() {
                assert_eq!(x[n], Shape::Prism.vertices()[a]);
            }
            assert_eq!(lattice(p).len(), x.len());
            assert!(lattice(p).iter().enumerate().all(|(n, &m)| lattice_index(p, m) == n));
        }
    }
}
