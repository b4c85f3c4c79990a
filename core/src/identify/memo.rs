//! The structural step's result kept in the [`Workspace`](super::Workspace) between calls.
//!
//! Why: the structural step of the identifiability analysis (which requested parameters are
//! redundant in the model itself, tested on generic configurations) does not look at the
//! data's poses, only at the model, the measured components, the measured points and the
//! auxiliary inputs. It took about a fifth of a 10-pose calibration and gives the same
//! answer on every call of a loop that fits the same model to new data. It is kept here
//! with an exact key — every bit of the robot ([`Robot::for_each_key_word`]) and of the
//! selection — so a changed model, parameter set, weight or point recomputes it, and a
//! repeated one replays the identical result (the same sets, partners and column order as
//! the computation, bit for bit).

use super::identifiability::{Partner, StructuralSel};
use super::{IdentifyOptions, MAX_MODEL_PARAMS};
use crate::cache_key::KeyWriter;
use crate::error::{ParamIndex, Result};
use crate::model::{Robot, key_words};
use crate::params::ParamSet;

/// Words of the largest key: the robot of [`crate::any::MAX_JOINTS`] joints plus the
/// selection (joints, mask, flags, two weights, the points, the requested set).
pub(crate) const KEY_CAPACITY: usize = key_words(crate::any::MAX_JOINTS)
    + 8
    + 3 * super::data::MAX_STRUCTURAL_POINTS
    + crate::params::PARAM_SET_CAPACITY / 64;

/// A remembered structural step: its key and what it wrote. All-zero is the empty state
/// (`valid` false).
#[derive(Debug, Clone)]
pub(crate) struct StructuralMemo<const P: usize> {
    key: [u64; KEY_CAPACITY],
    key_len: usize,
    valid: bool,
    /// Kept columns (flat indices, priority order): `ws.free[..n_kept]`.
    kept: [usize; P],
    n_kept: usize,
    /// Dropped columns (flat indices) with the partner the step wrote for each.
    dropped: [usize; P],
    dropped_partner: [usize; P],
    dropped_cosine: [f64; P],
    dropped_has_partner: [bool; P],
    n_dropped: usize,
}

impl<const P: usize> StructuralMemo<P> {
    /// Empty.
    pub(crate) const fn new() -> Self {
        StructuralMemo {
            key: [0; KEY_CAPACITY],
            key_len: 0,
            valid: false,
            kept: [0; P],
            n_kept: 0,
            dropped: [0; P],
            dropped_partner: [0; P],
            dropped_cosine: [0.0; P],
            dropped_has_partner: [false; P],
            n_dropped: 0,
        }
    }

    /// Forgets the remembered step.
    pub(crate) fn clear(&mut self) {
        self.valid = false;
        self.key_len = 0;
    }

    /// Whether the remembered step was made with exactly this robot and selection. On a
    /// miss the key is replaced by this one (and the memo stays invalid until
    /// [`StructuralMemo::store_kept`] and [`StructuralMemo::store_dropped`] have run);
    /// a key longer than [`KEY_CAPACITY`] is never remembered.
    pub(crate) fn lookup<const N: usize>(
        &mut self,
        robot: &Robot<N>,
        sel: &StructuralSel<'_>,
        opts: &IdentifyOptions<'_>,
    ) -> bool {
        let mut key = KeyWriter::new(&mut self.key);
        key.put(N as u64);
        robot.for_each_key_word(&mut |w| key.put(w));
        key.put(u64::from(sel.mask.0));
        key.put(u64::from(sel.any_approach));
        key.put(u64::from(sel.any_temp));
        key.put(u64::from(sel.base_first));
        // The structural rows carry the component weights (their right-hand side is zero,
        // so the orientation error and the data's poses do not enter).
        key.put(opts.weight_pos.to_bits());
        key.put(opts.weight_rot.to_bits());
        key.put(sel.points.len() as u64);
        for p in sel.points {
            match p {
                None => key.put(0),
                Some(v) => {
                    key.put(1);
                    v.iter().for_each(|x| key.put(x.to_bits()));
                }
            }
        }
        opts.requested.words().iter().for_each(|&w| key.put(w));
        let (key_len, same) = key.finish(self.key_len);
        let hit = self.valid && same;
        if !hit {
            self.valid = false;
            self.key_len = key_len;
            self.n_kept = 0;
            self.n_dropped = 0;
        }
        hit
    }

    /// Remembers the kept columns of the step just computed for the key of the last
    /// missed [`StructuralMemo::lookup`].
    pub(crate) fn store_kept(&mut self, kept: &[usize]) {
        self.n_kept = 0;
        for (slot, &c) in self.kept.iter_mut().zip(kept) {
            *slot = c;
            self.n_kept += 1;
        }
    }

    /// Remembers one dropped column and the partner the step wrote for it.
    pub(crate) fn store_dropped(&mut self, col: usize, partner: Option<Partner>) {
        let k = self.n_dropped;
        if let (Some(c), Some(pp), Some(pc), Some(ph)) = (
            self.dropped.get_mut(k),
            self.dropped_partner.get_mut(k),
            self.dropped_cosine.get_mut(k),
            self.dropped_has_partner.get_mut(k),
        ) {
            *c = col;
            *ph = partner.is_some();
            *pp = partner.map_or(0, |p| p.param.0);
            *pc = partner.map_or(0.0, |p| p.cosine);
            self.n_dropped += 1;
        }
    }

    /// Marks the stored step complete (when its key fitted).
    pub(crate) fn commit(&mut self) {
        self.valid = self.key_len > 0;
    }

    /// Replays the remembered step: the kept columns into `free`, each dropped requested
    /// column into `structural`, every dropped column's partner into `partner`. Returns the
    /// number of kept columns.
    pub(crate) fn replay(
        &self,
        requested: &ParamSet,
        free: &mut [usize; P],
        structural: &mut ParamSet,
        partner: &mut [Option<Partner>; MAX_MODEL_PARAMS],
    ) -> Result<usize> {
        let n = self.n_kept.min(P);
        for (f, &c) in free.iter_mut().zip(self.kept.iter().take(n)) {
            *f = c;
        }
        let dropped = self
            .dropped
            .iter()
            .zip(&self.dropped_partner)
            .zip(&self.dropped_cosine)
            .zip(&self.dropped_has_partner)
            .take(self.n_dropped);
        for (((&col, &param), &cosine), &has) in dropped {
            if requested.contains(col) {
                structural.insert(col)?;
            }
            if let Some(slot) = partner.get_mut(col) {
                *slot = has.then_some(Partner {
                    param: ParamIndex(param),
                    cosine,
                });
            }
        }
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Algorithm, IdentifyOptions, Workspace, analyze};
    use crate::identify::Measurement;
    use crate::model::{Robot, key_words};
    use crate::{ParamIndex, aria};

    fn data() -> [Measurement<6>; 8] {
        let truth = aria::virtual_truth();
        core::array::from_fn(|l| {
            let q = core::array::from_fn(|j| 0.3 * (l as f64 + 1.0) - 0.2 * j as f64);
            Measurement::new(q, truth.fk_q(&q).expect("fk"))
        })
    }

    /// The key has the documented length, and each robot's words differ when one
    /// parameter does.
    #[test]
    fn key_words_cover_the_robot() {
        let r = aria::nominal();
        let mut n = 0;
        r.for_each_key_word(&mut |_| n += 1);
        assert_eq!(n, key_words(6));
        let mut words = [0u64; key_words(6)];
        let mut i = 0;
        r.for_each_key_word(&mut |w| {
            words[i] = w;
            i += 1;
        });
        for p in 0..Robot::<6>::NUM_PARAMS {
            let mut other = r;
            let v = r.param(ParamIndex(p)).expect("param");
            other.set_param(ParamIndex(p), v + 1e-6).expect("set");
            let mut differ = false;
            let mut i = 0;
            other.for_each_key_word(&mut |w| {
                differ |= words[i] != w;
                i += 1;
            });
            assert!(differ, "parameter {p} is not in the key");
        }
    }

    /// The second analysis of the same problem replays the step; a change recomputes it.
    #[test]
    fn hit_on_repeat_miss_on_change() {
        let nominal = aria::nominal();
        let data = data();
        let opts = IdentifyOptions::new(Algorithm::Ols, nominal.geometric_param_set());
        let mut ws = Workspace::<32>::new();
        assert!(!ws.memo.valid);
        let a = analyze(&nominal, &data, &opts, &mut ws).expect("analysis");
        assert!(ws.memo.valid);
        let len = ws.memo.key_len;
        assert!(len > key_words(6) && len <= super::KEY_CAPACITY);
        let b = analyze(&nominal, &data, &opts, &mut ws).expect("analysis");
        assert_eq!(a, b);
        let mut other = nominal;
        other
            .set_param(
                ParamIndex(1),
                nominal.param(ParamIndex(1)).expect("d_1") + 1e-3,
            )
            .expect("set");
        let sel = super::StructuralSel {
            mask: crate::identify::ComponentMask::ALL,
            points: &[None],
            any_approach: false,
            any_temp: false,
            base_first: false,
        };
        assert!(ws.memo.lookup(&nominal, &sel, &opts), "same problem: a hit");
        assert!(
            !ws.memo.lookup(&other, &sel, &opts),
            "changed model: a miss"
        );
        assert!(!ws.memo.valid, "a miss leaves nothing to replay");
        assert!(
            !ws.memo.lookup(&other, &sel, &opts),
            "not stored yet: still a miss"
        );
        ws.forget_structure();
        assert!(!ws.memo.lookup(&nominal, &sel, &opts));
    }
}
