//! Line relaxation for the multigrid's smoother: the unknowns are split
//! into lines of nodes that follow each node's strongest couplings, and a
//! smoothing step solves every line's principal submatrix of A exactly
//! (banded Cholesky). On a thin boundary layer the lines run across the
//! layer, where cells of aspect ratio 10⁴–10⁵ couple their nodes 10⁸–10¹⁰
//! times more strongly than along it; a point (Jacobi) smoother cannot
//! touch the error that is smooth along the layer but not across it, a
//! line solve removes it.
//!
//! The lines are found algebraically from the node blocks of A (the
//! system's [`Structure`](super::Structure)), on every level, so that the
//! coarse operators of the aggregation, which keep the anisotropy, are
//! smoothed by lines too. Every node lies in exactly one line (isolated
//! nodes are lines of one, a node-block Jacobi). The line block is SPD
//! (a principal submatrix of A), so the smoother M⁻¹ is symmetric and
//! CG may use the cycle.
//!
//! Set-up is sequential and deterministic; factor and solve are parallel
//! over lines, each line a disjoint set of unknowns, so the result does
//! not depend on the thread count. The scratch is owned: no allocation
//! per application.

use super::Csr;
use rayon::prelude::*;

/// A line is cut where one of its nodes couples to a node more than this
/// many places back along it (a line that folds on itself), so that every
/// band is at most this many nodes wide.
const MAX_NODE_BAND: usize = 2;

/// A node whose third strongest coupling reaches this fraction of its
/// strongest is isotropic and keeps the point smoother. Measured: 0.3
/// left the extruded 1e-5 layer at p = 3 at 256 iterations (19 with
/// 0.75), and the 1e-2 layer at 54 (16).
const ISOTROPIC: f64 = 0.75;

/// The block-line smoother (see the module docs).
pub(super) struct Lines {
    /// Unknowns in line order: position → unknown.
    perm: Vec<u32>,
    /// Unknown → position.
    inv: Vec<u32>,
    /// Lines over positions.
    line_ptr: Vec<u32>,
    /// Half-bandwidth of each line's block, in unknowns.
    band: Vec<u32>,
    /// Start of each line's factor in `fac`.
    fac_ptr: Vec<usize>,
    /// Row-banded Cholesky factors: row i of a line holds L[i][i−w..=i]
    /// (entries before the line's start are unused), the diagonal stored
    /// inverted.
    fac: Vec<f64>,
    /// Right-hand side and solution in line order.
    scratch: Vec<f64>,
    /// Nodes per line, for reports.
    pub(super) longest: usize,
}

/// Squared Frobenius norms of the node blocks, as a node matrix.
pub(super) type BlockNorms = Csr;

impl Lines {
    /// Lines of `a` over its nodes: an edge I–J joins two lines when the
    /// coupling s_IJ = ‖A_IJ‖ / √(‖A_II‖ ‖A_JJ‖) is at least `ratio` times
    /// the strongest coupling of I and of J (both), in order of falling
    /// s_IJ, while each node has at most two line neighbours and no cycle
    /// forms. With `ratio` near 1 only a dominant coupling makes a line.
    pub(super) fn new(a: &Csr, node_ptr: &[u32], blocks: &BlockNorms, ratio: f64) -> Result<Lines, super::SolveError> {
        let nodes = node_ptr.len() - 1;
        let diag: Vec<f64> = (0..nodes).map(|k| blocks.position(k, k).map_or(0.0, |at| blocks.val[at].sqrt())).collect();
        // blocks hold ‖A_IJ‖², diag ‖A_II‖
        let strength = |k: usize, j: usize, s2: f64| s2.sqrt() / (diag[k] * diag[j]).sqrt();
        let mut strongest = vec![0.0f64; nodes];
        for k in 0..nodes {
            let (cols, vals) = blocks.row(k);
            for (&j, &s2) in cols.iter().zip(vals) {
                if j as usize != k {
                    strongest[k] = strongest[k].max(strength(k, j as usize, s2));
                }
            }
        }
        // a node is anisotropic when its third strongest coupling is well
        // below its strongest (a line through it); in an isotropic hex six
        // face neighbours tie
        let anisotropic: Vec<bool> = (0..nodes)
            .map(|k| {
                let mut top = [0.0f64; 3];
                let (cols, vals) = blocks.row(k);
                for (&j, &s2) in cols.iter().zip(vals) {
                    if j as usize != k {
                        let mut s = strength(k, j as usize, s2);
                        for t in top.iter_mut() {
                            if s > *t {
                                std::mem::swap(&mut s, t);
                            }
                        }
                    }
                }
                top[2] < ISOTROPIC * top[0]
            })
            .collect();
        if tracing::enabled!(tracing::Level::TRACE) {
            tracing::trace!("{} of {nodes} nodes anisotropic", anisotropic.iter().filter(|&&x| x).count());
        }
        let mut edges: Vec<(f64, u32, u32)> = Vec::new();
        for k in 0..nodes {
            if !anisotropic[k] {
                continue;
            }
            let (cols, vals) = blocks.row(k);
            for (&j, &s2) in cols.iter().zip(vals) {
                let j = j as usize;
                if j > k && anisotropic[j] {
                    let s = strength(k, j, s2);
                    if s > 0.0 && s >= ratio * strongest[k] && s >= ratio * strongest[j] {
                        edges.push((s, k as u32, j as u32));
                    }
                }
            }
        }
        // falling strength, ties by node numbers: deterministic
        edges.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
        let mut link = vec![[u32::MAX; 2]; nodes];
        let mut root: Vec<u32> = (0..nodes as u32).collect();
        fn find(root: &mut [u32], mut k: u32) -> u32 {
            while root[k as usize] != k {
                let up = root[root[k as usize] as usize];
                root[k as usize] = up;
                k = up;
            }
            k
        }
        let degree = |l: &[u32; 2]| l.iter().filter(|&&x| x != u32::MAX).count();
        for &(_, i, j) in &edges {
            if degree(&link[i as usize]) == 2 || degree(&link[j as usize]) == 2 {
                continue;
            }
            let (ri, rj) = (find(&mut root, i), find(&mut root, j));
            if ri == rj {
                continue;
            }
            root[ri.max(rj) as usize] = ri.min(rj);
            let free = |l: &mut [u32; 2], to: u32| {
                let at = if l[0] == u32::MAX { 0 } else { 1 };
                l[at] = to;
            };
            free(&mut link[i as usize], j);
            free(&mut link[j as usize], i);
        }
        // walk each path from its lower-numbered end, in node order
        let mut line_of = vec![u32::MAX; nodes];
        let mut place = vec![0u32; nodes];
        let mut node_order: Vec<u32> = Vec::with_capacity(nodes);
        let mut node_line_ptr: Vec<u32> = vec![0];
        for start in 0..nodes {
            if line_of[start] != u32::MAX || degree(&link[start]) == 2 {
                continue;
            }
            // a path end (degree 0 or 1); cut where the band would exceed
            let mut prev = u32::MAX;
            let mut cur = start as u32;
            let mut seg_start = node_order.len();
            loop {
                let c = cur as usize;
                let line = (node_line_ptr.len() - 1) as u32;
                let pos = (node_order.len() - seg_start) as u32;
                let (cols, _) = blocks.row(c);
                let folds = cols.iter().any(|&j| line_of[j as usize] == line && pos - place[j as usize] > MAX_NODE_BAND as u32);
                if folds {
                    node_line_ptr.push(node_order.len() as u32);
                    seg_start = node_order.len();
                }
                let line = (node_line_ptr.len() - 1) as u32;
                line_of[c] = line;
                place[c] = (node_order.len() - seg_start) as u32;
                node_order.push(cur);
                let next = link[c].iter().copied().find(|&x| x != u32::MAX && x != prev);
                match next {
                    Some(n) if line_of[n as usize] == u32::MAX => {
                        prev = cur;
                        cur = n;
                    }
                    _ => break,
                }
            }
            node_line_ptr.push(node_order.len() as u32);
        }
        debug_assert_eq!(node_order.len(), nodes, "every path has an end: no cycles");
        // unknowns in line order
        // lines of two or more nodes; a node alone keeps the point smoother
        let n = a.nrows;
        let mut perm = Vec::new();
        let mut line_ptr = vec![0u32];
        let mut longest = 0;
        for l in 0..node_line_ptr.len() - 1 {
            let (s, e) = (node_line_ptr[l] as usize, node_line_ptr[l + 1] as usize);
            if e - s < 2 {
                continue;
            }
            longest = longest.max(e - s);
            for &v in &node_order[s..e] {
                perm.extend(node_ptr[v as usize]..node_ptr[v as usize + 1]);
            }
            line_ptr.push(perm.len() as u32);
        }
        let lines = line_ptr.len() - 1;
        let mut inv = vec![u32::MAX; n];
        for (p, &i) in perm.iter().enumerate() {
            inv[i as usize] = p as u32;
        }
        // each line's half-bandwidth, from the couplings A has inside it
        let mut dof_line = vec![u32::MAX; n];
        for l in 0..lines {
            for p in line_ptr[l]..line_ptr[l + 1] {
                dof_line[perm[p as usize] as usize] = l as u32;
            }
        }
        let band: Vec<u32> = (0..lines)
            .map(|l| {
                let mut w = 0u32;
                for p in line_ptr[l]..line_ptr[l + 1] {
                    let (cols, _) = a.row(perm[p as usize] as usize);
                    for &j in cols {
                        if dof_line[j as usize] == l as u32 {
                            w = w.max(p.abs_diff(inv[j as usize]));
                        }
                    }
                }
                w
            })
            .collect();
        let mut fac_ptr = Vec::with_capacity(lines + 1);
        fac_ptr.push(0usize);
        for l in 0..lines {
            let m = (line_ptr[l + 1] - line_ptr[l]) as usize;
            fac_ptr.push(fac_ptr[l] + m * (band[l] as usize + 1));
        }
        let covered = perm.len();
        let mut out = Lines { perm, inv, line_ptr, band, fac: vec![0.0; fac_ptr[lines]], fac_ptr, scratch: vec![0.0; covered], longest };
        out.factor(a)?;
        Ok(out)
    }

    /// Number of lines.
    pub(super) fn count(&self) -> usize {
        self.line_ptr.len() - 1
    }

    /// Factors every line's block of the values now in `a` (same pattern
    /// as at [`Lines::new`]).
    pub(super) fn factor(&mut self, a: &Csr) -> Result<(), super::SolveError> {
        let Lines { perm, inv, line_ptr, band, fac_ptr, fac, .. } = self;
        let (perm, inv, line_ptr, band, fac_ptr) = (&*perm, &*inv, &*line_ptr, &*band, &*fac_ptr);
        let base = SharedMut(fac.as_mut_ptr());
        let ok = (0..line_ptr.len() - 1).into_par_iter().with_min_len(64).all(|l| {
            let (s, e) = (line_ptr[l] as usize, line_ptr[l + 1] as usize);
            let m = e - s;
            let w = band[l] as usize;
            let stride = w + 1;
            // SAFETY: lines own disjoint ranges fac_ptr[l]..fac_ptr[l + 1]
            let f = unsafe { std::slice::from_raw_parts_mut(base.get().add(fac_ptr[l]), m * stride) };
            f.fill(0.0);
            for i in 0..m {
                let (cols, vals) = a.row(perm[s + i] as usize);
                for (&j, &v) in cols.iter().zip(vals) {
                    let q = inv[j as usize] as usize; // u32::MAX off the lines
                    if q >= s && q <= s + i && s + i - q <= w {
                        // L[i][k] at i*stride + (k + w − i)
                        f[i * stride + (q - s) + w - i] = v;
                    }
                }
            }
            for i in 0..m {
                let lo = i.saturating_sub(w);
                for k in lo..=i {
                    let mut sum = f[i * stride + k + w - i];
                    for j in lo.max(k.saturating_sub(w))..k {
                        sum -= f[i * stride + j + w - i] * f[k * stride + j + w - k];
                    }
                    if k < i {
                        f[i * stride + k + w - i] = sum * f[k * stride + w];
                    } else {
                        if !(sum > 0.0) {
                            return false;
                        }
                        f[i * stride + w] = 1.0 / sum.sqrt();
                    }
                }
            }
            true
        });
        if ok {
            Ok(())
        } else {
            Err(super::SolveError::NotPositiveDefinite)
        }
    }

    /// Unknowns on lines (the rest are smoothed point by point).
    pub(super) fn covered(&self) -> usize {
        self.perm.len()
    }

    /// z = M⁻¹ r: every line's block solved, the other unknowns scaled by
    /// the inverted diagonal.
    pub(super) fn apply(&mut self, r: &[f64], inv_diag: &[f64], z: &mut [f64]) {
        z.par_iter_mut().zip(r.par_iter().zip(inv_diag)).with_min_len(4096).for_each(|(z, (r, w))| *z = w * r);
        let Lines { perm, line_ptr, band, fac_ptr, fac, scratch, .. } = self;
        let base = SharedMut(scratch.as_mut_ptr());
        let out = SharedMut(z.as_mut_ptr());
        let (perm, line_ptr, band, fac_ptr, fac) = (&*perm, &*line_ptr, &*band, &*fac_ptr, &*fac);
        (0..line_ptr.len() - 1).into_par_iter().with_min_len(256).for_each(|l| {
            let (s, e) = (line_ptr[l] as usize, line_ptr[l + 1] as usize);
            let m = e - s;
            let w = band[l] as usize;
            let stride = w + 1;
            let f = &fac[fac_ptr[l]..fac_ptr[l + 1]];
            // SAFETY: lines own disjoint ranges s..e of the scratch
            let x = unsafe { std::slice::from_raw_parts_mut(base.get().add(s), m) };
            for (x, &i) in x.iter_mut().zip(&perm[s..e]) {
                *x = r[i as usize];
            }
            for i in 0..m {
                let lo = i.saturating_sub(w);
                let mut sum = x[i];
                for k in lo..i {
                    sum -= f[i * stride + k + w - i] * x[k];
                }
                x[i] = sum * f[i * stride + w];
            }
            for i in (0..m).rev() {
                let mut sum = x[i];
                for j in i + 1..(i + w + 1).min(m) {
                    sum -= f[j * stride + i + w - j] * x[j];
                }
                x[i] = sum * f[i * stride + w];
            }
            for (&x, &i) in x.iter().zip(&perm[s..e]) {
                // SAFETY: every unknown is on at most one line
                unsafe { *out.get().add(i as usize) = x };
            }
        });
    }
}

/// A raw pointer that parallel tasks write through at disjoint offsets.
#[derive(Clone, Copy)]
struct SharedMut(*mut f64);
unsafe impl Send for SharedMut {}
unsafe impl Sync for SharedMut {}
impl SharedMut {
    fn get(self) -> *mut f64 {
        self.0
    }
}
