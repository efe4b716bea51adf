//! The fixed pseudo-random generator that builds every noise table.
//!
//! Why not the `rand` crate: a texture graph's output must be a pure function of the graph and its
//! seeds, forever. `rand`'s generators and distributions are allowed to change between versions
//! (and have), so a routine dependency upgrade could silently change every baked texture. The
//! tables are therefore built by this small, frozen generator, pinned by checksum tests.
//!
//! Generator: SplitMix64 (Steele, Lea & Flood, "Fast splittable pseudorandom number generators",
//! OOPSLA 2014), the same constants as `java.util.SplittableRandom` and Vigna's reference C code.

/// Per-table seed salts: each table of one `NoiseTable` gets its own SplitMix64 stream
/// (`seed ^ SALT`), so that, e.g., the permutation and the gradient vectors are independent
/// rather than two views of one stream. The constants are ASCII tags, chosen only to be distinct.
pub(super) const PERM_SALT: u64 = u64::from_be_bytes(*b"perm-tab");
/// Salt of the Gradient basis's unit-vector table; see [`PERM_SALT`].
pub(super) const GRAD_SALT: u64 = u64::from_be_bytes(*b"grad-tab");
/// Salt of the Value basis's value table; see [`PERM_SALT`].
pub(super) const VALUE_SALT: u64 = u64::from_be_bytes(*b"valu-tab");

/// Salt of the Cellular basis's feature-point table; see [`PERM_SALT`].
pub(super) const CELL_SALT: u64 = u64::from_be_bytes(*b"cell-tab");

/// SplitMix64: 64 bits of state, advanced by the golden-ratio increment and then mixed.
#[derive(Clone, Debug)]
pub(crate) struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    pub(crate) const fn new(seed: u64) -> Self {
        SplitMix64 { state: seed }
    }

    pub(crate) fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1): the top 53 bits scaled by 2^-53 (exact, no rounding).
    pub(crate) fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [-1, 1): exact too (2u is exact, 2u - 1 is exact for u in [0, 1)).
    pub(super) fn next_signed(&mut self) -> f64 {
        2.0 * self.next_f64() - 1.0
    }
}

/// The identity permutation of 0..=255 shuffled by Fisher–Yates (Durstenfeld's form), driven by
/// SplitMix64 seeded with `seed`. `j = next % (i + 1)`: the modulo bias is below 2^-56 and, being
/// part of the frozen definition, must not be "fixed".
pub(super) fn shuffled_permutation(seed: u64) -> [u8; 256] {
    let mut rng = SplitMix64::new(seed);
    let mut perm = [0u8; 256];
    for (i, p) in perm.iter_mut().enumerate() {
        *p = i as u8;
    }
    for i in (1..256usize).rev() {
        let j = (rng.next_u64() % (i as u64 + 1)) as usize;
        perm.swap(i, j);
    }
    perm
}
