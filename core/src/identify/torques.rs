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

use crate::any::MAX_JOINTS;
use crate::model::{Robot, gravity_key_words};

/// Rows (the first of the data, by index) whose torques are kept: 120-row sessions fit
/// whole; larger sets gain on their first rows only (the cache costs 18 KiB of workspace).
pub(crate) const TORQUE_ROWS: usize = 128;

/// Words of the largest key (a robot of [`MAX_JOINTS`] joints).
const KEY_CAPACITY: usize = gravity_key_words(MAX_JOINTS);

/// The cache. All-zero is the empty state (no key, no entry).
#[derive(Debug, Clone)]
pub(crate) struct TorqueCache {
    key: [u64; KEY_CAPACITY],
    key_len: usize,
    /// Readings of each row's entry (bits), `[..N]`.
    q: [[u64; MAX_JOINTS]; TORQUE_ROWS],
    /// Torques of each row's entry, `[..N]`.
    tau: [[f64; MAX_JOINTS]; TORQUE_ROWS],
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
            q: [[0; MAX_JOINTS]; TORQUE_ROWS],
            tau: [[0.0; MAX_JOINTS]; TORQUE_ROWS],
            filled: [false; TORQUE_ROWS],
            generation: 0,
        }
    }

    /// Makes the entries those of `robot`'s gravity key: kept when the key is the one they
    /// were computed under, all forgotten otherwise (and the key replaced). Call before
    /// [`TorqueCache::get`]/[`TorqueCache::put`] with a robot whose key may differ.
    pub(crate) fn bind<const N: usize>(&mut self, robot: &Robot<N>) {
        let mut pos = 0usize;
        let mut same = true;
        let key = &mut self.key;
        robot.for_each_gravity_key_word(&mut |w| {
            match key.get_mut(pos) {
                Some(k) if *k == w => {}
                Some(k) => {
                    *k = w;
                    same = false;
                }
                None => same = false,
            }
            pos += 1;
        });
        if !same || pos != self.key_len || pos > KEY_CAPACITY {
            self.key_len = pos;
            self.filled = [false; TORQUE_ROWS];
            self.generation = self.generation.wrapping_add(1);
        }
    }

    /// The number of key changes so far: equal before and after a stretch of work, the
    /// cache is still bound to the key it was bound to before.
    pub(crate) fn generation(&self) -> u64 {
        self.generation
    }

    /// The torques of row `l` at readings `q`, when kept (for the bound key).
    pub(crate) fn get<const N: usize>(&self, l: usize, q: &[f64; N]) -> Option<[f64; N]> {
        if N > MAX_JOINTS || !*self.filled.get(l)? {
            return None;
        }
        let (kq, kt) = (self.q.get(l)?, self.tau.get(l)?);
        if q.iter().zip(kq).any(|(a, &b)| a.to_bits() != b) {
            return None;
        }
        let mut out = [0.0; N];
        for (o, &t) in out.iter_mut().zip(kt) {
            *o = t;
        }
        Some(out)
    }

    /// Keeps `tau`, computed at readings `q` (under the bound key), for row `l`.
    pub(crate) fn put<const N: usize>(&mut self, l: usize, q: &[f64; N], tau: &[f64; N]) {
        if N > MAX_JOINTS || self.key_len > KEY_CAPACITY {
            return;
        }
        let (Some(kq), Some(kt), Some(f)) =
            (self.q.get_mut(l), self.tau.get_mut(l), self.filled.get_mut(l))
        else {
            return;
        };
        for (k, v) in kq.iter_mut().zip(q) {
            *k = v.to_bits();
        }
        for (k, &v) in kt.iter_mut().zip(tau) {
            *k = v;
        }
        *f = true;
    }
}
