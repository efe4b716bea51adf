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

use super::batch::CHUNK;

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
    let (table, _) = perm.as_chunks::<V>();
    let table = [
        load(&table[0]),
        load(&table[1]),
        load(&table[2]),
        load(&table[3]),
    ];
    let lookup = |i: __m512i| lookup(&table, i);
    let add = |a, b| _mm512_add_epi8(a, b);
    let one = _mm512_set1_epi8(1);
    for k in 0..n.div_ceil(V) {
        let [x, y, z] = cell.each_ref().map(|c| load(&c.as_chunks::<V>().0[k]));
        let h = if PERLIN {
            // perlin::sample: A = p[x] + y, AA = p[A] + z, AB = p[A + 1] + z, B = p[x + 1] + y, ...
            let a = add(lookup(x), y);
            let b = add(lookup(add(x, one)), y);
            let aa = add(lookup(a), z);
            let ab = add(lookup(add(a, one)), z);
            let ba = add(lookup(b), z);
            let bb = add(lookup(add(b, one)), z);
            [
                aa,
                ba,
                ab,
                bb,
                add(aa, one),
                add(ba, one),
                add(ab, one),
                add(bb, one),
            ]
            .map(lookup)
        } else {
            // lattice::corner_hashes: PERM(x + PERM(y + PERM(z))) with the +1 neighbours.
            let z0 = lookup(z);
            let z1 = lookup(add(z, one));
            let y1 = add(y, one);
            let p = [add(y, z0), add(y1, z0), add(y, z1), add(y1, z1)].map(lookup);
            let x1 = add(x, one);
            [
                add(x, p[0]),
                add(x1, p[0]),
                add(x, p[1]),
                add(x1, p[1]),
                add(x, p[2]),
                add(x1, p[2]),
                add(x, p[3]),
                add(x1, p[3]),
            ]
            .map(lookup)
        };
        for (o, h) in out.iter_mut().zip(h) {
            store(&mut o.as_chunks_mut::<V>().0[k], h);
        }
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
    let registers = |t: &[u8]| {
        let (t, _) = t.as_chunks::<V>();
        [load(&t[0]), load(&t[1]), load(&t[2]), load(&t[3])]
    };
    let table = registers(&perm[..256]);
    let signs = signs.each_ref().map(|s| registers(s));
    for k in 0..n.div_ceil(V) {
        let [x, y, z] = vertex.each_ref().map(|c| load(&c.as_chunks::<V>().0[k]));
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
