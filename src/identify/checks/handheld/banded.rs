//! The information of a few parameters when a long, banded nuisance is unknown: the Schur
//! complement J = B − Cᵀ·A⁻¹·C, streamed row by row.
//!
//! Measurements are scalar rows y = aᵀx + hᵀθ + n, n ~ N(0, 1/w), with x the nuisance (one
//! variable per index, many) and θ the parameters (few). Their information is
//! [[A, C], [Cᵀ, B]] = Σ w·[a; h]·[a; h]ᵀ; with x unknown, the information left for θ is
//! J = B − Cᵀ·A⁻¹·C. When every row's nuisance indices lie within `band` of each other, A is
//! banded and J follows from its Cholesky factor A = L·Lᵀ, itself banded, as B − YᵀY with
//! Y = L⁻¹·C. Rows are factored as soon as no later measurement can touch them, so memory is
//! O(band²) whatever the log's length and the cost O(n·band²).

use nalgebra::DMatrix;
use std::collections::VecDeque;

/// J = B − Cᵀ·A⁻¹·C of measurements added in the order of their nuisance indices (see the
/// module doc).
pub(super) struct BandedSchur {
    /// Half-bandwidth of A: |i − j| ≤ band for every entry.
    band: usize,
    /// The first nuisance index not yet factored.
    next: usize,
    /// Rows next, next + 1, … of A as assembled so far: A[i][i − band + m] at m (m = band is the
    /// diagonal), and C's row i.
    pending: VecDeque<(Vec<f64>, Vec<f64>)>,
    /// The last band + 1 rows of L (row i in slot i mod (band + 1), L[i][i − band + m] at m) and
    /// of Y.
    l: Vec<Vec<f64>>,
    y: Vec<Vec<f64>>,
    /// 1/L[i][i] of the same rows (a product is faster than a quotient on the critical path).
    inv: Vec<f64>,
    /// B, less YᵀY of the rows factored: its upper triangle, row-major p × p.
    j: Vec<f64>,
    /// The number of parameters p.
    p: usize,
    /// Rows of A and C factored, kept for reuse.
    spare: Vec<(Vec<f64>, Vec<f64>)>,
}

impl BandedSchur {
    /// An empty system of `p` parameters whose nuisance has half-bandwidth `band`.
    pub(super) fn new(p: usize, band: usize) -> Self {
        BandedSchur {
            band,
            next: 0,
            pending: VecDeque::new(),
            l: vec![vec![0.0; band + 1]; band + 1],
            y: vec![vec![0.0; p]; band + 1],
            inv: vec![0.0; band + 1],
            j: vec![0.0; p * p],
            p,
            spare: Vec::new(),
        }
    }

    /// Adds a measurement row of weight `w` (the inverse of its variance): its nuisance terms
    /// (index, coefficient) and its parameter row `h`.
    ///
    /// # Panics
    /// A term whose index is already factored, or two terms further apart than the band: both
    /// are the caller's ordering errors, not the data's.
    pub(super) fn add(&mut self, terms: &[(usize, f64)], h: &[f64], w: f64) {
        let b = self.band;
        for &(i, ai) in terms {
            assert!(i >= self.next, "nuisance index {i} is already factored (next {})", self.next);
            while self.pending.len() <= i - self.next {
                let row = self.spare.pop().unwrap_or_else(|| (vec![0.0; b + 1], vec![0.0; h.len()]));
                self.pending.push_back(row);
            }
            let (row, c) = &mut self.pending[i - self.next];
            for &(j, aj) in terms.iter().filter(|(j, _)| *j <= i) {
                assert!(i - j <= b, "terms {j} and {i} are further apart than the band {b}");
                row[b - (i - j)] += w * ai * aj;
            }
            for (c, h) in c.iter_mut().zip(h) {
                *c += w * ai * h;
            }
        }
        if h.iter().any(|x| *x != 0.0) {
            upper_rank_one(&mut self.j, h, w);
        }
    }

    /// Factors every row before `end`: no measurement added later may touch them. `None` when
    /// A is not positive definite there (a nuisance no measurement sees).
    pub(super) fn factor_until(&mut self, end: usize) -> Option<()> {
        let (b, p) = (self.band, self.p);
        while self.next < end {
            let i = self.next;
            let (mut a, mut c) = self.pending.pop_front().unwrap_or_else(|| (vec![0.0; b + 1], vec![0.0; p]));
            let mut row = std::mem::take(&mut self.l[i % (b + 1)]);
            row.iter_mut().for_each(|x| *x = 0.0);
            // L[i][j] for j = i − band … i, the entries before the first row zero
            for m in b.saturating_sub(i)..=b {
                // Σ over l from i − band to j − 1 of L[i][l]·L[j][l]: row i at 0..m, row j at b − m..b
                if m == b {
                    let s = a[b] - dot(&row[..b], &row[..b]);
                    if s.is_nan() || s <= 0.0 {
                        return None;
                    }
                    row[b] = s.sqrt();
                    self.inv[i % (b + 1)] = 1.0 / row[b];
                } else {
                    let lj = &self.l[(i + m - b) % (b + 1)];
                    row[m] = (a[m] - dot(&row[..m], &lj[b - m..b])) * self.inv[(i + m - b) % (b + 1)];
                }
            }
            for m in b.saturating_sub(i)..b {
                let yl = &self.y[(i + m - b) % (b + 1)];
                for (yk, yl) in c.iter_mut().zip(yl) {
                    *yk -= row[m] * yl;
                }
            }
            let inv = self.inv[i % (b + 1)];
            c.iter_mut().for_each(|v| *v *= inv);
            upper_rank_one(&mut self.j, &c, -1.0);
            self.l[i % (b + 1)] = row;
            // the slot's old Y row and this row's A go back to the spares, zeroed
            let mut old = std::mem::replace(&mut self.y[i % (b + 1)], c);
            a.iter_mut().for_each(|x| *x = 0.0);
            old.iter_mut().for_each(|x| *x = 0.0);
            self.spare.push((a, old));
            self.next += 1;
        }
        Some(())
    }

    /// J, once every nuisance index below `n` is factored. `None` as [`Self::factor_until`].
    pub(super) fn finish(mut self, n: usize) -> Option<DMatrix<f64>> {
        self.factor_until(n)?;
        let p = self.p;
        Some(DMatrix::from_fn(p, p, |r, s| self.j[r.min(s) * p + r.max(s)]))
    }
}

/// Σ x_i·y_i over four running sums (so that it vectorises), in a fixed order.
fn dot(x: &[f64], y: &[f64]) -> f64 {
    let mut acc = [0.0; 4];
    let (xc, yc) = (x.chunks_exact(4), y.chunks_exact(4));
    let tail: f64 = xc.remainder().iter().zip(yc.remainder()).map(|(a, b)| a * b).sum();
    for (a, b) in xc.zip(yc) {
        for k in 0..4 {
            acc[k] += a[k] * b[k];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// J += w·h·hᵀ on the upper triangle of a row-major square `j`.
fn upper_rank_one(j: &mut [f64], h: &[f64], w: f64) {
    let p = h.len();
    for (r, hr) in h.iter().enumerate().filter(|(_, x)| **x != 0.0) {
        let whr = w * hr;
        for (jv, hs) in j[r * p + r..(r + 1) * p].iter_mut().zip(&h[r..]) {
            *jv += whr * hs;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Component, Stream as Rng};

    /// The streamed J is the dense B − Cᵀ·A⁻¹·C of the same rows, built and inverted whole by
    /// nalgebra, on 60 nuisance variables of band 5 and 3 parameters with rows of random
    /// coefficients and weights, factored early in steps as a caller does. A band entry put on
    /// the wrong side of the diagonal, a term dropped from the dot product or a Y row taken
    /// from the wrong slot moves J far beyond 1e-9.
    #[test]
    fn the_streamed_schur_complement_is_the_dense_one() {
        let (n, band, p) = (60, 5, 3);
        let mut r = Rng::new(3, Component::Bound, 0);
        type Row = (Vec<(usize, f64)>, Vec<f64>, f64);
        let mut rows: Vec<Row> = Vec::new();
        for start in 0..n {
            for _ in 0..3 {
                let width = 1 + (r.uniform() * (band + 1) as f64) as usize;
                let terms: Vec<(usize, f64)> = (start..(start + width).min(n)).map(|i| (i, r.normal())).collect();
                let h: Vec<f64> = (0..p).map(|_| r.normal()).collect();
                rows.push((terms, h, 0.5 + r.uniform()));
            }
        }
        let mut streamed = BandedSchur::new(p, band);
        for (k, (terms, h, w)) in rows.iter().enumerate() {
            streamed.add(terms, h, *w);
            // rows before the next row's first index are complete
            if let Some((next, _, _)) = rows.get(k + 1) {
                streamed.factor_until(next[0].0).unwrap();
            }
        }
        let j = streamed.finish(n).unwrap();
        let mut full = DMatrix::<f64>::zeros(n + p, n + p);
        for (terms, h, w) in &rows {
            let mut v = nalgebra::DVector::<f64>::zeros(n + p);
            terms.iter().for_each(|(i, a)| v[*i] = *a);
            h.iter().enumerate().for_each(|(k, x)| v[n + k] = *x);
            full += &v * v.transpose() * *w;
        }
        let a = full.view((0, 0), (n, n)).clone_owned();
        let c = full.view((0, n), (n, p)).clone_owned();
        let b = full.view((n, n), (p, p)).clone_owned();
        let dense = b - c.transpose() * a.cholesky().unwrap().inverse() * &c;
        assert!((&j - &dense).abs().max() < 1e-9 * dense.abs().max(), "{j} against {dense}");
    }

    /// A nuisance variable no row sees leaves A singular: `None`, not a number.
    #[test]
    fn an_unseen_nuisance_is_none() {
        let mut s = BandedSchur::new(1, 1);
        s.add(&[(0, 1.0)], &[1.0], 1.0);
        s.add(&[(2, 1.0)], &[1.0], 1.0);
        assert!(s.finish(3).is_none());
    }
}
