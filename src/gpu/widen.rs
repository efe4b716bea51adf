//! The noise bases in f64, for noise the precision plan promoted (`Noise`, `Fractal`,
//! `NoiseGradient` and `FractalGradient` with `Prec::Wide`), made on naga's IR from the f32
//! bases ([`SOURCES`]: `cell.wgsl` and the bases) so that each basis keeps one definition.
//!
//! Every struct, constant and function of those modules that holds an f32, or calls a function
//! that gets a twin, gets an `_d` twin. [`declarations`] declares them in WGSL, written from the
//! f32 modules' IR: the structs and constants whole, each function's signature with a
//! placeholder body. A shader that calls a twin includes them; once its WGSL is parsed,
//! [`graft`] gives each twin the body of its f32 form made f64 (`ir::WIDEN`: types, literals
//! and conversions; its calls and constants pointed at the twins). No text is rewritten: the
//! generator reads the IR and writes declarations, and the bodies never exist as text.
//! Items without a real type (hashes, integer splits) are shared as they are; the few whose
//! f32 forms work on bit patterns are written by hand in `wide.wgsl` and take their twins'
//! place.

use super::ir::{self, WIDEN};
use naga::{
    ArraySize, Constant, Expression, Function, Handle, Literal, Module, Scalar, ScalarKind, Span,
    Type, TypeInner,
};
use std::collections::{HashMap, HashSet};
use std::fmt::Write;
use std::sync::OnceLock;

/// The f32 modules with f64 twins, in library order (`codegen::LIBRARY`).
pub(crate) const SOURCES: [&str; 5] = [
    include_str!("wgsl/cell.wgsl"),
    include_str!("wgsl/lattice.wgsl"),
    include_str!("wgsl/lattice_grad.wgsl"),
    include_str!("wgsl/simplex.wgsl"),
    include_str!("wgsl/cellular.wgsl"),
];

/// The library before them, which they use (tables, NaN tests; math.wgsl's f64 helpers for
/// `wide.wgsl`).
pub(crate) const CONTEXT: [&str; 2] = [
    include_str!("wgsl/common.wgsl"),
    include_str!("wgsl/math.wgsl"),
];

/// The hand-written f64 forms (`wgsl/wide.wgsl`).
const OVERRIDES: &str = include_str!("wgsl/wide.wgsl");

/// f32 helpers outside [`SOURCES`] (common.wgsl) whose f64 forms already exist under another
/// name (math.wgsl, wide.wgsl).
const EXTERNAL: [(&str, &str); 3] = [
    ("is_nan", "is_nan_d"),
    ("nan_f32", "nan_d"),
    ("is_nan3", "is_nan3_d"),
];

/// The suffix of a twin's name.
const SUFFIX: &str = "_d";

/// What the f32 modules' IR says of their twins.
struct Plan {
    /// `wide.wgsl`, then the derived twins' declarations.
    declarations: String,
    /// Every name with a twin (struct, constant, function, [`EXTERNAL`]) and the twin's name.
    renames: HashMap<String, String>,
    /// The f32 functions whose twins [`graft`] makes (not the hand-written ones), in order.
    functions: Vec<String>,
}

fn plan() -> Result<&'static Plan, String> {
    static PLAN: OnceLock<Result<Plan, String>> = OnceLock::new();
    PLAN.get_or_init(make_plan).as_ref().map_err(Clone::clone)
}

/// The WGSL that declares the f64 twins: include it once in a shader that calls one, and run
/// [`graft`] on the parsed module.
pub(crate) fn declarations() -> &'static str {
    // The library is fixed at build time: the unit tests prove the plan, so an error here is a
    // texgraph bug that they catch first; a shader without the declarations fails to parse with
    // the missing name.
    plan().map_or("", |p| p.declarations.as_str())
}

/// Gives each twin function [`declarations`] declared in `module` the body of its f32 form at
/// f64, then orders the functions by their calls and drops the types the widening left unused.
/// A module without twins is left as it is.
pub(crate) fn graft(module: &mut Module) -> Result<(), String> {
    let plan = plan()?;
    graft_twins(module, &plan.renames, &plan.functions)
}

/// [`graft`] for the twins of `functions` (f32 names), `renames` naming every twin.
fn graft_twins(
    module: &mut Module,
    renames: &HashMap<String, String>,
    functions: &[String],
) -> Result<(), String> {
    let handles: HashMap<String, Handle<Function>> = module
        .functions
        .iter()
        .filter_map(|(h, f)| Some((f.name.clone()?, h)))
        .collect();
    let pairs: Vec<(Handle<Function>, Handle<Function>)> = functions
        .iter()
        .filter_map(|name| Some((*handles.get(name)?, *handles.get(renames.get(name)?)?)))
        .collect();
    if pairs.is_empty() {
        return Ok(());
    }
    let calls: HashMap<Handle<Function>, Handle<Function>> = renames
        .iter()
        .filter_map(|(a, b)| Some((*handles.get(a)?, *handles.get(b)?)))
        .collect();
    let constant_handles: HashMap<String, Handle<Constant>> = module
        .constants
        .iter()
        .filter_map(|(h, c)| Some((c.name.clone()?, h)))
        .collect();
    let constants: HashMap<Handle<Constant>, Handle<Constant>> = renames
        .iter()
        .filter_map(|(a, b)| Some((*constant_handles.get(a)?, *constant_handles.get(b)?)))
        .collect();
    let types = WIDEN.types(module, |m, ty| {
        let twin = renames.get(ty.name.as_ref()?)?;
        m.types
            .iter()
            .find(|(_, t)| t.name.as_ref() == Some(twin))
            .map(|(h, _)| h)
    })?;
    let t = |h: Handle<Type>| types[h.index()];
    for (from, to) in pairs {
        let mut f = module.functions[from].clone();
        widen_function(&mut f, &t, &constants, &calls);
        let declared = &module.functions[to];
        if ir::signature(&f) != ir::signature(declared) {
            return Err(format!(
                "the twin `{}` differs from its declaration",
                declared.name.as_deref().unwrap_or_default()
            ));
        }
        f.name.clone_from(&declared.name);
        module.functions[to] = f;
    }
    ir::order_by_calls(module);
    naga::compact::compact(module, naga::compact::KeepUnused::Yes);
    Ok(())
}

/// `f` (a clone of an f32 function) made its twin: every type, literal and conversion at f64,
/// its constants and calls pointed at their twins.
fn widen_function(
    f: &mut Function,
    t: &impl Fn(Handle<Type>) -> Handle<Type>,
    constants: &HashMap<Handle<Constant>, Handle<Constant>>,
    calls: &HashMap<Handle<Function>, Handle<Function>>,
) {
    WIDEN.function(f, t);
    for (_, e) in f.expressions.iter_mut() {
        if let Expression::Constant(c) = e {
            *c = constants.get(c).copied().unwrap_or(*c);
        }
    }
    ir::map_function_calls(f, &|h| calls.get(&h).copied().unwrap_or(h));
}

/// The library (`CONTEXT`, `SOURCES`, `wide.wgsl`) parsed; the twins its IR calls for, and
/// their declarations.
fn make_plan() -> Result<Plan, String> {
    let mut text: String = CONTEXT.iter().map(|part| format!("{part}\n")).collect();
    let mut sources = Vec::new();
    for part in SOURCES {
        let start = text.len();
        text.push_str(part);
        text.push('\n');
        sources.push(start..text.len());
    }
    let overrides = text.len()..text.len() + OVERRIDES.len();
    text.push_str(OVERRIDES);
    let module = naga::front::wgsl::parse_str(&text).map_err(|e| e.emit_to_string(&text))?;
    let starts = |span: Span, ranges: &[std::ops::Range<usize>]| {
        span.to_range()
            .is_some_and(|r| ranges.iter().any(|s| s.contains(&r.start)))
    };
    let in_sources = |span: Span| starts(span, &sources);
    let overridden: HashSet<&str> = module
        .functions
        .iter()
        .filter(|&(h, _)| {
            starts(
                module.functions.get_span(h),
                std::slice::from_ref(&overrides),
            )
        })
        .filter_map(|(_, f)| f.name.as_deref())
        .collect();

    let mut renames: HashMap<String, String> = EXTERNAL
        .iter()
        .map(|&(a, b)| (a.to_string(), b.to_string()))
        .collect();
    let mut twin = |name: &str| renames.insert(name.to_string(), format!("{name}{SUFFIX}"));
    let structs: Vec<Handle<Type>> = module
        .types
        .iter()
        .filter(|&(h, ty)| {
            ty.name.is_some()
                && matches!(ty.inner, TypeInner::Struct { .. })
                && in_sources(module.types.get_span(h))
                && holds_f32(&module, h)
        })
        .map(|(h, _)| h)
        .collect();
    let constants: Vec<Handle<Constant>> = module
        .constants
        .iter()
        .filter(|&(h, c)| {
            c.name.is_some() && in_sources(module.constants.get_span(h)) && holds_f32(&module, c.ty)
        })
        .map(|(h, _)| h)
        .collect();
    for &h in &structs {
        twin(module.types[h].name.as_deref().unwrap_or_default());
    }
    for &h in &constants {
        twin(module.constants[h].name.as_deref().unwrap_or_default());
    }
    let candidates: Vec<(Handle<Function>, &Function)> = module
        .functions
        .iter()
        .filter(|&(h, f)| f.name.is_some() && in_sources(module.functions.get_span(h)))
        .collect();
    // To a fixed point: a function calling one with a twin needs a twin too.
    loop {
        let before = renames.len();
        for &(_, f) in &candidates {
            let name = f.name.as_deref().unwrap_or_default();
            if renames.contains_key(name) {
                continue;
            }
            let hand_written = overridden.contains(format!("{name}{SUFFIX}").as_str());
            if hand_written || uses_f32(&module, f, &renames) {
                renames.insert(name.to_string(), format!("{name}{SUFFIX}"));
            }
        }
        if renames.len() == before {
            break;
        }
    }

    let mut declarations = String::from(OVERRIDES);
    declarations.push_str(&declare_structs_and_constants(
        &module, &structs, &constants, &renames,
    )?);
    let mut functions = Vec::new();
    for &(_, f) in &candidates {
        let name = f.name.as_deref().unwrap_or_default();
        let Some(twin) = renames.get(name) else {
            continue;
        };
        if overridden.contains(twin.as_str()) {
            continue;
        }
        declarations.push_str(&placeholder(&module, f, twin, &renames)?);
        functions.push(name.to_string());
    }
    Ok(Plan {
        declarations,
        renames,
        functions,
    })
}

/// The twin structs' and constants' WGSL: each struct with its members at f64, each constant
/// with its value widened (`ir::widened`).
fn declare_structs_and_constants(
    module: &Module,
    structs: &[Handle<Type>],
    constants: &[Handle<Constant>],
    renames: &HashMap<String, String>,
) -> Result<String, String> {
    let mut declarations = String::from(
        "\n// The f64 twins of the f32 bases (gpu/widen.rs): structs and constants whole; each\n\
         // function's body is its f32 form's at f64, given on naga's IR (`widen::graft`).\n",
    );
    for &h in structs {
        let TypeInner::Struct { members, .. } = &module.types[h].inner else {
            continue;
        };
        let name = &renames[module.types[h].name.as_deref().unwrap_or_default()];
        let _ = writeln!(declarations, "struct {name} {{");
        for m in members {
            let member = m.name.as_deref().unwrap_or_default();
            let _ = writeln!(
                declarations,
                "    {member}: {},",
                wgsl_type(module, m.ty, renames)?
            );
        }
        declarations.push_str("}\n");
    }
    for &h in constants {
        let c = &module.constants[h];
        let value = match module.global_expressions[c.init] {
            // Finite (an f32 constant's value), written exactly: `{:e}` is the shortest
            // decimal that reads back as the same f64.
            Expression::Literal(Literal::F32(v)) if v.is_finite() => {
                format!("{:e}lf", ir::widened(v))
            }
            ref other => return Err(format!("the f32 constant {:?} is {other:?}", c.name)),
        };
        let name = &renames[c.name.as_deref().unwrap_or_default()];
        let _ = writeln!(
            declarations,
            "const {name}: {} = {value};",
            wgsl_type(module, c.ty, renames)?
        );
    }
    Ok(declarations)
}

/// `fn TWIN(ARGS) -> RESULT { return RESULT(); }`: the twin's signature, `f`'s at f64.
fn placeholder(
    module: &Module,
    f: &Function,
    twin: &str,
    renames: &HashMap<String, String>,
) -> Result<String, String> {
    let mut arguments = Vec::new();
    for a in &f.arguments {
        let name = a.name.as_deref().unwrap_or("_unnamed");
        arguments.push(format!("{name}: {}", wgsl_type(module, a.ty, renames)?));
    }
    let arguments = arguments.join(", ");
    Ok(match &f.result {
        Some(r) => {
            let ty = wgsl_type(module, r.ty, renames)?;
            format!("fn {twin}({arguments}) -> {ty} {{\n    return {ty}();\n}}\n")
        }
        None => format!("fn {twin}({arguments}) {{\n}}\n"),
    })
}

/// Whether the type holds an f32 (itself, a component, a member, an element).
fn holds_f32(module: &Module, ty: Handle<Type>) -> bool {
    match &module.types[ty].inner {
        TypeInner::Scalar(s)
        | TypeInner::Vector { scalar: s, .. }
        | TypeInner::Matrix { scalar: s, .. } => *s == Scalar::F32,
        TypeInner::Array { base, .. } | TypeInner::Pointer { base, .. } => holds_f32(module, *base),
        TypeInner::Struct { members, .. } => members.iter().any(|m| holds_f32(module, m.ty)),
        _ => false,
    }
}

/// Whether `f` works in f32: its signature, a variable, a literal, a conversion, a built value
/// or a constant of f32, or a call of a function with a twin.
fn uses_f32(module: &Module, f: &Function, renames: &HashMap<String, String>) -> bool {
    let f32 = |ty: Handle<Type>| holds_f32(module, ty);
    let twinned = |h: Handle<Function>| {
        module.functions[h]
            .name
            .as_ref()
            .is_some_and(|n| renames.contains_key(n))
    };
    if f.arguments.iter().any(|a| f32(a.ty))
        || f.result.as_ref().is_some_and(|r| f32(r.ty))
        || f.local_variables.iter().any(|(_, v)| f32(v.ty))
    {
        return true;
    }
    let expression = f.expressions.iter().any(|(_, e)| match *e {
        Expression::Literal(Literal::F32(_)) => true,
        Expression::As {
            kind: ScalarKind::Float,
            convert,
            ..
        } => convert != Some(8),
        Expression::ZeroValue(ty) | Expression::Compose { ty, .. } => f32(ty),
        Expression::Constant(c) => f32(module.constants[c].ty),
        Expression::CallResult(h) => twinned(h),
        _ => false,
    });
    let mut call = false;
    ir::each_call(&f.body, &mut |h| call |= twinned(h));
    expression || call
}

/// A type's WGSL at f64 (twin structs by their twins' names).
fn wgsl_type(
    module: &Module,
    ty: Handle<Type>,
    renames: &HashMap<String, String>,
) -> Result<String, String> {
    let scalar = |s: Scalar| match (s.kind, s.width) {
        (ScalarKind::Float, _) => Ok("f64"),
        (ScalarKind::Sint, 4) => Ok("i32"),
        (ScalarKind::Uint, 4) => Ok("u32"),
        (ScalarKind::Bool, _) => Ok("bool"),
        _ => Err(format!("a twin's signature holds the scalar {s:?}")),
    };
    Ok(match &module.types[ty].inner {
        TypeInner::Scalar(s) => scalar(*s)?.to_string(),
        TypeInner::Vector { size, scalar: s } => format!("vec{}<{}>", *size as u8, scalar(*s)?),
        TypeInner::Matrix {
            columns,
            rows,
            scalar: s,
        } => format!("mat{}x{}<{}>", *columns as u8, *rows as u8, scalar(*s)?),
        TypeInner::Array {
            base,
            size: ArraySize::Constant(n),
            ..
        } => format!("array<{}, {n}>", wgsl_type(module, *base, renames)?),
        TypeInner::Struct { .. } => {
            let name = module.types[ty].name.clone().unwrap_or_default();
            renames.get(&name).cloned().unwrap_or(name)
        }
        other => return Err(format!("a twin's signature holds the type {other:?}")),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use naga::valid::{Capabilities, ValidationFlags, Validator};

    /// The library's twins: declared, grafted and valid, each twin's body its f32 form's at
    /// f64 (no f32 left in it), the hand-written ones untouched, the shared ones not twinned.
    #[test]
    fn the_library_twins_are_its_f32_forms_at_f64() {
        let plan = plan().unwrap_or_else(|e| panic!("{e}"));
        let mut text: String = CONTEXT
            .iter()
            .chain(&SOURCES)
            .map(|part| format!("{part}\n"))
            .collect();
        text.push_str(declarations());
        let mut module = naga::front::wgsl::parse_str(&text).unwrap_or_else(|e| {
            panic!("{}", e.emit_to_string(&text));
        });
        graft(&mut module).unwrap_or_else(|e| panic!("{e}"));
        Validator::new(ValidationFlags::all(), Capabilities::FLOAT64)
            .validate(&module)
            .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&text)));
        let function = |name: &str| {
            module
                .functions
                .iter()
                .find(|(_, f)| f.name.as_deref() == Some(name))
                .map(|(_, f)| f)
                .unwrap_or_else(|| panic!("{name}"))
        };
        assert!(plan.functions.len() > 20, "{:?}", plan.functions);
        for name in &plan.functions {
            let twin = function(&plan.renames[name]);
            assert!(
                !uses_f32_itself(&module, twin),
                "{name}'s twin works in f32"
            );
            assert_eq!(
                twin.expressions.len(),
                function(name).expressions.len(),
                "{name}"
            );
        }
        // The hash and the integer split are shared; the NaN test is hand-written.
        assert!(!plan.renames.contains_key("pcg2d"));
        assert_eq!(plan.renames["is_nan3"], "is_nan3_d");
        assert!(plan.renames.contains_key("lattice"));
        assert!(!plan.functions.contains(&"hash_value".to_string()));
    }

    fn uses_f32_itself(module: &Module, f: &Function) -> bool {
        uses_f32(module, f, &HashMap::new())
    }

    /// A small module's twins: a struct, a constant, a call through a twin and a shared
    /// integer helper; literals keep the decimal written, conversions become f64.
    #[test]
    fn a_twin_follows_its_f32_form_through_calls_constants_and_structs() {
        let source = "struct Pair { a: f32, n: u32, }\n\
            const HALF: f32 = 0.5;\n\
            fn hash(x: u32) -> u32 { return x * 3u; }\n\
            fn kernel(x: f32) -> f32 { return x * 0.1 + HALF; }\n\
            fn pair(n: u32) -> Pair { return Pair(kernel(f32(hash(n))), n); }\n\
            fn pair_d(n: u32) -> Pair_d { return Pair_d(); }\n\
            fn kernel_d(x: f64) -> f64 { return f64(); }\n\
            struct Pair_d { a: f64, n: u32, }\n\
            const HALF_d: f64 = 0.5lf;\n\
            @compute @workgroup_size(1) fn main() { _ = pair_d(7u); }\n";
        let mut module = naga::front::wgsl::parse_str(source).unwrap();
        let renames: HashMap<String, String> = [("Pair", "Pair_d"), ("HALF", "HALF_d")]
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .into_iter()
            .chain(["kernel", "pair"].map(|n| (n.to_string(), format!("{n}_d"))))
            .collect();
        graft_twins(&mut module, &renames, &["kernel".into(), "pair".into()]).unwrap();
        let find = |m: &Module, n: &str| {
            m.functions
                .iter()
                .find(|(_, f)| f.name.as_deref() == Some(n))
                .map(|(h, _)| h)
                .unwrap()
        };
        Validator::new(ValidationFlags::all(), Capabilities::FLOAT64)
            .validate(&module)
            .unwrap_or_else(|e| panic!("{e:?}"));
        let kernel = &module.functions[find(&module, "kernel_d")];
        let literals: Vec<Literal> = kernel
            .expressions
            .iter()
            .filter_map(|(_, e)| match e {
                Expression::Literal(l) => Some(*l),
                _ => None,
            })
            .collect();
        assert_eq!(literals, [Literal::F64(0.1)]);
        let pair = &module.functions[find(&module, "pair_d")];
        let calls: Vec<String> = pair
            .expressions
            .iter()
            .filter_map(|(_, e)| match e {
                Expression::CallResult(h) => module.functions[*h].name.clone(),
                _ => None,
            })
            .collect();
        assert_eq!(calls, ["hash", "kernel_d"]);
        assert!(pair.expressions.iter().any(|(_, e)| matches!(
            e,
            Expression::As {
                kind: ScalarKind::Float,
                convert: Some(8),
                ..
            }
        )));
    }
}
