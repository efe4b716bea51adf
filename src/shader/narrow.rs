//! The f32 flavour of the GPU path's module, for the shader export (naga's MSL and GLSL ES have
//! no f64), made on naga's IR: every f64 type becomes its f32 form (structs and arrays laid out
//! again), every f64 literal and conversion an f32 one, and the functions whose narrowed f64
//! form would be wrong or poor in f32 take the bodies written for f32 ([`F32_FORMS`]).
//!
//! The generator writes the module once, in the GPU path's precision (the filtered rules and
//! the bases' twins in f64); the export parses it with the f32 forms appended under names
//! ending in `__export` (`options::EXPORT_FORM`), and this pass, not a rewrite of the text,
//! makes it all-f32. naga has no such pass of its own; it is small because only scalar widths
//! change (the same ops exist at both widths), and the validator, run afterwards without the
//! f64 capability, proves that nothing of f64 is left.

use crate::gpu::ir::NARROW;
use naga::{Expression, Handle, Literal, Module, Scalar, Type};
use std::collections::{HashMap, HashSet};

/// The module's f64 constants by name, with their values where they are literals.
pub type Wide = HashMap<String, Option<f64>>;

/// Functions that are one function once narrowed: calls of the first call the second
/// (`functions::redirect`), so the export carries one stepwise `ldexp`.
pub const SAME_IN_F32: &[(&str, &str)] = &[("s_ldexp", "d_ldexp")];

/// The f32 forms of the functions whose narrowed f64 form would be wrong or poor in f32: the
/// cell words of the hash (`c − floor(c / 2³²) · 2³²` rounds every negative cell's low word in
/// f32: white and cellular noise would hash the wrong cells), the NaN and infinity tests and the
/// range test of simplex noise (bit tests and a bound of f64), `ldexp` past f32's exponent range
/// (stepwise, exact with subnormals, as the f64 forms are), and the f64 transcendentals (written
/// for f64 with Cody–Waite splits and f64 polynomials; in f32 the library's own f32 forms, the
/// CPU f32 path's, are the right ones). Appended to the module as they are.
pub const F32_FORMS: &str = "
fn cell_words__export(c: f32) -> vec2<u32> {
    // An f32 cell is an integer below 2^31 in magnitude wherever positions are exact;
    // its two's-complement words as Rust's `floor as i64` gives them, saturating.
    let i = i32(clamp(c, -2147483648.0, 2147483520.0));
    return vec2<u32>(bitcast<u32>(i), select(0u, 0xffffffffu, i < 0));
}
// `x != x` may be folded to false by a fast-math shader compiler; the bit test cannot.
fn is_nan_d__export(x: f32) -> bool { return is_nan(x); }
fn d_is_inf__export(x: f32) -> bool { return is_inf(x); }
fn simplex_finite3__export(p: vec3<f32>) -> bool {
    let a = abs(p);
    return a.x <= 3.4028235e38 && a.y <= 3.4028235e38 && a.z <= 3.4028235e38;
}
// ln x for x > 0 finite (the level-of-detail octave count): f32's own.
fn d_ln_finite__export(x: f32) -> f32 { return log(x); }
fn d_div__export(a: f32, b: f32) -> f32 { return s_div(a, b); }
// x 2^e for any e: three steps of at most 2^127 each (a single `ldexp` past f32's exponent
// range is left to the driver by the languages).
fn d_ldexp__export(x: f32, e: i32) -> f32 {
    var y = x;
    var k = clamp(e, -450, 450);
    for (var i = 0; i < 3; i = i + 1) {
        let s = clamp(k, -126, 127);
        y = y * bitcast<f32>(u32(s + 127) << 23u);
        k = k - s;
    }
    return y;
}
// The driver's own sin and cos may be as coarse as 2^-11 (the precision Vulkan and WebGL
// allow; SwiftShader's, under Chromium's WebGL, are off by 1e-4): `sin_cos_f32` instead.
fn sin_cos_f32(x: f32) -> vec2<f32> {
    if (!(abs(x) < 51000.0)) {
        let w = x - floor(x / 6.2831855 + 0.5) * 6.2831855;
        return vec2<f32>(sin(w), cos(w));
    }
    let k = round(x * 0.63661975);
    let r = ((x - k * 1.5703125) - k * 4.837512969970703e-4) - k * 7.549789954891882e-8;
    let z = r * r;
    let s = r + r * z * (-0.16666654611 + z * (0.0083321608736 + z * -0.00019515295891));
    let c = 1.0 - 0.5 * z + z * z * (0.04166664568298827 + z * (-0.001388731625493765 + z * 0.00002443315711809948));
    let q = i32(k) & 3;
    if (q == 0) { return vec2<f32>(s, c); }
    if (q == 1) { return vec2<f32>(c, -s); }
    if (q == 2) { return vec2<f32>(-s, -c); }
    return vec2<f32>(-c, s);
}
fn s_sin__export(x: f32) -> f32 {
    if (is_inf(x)) { return nan_f32(); }
    return sin_cos_f32(x).x;
}
fn s_cos__export(x: f32) -> f32 {
    if (is_inf(x)) { return nan_f32(); }
    return sin_cos_f32(x).y;
}
fn s_tan__export(x: f32) -> f32 {
    if (is_inf(x)) { return nan_f32(); }
    let r = sin_cos_f32(x);
    return r.x / r.y;
}
fn d_sin__export(x: f32) -> f32 { return s_sin(x); }
fn d_cos__export(x: f32) -> f32 { return s_cos(x); }
fn d_tan__export(x: f32) -> f32 { return s_tan(x); }
fn d_sqrt__export(x: f32) -> f32 { return s_sqrt(x); }
fn d_fract__export(x: f32) -> f32 { return s_fract(x); }
fn d_exp__export(x: f32) -> f32 { return s_exp(x); }
fn d_log__export(x: f32) -> f32 { return s_log(x); }
fn d_log2__export(x: f32) -> f32 { return s_log2(x); }
fn d_asin__export(x: f32) -> f32 { return s_asin(x); }
fn d_acos__export(x: f32) -> f32 { return s_acos(x); }
fn d_sign__export(x: f32) -> f32 { return s_sign(x); }
fn d_round__export(x: f32) -> f32 { return s_round(x); }
fn d_min__export(a: f32, b: f32) -> f32 { return s_min(a, b); }
fn d_max__export(a: f32, b: f32) -> f32 { return s_max(a, b); }
fn d_pow__export(x: f32, y: f32) -> f32 { return s_pow(x, y); }
fn d_atan2__export(y: f32, x: f32) -> f32 { return s_atan2(y, x); }
fn d_mod__export(a: f32, b: f32) -> f32 { return s_mod(a, b); }
";

/// Makes `module` all-f32 in place: types, constants, globals, literals and conversions (see
/// the module comment). Leaves the old f64 types in the arena, unused, for compaction. Returns
/// the constants that were f64, by name, with their values where they are literals, for
/// [`settle_constants`].
pub fn narrow(module: &mut Module) -> Result<Wide, String> {
    let types = NARROW.types(module, |_, _| None)?;
    let t = |h: Handle<Type>| types[h.index()];
    let mut wide = Wide::new();
    for (_, c) in module.constants.iter_mut() {
        if let Some(name) = c.name.as_ref().filter(|_| t(c.ty) != c.ty) {
            let value = match module.global_expressions[c.init] {
                Expression::Literal(Literal::F64(v)) => Some(v),
                _ => None,
            };
            wide.insert(name.clone(), value);
        }
        c.ty = t(c.ty);
    }
    for (_, o) in module.overrides.iter_mut() {
        o.ty = t(o.ty);
    }
    for (_, g) in module.global_variables.iter_mut() {
        g.ty = t(g.ty);
    }
    for (_, e) in module.global_expressions.iter_mut() {
        NARROW.expression(e, &t);
    }
    let functions = module.functions.iter_mut().map(|(_, f)| f);
    let entries = module.entry_points.iter_mut().map(|e| &mut e.function);
    for f in functions.chain(entries) {
        NARROW.function(f, &t);
    }
    // `frexp` and `modf` of f64 would need their predeclared result types narrowed too; the
    // library calls neither on f64.
    use naga::PredeclaredType as P;
    let f64_result = |p: &P| match *p {
        P::AtomicCompareExchangeWeakResult(s)
        | P::ModfResult { scalar: s, .. }
        | P::FrexpResult { scalar: s, .. } => s == Scalar::F64,
    };
    if let Some(p) = module
        .special_types
        .predeclared_types
        .keys()
        .find(|p| f64_result(p))
    {
        return Err(format!(
            "the f64 predeclared type {p:?} has no f32 form here"
        ));
    }
    Ok(wide)
}

/// After compaction (which keeps every named constant): the constants in `wide` that nothing
/// reads any more lose their names, so that the next compaction drops them (f64's largest
/// finite value, the f64 just below 1: constants of the f64 forms the export replaced, which
/// have no f32 value); one still read must keep its meaning in f32 (finite, the same whole
/// part), or the export is refused.
pub fn settle_constants(module: &mut Module, wide: &Wide) -> Result<(), String> {
    let mut read = HashSet::new();
    let expressions = module
        .functions
        .iter()
        .map(|(_, f)| &f.expressions)
        .chain(module.entry_points.iter().map(|e| &e.function.expressions))
        .chain([&module.global_expressions]);
    for arena in expressions {
        for (_, e) in arena.iter() {
            if let Expression::Constant(c) = e {
                read.insert(*c);
            }
        }
    }
    for (h, c) in module.constants.iter_mut() {
        let Some((name, &wide_value)) = c.name.as_ref().and_then(|n| wide.get_key_value(n)) else {
            continue;
        };
        if !read.contains(&h) {
            c.name = None;
            continue;
        }
        if let Expression::Literal(Literal::F32(v)) = module.global_expressions[c.init] {
            if !v.is_finite() || wide_value.is_some_and(|w| w.floor() != f64::from(v).floor()) {
                return Err(format!("the f64 constant `{name}` has no f32 value ({v})"));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use naga::valid::{Capabilities, ValidationFlags, Validator};

    fn narrowed(source: &str) -> Module {
        let mut module = naga::front::wgsl::parse_str(source).expect("parses");
        let wide = narrow(&mut module).expect("narrows");
        naga::compact::compact(&mut module, naga::compact::KeepUnused::No);
        settle_constants(&mut module, &wide).expect("settles");
        naga::compact::compact(&mut module, naga::compact::KeepUnused::No);
        Validator::new(ValidationFlags::all(), Capabilities::empty())
            .validate(&module)
            .expect("valid without f64");
        module
    }

    #[test]
    fn types_literals_conversions_and_layouts_become_f32() {
        let module = narrowed(
            "struct S { a: f32, b: f64, c: vec3<f64>, d: array<f64, 3> }
             const BIG: f64 = 1e300lf;
             const HALF: f64 = 0.5lf;
             fn unused() -> f64 { return BIG; }
             @fragment fn main(@builtin(position) at: vec4<f32>) -> @location(0) vec4<f32> {
                 var s = S(at.x, f64(at.y) * HALF, vec3<f64>(0.1lf), array<f64, 3>(1lf, 2lf, 3lf));
                 return vec4<f32>(s.a, f32(s.b), f32(s.c.x), f32(s.d[2]));
             }",
        );
        let (_, s) = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some("S"))
            .expect("S kept");
        let naga::TypeInner::Struct { members, span } = &s.inner else {
            panic!("S is a struct");
        };
        // f32 at 0, f32 at 4, vec3<f32> aligned to 16, array<f32, 3> after it (stride 4).
        let offsets: Vec<u32> = members.iter().map(|m| m.offset).collect();
        assert_eq!(offsets, [0, 4, 16, 28]);
        assert_eq!(*span, 48);
        // The f64 constant past f32's range, read only by an unused function, is gone; the one
        // still read is f32.
        let names: Vec<_> = module
            .constants
            .iter()
            .filter_map(|(_, c)| c.name.clone())
            .collect();
        assert_eq!(names, ["HALF"]);
        let literal = |e: &Expression| matches!(e, Expression::Literal(Literal::F64(_)));
        assert!(!module.global_expressions.iter().any(|(_, e)| literal(e)));
        let text = naga::back::wgsl::write_string(
            &module,
            &Validator::new(ValidationFlags::all(), Capabilities::empty())
                .validate(&module)
                .unwrap(),
            naga::back::wgsl::WriterFlags::empty(),
        )
        .unwrap();
        assert!(!text.contains("f64"), "{text}");
        assert!(text.contains("0.1f"), "{text}");
    }

    #[test]
    fn a_constant_still_read_must_keep_its_meaning() {
        let mut module = naga::front::wgsl::parse_str(
            "const ONE_BELOW: f64 = 0.9999999999999999lf;
             @fragment fn main(@builtin(position) at: vec4<f32>) -> @location(0) vec4<f32> {
                 return vec4<f32>(f32(f64(at.x) * ONE_BELOW));
             }",
        )
        .unwrap();
        let wide = narrow(&mut module).unwrap();
        naga::compact::compact(&mut module, naga::compact::KeepUnused::No);
        let e = settle_constants(&mut module, &wide).unwrap_err();
        assert!(e.contains("ONE_BELOW"), "{e}");
    }
}
