//! The first rows' Jacobian columns and residuals at one model, kept across the passes of
//! a diagnosis.
//!
//! Why: every pass over the rows (outlier screen, Gram of all rows, each fold's Gram and
//! held-out residuals, the half-range splits of the extrapolation check) evaluates each
//! row's identification Jacobian at the same model again — about fifteen times per row at
//! 120 rows where two would do (one per model linearised at). An entry is used only while
//! the cache is bound to the exact model (every bit, [`Robot::for_each_key_word`]) and the
//! same union `U` of columns it was filled under, so a hit gives the columns and the
//! residual bit for bit as computed.
//!
//! Memory: a fixed pool of [`ROW_POOL`] numbers shared by the rows, `6·|U| + 6` per row:
//! only the union's columns are kept, so a narrow union (the verdict's model, after
//! `cv::narrow_to_model`) keeps more rows than the full one. The rows beyond the pool are
//! computed every time; the pool is sized so that the workspace grows by at most 128 KiB
//! with the fits' torque cache (firmware reserves it): the first 27 rows of the 71-column
//! union of a 6-joint arm with every effect, 41 rows of a 47-column verdict model. A
//! 120-row diagnosis evaluated 1,680 Jacobians for its passes; with the cache 1,028
//! (instructions per diagnosis 127.5 -> 123.4 M). A pool for all 120 rows would cost about
//! 420 KB more (the first attempt's 537 KB for 128 rows of 80 columns).

use crate::any::MAX_JOINTS;
use crate::cache_key::KeyWriter;
use crate::kinematics::JacobianColumn;
use crate::model::{Robot, key_words};

/// Numbers in the pool (96,000 bytes).
pub(crate) const ROW_POOL: usize = 12_000;
/// Rows kept at most (a narrow union's rows are short).
pub(crate) const MAX_CACHED_ROWS: usize = 256;
/// Words of the largest key (a robot of [`MAX_JOINTS`] joints).
const KEY_CAPACITY: usize = key_words(MAX_JOINTS);

/// The cache. All-zero is the empty state (no key, no entry).
#[derive(Debug, Clone)]
pub(crate) struct RowCache<const P: usize> {
    pool: [f64; ROW_POOL],
    key: [u64; KEY_CAPACITY],
    key_len: usize,
    /// The union `U` (flat parameter indices) the entries hold the columns of.
    cols: [usize; P],
    n_cols: usize,
    filled: [bool; MAX_CACHED_ROWS],
    /// Changes whenever the key or the union does (see `cv::Lin`).
    generation: u64,
}

impl<const P: usize> RowCache<P> {
    /// Empty.
    pub(crate) const fn new() -> Self {
        RowCache {
            pool: [0.0; ROW_POOL],
            key: [0; KEY_CAPACITY],
            key_len: 0,
            cols: [0; P],
            n_cols: 0,
            filled: [false; MAX_CACHED_ROWS],
            generation: 0,
        }
    }

    /// Forgets every entry.
    pub(crate) fn clear(&mut self) {
        self.key_len = 0;
        self.n_cols = 0;
        self.filled = [false; MAX_CACHED_ROWS];
        self.generation = self.generation.wrapping_add(1);
    }

    /// Binds the cache to `robot` and the union `u`: the entries are kept when both are
    /// the ones they were filled under, all forgotten otherwise.
    pub(crate) fn bind<const N: usize>(&mut self, robot: &Robot<N>, u: &[usize]) {
        let mut key = KeyWriter::new(&mut self.key);
        robot.for_each_key_word(&mut |w| key.put(w));
        let (key_len, same) = key.finish(self.key_len);
        let same_u = self.cols.get(..self.n_cols) == Some(u);
        if !same || !same_u || u.len() > P {
            self.key_len = key_len;
            self.n_cols = u.len().min(P);
            for (c, &i) in self.cols.iter_mut().zip(u) {
                *c = i;
            }
            self.filled = [false; MAX_CACHED_ROWS];
            self.generation = self.generation.wrapping_add(1);
        }
    }

    /// The number of key or union changes so far (as `TorqueCache::generation`).
    pub(crate) fn generation(&self) -> u64 {
        self.generation
    }

    /// Numbers per row: the residual and six per column of the union.
    fn stride(&self) -> usize {
        6 + 6 * self.n_cols
    }

    /// Row `l`'s slot in the pool, when it fits.
    fn slot(&self, l: usize) -> Option<core::ops::Range<usize>> {
        let stride = self.stride();
        let start = l.checked_mul(stride)?;
        let end = start.checked_add(stride)?;
        (l < MAX_CACHED_ROWS && end <= ROW_POOL && self.key_len <= KEY_CAPACITY)
            .then_some(start..end)
    }

    /// Row `l`'s residual and its Jacobian columns of the union (six numbers per column,
    /// in the union's order), when kept under the bound key.
    pub(crate) fn get(&self, l: usize) -> Option<([f64; 6], &[f64])> {
        if !*self.filled.get(l)? {
            return None;
        }
        let row = self.pool.get(self.slot(l)?)?;
        let (e, cols) = row.split_first_chunk::<6>()?;
        Some((*e, cols))
    }

    /// Keeps row `l`'s residual `e` and the union's columns of its Jacobian `jac` (all the
    /// model's columns, flat), computed at the bound key.
    pub(crate) fn put(&mut self, l: usize, e: &[f64; 6], jac: &[JacobianColumn]) {
        let Some(range) = self.slot(l) else {
            return;
        };
        let (Some(row), Some(f)) = (self.pool.get_mut(range), self.filled.get_mut(l)) else {
            return;
        };
        let Some((re, rc)) = row.split_first_chunk_mut::<6>() else {
            return;
        };
        *re = *e;
        let cols = self.cols.get(..self.n_cols).unwrap_or(&[]);
        for (dst, &c) in rc.chunks_exact_mut(6).zip(cols) {
            let col = jac.get(c).copied().unwrap_or([0.0; 6]);
            for (d, v) in dst.iter_mut().zip(col) {
                *d = v;
            }
        }
        *f = true;
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::error::ParamIndex;
    use crate::model::JointState;

    #[test]
    fn a_row_is_served_only_under_its_model_and_union() {
        let robot = crate::aria::nominal();
        let state = JointState::new([0.3, -0.7, 1.1, 0.2, -0.5, 0.9]);
        let mut jac = [[0.0; 6]; Robot::<6>::NUM_PARAMS];
        robot.jacobian(&state, &mut jac).unwrap();
        let e = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        // 40 columns: the pool holds 48 rows of them.
        let u: [usize; 40] = core::array::from_fn(|i| i + i / 8);
        let mut c = RowCache::<64>::new();
        c.bind(&robot, &u);
        assert!(c.get(2).is_none());
        c.put(2, &e, &jac);
        let (got_e, cols) = c.get(2).unwrap();
        assert_eq!(got_e, e);
        let want: std::vec::Vec<f64> = u.iter().flat_map(|&i| jac[i]).collect();
        assert_eq!(cols, &want[..]);
        assert!(c.get(3).is_none());
        // The same model and union again: kept, the generation unchanged.
        let generation = c.generation();
        c.bind(&robot, &u);
        assert_eq!(c.generation(), generation);
        assert!(c.get(2).is_some());
        // Another union, or another model (one parameter changed), forgets the row.
        c.bind(&robot, &u[..39]);
        assert_ne!(c.generation(), generation);
        assert!(c.get(2).is_none());
        c.bind(&robot, &u);
        c.put(2, &e, &jac);
        let mut fitted = robot;
        fitted.set_param(ParamIndex(4), 1e-3).unwrap();
        c.bind(&fitted, &u);
        assert!(c.get(2).is_none());
        // Rows beyond the pool are never kept.
        let beyond = ROW_POOL / (6 + 6 * u.len());
        assert_eq!(beyond, 48);
        c.put(beyond, &e, &jac);
        assert!(c.get(beyond).is_none());
        c.put(beyond - 1, &e, &jac);
        assert!(c.get(beyond - 1).is_some());
    }
}
