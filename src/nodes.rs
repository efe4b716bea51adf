//! The node catalogue: every node kind, defined once — its arguments, their types and defaults,
//! its output type and one sentence of meaning. The checker reads arguments through these
//! definitions, `texgraph nodes` prints them, and docs/format.md's node table is generated from
//! them (a test keeps the document in step).

use crate::limits;
use crate::ops::{BinaryOp, TernaryOp, UnaryOp};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kind {
    Position,
    Combine,
    Scale,
    Translate,
    Rotate,
    Noise,
    Fbm,
    Turbulence,
    Ridged,
    Billow,
    Cellular,
    WhiteNoise,
    VecNoise,
    VecFbm,
    Warp,
    Add,
    Sub,
    Mul,
    Div,
    Min,
    Max,
    Pow,
    Atan2,
    Mod,
    Abs,
    Neg,
    Sin,
    Cos,
    Sqrt,
    Floor,
    Fract,
    Exp,
    Log,
    Log2,
    Tan,
    Asin,
    Acos,
    Sign,
    Round,
    Trunc,
    Step,
    Select,
    MapRange,
    Length,
    Dot,
    Cross,
    Normalize,
    Distance,
    Gradient,
    Clamp,
    Mix,
    Smoothstep,
    Hermite,
    ColorRamp,
    Curve,
    Luminance,
    HsvToRgb,
    RgbToHsv,
    Blend,
    Import,
}

/// The operation a node kind lowers to in the checked graph.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lowering {
    Position,
    Combine,
    /// `input * by`, `by` broadcast to a vec3.
    Scale,
    /// `input + by`, `by` broadcast to a vec3.
    Translate,
    Rotate,
    Noise,
    Fractal(FractalKind),
    /// A cellular noise sample (a `Noise` with the Cellular basis).
    Cellular,
    /// A white-noise sample (a `Noise` with the internal White basis).
    White,
    /// Three decorrelated noise samples combined into a vec3.
    VecNoise,
    /// Three decorrelated fractal sums combined into a vec3.
    VecFractal,
    /// `input + amount * VecFbm(input)`.
    Warp,
    /// A per-lane math operation of `ops.rs` (scalars or vec3 component-wise).
    Unary(UnaryOp),
    Binary(BinaryOp),
    Ternary(TernaryOp),
    /// `to_min + t (to_max - to_min)`, `t = (input - from_min) / (from_max - from_min)`,
    /// optionally clamped to [0, 1].
    MapRange,
    Length,
    Dot,
    Cross,
    Normalize,
    /// `Length(a - b)`.
    Distance,
    /// Forward-mode differentiation of its argument's subgraph (`derive.rs`).
    Gradient,
    Hermite,
    Ramp,
    Curve,
    /// `Dot(colour, Rec. 709 weights)`.
    Luminance,
    /// Colour conversions, lowered into component-wise math.
    HsvToRgb,
    RgbToHsv,
    /// `Mix(base, mode(base, layer), t)`.
    Blend,
    /// Another graph file's output, its nodes rebuilt here with `Position` replaced by `input`.
    Import,
}

/// The fractal sums: how each octave's noise enters the sum (see `noise::Style`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FractalKind {
    Fbm,
    Turbulence,
    Ridged,
    Billow,
}

/// The type an input expression must have.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputType {
    Scalar,
    Vec3,
    /// Scalar or vec3; scalars broadcast when another `Any` operand is a vec3.
    Any,
}

/// A closed or half-open interval that a constant argument must lie in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    pub min: f64,
    pub max: f64,
    /// `min` itself is allowed (otherwise the argument must be strictly greater).
    pub min_inclusive: bool,
    pub integer: bool,
}

impl Range {
    pub const FINITE: Range = Range {
        min: f64::MIN,
        max: f64::MAX,
        min_inclusive: true,
        integer: false,
    };

    pub fn contains(&self, v: f64) -> bool {
        let above = if self.min_inclusive {
            v >= self.min
        } else {
            v > self.min
        };
        above && v <= self.max && (!self.integer || v.fract() == 0.0)
    }

    pub fn describe(&self) -> String {
        let kind = if self.integer {
            "an integer"
        } else {
            "a finite number"
        };
        if *self == Range::FINITE {
            return kind.to_string();
        }
        let low = if self.min_inclusive {
            format!(">= {}", self.min)
        } else {
            format!("> {}", self.min)
        };
        format!("{kind} {low} and <= {}", self.max)
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ArgKind {
    /// Any expression of the given type, evaluated per point.
    Input(InputType),
    /// A compile-time constant scalar (number, param, or constant expression) within a range.
    ConstScalar(Range),
    /// A compile-time constant, non-zero vec3 (Rotate's axis).
    ConstAxis,
    /// `Perlin`, `Gradient`, `Value` or `Value(interpolation: Linear | Smooth)`.
    Basis,
    /// One of the listed names (an interpolation, a metric, ...).
    Choice(&'static [&'static str]),
    /// `[(t, (r, g, b)), ...]`, constant, sorted by t.
    Stops,
    /// `[(x, y), ...]`, constant, sorted by x.
    Points,
    /// A tiling period: a constant whole number or vec3 of whole numbers, each 1 to 2^20.
    Period,
    /// `true` or `false`.
    Flag,
    /// A string (a file path, an output name).
    Text,
    /// `{ "name": constant, ... }`: param values for an imported graph.
    Overrides,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DefaultValue {
    Number(f64),
    Vec3([f64; 3]),
    Name(&'static str),
    /// Optional without a value (no tiling).
    Nothing,
    Flag(bool),
    /// The sample point (an `input` that defaults to `Position`).
    Position,
    /// No overrides (`{}`).
    Empty,
}

#[derive(Clone, Copy, Debug)]
pub struct ArgDef {
    pub name: &'static str,
    pub kind: ArgKind,
    /// `None`: the argument is required.
    pub default: Option<DefaultValue>,
    pub doc: &'static str,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputType {
    Scalar,
    Vec3,
    /// Vec3 if any `Any` input is a vec3, else scalar (component-wise math).
    Broadcast,
    /// The type of the imported output.
    Imported,
}

/// How a node's slope bound — its Lipschitz constant per unit of world distance, which level of
/// detail needs to know each octave's world frequency — follows from its arguments' bounds.
/// `lod::stretches` evaluates this rule for every node of a checked graph; a new kind states
/// its rule here, and the exhaustive `match` there makes a new rule a compile error until it
/// is evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slope {
    /// The sample point itself: 1.
    Identity,
    /// `|f'| <= 1`: no steeper than its (only varying) input — Neg, Abs, Sin, Cos, Length.
    NoSteeper,
    /// No steeper than the steeper operand (Min, Max).
    Steepest,
    /// The sum of the operands' bounds (Add, Sub, Translate).
    Sum,
    /// `sqrt(x'^2 + y'^2 + z'^2)` of the three components' bounds (Combine).
    Euclidean,
    /// A constant operand's largest component times the other operand's bound (Mul, Scale);
    /// unbounded when neither operand is constant.
    ConstantFactor,
    /// A constant vector's length times the other operand's bound (Dot).
    ConstantProjection,
    /// The dividend's bound over the constant divisor's smallest magnitude (Div).
    ConstantDivisor,
    /// The input's bound when both bounds are constant (Clamp).
    ConstantBounds,
    /// `|1 - t| a' + |t| b'` for a constant `t` (Mix).
    ConstantBlend,
    /// `1.5 / (edge1 - edge0)` times the input's bound, for constant edges (Smoothstep).
    ConstantEdges,
    /// The point's bound, for a constant angle (Rotate).
    RigidMotion,
    /// The basis' Lipschitz constant times the input's bound (Noise).
    Basis,
    /// The basis' constant times the sum over octaves of `|frequency x amplitude|` (Fbm,
    /// Turbulence).
    FractalSum,
    /// The steepest segment of the spline times the input's bound (ColorRamp, Curve).
    SteepestSegment,
    /// No useful bound (the reason): level of detail is off for noise downstream.
    Unbounded(&'static str),
    /// Lowered into other kinds' operations (VecNoise, VecFbm, Warp, MapRange, Distance, the
    /// colour kinds), each bounded by its own rule.
    Composite,
}

#[derive(Clone, Copy, Debug)]
pub struct NodeDef {
    pub kind: Kind,
    /// What the checker turns this kind into: each entry names its own operation, so a new
    /// kind can never be lowered as another one by a fall-through.
    pub lowering: Lowering,
    /// Its Lipschitz rule, for level of detail.
    pub slope: Slope,
    pub name: &'static str,
    pub args: &'static [ArgDef],
    pub output: OutputType,
    pub doc: &'static str,
}

const fn input(name: &'static str, ty: InputType, doc: &'static str) -> ArgDef {
    ArgDef {
        name,
        kind: ArgKind::Input(ty),
        default: None,
        doc,
    }
}

const fn input_or(name: &'static str, ty: InputType, default: f64, doc: &'static str) -> ArgDef {
    ArgDef {
        name,
        kind: ArgKind::Input(ty),
        default: Some(DefaultValue::Number(default)),
        doc,
    }
}

const fn constant(
    name: &'static str,
    range: Range,
    default: Option<f64>,
    doc: &'static str,
) -> ArgDef {
    let default = match default {
        Some(v) => Some(DefaultValue::Number(v)),
        None => None,
    };
    ArgDef {
        name,
        kind: ArgKind::ConstScalar(range),
        default,
        doc,
    }
}

const ANY_X: &[ArgDef] = &[input("x", InputType::Any, "operand")];
const ANY_AB: &[ArgDef] = &[
    input("a", InputType::Any, "left operand"),
    input("b", InputType::Any, "right operand"),
];

const SEED: Range = Range {
    min: 0.0,
    max: limits::MAX_SEED,
    min_inclusive: true,
    integer: true,
};
const OCTAVES: Range = Range {
    min: 0.0,
    max: limits::MAX_OCTAVES,
    min_inclusive: true,
    integer: false,
};
const FIRST_OCTAVE: Range = Range {
    min: 0.0,
    max: limits::MAX_FIRST_OCTAVE,
    min_inclusive: true,
    integer: true,
};
const LACUNARITY: Range = Range {
    min: 0.0,
    max: 1.0e6,
    min_inclusive: false,
    integer: false,
};
const GAIN: Range = Range {
    min: -1.0e6,
    max: 1.0e6,
    min_inclusive: true,
    integer: false,
};

const NOISE_INTERPOLATION: &[&str] = &["Linear", "Smooth"];
const RAMP_INTERPOLATION: &[&str] = &["Linear", "Smooth", "Constant"];

pub(crate) const METRICS: &[&str] = &["Euclidean", "Manhattan", "Chebyshev"];
/// Blend's modes, in the order docs/format.md gives their formulas.
pub const BLEND_MODES: &[&str] = &[
    "Mix",
    "Multiply",
    "Screen",
    "Overlay",
    "Add",
    "Subtract",
    "Difference",
    "Darken",
    "Lighten",
];

pub(crate) const CELLULAR_VALUES: &[&str] = &["F1", "F2", "F2MinusF1", "CellValue", "Edge"];

const JITTER: Range = Range {
    min: 0.0,
    max: 1.0,
    min_inclusive: true,
    integer: false,
};
const SHARPNESS: Range = Range {
    min: 0.0,
    max: 64.0,
    min_inclusive: false,
    integer: false,
};

const INPUT: ArgDef = input("input", InputType::Vec3, "the point to sample");
const BASIS: ArgDef = ArgDef {
    name: "basis",
    kind: ArgKind::Basis,
    default: None,
    doc: "the noise: Perlin, Gradient, Value, Simplex or Cellular",
};
const SEED_ARG: ArgDef = constant(
    "seed",
    SEED,
    Some(0.0),
    "selects the tables; 0 is the reference table for Perlin",
);
const OCTAVES_ARG: ArgDef = constant(
    "octaves",
    OCTAVES,
    None,
    "how many octaves; a fraction weights the last, partial octave",
);
const LACUNARITY_ARG: ArgDef = constant(
    "lacunarity",
    LACUNARITY,
    Some(2.0),
    "frequency ratio between octaves",
);
const GAIN_ARG: ArgDef = constant("gain", GAIN, Some(0.5), "amplitude ratio between octaves");
const FIRST_OCTAVE_ARG: ArgDef = constant(
    "first_octave",
    FIRST_OCTAVE,
    Some(0.0),
    "index of the first octave summed (seed 004's n1)",
);
const INTERPOLATION_ARG: ArgDef = ArgDef {
    name: "interpolation",
    kind: ArgKind::Choice(NOISE_INTERPOLATION),
    default: Some(DefaultValue::Name("Linear")),
    doc: "Value basis only: Linear (trilinear) or Smooth",
};
const JITTER_ARG: ArgDef = constant(
    "jitter",
    JITTER,
    Some(1.0),
    "Cellular only: how far feature points stray from their cell centres (0: a regular grid)",
);
const METRIC_ARG: ArgDef = ArgDef {
    name: "metric",
    kind: ArgKind::Choice(METRICS),
    default: Some(DefaultValue::Name("Euclidean")),
    doc: "Cellular only: the distance measured",
};
const VALUE_ARG: ArgDef = ArgDef {
    name: "value",
    kind: ArgKind::Choice(CELLULAR_VALUES),
    default: Some(DefaultValue::Name("F1")),
    doc: "Cellular only: F1, F2 (nearest, second nearest distance), F2MinusF1, CellValue (a random value per cell) or Edge ((F2 - F1) / 2)",
};

const PERIOD_ARG: ArgDef = ArgDef {
    name: "period",
    kind: ArgKind::Period,
    default: Some(DefaultValue::Nothing),
    doc: "seamless tiling: the noise repeats exactly every period cells along each axis (octave i of a fractal: period * lacunarity^i, lacunarity a whole number)",
};

const NOISE_ARGS: &[ArgDef] = &[
    INPUT,
    BASIS,
    SEED_ARG,
    INTERPOLATION_ARG,
    JITTER_ARG,
    METRIC_ARG,
    VALUE_ARG,
    PERIOD_ARG,
];

const FRACTAL_ARGS: &[ArgDef] = &[
    INPUT,
    BASIS,
    SEED_ARG,
    OCTAVES_ARG,
    LACUNARITY_ARG,
    GAIN_ARG,
    FIRST_OCTAVE_ARG,
    INTERPOLATION_ARG,
    JITTER_ARG,
    METRIC_ARG,
    VALUE_ARG,
    PERIOD_ARG,
];

const RIDGED_ARGS: &[ArgDef] = &[
    INPUT,
    BASIS,
    SEED_ARG,
    OCTAVES_ARG,
    LACUNARITY_ARG,
    GAIN_ARG,
    constant(
        "offset",
        GAIN,
        Some(1.0),
        "the ridge height: each octave's signal is offset - |noise|",
    ),
    constant(
        "sharpness",
        SHARPNESS,
        Some(2.0),
        "the exponent the signal is raised to: higher is sharper ridges",
    ),
    FIRST_OCTAVE_ARG,
    INTERPOLATION_ARG,
    JITTER_ARG,
    METRIC_ARG,
    VALUE_ARG,
    PERIOD_ARG,
];

const WARP_ARGS: &[ArgDef] = &[
    INPUT,
    input(
        "amount",
        InputType::Any,
        "how far the point moves: scalar or per axis, may vary per point",
    ),
    BASIS,
    SEED_ARG,
    OCTAVES_ARG,
    LACUNARITY_ARG,
    GAIN_ARG,
    FIRST_OCTAVE_ARG,
    INTERPOLATION_ARG,
    JITTER_ARG,
    METRIC_ARG,
    VALUE_ARG,
    PERIOD_ARG,
];

/// Every node kind, in the order `texgraph nodes` lists them.
pub const CATALOGUE: &[NodeDef] = &[
    NodeDef { kind: Kind::Position, lowering: Lowering::Position, slope: Slope::Identity, name: "Position", args: &[], output: OutputType::Vec3, doc: "The sample point (x, y, z)." },
    NodeDef {
        kind: Kind::Combine, lowering: Lowering::Combine, slope: Slope::Euclidean,
        name: "Combine",
        args: &[input("x", InputType::Scalar, "x component"), input("y", InputType::Scalar, "y component"), input("z", InputType::Scalar, "z component")],
        output: OutputType::Vec3,
        doc: "Builds a vec3 from three scalars.",
    },
    NodeDef {
        kind: Kind::Scale, lowering: Lowering::Scale, slope: Slope::ConstantFactor,
        name: "Scale",
        args: &[input("input", InputType::Vec3, "the point"), input("by", InputType::Any, "scale factor, scalar or per axis")],
        output: OutputType::Vec3,
        doc: "Component-wise product input * by (seed 001's texture repeat vector).",
    },
    NodeDef {
        kind: Kind::Translate, lowering: Lowering::Translate, slope: Slope::Sum,
        name: "Translate",
        args: &[input("input", InputType::Vec3, "the point"), input("by", InputType::Any, "offset, scalar or per axis")],
        output: OutputType::Vec3,
        doc: "Adds an offset: input + by.",
    },
    NodeDef {
        kind: Kind::Rotate, lowering: Lowering::Rotate, slope: Slope::RigidMotion,
        name: "Rotate",
        args: &[
            input("input", InputType::Vec3, "the point"),
            ArgDef { name: "axis", kind: ArgKind::ConstAxis, default: Some(DefaultValue::Vec3([0.0, 0.0, 1.0])), doc: "rotation axis through the origin (normalised)" },
            input("degrees", InputType::Scalar, "angle, right-handed about the axis; may vary per point (twist)"),
        ],
        output: OutputType::Vec3,
        doc: "Rotates the point about an axis through the origin; the pattern appears rotated the other way.",
    },
    NodeDef {
        kind: Kind::Noise, lowering: Lowering::Noise, slope: Slope::Basis,
        name: "Noise",
        args: NOISE_ARGS,
        output: OutputType::Scalar,
        doc: "One noise sample: Perlin (improved, 2002), Gradient (seed 000), Value (seeds 002/004), Simplex or Cellular.",
    },
    NodeDef {
        kind: Kind::Fbm, lowering: Lowering::Fractal(FractalKind::Fbm), slope: Slope::FractalSum,
        name: "Fbm",
        args: FRACTAL_ARGS,
        output: OutputType::Scalar,
        doc: "Fractal sum: sum over octaves i of gain^i * basis(input * lacunarity^i).",
    },
    NodeDef {
        kind: Kind::Turbulence, lowering: Lowering::Fractal(FractalKind::Turbulence), slope: Slope::FractalSum,
        name: "Turbulence",
        args: FRACTAL_ARGS,
        output: OutputType::Scalar,
        doc: "Perlin's turbulence: sum over octaves i of gain^i * |basis(input * lacunarity^i)|.",
    },
    NodeDef {
        kind: Kind::Ridged, lowering: Lowering::Fractal(FractalKind::Ridged), slope: Slope::Unbounded("each octave is weighted by the one before"),
        name: "Ridged",
        args: RIDGED_ARGS,
        output: OutputType::Scalar,
        doc: "Musgrave's ridged multifractal: sum of gain^i * s_i, s_i = max(offset - |n_i|, 0)^sharpness * w_i, w_0 = 1, w_i+1 = clamp(2 s_i, 0, 1).",
    },
    NodeDef {
        kind: Kind::Billow, lowering: Lowering::Fractal(FractalKind::Billow), slope: Slope::FractalSum,
        name: "Billow",
        args: FRACTAL_ARGS,
        output: OutputType::Scalar,
        doc: "Billowy fractal: sum over octaves i of gain^i * (2 |basis(input * lacunarity^i)| - 1).",
    },
    NodeDef {
        kind: Kind::Cellular, lowering: Lowering::Cellular, slope: Slope::Basis,
        name: "Cellular",
        args: &[INPUT, SEED_ARG, JITTER_ARG, METRIC_ARG, VALUE_ARG, PERIOD_ARG],
        output: OutputType::Scalar,
        doc: "Worley's cellular noise: distances to the nearest feature points, one point per integer cell (exact search).",
    },
    NodeDef {
        kind: Kind::WhiteNoise, lowering: Lowering::White, slope: Slope::Unbounded("white noise jumps at every cell face"),
        name: "WhiteNoise",
        args: &[INPUT, SEED_ARG, PERIOD_ARG],
        output: OutputType::Scalar,
        doc: "A random value in [0, 1) per integer cell of the point (a hash, no interpolation).",
    },
    NodeDef {
        kind: Kind::VecNoise, lowering: Lowering::VecNoise, slope: Slope::Composite,
        name: "VecNoise",
        args: NOISE_ARGS,
        output: OutputType::Vec3,
        doc: "Three decorrelated noise samples as a vec3: x uses `seed`, y and z the tables of seed + 2^53 and seed + 2^54.",
    },
    NodeDef {
        kind: Kind::VecFbm, lowering: Lowering::VecFractal, slope: Slope::Composite,
        name: "VecFbm",
        args: FRACTAL_ARGS,
        output: OutputType::Vec3,
        doc: "Three decorrelated fbm sums as a vec3 (seeds as VecNoise).",
    },
    NodeDef {
        kind: Kind::Warp, lowering: Lowering::Warp, slope: Slope::Composite,
        name: "Warp",
        args: WARP_ARGS,
        output: OutputType::Vec3,
        doc: "Domain warping: input + amount * VecFbm(input, ...); use it as the input of any node, nest it to warp the warp.",
    },
    NodeDef { kind: Kind::Add, lowering: Lowering::Binary(BinaryOp::Add), slope: Slope::Sum, name: "Add", args: ANY_AB, output: OutputType::Broadcast, doc: "a + b." },
    NodeDef { kind: Kind::Sub, lowering: Lowering::Binary(BinaryOp::Sub), slope: Slope::Sum, name: "Sub", args: ANY_AB, output: OutputType::Broadcast, doc: "a - b." },
    NodeDef { kind: Kind::Mul, lowering: Lowering::Binary(BinaryOp::Mul), slope: Slope::ConstantFactor, name: "Mul", args: ANY_AB, output: OutputType::Broadcast, doc: "a * b." },
    NodeDef { kind: Kind::Div, lowering: Lowering::Binary(BinaryOp::Div), slope: Slope::ConstantDivisor, name: "Div", args: ANY_AB, output: OutputType::Broadcast, doc: "a / b (IEEE: x/0 is +-inf, 0/0 is NaN)." },
    NodeDef { kind: Kind::Min, lowering: Lowering::Binary(BinaryOp::Min), slope: Slope::Steepest, name: "Min", args: ANY_AB, output: OutputType::Broadcast, doc: "The smaller of a and b; NaN if either is NaN." },
    NodeDef { kind: Kind::Max, lowering: Lowering::Binary(BinaryOp::Max), slope: Slope::Steepest, name: "Max", args: ANY_AB, output: OutputType::Broadcast, doc: "The larger of a and b; NaN if either is NaN." },
    NodeDef { kind: Kind::Pow, lowering: Lowering::Binary(BinaryOp::Pow), slope: Slope::Unbounded("the slope of a^b grows without bound"), name: "Pow", args: ANY_AB, output: OutputType::Broadcast, doc: "a raised to b (IEEE pow: a negative a with a non-integer b is NaN)." },
    NodeDef {
        kind: Kind::Atan2, lowering: Lowering::Binary(BinaryOp::Atan2), slope: Slope::Unbounded("the slope of atan2 grows without bound near the origin"),
        name: "Atan2",
        args: &[input("y", InputType::Any, "y"), input("x", InputType::Any, "x")],
        output: OutputType::Broadcast,
        doc: "The angle of (x, y) in radians, in [-pi, pi]; Atan2(0, 0) is 0.",
    },
    NodeDef { kind: Kind::Mod, lowering: Lowering::Binary(BinaryOp::Mod), slope: Slope::Unbounded("a floored modulo jumps"), name: "Mod", args: ANY_AB, output: OutputType::Broadcast, doc: "Floored modulo: the result takes the sign of b; Mod(a, 0) is NaN." },
    NodeDef { kind: Kind::Abs, lowering: Lowering::Unary(UnaryOp::Abs), slope: Slope::NoSteeper, name: "Abs", args: ANY_X, output: OutputType::Broadcast, doc: "|x|." },
    NodeDef { kind: Kind::Neg, lowering: Lowering::Unary(UnaryOp::Neg), slope: Slope::NoSteeper, name: "Neg", args: ANY_X, output: OutputType::Broadcast, doc: "-x." },
    NodeDef { kind: Kind::Sin, lowering: Lowering::Unary(UnaryOp::Sin), slope: Slope::NoSteeper, name: "Sin", args: ANY_X, output: OutputType::Broadcast, doc: "sin(x), x in radians." },
    NodeDef { kind: Kind::Cos, lowering: Lowering::Unary(UnaryOp::Cos), slope: Slope::NoSteeper, name: "Cos", args: ANY_X, output: OutputType::Broadcast, doc: "cos(x), x in radians." },
    NodeDef { kind: Kind::Sqrt, lowering: Lowering::Unary(UnaryOp::Sqrt), slope: Slope::Unbounded("the slope of a square root is unbounded at 0"), name: "Sqrt", args: ANY_X, output: OutputType::Broadcast, doc: "Square root; NaN for negative x." },
    NodeDef { kind: Kind::Floor, lowering: Lowering::Unary(UnaryOp::Floor), slope: Slope::Unbounded("floor jumps"), name: "Floor", args: ANY_X, output: OutputType::Broadcast, doc: "The largest integer <= x." },
    NodeDef { kind: Kind::Fract, lowering: Lowering::Unary(UnaryOp::Fract), slope: Slope::Unbounded("fract jumps"), name: "Fract", args: ANY_X, output: OutputType::Broadcast, doc: "x - floor(x), in [0, 1); NaN for infinite x." },
    NodeDef { kind: Kind::Exp, lowering: Lowering::Unary(UnaryOp::Exp), slope: Slope::Unbounded("the slope of e^x grows without bound"), name: "Exp", args: ANY_X, output: OutputType::Broadcast, doc: "e^x; overflows to inf above about 88.72 (f32) or 709.78 (f64)." },
    NodeDef { kind: Kind::Log, lowering: Lowering::Unary(UnaryOp::Log), slope: Slope::Unbounded("the slope of ln x is unbounded at 0"), name: "Log", args: ANY_X, output: OutputType::Broadcast, doc: "Natural logarithm; -inf at 0, NaN below 0 (IEEE)." },
    NodeDef { kind: Kind::Log2, lowering: Lowering::Unary(UnaryOp::Log2), slope: Slope::Unbounded("the slope of log2 x is unbounded at 0"), name: "Log2", args: ANY_X, output: OutputType::Broadcast, doc: "Base-2 logarithm; -inf at 0, NaN below 0 (IEEE); exact at powers of two." },
    NodeDef { kind: Kind::Tan, lowering: Lowering::Unary(UnaryOp::Tan), slope: Slope::Unbounded("tan has poles"), name: "Tan", args: ANY_X, output: OutputType::Broadcast, doc: "tan(x), x in radians; very large near the poles at pi/2 + k pi." },
    NodeDef { kind: Kind::Asin, lowering: Lowering::Unary(UnaryOp::Asin), slope: Slope::Unbounded("the slope of asin is unbounded at -1 and 1"), name: "Asin", args: ANY_X, output: OutputType::Broadcast, doc: "arcsin in [-pi/2, pi/2]; NaN outside [-1, 1] (IEEE)." },
    NodeDef { kind: Kind::Acos, lowering: Lowering::Unary(UnaryOp::Acos), slope: Slope::Unbounded("the slope of acos is unbounded at -1 and 1"), name: "Acos", args: ANY_X, output: OutputType::Broadcast, doc: "arccos in [0, pi]; NaN outside [-1, 1] (IEEE)." },
    NodeDef { kind: Kind::Sign, lowering: Lowering::Unary(UnaryOp::Sign), slope: Slope::Unbounded("sign jumps at 0"), name: "Sign", args: ANY_X, output: OutputType::Broadcast, doc: "-1 below 0, 1 above; x itself at +0, -0 and NaN (GLSL sign)." },
    NodeDef { kind: Kind::Round, lowering: Lowering::Unary(UnaryOp::Round), slope: Slope::Unbounded("round jumps"), name: "Round", args: ANY_X, output: OutputType::Broadcast, doc: "The nearest integer, halves away from zero (Round(2.5) = 3, Round(-2.5) = -3)." },
    NodeDef { kind: Kind::Trunc, lowering: Lowering::Unary(UnaryOp::Trunc), slope: Slope::Unbounded("trunc jumps"), name: "Trunc", args: ANY_X, output: OutputType::Broadcast, doc: "x rounded toward zero." },
    NodeDef {
        kind: Kind::Step, lowering: Lowering::Binary(BinaryOp::Step), slope: Slope::Unbounded("step jumps at its edge"),
        name: "Step",
        args: &[input("edge", InputType::Any, "the edge"), input("x", InputType::Any, "the value tested")],
        output: OutputType::Broadcast,
        doc: "GLSL step: 0 where x < edge, 1 where x >= edge; NaN if either is NaN.",
    },
    NodeDef {
        kind: Kind::Select, lowering: Lowering::Ternary(TernaryOp::Select), slope: Slope::Unbounded("select jumps where its condition changes sign"),
        name: "Select",
        args: &[input("condition", InputType::Scalar, "chooses a where > 0, else b (NaN chooses b)"), input("a", InputType::Any, "value where condition > 0"), input("b", InputType::Any, "value elsewhere")],
        output: OutputType::Broadcast,
        doc: "a where condition > 0, else b (a scalar condition chooses whole vec3 branches).",
    },
    NodeDef {
        kind: Kind::MapRange, lowering: Lowering::MapRange, slope: Slope::Composite,
        name: "MapRange",
        args: &[
            input("input", InputType::Any, "the value"),
            input_or("from_min", InputType::Any, 0.0, "input value mapped to to_min"),
            input_or("from_max", InputType::Any, 1.0, "input value mapped to to_max"),
            input_or("to_min", InputType::Any, 0.0, "output at from_min"),
            input_or("to_max", InputType::Any, 1.0, "output at from_max"),
            ArgDef { name: "clamp", kind: ArgKind::Flag, default: Some(DefaultValue::Flag(false)), doc: "keep the result between to_min and to_max" },
        ],
        output: OutputType::Broadcast,
        doc: "Linear remap: to_min + t (to_max - to_min), t = (input - from_min) / (from_max - from_min), t clamped to [0, 1] when clamp is true.",
    },
    NodeDef { kind: Kind::Length, lowering: Lowering::Length, slope: Slope::NoSteeper, name: "Length", args: &[input("v", InputType::Vec3, "the vector")], output: OutputType::Scalar, doc: "Euclidean length of a vec3." },
    NodeDef {
        kind: Kind::Dot, lowering: Lowering::Dot, slope: Slope::ConstantProjection,
        name: "Dot",
        args: &[input("a", InputType::Vec3, "left vector"), input("b", InputType::Vec3, "right vector")],
        output: OutputType::Scalar,
        doc: "Dot product of two vec3.",
    },
    NodeDef {
        kind: Kind::Cross, lowering: Lowering::Cross, slope: Slope::ConstantProjection,
        name: "Cross",
        args: &[input("a", InputType::Vec3, "left vector"), input("b", InputType::Vec3, "right vector")],
        output: OutputType::Vec3,
        doc: "Cross product a x b (right-handed).",
    },
    NodeDef {
        kind: Kind::Normalize, lowering: Lowering::Normalize, slope: Slope::Unbounded("a direction turns fastest near the origin"),
        name: "Normalize",
        args: &[input("v", InputType::Vec3, "the vector")],
        output: OutputType::Vec3,
        doc: "v / |v| (no overflow or underflow for any finite v); (0, 0, 0) for the zero vector; NaN if a component is infinite or NaN.",
    },
    NodeDef {
        kind: Kind::Distance, lowering: Lowering::Distance, slope: Slope::Composite,
        name: "Distance",
        args: &[input("a", InputType::Vec3, "one point"), input("b", InputType::Vec3, "the other point")],
        output: OutputType::Scalar,
        doc: "Euclidean distance |a - b|.",
    },
    NodeDef {
        kind: Kind::Gradient, lowering: Lowering::Gradient, slope: Slope::Composite,
        name: "Gradient",
        args: &[input("of", InputType::Scalar, "the scalar node differentiated")],
        output: OutputType::Vec3,
        doc: "The exact gradient (d/dx, d/dy, d/dz) of a scalar node with respect to the sample point (forward-mode differentiation; analytic noise derivatives).",
    },
    NodeDef {
        kind: Kind::Clamp, lowering: Lowering::Ternary(TernaryOp::Clamp), slope: Slope::ConstantBounds,
        name: "Clamp",
        args: &[input("input", InputType::Any, "the value"), input_or("min", InputType::Any, 0.0, "lower bound"), input_or("max", InputType::Any, 1.0, "upper bound")],
        output: OutputType::Broadcast,
        doc: "min(max(input, min), max); NaN stays NaN.",
    },
    NodeDef {
        kind: Kind::Mix, lowering: Lowering::Ternary(TernaryOp::Mix), slope: Slope::ConstantBlend,
        name: "Mix",
        args: &[input("a", InputType::Any, "value at t = 0"), input("b", InputType::Any, "value at t = 1"), input("t", InputType::Any, "blend factor, not clamped")],
        output: OutputType::Broadcast,
        doc: "Linear blend a + t * (b - a), t not clamped.",
    },
    NodeDef {
        kind: Kind::Smoothstep, lowering: Lowering::Ternary(TernaryOp::Smoothstep), slope: Slope::ConstantEdges,
        name: "Smoothstep",
        args: &[input("edge0", InputType::Any, "where the step starts"), input("edge1", InputType::Any, "where the step ends"), input("x", InputType::Any, "the value")],
        output: OutputType::Broadcast,
        doc: "GLSL smoothstep: t = clamp((x - edge0) / (edge1 - edge0), 0, 1), t*t*(3 - 2t); a hard step at edge0 when edge0 = edge1.",
    },
    NodeDef {
        kind: Kind::Hermite, lowering: Lowering::Hermite, slope: Slope::Unbounded("not yet bounded (its steepest slope depends on the tangents)"),
        name: "Hermite",
        args: &[
            input("input", InputType::Scalar, "the value; clamped to [0, 1]"),
            constant("p0", Range::FINITE, Some(0.0), "value at 0"),
            constant("p1", Range::FINITE, Some(1.0), "value at 1"),
            constant("m0", Range::FINITE, Some(1.0), "slope at 0"),
            constant("m1", Range::FINITE, Some(1.0), "slope at 1"),
        ],
        output: OutputType::Scalar,
        doc: "Cubic Hermite spline on t = clamp(input, 0, 1) from p0 (slope m0) to p1 (slope m1): seed 000's crack sharpening.",
    },
    NodeDef {
        kind: Kind::ColorRamp, lowering: Lowering::Ramp, slope: Slope::SteepestSegment,
        name: "ColorRamp",
        args: &[
            input("input", InputType::Scalar, "the value; clamped to the first and last stop"),
            ArgDef { name: "stops", kind: ArgKind::Stops, default: None, doc: "[(t, (r, g, b)), ...] sorted by t; equal t make a hard edge" },
            ArgDef {
                name: "interpolation",
                kind: ArgKind::Choice(RAMP_INTERPOLATION),
                default: Some(DefaultValue::Name("Linear")),
                doc: "Linear, Smooth (smoothstep-eased) or Constant (hold each stop)",
            },
        ],
        output: OutputType::Vec3,
        doc: "Colour spline: maps a scalar to a colour through sorted stops.",
    },
    NodeDef {
        kind: Kind::Curve, lowering: Lowering::Curve, slope: Slope::SteepestSegment,
        name: "Curve",
        args: &[
            input("input", InputType::Scalar, "the value; clamped to the first and last point"),
            ArgDef { name: "points", kind: ArgKind::Points, default: None, doc: "[(x, y), ...] sorted by x; equal x make a jump" },
            ArgDef {
                name: "interpolation",
                kind: ArgKind::Choice(RAMP_INTERPOLATION),
                default: Some(DefaultValue::Name("Linear")),
                doc: "Linear, Smooth (smoothstep-eased) or Constant (hold each point)",
            },
        ],
        output: OutputType::Scalar,
        doc: "Scalar spline: maps a scalar through sorted (x, y) points.",
    },
    NodeDef {
        kind: Kind::Luminance, lowering: Lowering::Luminance, slope: Slope::Composite,
        name: "Luminance",
        args: &[input("colour", InputType::Vec3, "linear RGB")],
        output: OutputType::Scalar,
        doc: "Relative luminance with the Rec. 709 weights: 0.2126 r + 0.7152 g + 0.0722 b.",
    },
    NodeDef {
        kind: Kind::HsvToRgb, lowering: Lowering::HsvToRgb, slope: Slope::Composite,
        name: "HsvToRgb",
        args: &[input("hsv", InputType::Vec3, "(hue in turns, wrapping; saturation; value)")],
        output: OutputType::Vec3,
        doc: "HSV to RGB: hue in turns (0 red, 1/3 green, 2/3 blue; any real hue wraps), saturation and value not clamped.",
    },
    NodeDef {
        kind: Kind::RgbToHsv, lowering: Lowering::RgbToHsv, slope: Slope::Composite,
        name: "RgbToHsv",
        args: &[input("rgb", InputType::Vec3, "the colour")],
        output: OutputType::Vec3,
        doc: "RGB to HSV: hue in turns [0, 1) (0 for greys), saturation (max - min) / max (0 where max <= 0), value max(r, g, b).",
    },
    NodeDef {
        kind: Kind::Blend, lowering: Lowering::Blend, slope: Slope::Composite,
        name: "Blend",
        args: &[
            input("base", InputType::Any, "the colour below"),
            input("layer", InputType::Any, "the colour blended over it"),
            input_or("t", InputType::Any, 1.0, "opacity of the layer, not clamped"),
            ArgDef { name: "mode", kind: ArgKind::Choice(BLEND_MODES), default: Some(DefaultValue::Name("Mix")), doc: "how base and layer combine (formulas in docs/format.md)" },
        ],
        output: OutputType::Broadcast,
        doc: "Blend modes of image editors: Mix(base, mode(base, layer), t), per component, not clamped.",
    },
    NodeDef {
        kind: Kind::Import, lowering: Lowering::Import, slope: Slope::Composite,
        name: "Import",
        args: &[
            ArgDef { name: "file", kind: ArgKind::Text, default: None, doc: "the graph file, relative to this file" },
            ArgDef { name: "output", kind: ArgKind::Text, default: None, doc: "which of its outputs" },
            ArgDef { name: "input", kind: ArgKind::Input(InputType::Vec3), default: Some(DefaultValue::Position), doc: "what Position means inside the imported graph" },
            ArgDef { name: "set", kind: ArgKind::Overrides, default: Some(DefaultValue::Empty), doc: "its params' values, as --set gives them: constants, params or constant expressions of this graph" },
        ],
        output: OutputType::Imported,
        doc: "An output of another graph file, evaluated at input (checked as its own file; one file imported twice with the same arguments is built once).",
    },
];

/// Looks a kind up by its name as written in graph files.
pub fn lookup(name: &str) -> Option<&'static NodeDef> {
    CATALOGUE.iter().find(|def| def.name == name)
}

pub fn def(kind: Kind) -> &'static NodeDef {
    &CATALOGUE[kind as usize]
}

// The catalogue lists the kinds in `Kind` order, one entry each: checked when the crate
// compiles, so `def` can index it (a test pins that every kind has its entry).
const _: () = {
    let mut i = 0;
    while i < CATALOGUE.len() {
        assert!(
            CATALOGUE[i].kind as usize == i,
            "CATALOGUE must list the kinds in Kind order"
        );
        i += 1;
    }
};

/// The names of the catalogue's kinds whose lowering `keep` accepts, in catalogue order (the
/// test generators and the fuzz harness iterate the table through this).
pub fn names_where(keep: impl Fn(Lowering) -> bool) -> Vec<&'static str> {
    CATALOGUE
        .iter()
        .filter(|d| keep(d.lowering))
        .map(|d| d.name)
        .collect()
}

/// The closest catalogue name to a misspelt one, for "did you mean" hints.
pub fn suggest(name: &str) -> Option<&'static str> {
    suggest_from(name, CATALOGUE.iter().map(|d| d.name))
}

/// The closest candidate by edit distance (case-insensitive), if it is close enough to help.
pub fn suggest_from<'a>(name: &str, candidates: impl Iterator<Item = &'a str>) -> Option<&'a str> {
    let lower = name.to_ascii_lowercase();
    candidates
        .map(|c| (edit_distance(&lower, &c.to_ascii_lowercase()), c))
        .filter(|(d, c)| *d <= 2.max(c.len() / 3))
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

/// Levenshtein distance; tiny inputs only (names), so the quadratic table is fine and no crate
/// is worth a dependency.
fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    let mut previous: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.iter().enumerate() {
        let mut current = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            let substitution = previous[j] + usize::from(ca != cb);
            current[j + 1] = substitution.min(previous[j + 1] + 1).min(current[j] + 1);
        }
        previous = current;
    }
    previous[b.len()]
}

/// An argument's type as `texgraph nodes` prints it (`scalar`, `constant, 1 to 16`, …).
pub fn describe_arg(arg: &ArgDef) -> String {
    match arg.kind {
        ArgKind::Input(InputType::Scalar) => "scalar".into(),
        ArgKind::Input(InputType::Vec3) => "vec3".into(),
        ArgKind::Input(InputType::Any) => "scalar|vec3".into(),
        ArgKind::ConstScalar(range) => format!("constant, {}", range.describe()),
        ArgKind::ConstAxis => "constant non-zero vec3".into(),
        ArgKind::Basis => "Perlin|Gradient|Value|Simplex|Cellular".into(),
        ArgKind::Choice(names) => names.join("|"),
        ArgKind::Stops => "[(t, (r, g, b)), ...]".into(),
        ArgKind::Points => "[(x, y), ...]".into(),
        ArgKind::Period => "constant whole number or (px, py, pz), each 1 to 2^20".into(),
        ArgKind::Flag => "true|false".into(),
        ArgKind::Text => "string".into(),
        ArgKind::Overrides => "{ \"param\": constant, ... }".into(),
    }
}

/// An argument's default as `texgraph nodes` prints it (`required`, `default 0.5`, …).
pub fn describe_default(default: Option<DefaultValue>) -> String {
    match default {
        None => "required".into(),
        Some(DefaultValue::Number(v)) => format!("default {v}"),
        Some(DefaultValue::Vec3([x, y, z])) => format!("default ({x}, {y}, {z})"),
        Some(DefaultValue::Name(n)) => format!("default {n}"),
        Some(DefaultValue::Nothing) => "default none".into(),
        Some(DefaultValue::Flag(b)) => format!("default {b}"),
        Some(DefaultValue::Position) => "default Position".into(),
        Some(DefaultValue::Empty) => "default {}".into(),
    }
}

/// A kind's output type as `texgraph nodes` prints it.
pub fn describe_output(output: OutputType) -> &'static str {
    match output {
        OutputType::Scalar => "scalar",
        OutputType::Vec3 => "vec3",
        OutputType::Broadcast => "scalar, or vec3 if any operand is a vec3 (component-wise)",
        OutputType::Imported => "the imported output's type",
    }
}

/// The catalogue as plain text, for `texgraph nodes`.
pub fn catalogue_text() -> String {
    let mut out = String::new();
    for def in CATALOGUE {
        let signature: Vec<&str> = def.args.iter().map(|a| a.name).collect();
        out.push_str(&format!(
            "{}({}) -> {}\n",
            def.name,
            signature.join(", "),
            describe_output(def.output)
        ));
        out.push_str(&format!("    {}\n", def.doc));
        for arg in def.args {
            // Name, type and default on one line, the meaning indented below: columns stay
            // aligned however long a type is.
            out.push_str(&format!(
                "    {:<14} {} ({})\n                   {}\n",
                arg.name,
                describe_arg(arg),
                describe_default(arg.default),
                arg.doc
            ));
        }
        out.push('\n');
    }
    out
}

/// The catalogue as a Markdown table, for docs/format.md.
pub fn catalogue_markdown() -> String {
    let mut out = String::from("| node | arguments | output | meaning |\n|---|---|---|---|\n");
    for def in CATALOGUE {
        let args: Vec<String> = def
            .args
            .iter()
            .map(|a| {
                format!(
                    "`{}`: {} ({}) — {}",
                    a.name,
                    describe_arg(a),
                    describe_default(a.default),
                    a.doc
                )
            })
            .collect();
        let args = if args.is_empty() {
            "—".to_string()
        } else {
            args.join("<br>")
        };
        out.push_str(&format!(
            "| `{}` | {} | {} | {} |\n",
            def.name,
            args.replace('|', "\\|"),
            describe_output(def.output),
            def.doc.replace('|', "\\|")
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_is_defined_once() {
        for (i, a) in CATALOGUE.iter().enumerate() {
            for b in &CATALOGUE[i + 1..] {
                assert_ne!(a.kind, b.kind);
                assert_ne!(a.name, b.name);
            }
            assert_eq!(def(a.kind).name, a.name);
            assert_eq!(lookup(a.name).map(|d| d.kind), Some(a.kind));
        }
        assert_eq!(CATALOGUE.len(), 60);
    }

    /// Each entry lowers to its own operation: a math kind to the `ops` operation of the same
    /// name (a copied entry that kept its neighbour's operation fails here), the rest to their
    /// own lowering.
    #[test]
    fn every_kind_lowers_to_its_own_operation() {
        for d in CATALOGUE {
            let own = match d.lowering {
                Lowering::Unary(op) => format!("{op:?}"),
                Lowering::Binary(op) => format!("{op:?}"),
                Lowering::Ternary(op) => format!("{op:?}"),
                Lowering::Fractal(kind) => format!("{kind:?}"),
                Lowering::White => "WhiteNoise".into(),
                Lowering::VecFractal => "VecFbm".into(),
                Lowering::Ramp => "ColorRamp".into(),
                other => format!("{other:?}"),
            };
            assert_eq!(own, d.name, "{:?}", d.kind);
        }
    }

    #[test]
    fn suggestions() {
        assert_eq!(suggest("Fmb"), Some("Fbm"));
        assert_eq!(suggest("sin"), Some("Sin"));
        assert_eq!(suggest("Turbulance"), Some("Turbulence"));
        assert_eq!(suggest("Xyzzyplugh"), None);
    }
}
