//! Compressed sparse rows with `u32` column indices, and the parallel
//! kernels the iterative solvers are made of.
//!
//! Every kernel here is deterministic: rows are independent, and sums
//! over a vector are taken in fixed chunks whose partial sums are added in
//! order, so a run gives the same iterates on one core or many.

use rayon::prelude::*;

/// Rows per parallel task: large enough to amortise scheduling, small
/// enough to balance two cores on the smallest meshes we parallelise.
const ROWS_PER_TASK: usize = 2048;
/// Entries per partial sum of [`dot`] (fixed, for determinism).
const DOT_CHUNK: usize = 8192;

/// A sparse matrix in compressed-row form; column indices sorted in each
/// row. `u32` columns keep an entry at 12 bytes, which is what a mat-vec
/// streams.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Csr {
    /// Number of rows.
    pub nrows: usize,
    /// Number of columns.
    pub ncols: usize,
    /// Row pointers, `nrows + 1` entries.
    pub row_ptr: Vec<usize>,
    /// Column of every stored entry.
    pub col: Vec<u32>,
    /// Value of every stored entry.
    pub val: Vec<f64>,
    /// The column runs shared by blocks of rows (see [`Csr::with_runs`]);
    /// when present the mat-vec reads them instead of `col`.
    pub runs: Option<Box<RowRuns>>,
}

impl Csr {
    /// The symmetric pattern (both triangles, diagonal always included)
    /// of `n × n` entries named by `pairs` in either triangle, values zero.
    pub fn symmetric_from_pairs(n: usize, pairs: impl IntoIterator<Item = (usize, usize)>) -> Csr {
        let mut rows: Vec<Vec<u32>> = (0..n).map(|i| vec![i as u32]).collect();
        for (i, j) in pairs {
            rows[i].push(j as u32);
            rows[j].push(i as u32);
        }
        let mut row_ptr = Vec::with_capacity(n + 1);
        let mut col = Vec::new();
        row_ptr.push(0);
        for mut r in rows {
            r.sort_unstable();
            r.dedup();
            col.extend_from_slice(&r);
            row_ptr.push(col.len());
        }
        let val = vec![0.0; col.len()];
        Csr { nrows: n, ncols: n, row_ptr, col, val, runs: None }
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.col.len()
    }

    /// Attaches [`RowRuns`] for the row blocks `block_ptr` (block k is rows
    /// `block_ptr[k]..block_ptr[k+1]`) if every block's rows share one
    /// pattern; otherwise the matrix is returned unchanged.
    pub fn with_runs(mut self, block_ptr: &[u32]) -> Csr {
        self.runs = RowRuns::new(&self, block_ptr).map(Box::new);
        self
    }

    /// The columns and values of row `i`.
    pub fn row(&self, i: usize) -> (&[u32], &[f64]) {
        let (a, b) = (self.row_ptr[i], self.row_ptr[i + 1]);
        (&self.col[a..b], &self.val[a..b])
    }

    /// Position of entry (i, j) in `col`/`val`, if stored (a search:
    /// for set-up and tests, not for hot loops).
    pub fn position(&self, i: usize, j: usize) -> Option<usize> {
        let (a, b) = (self.row_ptr[i], self.row_ptr[i + 1]);
        self.col[a..b].binary_search(&(j as u32)).ok().map(|k| a + k)
    }

    /// The diagonal entries (0 where none is stored).
    pub fn diagonal(&self, out: &mut [f64]) {
        out.par_iter_mut().enumerate().with_min_len(ROWS_PER_TASK).for_each(|(i, d)| {
            *d = self.position(i, i).map_or(0.0, |k| self.val[k]);
        });
    }

    /// y = A x, rows in parallel.
    pub fn apply(&self, x: &[f64], y: &mut [f64]) {
        debug_assert!(x.len() == self.ncols && y.len() == self.nrows);
        if let Some(runs) = &self.runs {
            return runs.for_rows(self, x, y, |_, ax| ax);
        }
        y.par_chunks_mut(ROWS_PER_TASK).enumerate().for_each(|(c, ys)| {
            let first = c * ROWS_PER_TASK;
            for (k, yi) in ys.iter_mut().enumerate() {
                *yi = self.row_dot(first + k, x);
            }
        });
    }

    /// r = b − A x, rows in parallel.
    pub fn residual(&self, b: &[f64], x: &[f64], r: &mut [f64]) {
        if let Some(runs) = &self.runs {
            return runs.for_rows(self, x, r, |i, ax| b[i] - ax);
        }
        r.par_chunks_mut(ROWS_PER_TASK).enumerate().for_each(|(c, rs)| {
            let first = c * ROWS_PER_TASK;
            for (k, ri) in rs.iter_mut().enumerate() {
                *ri = b[first + k] - self.row_dot(first + k, x);
            }
        });
    }

    /// Row i times x, with two accumulators so that the additions of a
    /// long row overlap.
    #[inline]
    fn row_dot(&self, i: usize, x: &[f64]) -> f64 {
        let (a, b) = (self.row_ptr[i], self.row_ptr[i + 1]);
        let (cols, vals) = (&self.col[a..b], &self.val[a..b]);
        let (mut s0, mut s1) = (0.0, 0.0);
        let mut pairs = cols.chunks_exact(2).zip(vals.chunks_exact(2));
        for (c, v) in &mut pairs {
            s0 += v[0] * x[c[0] as usize];
            s1 += v[1] * x[c[1] as usize];
        }
        if cols.len() % 2 == 1 {
            s0 += vals[cols.len() - 1] * x[cols[cols.len() - 1] as usize];
        }
        s0 + s1
    }

    /// The transpose.
    pub fn transpose(&self) -> Csr {
        let mut count = vec![0usize; self.ncols + 1];
        for &c in &self.col {
            count[c as usize + 1] += 1;
        }
        for j in 0..self.ncols {
            count[j + 1] += count[j];
        }
        let row_ptr = count.clone();
        let mut next = count;
        let mut col = vec![0u32; self.nnz()];
        let mut val = vec![0.0; self.nnz()];
        for i in 0..self.nrows {
            let (a, b) = (self.row_ptr[i], self.row_ptr[i + 1]);
            for k in a..b {
                let j = self.col[k] as usize;
                col[next[j]] = i as u32;
                val[next[j]] = self.val[k];
                next[j] += 1;
            }
        }
        Csr { nrows: self.ncols, ncols: self.nrows, row_ptr, col, val, runs: None }
    }

    /// The product A B (rows of the result in parallel, each row gathered
    /// in a dense accumulator of the task's own).
    pub fn matmul(&self, other: &Csr) -> Csr {
        assert_eq!(self.ncols, other.nrows, "inner dimensions of a sparse product");
        let ncols = other.ncols;
        let chunks: Vec<(Vec<usize>, Vec<u32>, Vec<f64>)> = (0..self.nrows.div_ceil(ROWS_PER_TASK))
            .into_par_iter()
            .map(|c| {
                let rows = c * ROWS_PER_TASK..((c + 1) * ROWS_PER_TASK).min(self.nrows);
                let mut acc = vec![0.0; ncols];
                let mut seen = vec![u32::MAX; ncols];
                let (mut lens, mut col, mut val) = (Vec::with_capacity(rows.len()), Vec::new(), Vec::new());
                for i in rows {
                    let start = col.len();
                    let (ca, va) = self.row(i);
                    for (&k, &a) in ca.iter().zip(va) {
                        let (cb, vb) = other.row(k as usize);
                        for (&j, &b) in cb.iter().zip(vb) {
                            if seen[j as usize] != i as u32 {
                                seen[j as usize] = i as u32;
                                acc[j as usize] = 0.0;
                                col.push(j);
                            }
                            acc[j as usize] += a * b;
                        }
                    }
                    col[start..].sort_unstable();
                    val.extend(col[start..].iter().map(|&j| acc[j as usize]));
                    lens.push(col.len() - start);
                }
                (lens, col, val)
            })
            .collect();
        let mut out = Csr { nrows: self.nrows, ncols, row_ptr: Vec::with_capacity(self.nrows + 1), col: Vec::new(), val: Vec::new(), runs: None };
        let total: usize = chunks.iter().map(|c| c.1.len()).sum();
        out.col.reserve_exact(total);
        out.val.reserve_exact(total);
        out.row_ptr.push(0);
        for (lens, col, val) in chunks {
            for l in lens {
                let last = *out.row_ptr.last().expect("row_ptr starts with 0");
                out.row_ptr.push(last + l);
            }
            out.col.extend_from_slice(&col);
            out.val.extend_from_slice(&val);
        }
        out
    }
}

/// A compressed index for matrices whose rows come in blocks with one
/// pattern (the D rows of a node in the LSFEM system): per block, its
/// columns as runs of consecutive indices. A run costs 5 bytes for the
/// whole block where `col` costs 4 bytes per entry per row, so a mat-vec
/// streams about 8.6 instead of 12 bytes per entry (3 rows, runs of 3),
/// and each x entry is loaded once per block instead of once per row.
#[derive(Clone, Debug, PartialEq)]
pub struct RowRuns {
    block_ptr: Vec<u32>,
    run_ptr: Vec<u32>,
    run_col: Vec<u32>,
    run_len: Vec<u8>,
    /// Block boundaries of the parallel tasks (about ROWS_PER_TASK rows).
    tasks: Vec<u32>,
}

/// Most rows in a block the kernels take (a 3D node has 3).
const MAX_BLOCK: usize = 4;

impl RowRuns {
    fn new(a: &Csr, block_ptr: &[u32]) -> Option<RowRuns> {
        let ok_ends = block_ptr.first() == Some(&0) && block_ptr.last().map(|&e| e as usize) == Some(a.nrows);
        if !ok_ends || block_ptr.windows(2).any(|w| w[1] <= w[0] || (w[1] - w[0]) as usize > MAX_BLOCK) {
            return None;
        }
        let (mut run_ptr, mut run_col, mut run_len, mut tasks) = (vec![0u32], Vec::new(), Vec::new(), vec![0u32]);
        for (k, w) in block_ptr.windows(2).enumerate() {
            let (first, cols) = (w[0] as usize, a.row(w[0] as usize).0);
            if (first + 1..w[1] as usize).any(|i| a.row(i).0 != cols) {
                return None;
            }
            for &c in cols {
                match (run_col.last(), run_len.last_mut()) {
                    (Some(&c0), Some(l)) if run_col.len() > run_ptr[k] as usize && c == c0 + *l as u32 && *l < u8::MAX => *l += 1,
                    _ => {
                        run_col.push(c);
                        run_len.push(1);
                    }
                }
            }
            run_ptr.push(run_col.len() as u32);
            if w[1] as usize - block_ptr[*tasks.last().unwrap() as usize] as usize >= ROWS_PER_TASK {
                tasks.push(k as u32 + 1);
            }
        }
        if *tasks.last().unwrap() as usize != block_ptr.len() - 1 {
            tasks.push(block_ptr.len() as u32 - 1);
        }
        Some(RowRuns { block_ptr: block_ptr.to_vec(), run_ptr, run_col, run_len, tasks })
    }

    /// `out[i] = finish(i, (A x)_i)` for every row, blocks in parallel.
    fn for_rows(&self, a: &Csr, x: &[f64], out: &mut [f64], finish: impl Fn(usize, f64) -> f64 + Sync) {
        let out_ptr = SyncPtr(out.as_mut_ptr());
        self.tasks.par_windows(2).for_each(|t| {
            let mut buf = [0.0; GATHER + 4];
            for k in t[0] as usize..t[1] as usize {
                let (r0, r1) = (self.block_ptr[k] as usize, self.block_ptr[k + 1] as usize);
                let sums = match r1 - r0 {
                    1 => self.block_dot::<1>(a, k, r0, x, &mut buf),
                    2 => self.block_dot::<2>(a, k, r0, x, &mut buf),
                    3 => self.block_dot::<3>(a, k, r0, x, &mut buf),
                    _ => self.block_dot::<MAX_BLOCK>(a, k, r0, x, &mut buf), // exactly 4: see `new`
                };
                for (q, i) in (r0..r1).enumerate() {
                    // SAFETY: the tasks' row ranges are disjoint and in bounds
                    unsafe { *out_ptr.get().add(i) = finish(i, sums[q]) };
                }
            }
        });
    }

    /// The K rows of block k (starting at row r0) times x: the block's x
    /// entries are gathered once into a contiguous buffer, then each row
    /// is a dense dot product (vectorised, four accumulators).
    #[inline]
    fn block_dot<const K: usize>(&self, a: &Csr, k: usize, r0: usize, x: &[f64], buf: &mut [f64; GATHER + 4]) -> [f64; MAX_BLOCK] {
        let base = a.row_ptr[r0];
        let width = a.row_ptr[r0 + 1] - base;
        let (first, last) = (self.run_ptr[k] as usize, self.run_ptr[k + 1] as usize);
        let mut s = [0.0; MAX_BLOCK];
        if width > GATHER {
            // a node with very many neighbours: plain rows
            for (q, sq) in s.iter_mut().enumerate().take(K) {
                *sq = a.row_dot(r0 + q, x);
            }
            return s;
        }
        let mut off = 0;
        for run in first..last {
            let (c0, len) = (self.run_col[run] as usize, self.run_len[run] as usize);
            gather(&x[c0..], len, &mut buf[off..]);
            off += len;
        }
        let xs = &buf[..width];
        for (q, sq) in s.iter_mut().enumerate().take(K) {
            *sq = dense_dot(&a.val[base + q * width..base + (q + 1) * width], xs);
        }
        s
    }
}

/// Longest block row the gathering mat-vec buffers (on the stack).
const GATHER: usize = 512;

/// `dst[..len] = src[..len]` for short runs, in fixed copies of 4 (which
/// compile to two vector moves: a copy of a run's length calls memmove,
/// which cost more than the products); `dst` may be overwritten up to the
/// next multiple of 4, hence the slack of the gather buffer.
#[inline]
fn gather(src: &[f64], len: usize, dst: &mut [f64]) {
    let mut t = 0;
    while t < len {
        if t + 4 <= src.len() {
            dst[t..t + 4].copy_from_slice(&src[t..t + 4]);
        } else {
            // the last entries of x: one at a time
            for u in t..len {
                dst[u] = src[u];
            }
        }
        t += 4;
    }
}

/// Σ aᵢ bᵢ for short equal-length slices, four accumulators.
#[inline]
fn dense_dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (p, q) in ca.zip(cb) {
        for i in 0..4 {
            acc[i] += p[i] * q[i];
        }
    }
    let tail: f64 = ra.iter().zip(rb).map(|(p, q)| p * q).sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

#[derive(Clone, Copy)]
struct SyncPtr(*mut f64);
// SAFETY: written only at disjoint rows, see `RowRuns::for_rows`.
unsafe impl Sync for SyncPtr {}
unsafe impl Send for SyncPtr {}
impl SyncPtr {
    fn get(self) -> *mut f64 {
        self.0
    }
}

/// Σ aᵢ bᵢ in fixed chunks (deterministic, parallel).
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    if a.len() <= DOT_CHUNK {
        return a.iter().zip(b).map(|(x, y)| x * y).sum();
    }
    let partial: Vec<f64> =
        a.par_chunks(DOT_CHUNK).zip(b.par_chunks(DOT_CHUNK)).map(|(x, y)| x.iter().zip(y).map(|(p, q)| p * q).sum()).collect();
    partial.iter().sum()
}

/// y ← y + α x, in parallel.
pub fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    y.par_chunks_mut(ROWS_PER_TASK).zip(x.par_chunks(ROWS_PER_TASK)).for_each(|(ys, xs)| {
        for (yi, xi) in ys.iter_mut().zip(xs) {
            *yi += alpha * xi;
        }
    });
}

/// z = d ⊙ r, in parallel.
pub fn scale(d: &[f64], r: &[f64], z: &mut [f64]) {
    z.par_chunks_mut(ROWS_PER_TASK).zip(d.par_chunks(ROWS_PER_TASK).zip(r.par_chunks(ROWS_PER_TASK))).for_each(|(zs, (ds, rs))| {
        for ((zi, di), ri) in zs.iter_mut().zip(ds).zip(rs) {
            *zi = di * ri;
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    fn random_csr(nrows: usize, ncols: usize, seed: u64) -> Csr {
        let mut s = seed;
        let mut next = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 33) as usize
        };
        let mut row_ptr = vec![0];
        let (mut col, mut val) = (Vec::new(), Vec::new());
        for _ in 0..nrows {
            let mut cols: Vec<u32> = (0..next() % 6).map(|_| (next() % ncols) as u32).collect();
            cols.sort_unstable();
            cols.dedup();
            for c in cols {
                col.push(c);
                val.push((next() % 1000) as f64 / 100.0 - 5.0);
            }
            row_ptr.push(col.len());
        }
        Csr { nrows, ncols, row_ptr, col, val, runs: None }
    }

    fn dense(a: &Csr) -> Vec<Vec<f64>> {
        let mut d = vec![vec![0.0; a.ncols]; a.nrows];
        for (i, row) in d.iter_mut().enumerate() {
            let (c, v) = a.row(i);
            for (&j, &x) in c.iter().zip(v) {
                row[j as usize] += x;
            }
        }
        d
    }

    #[test]
    fn product_and_transpose_match_dense_arithmetic() {
        // more rows than one task, so the chunked paths are taken
        let a = random_csr(5000, 300, 1);
        let b = random_csr(300, 40, 2);
        let (da, db, dc) = (dense(&a), dense(&b), dense(&a.matmul(&b)));
        for i in (0..5000).step_by(37) {
            for j in 0..40 {
                let e: f64 = (0..300).map(|k| da[i][k] * db[k][j]).sum();
                assert!((dc[i][j] - e).abs() < 1e-12, "({i},{j}): {} vs {e}", dc[i][j]);
            }
        }
        let t = a.transpose();
        let dt = dense(&t);
        assert!((0..5000).all(|i| (0..300).all(|j| da[i][j] == dt[j][i])));
        assert_eq!(t.transpose(), a);
    }

    #[test]
    fn apply_and_dot_match_serial_sums() {
        let a = random_csr(20_000, 20_000, 3);
        let x: Vec<f64> = (0..20_000).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut y = vec![0.0; 20_000];
        a.apply(&x, &mut y);
        for i in (0..20_000).step_by(101) {
            let (c, v) = a.row(i);
            let e: f64 = c.iter().zip(v).map(|(&j, &w)| w * x[j as usize]).sum();
            assert!((y[i] - e).abs() < 1e-12);
        }
        let serial: f64 = x.iter().zip(&y).map(|(p, q)| p * q).sum();
        assert!((dot(&x, &y) - serial).abs() < 1e-9 * serial.abs().max(1.0));
        assert_eq!(dot(&x, &y), dot(&x, &y));
    }

    /// Rows in blocks of 1–3 with one pattern per block (as the LSFEM
    /// nodes have), neighbour blocks picked at random.
    fn blocked_csr(blocks: usize, seed: u64) -> (Csr, Vec<u32>) {
        let mut s = seed;
        let mut next = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 33) as usize
        };
        let sizes: Vec<usize> = (0..blocks).map(|_| 1 + next() % 3).collect();
        let mut block_ptr = vec![0u32];
        for &n in &sizes {
            block_ptr.push(block_ptr.last().unwrap() + n as u32);
        }
        let n = *block_ptr.last().unwrap() as usize;
        let (mut row_ptr, mut col, mut val) = (vec![0], Vec::new(), Vec::new());
        for k in 0..blocks {
            let mut nb: Vec<usize> = (0..1 + next() % 9).map(|_| next() % blocks).chain([k]).collect();
            nb.sort_unstable();
            nb.dedup();
            for _ in 0..sizes[k] {
                for &j in &nb {
                    for c in block_ptr[j]..block_ptr[j + 1] {
                        col.push(c);
                        val.push((next() % 1000) as f64 / 500.0 - 1.0);
                    }
                }
                row_ptr.push(col.len());
            }
        }
        (Csr { nrows: n, ncols: n, row_ptr, col, val, runs: None }, block_ptr)
    }

    #[test]
    fn runs_give_the_plain_mat_vec_and_residual() {
        let (plain, block_ptr) = blocked_csr(9000, 5);
        let runs = plain.clone().with_runs(&block_ptr);
        assert!(runs.runs.is_some());
        let n = plain.nrows;
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.11).cos()).collect();
        let (mut y0, mut y1, mut r0, mut r1) = (vec![0.0; n], vec![1.0; n], vec![0.0; n], vec![1.0; n]);
        plain.apply(&x, &mut y0);
        runs.apply(&x, &mut y1);
        plain.residual(&b, &x, &mut r0);
        runs.residual(&b, &x, &mut r1);
        for i in 0..n {
            assert!((y0[i] - y1[i]).abs() < 1e-13, "row {i}: {} vs {}", y0[i], y1[i]);
            assert!((r0[i] - r1[i]).abs() < 1e-13, "row {i}: {} vs {}", r0[i], r1[i]);
        }
    }

    #[test]
    fn runs_refuse_blocks_whose_rows_differ() {
        let (mut a, block_ptr) = blocked_csr(50, 9);
        let k = (0..50).find(|&k| block_ptr[k + 1] - block_ptr[k] >= 2).unwrap();
        // drop the last entry of the block's last row: its pattern differs
        let last = block_ptr[k + 1] as usize - 1;
        let end = a.row_ptr[last + 1] - 1;
        a.col.remove(end);
        a.val.remove(end);
        a.row_ptr[last + 1..].iter_mut().for_each(|p| *p -= 1);
        assert!(a.with_runs(&block_ptr).runs.is_none());
    }
}
