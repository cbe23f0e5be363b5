//! Deterministic randomness: the same seed gives the same numbers on every machine and for any
//! thread count (values are hashed from keys, never drawn from shared generator state).

/// Sebastiano Vigna's SplitMix64 finaliser: a cheap, well-mixed 64-bit hash.
pub fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A sequential SplitMix64 generator, for the few places that draw in order (random walks).
#[derive(Debug, Clone)]
pub struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    /// A generator seeded with `seed`.
    pub fn new(seed: u64) -> SplitMix64 {
        SplitMix64 { state: seed }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        splitmix64(self.state)
    }

    /// A uniform number in [0, 1).
    pub fn next_f64(&mut self) -> f64 {
        unit_interval(self.next_u64())
    }
}

/// The `count` indices of 0 .. n whose hash of (index, `seed`, `salt`) ranks lowest, ascending: a
/// seeded choice that depends on neither order nor thread count.
pub fn ranked_choice(n: usize, count: usize, seed: u64, salt: u64) -> Vec<usize> {
    let mut ranked: Vec<(u64, usize)> = (0..n).map(|i| (splitmix64(seed ^ splitmix64(i as u64) ^ salt), i)).collect();
    if count == 0 || n == 0 {
        return Vec::new();
    }
    ranked.select_nth_unstable(count.min(n) - 1);
    let mut chosen: Vec<usize> = ranked[..count.min(n)].iter().map(|(_, i)| *i).collect();
    chosen.sort_unstable();
    chosen
}

/// Maps 64 random bits to a uniform number in [0, 1) with 53 bits of precision.
pub fn unit_interval(bits: u64) -> f64 {
    (bits >> 11) as f64 / (1u64 << 53) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ranked_choice_is_seeded_sorted_and_distinct() {
        let chosen = ranked_choice(1000, 24, 3, 0x5a4d);
        assert_eq!(chosen.len(), 24);
        assert!(chosen.windows(2).all(|pair| pair[0] < pair[1]));
        assert_eq!(chosen, ranked_choice(1000, 24, 3, 0x5a4d));
        assert_ne!(chosen, ranked_choice(1000, 24, 4, 0x5a4d));
        assert_eq!(ranked_choice(5, 9, 3, 0).len(), 5);
    }

    #[test]
    fn the_generator_is_reproducible_and_uniform() {
        let mut a = SplitMix64::new(42);
        let mut b = SplitMix64::new(42);
        let draws: Vec<f64> = (0..100_000).map(|_| a.next_f64()).collect();
        assert!(draws.iter().zip(std::iter::repeat_with(|| b.next_f64())).all(|(x, y)| *x == y));
        let mean = draws.iter().sum::<f64>() / draws.len() as f64;
        assert!((mean - 0.5).abs() < 0.005);
        assert!(draws.iter().all(|x| (0.0..1.0).contains(x)));
    }
}
