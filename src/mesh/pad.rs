//! Padding (edge dilation): uncovered texels within N texels of a UV island take the value of
//! the nearest covered texel, so bilinear filtering and mip levels do not bleed the background
//! into the islands; texels further away stay 0.
//!
//! Nearest is Euclidean, between texel centres, found exactly in two passes: per row the
//! nearest covered column on each side, then per texel the best of the 2N + 1 rows within
//! reach (a fixed dy is best served by that row's nearest column). Ties go to the upper row,
//! then the left column, so the result does not depend on the thread count.

use rayon::prelude::*;

/// The padded texels: per uncovered texel within `radius` texels (Euclidean) of a covered one,
/// `(texel, nearest covered texel)`, in texel order. Texels are `j * width + i`.
pub fn padding(covered: &[bool], width: usize, height: usize, radius: u32) -> Vec<(u32, u32)> {
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
            for i in 0..width {
                if covered[i] {
                    left = Some(i as i64);
                }
                nearest[i] = left.filter(|&l| i as i64 - l <= r).unwrap_or(-1) as i32;
            }
            let mut right = None;
            for i in (0..width).rev() {
                if covered[i] {
                    right = Some(i as i64);
                }
                let right = right.filter(|&c| c - i as i64 <= r);
                let l = i64::from(nearest[i]);
                nearest[i] = match (l, right) {
                    (-1, Some(c)) => c,
                    (l, Some(c)) if l >= 0 && c - (i as i64) < (i as i64) - l => c,
                    (l, _) => l,
                } as i32;
            }
        });
    let any: Vec<bool> = covered
        .par_chunks(width)
        .map(|row| row.iter().any(|&c| c))
        .collect();
    let rows: Vec<Vec<(u32, u32)>> = covered
        .par_chunks(width)
        .enumerate()
        .map(|(j, covered)| {
            let top = (j as i64 - r).max(0) as usize;
            let bottom = (j as i64 + r).min(height as i64 - 1) as usize;
            // A row with no covered texel within reach pads nothing.
            if !any[top..=bottom].iter().any(|&a| a) {
                return Vec::new();
            }
            let mut pairs = Vec::new();
            for (i, _) in covered.iter().enumerate().filter(|(_, c)| !**c) {
                let mut best: Option<(i64, usize)> = None;
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
                    pairs.push(((j * width + i) as u32, texel as u32));
                }
            }
            pairs
        })
        .collect();
    rows.concat()
}

/// Copies each padded texel's source into it, in `data` (`k` values a texel).
pub fn apply(pairs: &[(u32, u32)], data: &mut [f32], k: usize) {
    for &(texel, source) in pairs {
        let (t, s) = (texel as usize * k, source as usize * k);
        data.copy_within(s..s + k, t);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// No source.
    const NONE: u32 = u32::MAX;

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

    /// Per texel: itself when covered, its padding source when padded, else [`NONE`].
    fn nearest_covered(covered: &[bool], width: usize, height: usize, radius: u32) -> Vec<u32> {
        let mut sources: Vec<u32> = (0..covered.len())
            .map(|t| if covered[t] { t as u32 } else { NONE })
            .collect();
        for (texel, source) in padding(covered, width, height, radius) {
            sources[texel as usize] = source;
        }
        sources
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
