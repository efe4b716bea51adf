//! `--uniforms`: which of a graph's params the exported shader reads from the `TexgraphParams`
//! uniform, found by compiling the graph with each param moved to two probe values and
//! comparing the tapes with the exported one.
//!
//! A param can be a uniform where every use of it reaches the tape as a constant slot of its
//! own (an operand: `Mul("period", "v.x")`, or a component of a folded vec3). It cannot where
//! it shapes the tape (octaves, seeds, gains, periods of tiling, ramp stops, rotation angles
//! folded into a matrix: the probes' tapes differ outside their constants) or where the
//! compiler folds it with other constants (`Mul("period", 2)` becomes one constant: its slot
//! holds neither probe). Those stay constants with the graph's value, and the export says why.
//! Probing, not a new kind of node: the checker and compiler stay as they are, and the
//! criterion is exactly what they do with the value.

use super::options::ShaderError;
use crate::check::CheckOptions;
use crate::compile::CompileOptions;
use crate::gpu::codegen::ConstantExprs;
use crate::tape::Tape;
use std::path::Path;

/// The uniform block's struct in the export's WGSL (GLSL's block is `TexgraphParamsBlock`).
pub const STRUCT: &str = "TexgraphParams";

/// The uniform block's instance name in every language.
pub const INSTANCE: &str = "texgraph_params";

/// One param of the exported graph: its field, value and whether the shader reads it.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamField {
    /// The param's name in the graph.
    pub name: String,
    /// Its field in `TexgraphParams` (`[A-Za-z0-9_]`, see [`field_name`]).
    pub field: String,
    /// The value it was exported with (the graph's, after `--set`).
    pub value: f64,
    /// `None`: the functions read the field. `Some(why)`: the constant is written in and the
    /// field is not read.
    pub constant: Option<String>,
}

/// The params and the constant slots that read them.
#[derive(Clone, Debug, Default)]
pub struct UniformPlan {
    pub params: Vec<ParamField>,
    pub(super) exprs: ConstantExprs,
}

/// A param's field name: characters outside `[A-Za-z0-9_]` become `_`, and a name that starts
/// with a digit gets a leading `p_`.
pub fn field_name(param: &str) -> String {
    let clean = super::options::identifier(param);
    if clean.starts_with(|c: char| c.is_ascii_digit()) || clean.is_empty() {
        format!("p_{clean}")
    } else {
        clean
    }
}

/// The plan for the graph file `path` checked with `check` (its params at `params`, the
/// graph's values after `--set`) and compiled with `compile`, and the tape to export with it.
///
/// Each param is probed alone (two values: equal tape shapes, and constant slots that hold
/// exactly the probe values); those that pass are then compiled together at their probes: that
/// tape is the one exported (a param whose value the compiler would simplify, `× 1` say, keeps
/// its instruction), its slots read the uniform. Without any such param: `None` for the tape
/// (export the one compiled with the values).
pub fn plan(
    path: &Path,
    params: &[(String, f64)],
    check: &CheckOptions,
    compile: &CompileOptions,
) -> Result<(UniformPlan, Option<Tape>), ShaderError> {
    let mut plan = UniformPlan::default();
    let mut fields = std::collections::HashSet::new();
    let mut candidates = Vec::new();
    for (k, (name, value)) in params.iter().enumerate() {
        let field = field_name(name);
        if !fields.insert(field.clone()) {
            return Err(ShaderError::SameField(field));
        }
        let set = [(name.clone(), probes(*value)[0])];
        let other = [(name.clone(), probes(*value)[1])];
        let constant = match probe_pair(path, check, compile, &set, &other) {
            Ok(0) => Some("no exported output reads it".to_string()),
            Ok(_) => {
                candidates.push(k);
                None
            }
            Err(why) => Some(why),
        };
        plan.params.push(ParamField {
            name: name.clone(),
            field,
            value: *value,
            constant,
        });
    }
    if candidates.is_empty() {
        return Ok((plan, None));
    }
    // All candidates at once: every slot belongs to one of them or to no param.
    let at = |which: usize| -> Vec<(String, f64)> {
        candidates
            .iter()
            .map(|&k| (params[k].0.clone(), probes(params[k].1)[which]))
            .collect()
    };
    let (a, c) = compile_pair(path, check, compile, &at(0), &at(1))
        .map_err(|why| ShaderError::Internal(format!("params probed together: {why}")))?;
    let owner = |x: f64, y: f64| {
        candidates
            .iter()
            .find(|&&k| probes(params[k].1) == [x, y])
            .map(|&k| format!("{INSTANCE}.{}", plan.params[k].field))
    };
    for (slot, x, y) in constant_pairs(&a, &c) {
        let Some(expr) = owner(x, y) else { continue };
        match slot {
            Slot::Scalar(s) => {
                plan.exprs.scalar.insert(s, expr);
            }
            Slot::Vec3(s, axis) => plan.exprs.vec3.entry(s).or_default()[axis] = Some(expr),
        }
    }
    Ok((plan, Some(a)))
}

/// Two values no graph writes by hand, far enough apart that no folding rounds them alike.
fn probes(value: f64) -> [f64; 2] {
    [
        value * (1.0 + 2f64.powi(-20)) + 2f64.powi(-20),
        value * 1.375 + 0.618_033_988_75,
    ]
}

/// The graph compiled with `a`'s and with `c`'s param values (each pair replacing `--set`'s),
/// when both check and the two tapes have one shape.
fn compile_pair(
    path: &Path,
    check: &CheckOptions,
    compile: &CompileOptions,
    a: &[(String, f64)],
    c: &[(String, f64)],
) -> Result<(Tape, Tape), String> {
    let load = |values: &[(String, f64)]| {
        let mut options = check.clone();
        options
            .overrides
            .retain(|(n, _)| !values.iter().any(|(m, _)| m == n));
        options.overrides.extend(values.iter().cloned());
        crate::load::load_tape(path, &options, compile)
            .map(|(_, t)| t)
            .map_err(|_| "another value is refused by the graph's checks".to_string())
    };
    let (ta, tc) = (load(a)?, load(c)?);
    if shape(&ta) != shape(&tc) {
        return Err(
            "it shapes the tape (octaves, seeds, tiling, ramp stops, a rotation \
                    folded into a matrix)"
                .to_string(),
        );
    }
    Ok((ta, tc))
}

/// One param probed alone (`a` and `c` its two probe values): how many constant slots hold it
/// and nothing else, or why it must stay a constant.
fn probe_pair(
    path: &Path,
    check: &CheckOptions,
    compile: &CompileOptions,
    a: &[(String, f64); 1],
    c: &[(String, f64); 1],
) -> Result<usize, String> {
    let (ta, tc) = compile_pair(path, check, compile, a, c)?;
    let (pa, pc) = (a[0].1, c[0].1);
    let mut slots = 0;
    let mut classify = |x: f64, y: f64| -> Result<(), String> {
        if x.to_bits() == y.to_bits() {
            Ok(())
        } else if x == pa && y == pc {
            slots += 1;
            Ok(())
        } else {
            Err("the compiler folds it with other constants into one".to_string())
        }
    };
    for (_, x, y) in constant_pairs(&ta, &tc) {
        classify(x, y)?;
    }
    if ta
        .wide_constants
        .iter()
        .zip(&tc.wide_constants)
        .any(|(x, y)| x.1 != y.1)
    {
        return Err("it reaches an instruction promoted to f64".to_string());
    }
    Ok(slots)
}

/// A constant slot: a scalar, or one component of a vec3.
enum Slot {
    Scalar(u32),
    Vec3(u32, usize),
}

/// Every constant of two tapes of one shape, slot by slot: (slot, value in `a`, value in `c`).
fn constant_pairs<'t>(a: &'t Tape, c: &'t Tape) -> impl Iterator<Item = (Slot, f64, f64)> + 't {
    let scalars = a
        .scalar_constants
        .iter()
        .zip(&c.scalar_constants)
        .map(|(&(slot, x), &(_, y))| (Slot::Scalar(slot), x, y));
    let vec3s = a
        .vec3_constants
        .iter()
        .zip(&c.vec3_constants)
        .flat_map(|(&(slot, x), &(_, y))| (0..3).map(move |k| (Slot::Vec3(slot, k), x[k], y[k])));
    scalars.chain(vec3s)
}

/// The tape's disassembly without its constants' values: equal for two compiles exactly when
/// they differ in constant values only.
fn shape(tape: &Tape) -> String {
    tape.to_string()
        .lines()
        .filter(|l| !l.starts_with("const "))
        .collect::<Vec<_>>()
        .join("\n")
}
