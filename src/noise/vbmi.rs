//! Corner hashing by byte shuffles (AVX-512 VBMI), 64 lanes per instruction.
//!
//! Why: in the batch kernels the 14 permutation reads per lane are otherwise seven 16-lane
//! gathers (`perlin::hashes_paired`, `lattice::corner_hashes_paired`), the largest single cost
//! of a Perlin octave (about a third of it in f32 on a Sapphire Rapids class CPU). The
//! permutation has 256 byte entries, four zmm registers: `vpermi2b` looks 64 byte indices up in
//! two registers (128 entries, index bits 0–6) at once, so two of them and a blend on index bit 7
//! look up 64 lanes in the whole table. The hash arithmetic wraps mod 256 in byte lanes, which
//! is what the doubled table does (`perm[i] == perm[i mod 256]` for i <= 511), so the hashes are
//! the same numbers as the gather formulations' (tested). The auto-vectoriser cannot emit byte
//! shuffles from table reads, hence intrinsics here, and only here. (AVX-512 intrinsics and
//! target features are stable since Rust 1.89.)
//!
//! `unsafe` is confined to the helpers [`load`] and [`store`] (the load / store intrinsics take
//! raw pointers; every other intrinsic used is safe in a function with the features) and to the
//! call of [`corner_hashes`] from the batch kernels, made only in the clone that the dispatcher
//! runs on CPUs with these features.

use std::arch::x86_64::{
    __m512i, _mm512_add_epi8, _mm512_loadu_si512, _mm512_mask_blend_epi8, _mm512_movepi8_mask,
    _mm512_permutex2var_epi8, _mm512_set1_epi8, _mm512_storeu_si512,
};

use super::lanes::CHUNK;

/// Lanes per vector: bytes per zmm register.
const V: usize = 64;

/// Writes the eight corner hashes (`[dx + 2 dy + 4 dz]`, Perlin's scheme when `PERLIN`, else
/// Ebert's) of the first `n` lanes of `cell` into `out`; lanes from `n` up to the next multiple
/// of 64 get hashes of whatever `cell` holds there (valid bytes, ignored by the caller).
#[inline]
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
pub(super) fn corner_hashes<const PERLIN: bool>(
    perm: &[u8; 512],
    cell: &[[u8; CHUNK]; 3],
    n: usize,
    out: &mut [[u8; CHUNK]; 8],
) {
    let table = registers(perm);
    let one = _mm512_set1_epi8(1);
    for k in 0..n.div_ceil(V) {
        let lo = load3(cell, k);
        let hi = [
            _mm512_add_epi8(lo[0], one),
            _mm512_add_epi8(lo[1], one),
            _mm512_add_epi8(lo[2], one),
        ];
        store_hashes(out, k, hashes::<PERLIN>(&table, lo, hi));
    }
}

/// [`corner_hashes`] with the upper corner's index given per axis (`hi`, each already mod 256)
/// instead of following the lower one: `lattice::corner_hashes_wrapped` over lanes, for tiling,
/// where a period's last cell wraps its upper corner to index 0.
#[inline]
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
pub(super) fn corner_hashes_wrapped<const PERLIN: bool>(
    perm: &[u8; 512],
    lo: &[[u8; CHUNK]; 3],
    hi: &[[u8; CHUNK]; 3],
    n: usize,
    out: &mut [[u8; CHUNK]; 8],
) {
    let table = registers(perm);
    for k in 0..n.div_ceil(V) {
        let (lo, hi) = (load3(lo, k), load3(hi, k));
        store_hashes(out, k, hashes::<PERLIN>(&table, lo, hi));
    }
}

/// The permutation's first 256 entries in four registers.
#[inline]
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
fn registers(perm: &[u8]) -> [__m512i; 4] {
    let (t, _) = perm[..256].as_chunks::<V>();
    [load(&t[0]), load(&t[1]), load(&t[2]), load(&t[3])]
}

/// The eight corner hashes of 64 lanes from each axis's lower and upper corner index bytes:
/// Perlin's `p[p[p[x] + y] + z]` or Ebert's `p[x + p[y + p[z]]]`, 14 lookups either way.
#[inline]
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
fn hashes<const PERLIN: bool>(
    table: &[__m512i; 4],
    lo: [__m512i; 3],
    hi: [__m512i; 3],
) -> [__m512i; 8] {
    // Written out without closures: a closure does not inherit the target features, so
    // `lookup` would not be inlined into it (measured: a call per lookup, 7% of an fbm).
    let t = table;
    let [x0, y0, z0] = lo;
    let [x1, y1, z1] = hi;
    if PERLIN {
        // perlin::sample: A = p[x] + y, AA = p[A] + z, ...; corner (i, j, k) = p[p[p[x_i] + y_j] + z_k].
        let (px0, px1) = (lookup(t, x0), lookup(t, x1));
        let a0 = lookup(t, _mm512_add_epi8(px0, y0));
        let b0 = lookup(t, _mm512_add_epi8(px1, y0));
        let a1 = lookup(t, _mm512_add_epi8(px0, y1));
        let b1 = lookup(t, _mm512_add_epi8(px1, y1));
        [
            lookup(t, _mm512_add_epi8(a0, z0)),
            lookup(t, _mm512_add_epi8(b0, z0)),
            lookup(t, _mm512_add_epi8(a1, z0)),
            lookup(t, _mm512_add_epi8(b1, z0)),
            lookup(t, _mm512_add_epi8(a0, z1)),
            lookup(t, _mm512_add_epi8(b0, z1)),
            lookup(t, _mm512_add_epi8(a1, z1)),
            lookup(t, _mm512_add_epi8(b1, z1)),
        ]
    } else {
        // lattice::corner_hashes: PERM(x + PERM(y + PERM(z))); corner (i, j, k).
        let (pz0, pz1) = (lookup(t, z0), lookup(t, z1));
        let p00 = lookup(t, _mm512_add_epi8(y0, pz0));
        let p10 = lookup(t, _mm512_add_epi8(y1, pz0));
        let p01 = lookup(t, _mm512_add_epi8(y0, pz1));
        let p11 = lookup(t, _mm512_add_epi8(y1, pz1));
        [
            lookup(t, _mm512_add_epi8(x0, p00)),
            lookup(t, _mm512_add_epi8(x1, p00)),
            lookup(t, _mm512_add_epi8(x0, p10)),
            lookup(t, _mm512_add_epi8(x1, p10)),
            lookup(t, _mm512_add_epi8(x0, p01)),
            lookup(t, _mm512_add_epi8(x1, p01)),
            lookup(t, _mm512_add_epi8(x0, p11)),
            lookup(t, _mm512_add_epi8(x1, p11)),
        ]
    }
}

/// Lane group `k` (64 lanes) of three byte planes.
#[inline]
#[target_feature(enable = "avx512f")]
fn load3(planes: &[[u8; CHUNK]; 3], k: usize) -> [__m512i; 3] {
    [
        load(&planes[0].as_chunks::<V>().0[k]),
        load(&planes[1].as_chunks::<V>().0[k]),
        load(&planes[2].as_chunks::<V>().0[k]),
    ]
}

/// Stores the eight hash vectors of lane group `k`.
#[inline]
#[target_feature(enable = "avx512f")]
fn store_hashes(out: &mut [[u8; CHUNK]; 8], k: usize, h: [__m512i; 8]) {
    for (o, h) in out.iter_mut().zip(h) {
        store(&mut o.as_chunks_mut::<V>().0[k], h);
    }
}

/// Simplex noise's gradient bytes: for the first `n` lanes of `vertex` (index bytes x, y, z),
/// `out[a] = signs[a][x + perm[y + perm[z]]]` (sums mod 256, as `simplex::hash` wraps them),
/// the permutation's three steps and the gradient lookup of the batch kernel's `NoiseTable`
/// tables, 64 lanes per instruction; lanes from `n` up to the next multiple of 64 get bytes of
/// whatever `vertex` holds there (ignored by the caller).
#[inline]
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
pub(super) fn simplex_gradients(
    perm: &[u8; 512],
    signs: &[[u8; 256]; 3],
    vertex: &[[u8; CHUNK]; 3],
    n: usize,
    out: &mut [[u8; CHUNK]; 3],
) {
    let table = registers(perm);
    let signs = [
        registers(&signs[0]),
        registers(&signs[1]),
        registers(&signs[2]),
    ];
    for k in 0..n.div_ceil(V) {
        let [x, y, z] = load3(vertex, k);
        let pz = lookup(&table, z);
        let py = lookup(&table, _mm512_add_epi8(y, pz));
        let j = _mm512_add_epi8(x, py);
        for (o, s) in out.iter_mut().zip(&signs) {
            store(&mut o.as_chunks_mut::<V>().0[k], lookup(s, j));
        }
    }
}

/// Lane-wise `table[i]` for the 256-entry table held in four registers: two two-register byte
/// permutes look up entries 0..=127 and 128..=255 by index bits 0-6, and index bit 7 (the byte's
/// sign bit) picks between them. [`lookup_portable`] writes the same out instruction by
/// instruction; the tests hold this to it on CPUs that have VBMI.
#[inline]
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
fn lookup(table: &[__m512i; 4], i: __m512i) -> __m512i {
    let low = _mm512_permutex2var_epi8(table[0], i, table[1]); // entries 0..=127
    let high = _mm512_permutex2var_epi8(table[2], i, table[3]); // entries 128..=255
    _mm512_mask_blend_epi8(_mm512_movepi8_mask(i), low, high) // index bit 7
}

/// [`lookup`] on byte arrays, for the tests: loads, looks up, stores.
#[cfg(test)]
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
pub(super) fn lookup_bytes(table: &[[u8; V]; 4], i: &[u8; V]) -> [u8; V] {
    let table = [
        load(&table[0]),
        load(&table[1]),
        load(&table[2]),
        load(&table[3]),
    ];
    let mut out = [0u8; V];
    store(&mut out, lookup(&table, load(i)));
    out
}

/// [`lookup`]'s three instructions written out on plain arrays (Intel's definitions of
/// VPERMI2B — index bits 0-5 pick a byte, bit 6 the first or second source —, VPMOVB2M — the
/// sign bit of each byte — and VPBLENDMB — the second source where the mask bit is set), so
/// the way the table is split over four registers is tested on every CPU.
#[cfg(test)]
pub(super) fn lookup_portable(table: &[[u8; V]; 4], i: &[u8; V]) -> [u8; V] {
    let permute2 = |a: &[u8; V], b: &[u8; V], idx: u8| {
        let source = if idx & 0x40 == 0 { a } else { b };
        source[(idx & 0x3f) as usize]
    };
    std::array::from_fn(|j| {
        let idx = i[j];
        let low = permute2(&table[0], &table[1], idx);
        let high = permute2(&table[2], &table[3], idx);
        if idx & 0x80 != 0 {
            high
        } else {
            low
        }
    })
}

/// Loads 64 bytes.
#[inline]
#[target_feature(enable = "avx512f")]
fn load(a: &[u8; V]) -> __m512i {
    // SAFETY: reads exactly the 64 bytes of `a` (an unaligned load; no alignment required).
    unsafe { _mm512_loadu_si512(a.as_ptr().cast()) }
}

/// Stores 64 bytes.
#[inline]
#[target_feature(enable = "avx512f")]
fn store(a: &mut [u8; V], v: __m512i) {
    // SAFETY: writes exactly the 64 bytes of `a` (an unaligned store; no alignment required).
    unsafe { _mm512_storeu_si512(a.as_mut_ptr().cast(), v) }
}
