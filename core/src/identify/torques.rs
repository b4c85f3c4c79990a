//! Gravity torques of the first rows of a data set, kept in the
//! [`Workspace`](super::Workspace) across the passes of a fit and across fits.
//!
//! Why: the compliance's joint angles and the identification Jacobian's compliance columns
//! need the gravity torques at each row's readings, a chain of the *nominal* geometry
//! (about as costly as a forward kinematics). They depend only on the nominal geometry,
//! the joint kinds, the mass model and the readings ([`Robot::for_each_gravity_key_word`]),
//! not on the calibrated geometry or the effects a fit changes every iteration: a
//! 120-row diagnosis computed them about 5,200 times where 120 would do. An entry is used
//! only for the robot key it was computed under and for readings equal bit for bit, so a
//! hit returns exactly what [`Robot::gravity_torques`] would compute.
//!
//! Memory: 13.7 KiB of the identification workspace (a 12 KiB pool of readings and
//! torques, the key of a 12-joint robot).

use crate::any::MAX_JOINTS;
use crate::cache_key::KeyWriter;
use crate::error::Result;
use crate::model::{Robot, gravity_key_words};

/// Rows (the first of the data, by index) whose torques are kept at most.
pub(crate) const TORQUE_ROWS: usize = 128;
/// Numbers in the pool: per row its readings and its torques, `2·N` (128 rows of a 6-joint
/// arm, 64 of a 12-joint one; 12 KiB).
const POOL: usize = 1_536;

/// Words of the largest key (a robot of [`MAX_JOINTS`] joints).
const KEY_CAPACITY: usize = gravity_key_words(MAX_JOINTS);

/// The cache. All-zero is the empty state (no key, no entry).
#[derive(Debug, Clone)]
pub(crate) struct TorqueCache {
    key: [u64; KEY_CAPACITY],
    key_len: usize,
    /// Row `l`'s readings and torques at `[2N·l, 2N·(l+1))`.
    pool: [f64; POOL],
    filled: [bool; TORQUE_ROWS],
    /// Changes whenever the key does: a pass that bound the cache once can check with one
    /// comparison that nothing rebound it meanwhile ([`TorqueCache::generation`]).
    generation: u64,
}

impl TorqueCache {
    /// Empty.
    pub(crate) const fn new() -> Self {
        TorqueCache {
            key: [0; KEY_CAPACITY],
            key_len: 0,
            pool: [0.0; POOL],
            filled: [false; TORQUE_ROWS],
            generation: 0,
        }
    }

    /// Makes the entries those of `robot`'s gravity key: kept when the key is the one they
    /// were computed under, all forgotten otherwise (and the key replaced). Call before
    /// [`TorqueCache::get`]/[`TorqueCache::put`] with a robot whose key may differ.
    pub(crate) fn bind<const N: usize>(&mut self, robot: &Robot<N>) {
        let mut key = KeyWriter::new(&mut self.key);
        robot.for_each_gravity_key_word(&mut |w| key.put(w));
        let (key_len, same) = key.finish(self.key_len);
        if !same {
            self.key_len = key_len;
            self.filled = [false; TORQUE_ROWS];
            self.generation = self.generation.wrapping_add(1);
        }
    }

    /// The number of key changes so far: equal before and after a stretch of work, the
    /// cache is still bound to the key it was bound to before.
    pub(crate) fn generation(&self) -> u64 {
        self.generation
    }

    /// Row `l`'s readings and torques in the pool, for `N` joints, when they fit.
    fn slot<const N: usize>(&self, l: usize) -> Option<core::ops::Range<usize>> {
        let start = l.checked_mul(2 * N)?;
        let end = start.checked_add(2 * N)?;
        (l < TORQUE_ROWS && end <= POOL && N <= MAX_JOINTS && self.key_len <= KEY_CAPACITY)
            .then_some(start..end)
    }

    /// The torques of row `l` at readings `q`, when kept (for the bound key).
    pub(crate) fn get<const N: usize>(&self, l: usize, q: &[f64; N]) -> Option<[f64; N]> {
        if !*self.filled.get(l)? {
            return None;
        }
        let (kq, kt) = self.pool.get(self.slot::<N>(l)?)?.split_at_checked(N)?;
        if q.iter().zip(kq).any(|(a, b)| a.to_bits() != b.to_bits()) {
            return None;
        }
        let mut out = [0.0; N];
        for (o, &t) in out.iter_mut().zip(kt) {
            *o = t;
        }
        Some(out)
    }

    /// Runs `compute` with row `l`'s torques at readings `q` when kept (`Some`), else with
    /// `None` for it to fill in as it computes them, and keeps what it computed: the one
    /// way the fits and the diagnosis use the cache (bound to their robot's key first).
    pub(crate) fn through<const N: usize, T>(
        &mut self,
        l: usize,
        q: &[f64; N],
        compute: impl FnOnce(&mut Option<[f64; N]>) -> Result<T>,
    ) -> Result<T> {
        let known = self.get(l, q);
        let mut tau = known;
        let out = compute(&mut tau)?;
        if let (None, Some(tau)) = (known, tau) {
            self.put(l, q, &tau);
        }
        Ok(out)
    }

    /// Keeps `tau`, computed at readings `q` (under the bound key), for row `l`.
    pub(crate) fn put<const N: usize>(&mut self, l: usize, q: &[f64; N], tau: &[f64; N]) {
        let Some(range) = self.slot::<N>(l) else {
            return;
        };
        let (Some(row), Some(f)) = (self.pool.get_mut(range), self.filled.get_mut(l)) else {
            return;
        };
        for (k, v) in row.iter_mut().zip(q.iter().chain(tau)) {
            *k = *v;
        }
        *f = true;
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::error::ParamIndex;

    fn bits(t: [f64; 6]) -> [u64; 6] {
        t.map(f64::to_bits)
    }

    #[test]
    fn an_entry_serves_only_its_row_readings_and_gravity_key() {
        let robot = crate::aria::nominal();
        let q = [0.3, -0.7, 1.1, 0.2, -0.5, 0.9];
        let tau = robot.gravity_torques(&q);
        let mut c = TorqueCache::new();
        c.bind(&robot);
        assert_eq!(c.get(3, &q), None);
        c.put(3, &q, &tau);
        assert_eq!(c.get(3, &q).map(bits), Some(bits(tau)));
        // Another row, or readings one ulp away, miss.
        assert_eq!(c.get(4, &q), None);
        let mut q2 = q;
        q2[5] = f64::from_bits(q[5].to_bits() + 1);
        assert_eq!(c.get(3, &q2), None);
        // A fitted geometry or effect (what a fit changes) keeps the entries: the torques
        // come from the nominal geometry and the mass model only.
        let generation = c.generation();
        let mut fitted = robot;
        fitted.set_param(ParamIndex(0), 0.01).unwrap();
        let compliance = crate::params::ParamId::Compliance(1).index(6);
        fitted.set_param(compliance, 1e-4).unwrap();
        assert_eq!(fitted.gravity_torques(&q).map(f64::to_bits), bits(tau));
        c.bind(&fitted);
        assert_eq!(c.generation(), generation);
        assert_eq!(c.get(3, &q).map(bits), Some(bits(tau)));
        // Another mass model forgets them, and binding back does not revive them.
        let mut heavy = robot;
        heavy.mass.tool_mass_kg += 1.0;
        assert_ne!(heavy.gravity_torques(&q).map(f64::to_bits), bits(tau));
        c.bind(&heavy);
        assert_ne!(c.generation(), generation);
        assert_eq!(c.get(3, &q), None);
        c.bind(&robot);
        assert_eq!(c.get(3, &q), None);
        // Rows beyond the cache are never kept.
        c.put(TORQUE_ROWS, &q, &tau);
        assert_eq!(c.get(TORQUE_ROWS, &q), None);
    }

    /// `through` hands a kept row's torques to the computation and keeps what a computation
    /// of a new row left, so the second pass over a row computes nothing.
    #[test]
    fn through_keeps_what_was_computed_and_serves_it_next_time() {
        let robot = crate::aria::nominal();
        let q = [0.3, -0.7, 1.1, 0.2, -0.5, 0.9];
        let tau = robot.gravity_torques(&q);
        let mut c = TorqueCache::new();
        c.bind(&robot);
        let first = c.through(2, &q, |t| {
            assert!(t.is_none());
            *t = Some(tau);
            Ok(7)
        });
        assert_eq!(first, Ok(7));
        let second = c.through(2, &q, |t| Ok(t.map(bits)));
        assert_eq!(second, Ok(Some(bits(tau))));
        // A failed computation keeps nothing.
        let failed: Result<()> = c.through(5, &q, |t| {
            *t = Some(tau);
            Err(crate::Error::NonFinite {
                what: crate::Quantity::JointReading,
                index: 0,
            })
        });
        assert!(failed.is_err());
        assert_eq!(c.get(5, &q), None);
    }
}
