//! Padding (edge dilation): uncovered texels within N texels of a UV island take the value of
//! the nearest covered texel, so bilinear filtering and mip levels do not bleed the background
//! into the islands; texels further away stay 0.
//!
//! Nearest is Euclidean, between texel centres, found exactly in two passes: per row the
//! nearest covered column on each side, then per texel the best of the 2N + 1 rows within
//! reach (a fixed dy is best served by that row's nearest column). Ties go to the upper row,
//! then the left column, so the result does not depend on the thread count.

use rayon::prelude::*;

/// No source.
pub const NONE: u32 = u32::MAX;

/// Per texel: itself when covered, the nearest covered texel within `radius` texels (Euclidean)
/// when not, else [`NONE`].
pub fn nearest_covered(covered: &[bool], width: usize, height: usize, radius: u32) -> Vec<u32> {
    assert_eq!(covered.len(), width * height);
    let r = radius as i64;
    // Per texel, the column of the nearest covered texel in its own row within `radius` (-1:
    // none); ties to the left.
    let mut row_nearest = vec![-1i32; width * height];
    row_nearest
        .par_chunks_mut(width)
        .zip(covered.par_chunks(width))
        .for_each(|(nearest, covered)| {
            let mut left = None;
            let mut lefts = vec![-1i64; width];
            for i in 0..width {
                if covered[i] {
                    left = Some(i as i64);
                }
                lefts[i] = left.filter(|&l| i as i64 - l <= r).unwrap_or(-1);
            }
            let mut right = None;
            for i in (0..width).rev() {
                if covered[i] {
                    right = Some(i as i64);
                }
                let right = right.filter(|&c| c - i as i64 <= r);
                nearest[i] = match (lefts[i], right) {
                    (-1, None) => -1,
                    (-1, Some(c)) => c,
                    (l, None) => l,
                    (l, Some(c)) if c - (i as i64) < (i as i64) - l => c,
                    (l, Some(_)) => l,
                } as i32;
            }
        });
    let mut source = vec![NONE; width * height];
    source
        .par_chunks_mut(width)
        .enumerate()
        .for_each(|(j, sources)| {
            for (i, out) in sources.iter_mut().enumerate() {
                if covered[j * width + i] {
                    *out = (j * width + i) as u32;
                    continue;
                }
                let mut best: Option<(i64, usize)> = None;
                let top = (j as i64 - r).max(0) as usize;
                let bottom = (j as i64 + r).min(height as i64 - 1) as usize;
                for row in top..=bottom {
                    let c = i64::from(row_nearest[row * width + i]);
                    if c < 0 {
                        continue;
                    }
                    let (dx, dy) = (c - i as i64, row as i64 - j as i64);
                    let d2 = dx * dx + dy * dy;
                    if d2 <= r * r && best.is_none_or(|(b, _)| d2 < b) {
                        best = Some((d2, row * width + c as usize));
                    }
                }
                if let Some((_, texel)) = best {
                    *out = texel as u32;
                }
            }
        });
    source
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same answer by brute force: every covered texel, nearest by distance, ties to the
    /// upper row then the left column.
    fn brute(covered: &[bool], width: usize, height: usize, radius: u32) -> Vec<u32> {
        (0..width * height)
            .map(|t| {
                if covered[t] {
                    return t as u32;
                }
                let (i, j) = ((t % width) as i64, (t / width) as i64);
                let mut best: Option<(i64, i64, i64, usize)> = None;
                for (s, _) in covered.iter().enumerate().filter(|(_, c)| **c) {
                    let (x, y) = ((s % width) as i64, (s / width) as i64);
                    let d2 = (x - i).pow(2) + (y - j).pow(2);
                    let key = (d2, y, x, s);
                    if d2 <= i64::from(radius).pow(2) && best.is_none_or(|b| key < b) {
                        best = Some(key);
                    }
                }
                best.map_or(NONE, |b| b.3 as u32)
            })
            .collect()
    }

    #[test]
    fn nearest_covered_texel_agrees_with_brute_force() {
        let (width, height) = (23, 17);
        let mut state = 12345u64;
        for radius in [0, 1, 2, 5, 30] {
            let covered: Vec<bool> = (0..width * height)
                .map(|_| {
                    state = state.wrapping_mul(6364136223846793005).wrapping_add(1);
                    (state >> 60) == 0
                })
                .collect();
            let fast = nearest_covered(&covered, width, height, radius);
            let slow = brute(&covered, width, height, radius);
            // Equal distances may pick different texels: compare distances and reach.
            for t in 0..width * height {
                let d = |s: u32| {
                    if s == NONE {
                        return -1;
                    }
                    let (s, t) = (s as usize, t);
                    ((s % width) as i64 - (t % width) as i64).pow(2)
                        + ((s / width) as i64 - (t / width) as i64).pow(2)
                };
                assert_eq!(d(fast[t]), d(slow[t]), "radius {radius}, texel {t}");
            }
        }
    }
}
