//! The seeded generator the unit tests draw their random pictures and cases from: Knuth's MMIX
//! linear congruential generator, one stream per seed, so a failing case is the same case on
//! every run and every machine. One place for the constants and for which bits are used (the
//! high ones: an LCG's low bits cycle with short periods).

/// The generator's state; `Lcg(seed)` starts a stream.
pub(crate) struct Lcg(pub(crate) u64);

impl Lcg {
    /// The next state, all 64 bits (for tests that want raw words).
    pub(crate) fn next_u64(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0
    }

    /// A number below `n` (> 0), from the state's high 31 bits.
    pub(crate) fn below(&mut self, n: u64) -> u64 {
        (self.next_u64() >> 33) % n
    }

    /// A number in [0, 1), from the state's high 53 bits.
    pub(crate) fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::Lcg;

    /// The stream is MMIX's: the first states from seed 0 are the increment, then one step of
    /// the recurrence on it; `below` and `unit` stay in range.
    #[test]
    fn the_stream_is_mmix_and_draws_stay_in_range() {
        let mut r = Lcg(0);
        assert_eq!(r.next_u64(), 1442695040888963407);
        assert_eq!(
            r.next_u64(),
            1442695040888963407u64
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407)
        );
        let mut r = Lcg(42);
        let mut seen = [false; 7];
        for _ in 0..1000 {
            let b = r.below(7);
            assert!(b < 7);
            seen[b as usize] = true;
            let u = r.unit();
            assert!((0.0..1.0).contains(&u), "{u}");
        }
        assert!(
            seen.iter().all(|&s| s),
            "every value below 7 drawn: {seen:?}"
        );
    }
}
