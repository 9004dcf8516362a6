//! Compressed sparse rows with `u32` column indices, and the parallel
//! kernels the iterative solvers are made of.
//!
//! Every kernel here is deterministic: rows are independent, and sums
//! over a vector are taken in fixed chunks whose partial sums are added in
//! order, so a run gives the same iterates on one core or many.

use rayon::prelude::*;
use std::ops::Range;

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
        Csr { nrows: n, ncols: n, row_ptr, col, val }
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.col.len()
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
        y.par_chunks_mut(ROWS_PER_TASK).enumerate().for_each(|(c, ys)| {
            let first = c * ROWS_PER_TASK;
            for (k, yi) in ys.iter_mut().enumerate() {
                *yi = self.row_dot(first + k, x);
            }
        });
    }

    /// r = b − A x, rows in parallel.
    pub fn residual(&self, b: &[f64], x: &[f64], r: &mut [f64]) {
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
        Csr { nrows: self.ncols, ncols: self.nrows, row_ptr, col, val }
    }

    /// The product A B (rows of the result in parallel, each row gathered
    /// in a dense accumulator of the task's own).
    pub fn matmul(&self, other: &Csr) -> Csr {
        self.matmul_rows(0..self.nrows, other)
    }

    /// The rows `rows` of A B (numbered from 0): a product taken in row
    /// blocks needs memory for one block only.
    pub fn matmul_rows(&self, rows: Range<usize>, other: &Csr) -> Csr {
        assert_eq!(self.ncols, other.nrows, "inner dimensions of a sparse product");
        let first = rows.start;
        Csr::accumulate_rows(rows.len(), other.ncols, |i, acc| {
            let (ca, va) = self.row(first + i);
            for (&k, &a) in ca.iter().zip(va) {
                let (cb, vb) = other.row(k as usize);
                for (&j, &b) in cb.iter().zip(vb) {
                    acc.add(j, a * b);
                }
            }
        })
    }

    /// Builds a matrix whose row i sums what `row(i, acc)` adds to `acc`
    /// (entries named twice are summed, columns come out sorted): rows
    /// in parallel, each gathered in a dense accumulator of its task.
    pub fn accumulate_rows<F: Fn(usize, &mut RowAccumulator) + Sync>(nrows: usize, ncols: usize, row: F) -> Csr {
        let chunks: Vec<(Vec<usize>, Vec<u32>, Vec<f64>)> = (0..nrows.div_ceil(ROWS_PER_TASK))
            .into_par_iter()
            .map(|c| {
                let rows = c * ROWS_PER_TASK..((c + 1) * ROWS_PER_TASK).min(nrows);
                let mut acc = RowAccumulator { sum: vec![0.0; ncols], seen: vec![u32::MAX; ncols], row: 0, col: Vec::new() };
                let (mut lens, mut val) = (Vec::with_capacity(rows.len()), Vec::new());
                for i in rows {
                    let start = acc.col.len();
                    acc.row = i as u32;
                    row(i, &mut acc);
                    acc.col[start..].sort_unstable();
                    val.extend(acc.col[start..].iter().map(|&j| acc.sum[j as usize]));
                    lens.push(acc.col.len() - start);
                }
                (lens, acc.col, val)
            })
            .collect();
        let mut out = Csr { nrows, ncols, row_ptr: Vec::with_capacity(nrows + 1), col: Vec::new(), val: Vec::new() };
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

/// The dense accumulator of one row of [`Csr::accumulate_rows`].
pub struct RowAccumulator {
    sum: Vec<f64>,
    seen: Vec<u32>,
    row: u32,
    col: Vec<u32>,
}

impl RowAccumulator {
    /// Adds `v` to entry `j` of the current row.
    #[inline]
    pub fn add(&mut self, j: u32, v: f64) {
        let k = j as usize;
        if self.seen[k] != self.row {
            self.seen[k] = self.row;
            self.sum[k] = 0.0;
            self.col.push(j);
        }
        self.sum[k] += v;
    }
}

impl Csr {
    /// Rows `rows` of the matrix (numbered from 0), copied.
    pub fn row_block(&self, rows: Range<usize>) -> Csr {
        let (a, b) = (self.row_ptr[rows.start], self.row_ptr[rows.end]);
        Csr {
            nrows: rows.len(),
            ncols: self.ncols,
            row_ptr: self.row_ptr[rows.start..=rows.end].iter().map(|&k| k - a).collect(),
            col: self.col[a..b].to_vec(),
            val: self.val[a..b].to_vec(),
        }
    }

    /// The sum A + B of two matrices of the same shape (merged row by row).
    pub fn add(&self, other: &Csr) -> Csr {
        assert_eq!((self.nrows, self.ncols), (other.nrows, other.ncols), "shapes of a sparse sum");
        let mut out = Csr { nrows: self.nrows, ncols: self.ncols, row_ptr: Vec::with_capacity(self.nrows + 1), col: Vec::new(), val: Vec::new() };
        out.row_ptr.push(0);
        for i in 0..self.nrows {
            let (ca, va) = self.row(i);
            let (cb, vb) = other.row(i);
            let (mut x, mut y) = (0, 0);
            while x < ca.len() || y < cb.len() {
                let (c, v) = match (ca.get(x), cb.get(y)) {
                    (Some(&p), Some(&q)) if p == q => {
                        x += 1;
                        y += 1;
                        (p, va[x - 1] + vb[y - 1])
                    }
                    (Some(&p), Some(&q)) if p < q => {
                        x += 1;
                        (p, va[x - 1])
                    }
                    (Some(&p), None) => {
                        x += 1;
                        (p, va[x - 1])
                    }
                    (_, Some(&q)) => {
                        y += 1;
                        (q, vb[y - 1])
                    }
                    (None, None) => unreachable!("the loop runs while either row has entries"),
                };
                out.col.push(c);
                out.val.push(v);
            }
            out.row_ptr.push(out.col.len());
        }
        out
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
        Csr { nrows, ncols, row_ptr, col, val }
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
}
