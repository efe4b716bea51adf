//! Which triangle covers each texel centre of a W×H UV layout, and where on it.
//!
//! Texel (i, j) samples UV ((i + 0.5)/W, (j + 0.5)/H). Coverage is decided exactly, as a GPU
//! rasteriser does: the UVs are snapped to 1/256 of a texel and the edge functions evaluated in
//! integers with a top-left rule, so a texel centre on an edge two triangles share belongs to
//! exactly one of them, however the mesh is laid out (a texel claimed twice is then a real
//! overlap of the UV layout: the first triangle keeps it, and the overlaps are counted). The
//! barycentric coordinates of a covered centre are computed in f64 from the UVs as stored.
//! Rows are cut into bands rasterised in parallel, each band's triangles in model order.

use super::model::Model;
use rayon::prelude::*;

/// Subpixel steps per texel side for the coverage decision (8 bits, as GPUs snap vertices).
const SUBPIXEL: i64 = 256;
/// Rows per band (the unit of parallel work).
pub const BAND: usize = 16;
/// No triangle.
pub const NONE: u32 = u32::MAX;

/// A covered texel: which triangle of which part covers its centre, and the centre's
/// barycentric coordinates on it (in the triangle's vertex order).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// `j * width + i`.
    pub texel: u32,
    pub part: u32,
    pub triangle: u32,
    pub bary: [f64; 3],
}

/// The covered texels of a layout, in texel order.
#[derive(Clone, Debug, Default)]
pub struct Coverage {
    pub width: usize,
    pub height: usize,
    pub hits: Vec<Hit>,
    /// Texel centres a later triangle also covered (kept by the first).
    pub overlaps: u64,
}

impl Coverage {
    /// Per texel, whether a triangle covers its centre.
    pub fn mask(&self) -> Vec<bool> {
        let mut mask = vec![false; self.width * self.height];
        for hit in &self.hits {
            mask[hit.texel as usize] = true;
        }
        mask
    }
}

/// A triangle prepared for the coverage test.
struct Prepared {
    part: u32,
    triangle: u32,
    /// Snapped vertices, counter-clockwise in (column, row) space's orientation test.
    fixed: [[i64; 2]; 3],
    /// The barycentric coordinates b1 and b2 (in the triangle's own vertex order) as affine
    /// functions of the UV: `b = k[0] u + k[1] v + k[2]` (made once, two products a texel).
    affine: [[f64; 3]; 2],
    rows: (usize, usize),
    columns: (usize, usize),
}

/// Snaps a UV to subpixel units, clamped to ±2^29 (so the edge functions' products fit an
/// i64: 2^21 texels a side around the image, far outside any texel centre).
fn snap(uv: [f64; 2], width: usize, height: usize) -> [i64; 2] {
    const LIMIT: f64 = (1i64 << 29) as f64;
    [
        (uv[0] * (width as f64) * SUBPIXEL as f64)
            .round()
            .clamp(-LIMIT, LIMIT) as i64,
        (uv[1] * (height as f64) * SUBPIXEL as f64)
            .round()
            .clamp(-LIMIT, LIMIT) as i64,
    ]
}

/// The edge function of a → b at p: twice the signed area of (a, b, p).
#[inline]
fn edge(a: [i64; 2], b: [i64; 2], p: [i64; 2]) -> i64 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

/// Whether a point with edge value 0 on a → b belongs to the triangle: one of the two
/// directions of every edge does, so a shared edge's centres go to exactly one side.
#[inline]
fn owns_edge(a: [i64; 2], b: [i64; 2]) -> bool {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    dy > 0 || (dy == 0 && dx < 0)
}

/// The texel indices whose centres (`k * SUBPIXEL + SUBPIXEL / 2`) lie in `[lo, hi]`, clamped
/// to `0..n`; `None` when empty.
fn centre_range(lo: i64, hi: i64, n: usize) -> Option<(usize, usize)> {
    let half = SUBPIXEL / 2;
    let first = (lo - half).div_euclid(SUBPIXEL) + i64::from((lo - half).rem_euclid(SUBPIXEL) != 0);
    let last = (hi - half).div_euclid(SUBPIXEL);
    let first = first.max(0);
    let last = last.min(n as i64 - 1);
    (first <= last).then_some((first as usize, last as usize))
}

fn prepare(model: &Model, width: usize, height: usize) -> Vec<Prepared> {
    let mut prepared = Vec::with_capacity(model.triangles());
    for (p, part) in model.parts.iter().enumerate() {
        for (t, tri) in part.triangles.iter().enumerate() {
            let uv = tri.map(|i| part.uvs[i as usize]);
            let mut fixed = uv.map(|c| snap(c, width, height));
            let area = edge(fixed[0], fixed[1], fixed[2]);
            if area == 0 {
                continue;
            }
            if area < 0 {
                fixed.swap(1, 2);
            }
            let xs = fixed.map(|v| v[0]);
            let ys = fixed.map(|v| v[1]);
            let min = |v: [i64; 3]| v.into_iter().min().unwrap_or(0);
            let max = |v: [i64; 3]| v.into_iter().max().unwrap_or(0);
            let (Some(rows), Some(columns)) = (
                centre_range(min(ys), max(ys), height),
                centre_range(min(xs), max(xs), width),
            ) else {
                continue;
            };
            prepared.push(Prepared {
                part: p as u32,
                triangle: t as u32,
                fixed,
                affine: affine_barycentric(&uv),
                rows,
                columns,
            });
        }
    }
    prepared
}

/// b1 and b2 of the triangle `uv` as affine functions of the UV (`cross(p − uv0, e2) / area`
/// and `cross(e1, p − uv0) / area` expanded).
fn affine_barycentric(uv: &[[f64; 2]; 3]) -> [[f64; 3]; 2] {
    let (e1, e2) = (
        [uv[1][0] - uv[0][0], uv[1][1] - uv[0][1]],
        [uv[2][0] - uv[0][0], uv[2][1] - uv[0][1]],
    );
    let area = e1[0] * e2[1] - e1[1] * e2[0];
    let [u0, v0] = uv[0];
    [
        [
            e2[1] / area,
            -e2[0] / area,
            (v0 * e2[0] - u0 * e2[1]) / area,
        ],
        [
            -e1[1] / area,
            e1[0] / area,
            (u0 * e1[1] - v0 * e1[0]) / area,
        ],
    ]
}

/// The barycentric coordinates at UV `p`, clamped onto the triangle (the snapped coverage test
/// can accept a centre a 1/256 texel outside the stored triangle).
#[inline]
fn barycentric(affine: &[[f64; 3]; 2], p: [f64; 2]) -> [f64; 3] {
    let at = |k: &[f64; 3]| k[0] * p[0] + k[1] * p[1] + k[2];
    let (b1, b2) = (at(&affine[0]), at(&affine[1]));
    if b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 {
        [1.0 - b1 - b2, b1, b2]
    } else {
        clamped(b1, b2)
    }
}

/// [`barycentric`] for a centre outside the stored triangle (rare: on its rim).
#[cold]
fn clamped(b1: f64, b2: f64) -> [f64; 3] {
    let (b1, b2) = (b1.clamp(0.0, 1.0), b2.clamp(0.0, 1.0));
    let sum = b1 + b2;
    let (b1, b2) = if sum > 1.0 {
        (b1 / sum, b2 / sum)
    } else {
        (b1, b2)
    };
    [1.0 - b1 - b2, b1, b2]
}

/// A layout's triangles prepared and binned by bands of [`BAND`] rows: what each band's
/// rasterisation reads.
pub struct Bins {
    prepared: Vec<Prepared>,
    bins: Vec<Vec<u32>>,
    width: usize,
    height: usize,
}

impl Bins {
    pub fn new(model: &Model, width: usize, height: usize) -> Bins {
        let prepared = prepare(model, width, height);
        let mut bins: Vec<Vec<u32>> = vec![Vec::new(); height.div_ceil(BAND)];
        for (k, tri) in prepared.iter().enumerate() {
            for bin in &mut bins[tri.rows.0 / BAND..=tri.rows.1 / BAND] {
                bin.push(k as u32);
            }
        }
        Bins {
            prepared,
            bins,
            width,
            height,
        }
    }

    /// The covered texels of band `band` (rows `band * BAND ..`), in texel order, and the
    /// overlaps counted there.
    pub fn band(&self, band: usize) -> (Vec<Hit>, u64) {
        let mut hits = Vec::new();
        let overlaps = self.band_into(band, &mut Vec::new(), &mut hits);
        (hits, overlaps)
    }

    /// [`Bins::band`] into `hits` (cleared first), with `owner` as the band's scratch: what a
    /// worker calls band after band without allocating.
    pub fn band_into(&self, band: usize, owner: &mut Vec<u32>, hits: &mut Vec<Hit>) -> u64 {
        rasterize_band(
            &self.prepared,
            &self.bins[band],
            band,
            [self.width, self.height],
            owner,
            hits,
        )
    }
}

/// Every texel centre of a `width` × `height` layout covered by a triangle of `model`.
pub fn rasterize(model: &Model, width: usize, height: usize) -> Coverage {
    let bins = Bins::new(model, width, height);
    let results: Vec<(Vec<Hit>, u64)> = (0..bins.bins.len())
        .into_par_iter()
        .map(|band| bins.band(band))
        .collect();
    let mut coverage = Coverage {
        width,
        height,
        hits: Vec::with_capacity(results.iter().map(|r| r.0.len()).sum()),
        overlaps: 0,
    };
    for (hits, overlaps) in results {
        coverage.hits.extend(hits);
        coverage.overlaps += overlaps;
    }
    coverage
}

/// One band of rows: its triangles in model order, the first to cover a centre keeping it.
fn rasterize_band(
    prepared: &[Prepared],
    bin: &[u32],
    band: usize,
    [width, height]: [usize; 2],
    owner: &mut Vec<u32>,
    hits: &mut Vec<Hit>,
) -> u64 {
    let row0 = band * BAND;
    let rows = BAND.min(height - row0);
    owner.clear();
    owner.resize(rows * width, NONE);
    let mut overlaps = 0u64;
    for &k in bin {
        let tri = &prepared[k as usize];
        let [a, b, c] = tri.fixed;
        let edges = [(b, c), (c, a), (a, b)];
        let bias = edges.map(|(from, to)| i64::from(!owns_edge(from, to)));
        // Along a row an edge function steps by a constant, −(to.y − from.y) · SUBPIXEL: the
        // columns where all three reach their bias are one interval, found exactly.
        let steps = edges.map(|(from, to)| -(to[1] - from[1]) * SUBPIXEL);
        for j in tri.rows.0.max(row0)..=tri.rows.1.min(row0 + rows - 1) {
            let c0 = tri.columns.0 as i64;
            let start = [
                c0 * SUBPIXEL + SUBPIXEL / 2,
                j as i64 * SUBPIXEL + SUBPIXEL / 2,
            ];
            let (mut first, mut last) = (c0, tri.columns.1 as i64);
            for (e, (from, to)) in edges.into_iter().enumerate() {
                let (v0, step, need) = (edge(from, to, start), steps[e], bias[e]);
                match step.signum() {
                    0 if v0 < need => last = first - 1,
                    1 => first = first.max(c0 + (need - v0 + step - 1).div_euclid(step)),
                    -1 => last = last.min(c0 + (v0 - need).div_euclid(-step)),
                    _ => {}
                }
            }
            if first > last {
                continue;
            }
            let row = &mut owner[(j - row0) * width..(j - row0 + 1) * width];
            for slot in &mut row[first as usize..=last as usize] {
                if *slot == NONE {
                    *slot = k;
                } else {
                    overlaps += 1;
                }
            }
        }
    }
    hits.clear();
    // Texel centres by products with the reciprocals (within an ulp of the quotients).
    let (w, h) = (1.0 / width as f64, 1.0 / height as f64);
    for (j, row) in (row0..).zip(owner.chunks_exact(width)) {
        let v = (j as f64 + 0.5) * h;
        for (i, &k) in row.iter().enumerate() {
            if k == NONE {
                continue;
            }
            let tri = &prepared[k as usize];
            hits.push(Hit {
                texel: (j * width + i) as u32,
                part: tri.part,
                triangle: tri.triangle,
                bary: barycentric(&tri.affine, [(i as f64 + 0.5) * w, v]),
            });
        }
    }
    overlaps
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::model::Part;

    fn quad_model() -> Model {
        // Two triangles sharing the diagonal from (0,0) to (1,1): centres on it (W = H) must
        // go to one triangle only.
        Model {
            path: "quad".into(),
            skipped: 0,
            parts: vec![Part {
                name: "quad".into(),
                positions: vec![[0.0; 3], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
                normals: vec![[0.0, 0.0, 1.0]; 4],
                uvs: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
                triangles: vec![[0, 1, 2], [0, 2, 3]],
            }],
        }
    }

    #[test]
    fn a_shared_edge_gives_every_centre_to_one_triangle() {
        for n in [1, 2, 7, 16, 33] {
            let coverage = rasterize(&quad_model(), n, n);
            assert_eq!(coverage.hits.len(), n * n, "{n}");
            assert_eq!(coverage.overlaps, 0, "{n}");
        }
    }

    #[test]
    fn overlapping_triangles_are_counted_and_the_first_wins() {
        let mut model = quad_model();
        model.parts[0].triangles.push([0, 1, 2]);
        let coverage = rasterize(&model, 8, 8);
        assert_eq!(coverage.hits.len(), 64);
        // The lower-right triangle's centres (below the diagonal and on it, as it owns them).
        let first = coverage.hits.iter().filter(|h| h.triangle == 0).count() as u64;
        assert_eq!(coverage.overlaps, first);
        assert!(coverage.hits.iter().all(|h| h.triangle != 2));
    }
}
