//! [`WindowStats`]: one channel's statistics over a GPU bake window, as `wgsl/pack.wgsl`
//! reduces them per workgroup and `bake.rs` adds them up.

/// Bytes of one `pack` workgroup's statistics record (`Stats` in `wgsl/pack.wgsl`: an f64, two
/// f32, six u32).
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub(super) const STATS_BYTES: u64 = 40;

/// One channel's statistics over a window, as `pack.wgsl` reduces them: min, max and sum over
/// the finite values, and the counts the bake's report prints.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindowStats {
    pub min: f32,
    pub max: f32,
    pub sum: f64,
    pub finite: u64,
    pub nan: u64,
    pub pos_inf: u64,
    pub neg_inf: u64,
    /// Values below 0 and above 1 (infinities included).
    pub below: u64,
    pub above: u64,
}

impl Default for WindowStats {
    fn default() -> Self {
        WindowStats {
            min: f32::MAX,
            max: -f32::MAX,
            sum: 0.0,
            finite: 0,
            nan: 0,
            pos_inf: 0,
            neg_inf: 0,
            below: 0,
            above: 0,
        }
    }
}

impl WindowStats {
    /// Adds one workgroup's `Stats` record (40 bytes, little-endian).
    #[cfg_attr(not(feature = "gpu"), allow(dead_code))]
    pub(crate) fn add(&mut self, b: &[u8]) {
        let word = |i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
        let finite = u64::from(word(16));
        if finite > 0 {
            let mut sum = [0u8; 8];
            sum.copy_from_slice(&b[..8]);
            self.sum += f64::from_le_bytes(sum);
            self.min = self.min.min(f32::from_bits(word(8)));
            self.max = self.max.max(f32::from_bits(word(12)));
        }
        self.finite += finite;
        self.nan += u64::from(word(20));
        self.pos_inf += u64::from(word(24));
        self.neg_inf += u64::from(word(28));
        self.below += u64::from(word(32));
        self.above += u64::from(word(36));
    }
}
