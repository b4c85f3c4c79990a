//! Exact cache keys. A cache that replays earlier work (the structural memo, the per-row
//! torque and Jacobian caches) keeps the words of what that work was computed from (every
//! bit of the robot through `Robot::for_each_key_word`, plus its own inputs) and serves
//! only while a new call produces the very same words.

/// Writes a new key over an old one word by word and tells whether they were equal.
pub(crate) struct KeyWriter<'a> {
    key: &'a mut [u64],
    pos: usize,
    same: bool,
}

impl<'a> KeyWriter<'a> {
    /// Starts writing over `key` (its capacity; the old key's length is given at
    /// [`KeyWriter::finish`]).
    pub(crate) fn new(key: &'a mut [u64]) -> Self {
        KeyWriter {
            key,
            pos: 0,
            same: true,
        }
    }

    /// The next word of the new key.
    pub(crate) fn put(&mut self, w: u64) {
        match self.key.get_mut(self.pos) {
            Some(slot) if *slot == w => {}
            Some(slot) => {
                *slot = w;
                self.same = false;
            }
            None => self.same = false,
        }
        self.pos += 1;
    }

    /// `(the new key's length, hit)`: a hit when the new key equals the old one of `old_len`
    /// words (same words, same length, within capacity). A key longer than the capacity is
    /// never a hit; its length, kept by the caller, says so to the cache's other checks.
    pub(crate) fn finish(self, old_len: usize) -> (usize, bool) {
        let hit = self.same && self.pos <= self.key.len() && self.pos == old_len;
        (self.pos, hit)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(key: &mut [u64], words: &[u64], old_len: usize) -> (usize, bool) {
        let mut w = KeyWriter::new(key);
        words.iter().for_each(|&x| w.put(x));
        w.finish(old_len)
    }

    #[test]
    fn a_key_hits_only_when_every_word_and_the_length_are_the_same() {
        let mut key = [0u64; 4];
        assert_eq!(write(&mut key, &[1, 2, 3], 0), (3, false));
        assert_eq!(write(&mut key, &[1, 2, 3], 3), (3, true));
        assert_eq!(write(&mut key, &[1, 9, 3], 3), (3, false));
        assert_eq!(key, [1, 9, 3, 0]);
        // A prefix of the old key, or the old key extended by stale words, is a miss.
        assert_eq!(write(&mut key, &[1, 9], 3), (2, false));
        assert_eq!(write(&mut key, &[1, 9, 3], 2), (3, false));
        // Longer than the capacity: never a hit, even against its own length.
        assert_eq!(write(&mut key, &[1, 9, 3, 0, 5], 0), (5, false));
        assert_eq!(write(&mut key, &[1, 9, 3, 0, 5], 5), (5, false));
    }
}
