//! A small deterministic random number generator: xoshiro256++ seeded
//! through SplitMix64, one independent stream per (seed, stream index).

/// SplitMix64's output function (a bijection of u64).
#[inline]
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// xoshiro256++ (Blackman and Vigna, 2019).
#[derive(Clone, Debug)]
pub struct Rng {
    s: [u64; 4],
}

impl Rng {
    /// The generator of stream `stream` under `seed`: its state is four
    /// SplitMix64 outputs from a start that mixes both, so streams of one
    /// seed and seeds of one stream are unrelated.
    pub fn new(seed: u64, stream: u64) -> Rng {
        let mut x = mix(mix(seed ^ 0x6A09_E667_F3BC_C908) ^ stream);
        let mut next = || {
            x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
            mix(x)
        };
        let s = [next(), next(), next(), next()];
        Rng { s }
    }

    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        let s = &mut self.s;
        let r = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        r
    }

    /// Uniform in [0, 1) with 53 random bits.
    #[inline]
    pub fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<u64> = (0..4).map(|_| Rng::new(1, 0).next_u64()).collect();
        assert!(a.windows(2).all(|w| w[0] == w[1]));
        let mut x = Rng::new(1, 0);
        let mut y = Rng::new(1, 1);
        let mut z = Rng::new(2, 0);
        let (p, q, r) = (x.next_u64(), y.next_u64(), z.next_u64());
        assert!(p != q && p != r && q != r);
    }

    #[test]
    fn uniform_mean_and_range() {
        let mut r = Rng::new(7, 3);
        let n = 100_000;
        let mut sum = 0.0;
        for _ in 0..n {
            let u = r.f64();
            assert!((0.0..1.0).contains(&u));
            sum += u;
        }
        let mean = sum / n as f64;
        // Standard error of the mean: sqrt(1/12 / n) ≈ 0.0009.
        assert!((mean - 0.5).abs() < 0.004, "{mean}");
    }
}
