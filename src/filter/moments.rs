//! Moments of a function of a value spread over a footprint: the one-variable mathematics of
//! filtered evaluation. This file is the reference for the derivations in docs/filtering.md.
//!
//! # The model
//!
//! A filtered evaluator computes the mean of `f(V)` over a footprint, a box `p0 + Σ_k u_k e_k`
//! (`u_k` uniform on `[-1/2, 1/2]`, `e_k` its edge vectors). A value linear in the position,
//! `V(p) = t + g·(p − p0)`, takes there the value `t + Σ_k u_k (g·e_k)`; as `u_k` and `−u_k` have
//! the same distribution, that is the distribution of
//!
//! ```text
//! X = t + S,   S = w1 U1 + w2 U2 + w3 U3,   w_k = |g·e_k| >= 0,   U_k iid uniform on [-1/2, 1/2]
//! ```
//!
//! ([`Spread`] holds the widths `w_k`). A part of the value that is not linear in the position
//! (its *residual* variance `r`) is modelled as one more independent uniform of the same
//! variance, of width `sqrt(12 r)` (`Var(w U) = w²/12`). For `f` a piecewise polynomial
//! ([`Piecewise`]), a truncated or plain power ([`ramp_mean`], [`power_mean`]) or `fract`
//! ([`fract_moments`]) this file computes `E[f(X)]`, `Var f(X)` and the *slope*
//! `d/dt E[f(X)] = E[f'(X)]` (with a Dirac term `jump · density` at each jump of `f`), exactly:
//! no sampling, no truncated series, and rounding errors bounded independently of the widths'
//! sizes and ratios and of `t` (the tests agree with an independent quadrature to `1e-10` of the
//! function's scale for widths up to `10⁶` and `|t|` up to `10⁸`).
//!
//! # The moments of S
//!
//! `E[U^j] = ∫_{-1/2}^{1/2} u^j du = 2^{-j} / (j + 1)` for even `j` and `0` for odd `j`, so
//! `E[(wU)^j] / j! = (w/2)^j / (j + 1)!` (even `j`). For independent `A`, `B` the binomial theorem
//! gives `E[(A + B)^j] / j! = Σ_i (E[A^i] / i!) (E[B^{j−i}] / (j − i)!)`: the sequences
//! `e_j = E[S^j] / j!` multiply as power series (exponential generating functions), which is how
//! they are computed (`times_width`, one width at a time; every term is ≥ 0, no cancellation).
//! Written out:
//!
//! ```text
//! E[S²] = Σ_k w_k²/12
//! E[S⁴] = Σ_k w_k⁴/80 + 6 Σ_{i<j} (w_i²/12)(w_j²/12)
//! E[S⁶] = Σ_k w_k⁶/448 + 15 Σ_{i≠j} (w_i⁴/80)(w_j²/12) + 90 (w_1²/12)(w_2²/12)(w_3²/12)
//! ```
//!
//! (`E[U⁴] = 1/80`, `E[U⁶] = 1/448`; the multinomial coefficients `4!/(2!2!) = 6`,
//! `6!/(4!2!) = 15`, `6!/(2!2!2!) = 90`; odd moments vanish by symmetry). A polynomial's mean then
//! follows from its Taylor expansion at `t`:
//!
//! ```text
//! E[(t + S)^n / n!] = Σ_{i even, i <= n} t^{n−i}/(n−i)! · E[S^i]/i!                      (P)
//! ```
//!
//! All terms have the sign of `t^n` (`n − i ≡ n mod 2`), so (P) has no cancellation at any `t`.
//!
//! # Truncated powers
//!
//! `T_n(x) = x₊^n / n!` (`T_0` the unit step, 1 for `x >= 0`), so `T_n' = T_{n−1}`. For one
//! width, `E[g(x + wU)] = (G(x + w/2) − G(x − w/2)) / w` for any antiderivative `G` of `g`
//! (`G` absolutely continuous; the fundamental theorem of calculus). Applied once per width with
//! `G = T_{n+1}`:
//!
//! ```text
//! E[T_n(x + S)] = (1/Π w) Σ_{σ ∈ {±1}^k} (Π σ) T_{n+k}(x + Σ_j σ_j w_j / 2)                (D)
//! ```
//!
//! (over the `k` non-zero widths: the k-th central divided difference of the k-fold
//! antiderivative, the B-spline identity behind box-filtered pulses). Evaluated as written, (D)
//! loses up to `ε (Σw)^k / Π w` relative to its result (`ε` the f64 epsilon): up to `ε · 10^12` with
//! three widths each `10⁻⁴` of the previous. So it is evaluated *nested*, one width at a time,
//! the largest outermost, each level with two exact shortcuts (`tp_means`):
//!
//! - if `x − Σw/2 >= 0` (the whole support right of the kink): `E[T_n(x + S)] = E[(x + S)^n/n!]`,
//!   the polynomial moment (P);
//! - if `x + Σw/2 <= 0` (the whole support left of it): 0;
//! - else `R_n(x; w_1..w_k) = (R_{n+1}(x + w_1/2; w_2..w_k) − R_{n+1}(x − w_1/2; w_2..w_k)) / w_1`.
//!
//! Each level loses at most a small constant factor: `ψ(y) = R_{n+1}(y; w_2..w_k)` is convex,
//! nondecreasing and 0 for `y <= −r` (`r = (w_2 + … + w_k)/2 <= w_1`); in the third case
//! `y₋ = x − w_1/2 ∈ (−r, r)`, and convexity gives `ψ(y₊) − ψ(y₋) >= w_1 ψ'(y₋)` and
//! `ψ(y₋) <= (y₋ + r) ψ'(y₋) <= 2 w_1 ψ'(y₋)`, so `ψ(y₋) <= 2 (ψ(y₊) − ψ(y₋))`: the difference is
//! at least a third of its larger term, and relative errors grow at most 5-fold per level
//! (≤ 125 ε for three widths), whatever the width ratios.
//!
//! The density of `S` (`p_S(u) = d/du P(u + S >= 0)`; [`density`] is `p_S(−t)`, the density of
//! `X` at 0) is the first step of the same recursion one order down,
//! `p_S(u) = (P(u + w_1/2 + S' >= 0) − P(u − w_1/2 + S' >= 0)) / w_1` (`S'` the other widths),
//! evaluated at `u = −|u|` (`p_S` is even): there the second probability is the smaller one, and
//! both keep their relative accuracy into the tails.
//!
//! # Piecewise polynomials
//!
//! The mean of a piecewise polynomial is the sum of its pieces' *partial means*
//! `E[Q(X) 1{X ∈ [a, b)}]` over the pieces `[a, b)` that meet the support
//! `[x_l, x_r] = [t − Σw/2, t + Σw/2]`, with `Q` the piece for the mean, its derivative for the
//! slope, and `(P − m)²` (`m` the mean) for the variance. Each partial mean is computed where it
//! lives (`plan`):
//!
//! - the piece covers the support: `Q` re-expanded at `t`, `Q(t + s) = Σ_d q_d s^d`, gives
//!   `Σ_d q_d E[S^d]` (P);
//! - the support starts left of the piece's start `a` and ends inside the piece:
//!   `E[Q(X) 1{X >= a}] = Σ_d Q^{(d)}(a) E[T_d(X − a)]` (Taylor at `a`; (D));
//! - the support ends right of the piece's end `b` and starts inside it:
//!   `E[Q(X) 1{X < b}] = Σ_d Q^{(d)}(b) (−1)^d E[T_d(b − X)]`, and `b − X` has the distribution
//!   of `(b − t) + S` (`S` is symmetric): (D) again;
//! - a piece inside the support at least half as long as it: the difference of two of those,
//!   `E[Q 1{X >= a}] − E[Q 1{X >= b}]` or `E[Q 1{X < b}] − E[Q 1{X < a}]`, on the side of the
//!   shorter tail, so `Q` is continued at most half the piece's length beyond it, where a
//!   polynomial of degree <= 6 bounded by `M` on the piece is bounded by `T_6(2) M = 1351 M`
//!   (Chebyshev): the cancellation is bounded;
//! - a shorter piece inside the support: `∫_a^b Q(x) p_S(x − t) dx` by 5-node Gauss–Legendre on
//!   each sub-interval between the density's breakpoints `t + Σ_j ±w_j/2`; there `p_S` is a
//!   polynomial of degree `k − 1 <= 2`, so the integrand has degree <= 8 and the rule (exact to
//!   degree 9) is exact.
//!
//! Every partial mean is thus bounded by `max |Q|` on its piece times the piece's probability.
//! (The textbook form `f = P_0 + Σ_i Σ_d J_{i,d} (x − c_i)₊^d / d!`, `J_{i,d}` the jump of
//! `f^{(d)}` at knot `c_i`, with one truncated-power mean per knot, is equivalent but not
//! bounded: its terms grow like `J_{i,d} (Σw)^d` — a smoothstep under a support `10⁶` wide
//! sums terms of `10^17` to a mean of 1/2.)
//!
//! ```text
//! mean     = Σ_pieces E[P(X) 1{X ∈ piece}]
//! slope    = Σ_pieces E[P'(X) 1{X ∈ piece}] + Σ_{knots c inside} (f(c+) − f(c−)) p_S(c − t)
//! variance = Σ_pieces E[(P(X) − mean)² 1{X ∈ piece}]
//! ```
//!
//! The slope: `d/dt E[f(t + S)] = E[f'(X)]` for the continuous part of `f` and
//! `d/dt P(X >= c) = p_S(c − t)` for each jump. The variance is centred (`E[(f − m)²]` with `m`
//! the computed mean; `(E f − m)²` is 0 to rounding) and its partial means are all `>= 0` (but for
//! the bounded differences above), so it keeps its relative accuracy where `Var f ≪ (E f)²`; each
//! piece is re-expanded at the evaluation point before `m` is subtracted and the result squared.
//!
//! # fract
//!
//! With `B_n` the Bernoulli polynomials and `P_n(x) = B_n(fract x)` their 1-periodic extensions,
//! `fract x − 1/2 = P_1(x)`, and for `n >= 1`, `d/dx P_{n+1}(x)/(n+1)! = P_n(x)/n!` with `P_{n+1}`
//! continuous (`B_{n+1}' = (n+1) B_n` and `B_{n+1}(1) = B_{n+1}(0)`) and of zero mean over a
//! period. So (D) holds with `P_{n+k}/(n+k)!` in place of `T_{n+k}`:
//! `E[P_n(X)]/n! = (1/Π w) Σ_σ (Π σ) P_{n+k}(t + Σ σ_j w_j/2) / (n + k)!`, bounded at any `t`.
//! `fract² = (P_1 + 1/2)² = P_1² + P_1 + 1/4` and `B_1(u)² = u² − u + 1/4 = B_2(u) + 1/12`, so
//! `fract² = P_2 + P_1 + 1/3` and, with `Φ_n = E[P_n(X)]/n!`,
//!
//! ```text
//! E[fract X] = 1/2 + Φ_1,   Var fract X = 1/3 + Φ_1 + 2Φ_2 − (1/2 + Φ_1)² = 1/12 + 2Φ_2 − Φ_1²
//! slope      = (Φ_1(t + w_1/2; w_2..) − Φ_1(t − w_1/2; w_2..)) / w_1
//! ```
//!
//! (the slope: differentiate the one-width step of (D); for one width it is
//! `1 − #{integers in (t − w/2, t + w/2]} / w`). `t` is first reduced to `t − floor t` (exact in
//! f64; `fract` is 1-periodic). The nested evaluation (`periodic_mean`) again uses shortcuts:
//!
//! - no integer inside the support: `P_n = B_n(x − m₀)` there (`m₀ = floor` of the support's
//!   left end), and `E[B_n(u + S)]/n! = Σ_{i even} B_{n−i}(u)/(n−i)! · E[S^i]/i!` (Taylor,
//!   `B_n^{(i)} = n!/(n−i)! B_{n−i}`);
//! - a short support (`Σw <= 2`) with integers `m` in it: `B_n(v + 1) − B_n(v) = n v^{n−1}` gives
//!   `P_n(x)/n! = B_n(x − m₀)/n! − Σ_{m₀ < m} T_{n−1}(x − m)` there (the only discontinuity of
//!   `P_n`'s derivatives is the unit drop of `P_1` at each integer), so the mean is the
//!   polynomial moment above minus truncated-power means — no division by a small width;
//! - else the difference over the largest width (then `w_1 > 2/3`: the division does not
//!   amplify rounding).
//!
//! At the top level a short support uses the [`Piecewise`] machinery directly
//! (`fract(x) = x − m₀ − Σ_m (x − m)₊^0`), whose variance is centred and so exact relative to
//! the (small) variance itself; a support with no integer is the linear case
//! (`mean t − m₀`, variance `Var S`, slope 1).

use std::array;

/// Widths below `RATIO` times the next larger one are merged into it by variance
/// ([`Spread::new`]). Merging keeps the mean and variance of `S` (it changes its fourth and
/// higher moments) and moves the mean of a step by at most about `RATIO / 8` of its jump (the
/// corners of the density, `w_small` wide, are squared off); it keeps the spreads simple (at
/// most three widths, none negligible).
const RATIO: f64 = 1e-4;

/// The support length up to which `fract` and the periodic recursion expand around the
/// integers inside the support instead of differencing over the largest width (see the module
/// docs): above it the largest width exceeds `2/3`.
pub(super) const LOCAL_SPAN: f64 = 2.0;

/// `n!` for `n <= 15`, exact in f64.
const FACT: [f64; 16] = [
    1.0,
    1.0,
    2.0,
    6.0,
    24.0,
    120.0,
    720.0,
    5040.0,
    40320.0,
    362880.0,
    3628800.0,
    39916800.0,
    479001600.0,
    6227020800.0,
    87178291200.0,
    1307674368000.0,
];

/// The length of the moment and power series (`e_j = E[S^j]/j!`, `x^j/j!` for `j < SERIES`).
const SERIES: usize = 16;

/// Bernoulli polynomials `B_0..B_10`, coefficients in ascending powers of `u`
/// (`B_n(u) = Σ_k C(n,k) B_k u^{n−k}` with the Bernoulli numbers
/// `1, −1/2, 1/6, 0, −1/30, 0, 1/42, 0, −1/30, 0, 5/66`): up to `B_7` for the second moment of
/// a periodic cubic (`periodic.rs`), three more for the nested widths.
const BERNOULLI: [[f64; 11]; 11] = [
    [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [-1.0 / 2.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [1.0 / 6.0, -1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [
        0.0,
        1.0 / 2.0,
        -3.0 / 2.0,
        1.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        -1.0 / 30.0,
        0.0,
        1.0,
        -2.0,
        1.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.0,
        -1.0 / 6.0,
        0.0,
        5.0 / 3.0,
        -5.0 / 2.0,
        1.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        1.0 / 42.0,
        0.0,
        -1.0 / 2.0,
        0.0,
        5.0 / 2.0,
        -3.0,
        1.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.0,
        1.0 / 6.0,
        0.0,
        -7.0 / 6.0,
        0.0,
        7.0 / 2.0,
        -7.0 / 2.0,
        1.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        -1.0 / 30.0,
        0.0,
        2.0 / 3.0,
        0.0,
        -7.0 / 3.0,
        0.0,
        14.0 / 3.0,
        -4.0,
        1.0,
        0.0,
        0.0,
    ],
    [
        0.0,
        -3.0 / 10.0,
        0.0,
        2.0,
        0.0,
        -21.0 / 5.0,
        0.0,
        6.0,
        -9.0 / 2.0,
        1.0,
        0.0,
    ],
    [
        5.0 / 66.0,
        0.0,
        -3.0 / 2.0,
        0.0,
        5.0,
        0.0,
        -7.0,
        0.0,
        15.0 / 2.0,
        -5.0,
        1.0,
    ],
];

/// The spread of a value over a footprint: `S = Σ w_k U_k` (see the module docs).
///
/// Holds at most three widths, sorted descending, each at least `RATIO` (`1e-4`) times the
/// previous one, zeros after; or "unbounded" (an infinite or undefined width or residual).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spread {
    w: [f64; 3],
    unbounded: bool,
}

/// The width of two uniforms' sum by variance, `sqrt(a² + b²)`: the plain formula where the
/// squares can neither overflow nor underflow (libm's `hypot`, several times slower and once
/// a twentieth of the filtered batch's time, elsewhere); the larger where the other is 0.
fn merged(a: f64, b: f64) -> f64 {
    let (hi, lo) = (a.max(b), a.min(b));
    if lo == 0.0 {
        hi
    } else if hi < 1e150 && lo > 1e-150 {
        (a * a + b * b).sqrt()
    } else {
        a.hypot(b)
    }
}

impl Spread {
    /// From the box widths (any order, each >= 0; negative taken as abs) and a residual variance
    /// `residual` >= 0 (a part of the value not linear in position, modelled as two more
    /// independent uniforms of half its variance each, width `sqrt(6 · residual)`: a triangular
    /// distribution; a negative residual is taken as 0). Beyond three widths, the two smallest
    /// are merged into one of the same variance (`sqrt(a² + b²)`:
    /// `Var(aU) + Var(bU) = Var(sqrt(a² + b²) U)`), twice at most; then sorted
    /// descending; then any width below `RATIO = 1e-4` times the one before it is merged into
    /// that one by variance and the rest shifted (so at most 3 widths, each >= `1e-4` × the
    /// previous, and zeros after). Widths below `f64::MIN_POSITIVE` (subnormal: their reciprocal,
    /// a density, would overflow) count as 0. A non-finite width or residual (inf or NaN) makes
    /// an "unbounded" spread.
    pub fn new(widths: [f64; 3], residual: f64) -> Spread {
        if !residual.is_finite() || widths.iter().any(|w| !w.is_finite()) {
            return Spread::UNBOUNDED;
        }
        // The residual as two equal uniforms, a triangular distribution: its kurtosis 2.4 and
        // E|X| = 0.816 σ are close to a noise's (kurtosis about 2.6, E|n| = 0.81 σ for the
        // gradient bases), where one uniform (1.8, 0.866 σ) made `abs` of a faded octave,
        // and so turbulence, 7 % too bright (docs/filtering.md).
        let half = (6.0 * residual.max(0.0)).sqrt();
        let mut five = [
            widths[0].abs(),
            widths[1].abs(),
            widths[2].abs(),
            half,
            half,
        ];
        // The two smallest merged by variance until three are left.
        five.sort_by(|a, b| b.total_cmp(a));
        for n in [5, 4] {
            five[n - 2] = merged(five[n - 2], five[n - 1]);
            five[..n - 1].sort_by(|a, b| b.total_cmp(a));
        }
        let mut three = [five[0], five[1], five[2]];
        three.sort_by(|a, b| b.total_cmp(a));
        let mut w = [0.0; 3];
        let mut k = 0;
        for x in three {
            if x < f64::MIN_POSITIVE {
                break; // 0 or subnormal, and so are the rest
            }
            if k > 0 && x < RATIO * w[k - 1] {
                w[k - 1] = merged(w[k - 1], x);
            } else {
                w[k] = x;
                k += 1;
            }
        }
        // A merge grows a width by at most a factor 1 + 5e-9, which may put it just above an
        // equal predecessor: sort again (the ratio invariant survives a swap of near-equals).
        w.sort_by(|a, b| b.total_cmp(a));
        if w.iter().any(|x| !x.is_finite()) {
            return Spread::UNBOUNDED;
        }
        Spread {
            w,
            unbounded: false,
        }
    }

    const UNBOUNDED: Spread = Spread {
        w: [f64::INFINITY, 0.0, 0.0],
        unbounded: true,
    };

    /// No spread: `X = t`.
    pub fn point() -> Spread {
        Spread {
            w: [0.0; 3],
            unbounded: false,
        }
    }

    /// The widths, descending (`[inf, 0, 0]` when unbounded).
    pub fn widths(&self) -> [f64; 3] {
        self.w
    }

    /// `Var S = Σ w² / 12` (inf when unbounded).
    /// Half the width of the support, `Σ w / 2` (infinite for an unbounded spread).
    pub fn half_support(&self) -> f64 {
        if self.unbounded {
            return f64::INFINITY;
        }
        self.active().iter().sum::<f64>() / 2.0
    }

    pub fn variance(&self) -> f64 {
        if self.unbounded {
            f64::INFINITY
        } else {
            self.w.iter().map(|w| w * w).sum::<f64>() / 12.0
        }
    }

    /// Whether a width or the residual was infinite or NaN.
    pub fn is_unbounded(&self) -> bool {
        self.unbounded
    }

    /// The non-zero widths (descending); empty for a point.
    fn active(&self) -> &[f64] {
        let k = self.w.iter().take_while(|&&w| w > 0.0).count();
        &self.w[..k]
    }
}

/// Mean, variance and slope (`d/dt` of the mean) of `f(X)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Moments {
    pub mean: f64,
    pub variance: f64,
    pub slope: f64,
}

impl Moments {
    const NAN: Moments = Moments {
        mean: f64::NAN,
        variance: f64::NAN,
        slope: f64::NAN,
    };
}

/// `e_j = E[S^j] / j!` for `j < SERIES` (odd ones 0): the product of the series
/// `Σ_i (w/2)^{2i} z^{2i} / (2i + 1)!` of the widths (module docs, "The moments of S"), as
/// [`Widths::new`] makes it one width at a time.
#[cfg(test)]
fn moment_series(w: &[f64]) -> [f64; SERIES] {
    let mut e = [0.0; SERIES];
    e[0] = 1.0;
    for &wk in w {
        e = times_width(&e, wk);
    }
    e
}

/// A moment series `e` times one width's (`S + wU`'s from `S`'s): [`Widths::new`] makes each
/// suffix's series from the next one's, one width each.
#[inline]
fn times_width(e: &[f64; SERIES], wk: f64) -> [f64; SERIES] {
    // Plain index loops over the even orders (the odd ones are 0): this runs once per rule
    // application and level, and stepped iterators did not optimise well (a fifth of a
    // turbulence render's time).
    const HALF: usize = SERIES / 2;
    // u_i = E[(wU)^i] / i! = (w/2)^i / (i + 1)! for even i, kept at u[i / 2].
    let h2 = (wk / 2.0) * (wk / 2.0);
    let mut u = [0.0; HALF];
    let mut p = 1.0;
    for (i, ui) in u.iter_mut().enumerate() {
        *ui = p / FACT[2 * i + 1];
        p *= h2;
    }
    let mut next = [0.0; SERIES];
    for j in 0..HALF {
        let mut acc = 0.0;
        for i in 0..=j {
            acc += e[2 * i] * u[j - i];
        }
        next[2 * j] = acc;
    }
    next
}

/// `x^j / j!` for `j < n` (at most `SERIES`; the entries past `n` are not computed and must
/// not be read). Each term is a division of the one before (a dependent chain): computing only
/// the terms a caller reads halves the cost of the periodic chains' moments (`tp_means` of one
/// order asks for one term, `plan`'s for seven).
fn power_series(x: f64, n: usize) -> [f64; SERIES] {
    let mut p = [1.0; SERIES];
    for j in 1..n.min(SERIES) {
        p[j] = p[j - 1] * x / j as f64;
    }
    p
}

/// A bounded spread's non-zero widths (descending) with what every evaluation needs, computed
/// once per call: for each suffix `w[level..k]`, its half-sum and moment series.
struct Widths {
    w: [f64; 3],
    k: usize,
    half: [f64; 4],
    series: [[f64; SERIES]; 4],
}

impl Widths {
    fn new(s: &Spread) -> Widths {
        let k = s.active().len();
        let mut half = [0.0; 4];
        for level in (0..k).rev() {
            half[level] = half[level + 1] + s.w[level] / 2.0;
        }
        // Each suffix's series from the next one's: one width's product per level (the
        // widths' order within a product does not change it but for rounding).
        let mut series = [[0.0; SERIES]; 4];
        series[k][0] = 1.0;
        for level in (0..k).rev() {
            series[level] = times_width(&series[level + 1], s.w[level]);
        }
        for level in k + 1..4 {
            series[level] = series[k];
        }
        Widths {
            w: s.w,
            k,
            half,
            series,
        }
    }

    /// `Σ w` over all widths.
    fn sum(&self) -> f64 {
        2.0 * self.half[0]
    }

    /// The `2^k` corner sums `Σ ±w_j/2`, sorted: the breakpoints of the density of `S`.
    fn corners(&self) -> ([f64; 8], usize) {
        let mut c = [0.0; 8];
        let mut n = 1;
        for &w in &self.w[..self.k] {
            for i in 0..n {
                c[n + i] = c[i] + w / 2.0;
                c[i] -= w / 2.0;
            }
            n *= 2;
        }
        c[..n].sort_by(f64::total_cmp);
        (c, n)
    }
}

/// `E[(x + S_level)^m / m!]` for `m = n0..n0 + 6` by (P), `S_level` over the widths
/// `w[level..]`.
fn poly_means(x: f64, ws: &Widths, level: usize, n0: usize, len: usize) -> [f64; 7] {
    debug_assert!(n0 + 6 < SERIES);
    let e = &ws.series[level];
    let p = power_series(x, n0 + len);
    array::from_fn(|d| {
        if d >= len {
            return 0.0;
        }
        let m = n0 + d;
        let mut acc = 0.0;
        for i in 0..=m / 2 {
            acc += p[m - 2 * i] * e[2 * i];
        }
        acc
    })
}

/// `E[T_m(x + S_level)]` (`T_m(x) = x₊^m / m!`) for `m = n0..n0 + 6`, `S_level` over the widths
/// `w[level..]`: the nested evaluation of (D) with its two shortcuts (module docs).
fn tp_means(x: f64, ws: &Widths, level: usize, n0: usize, len: usize) -> [f64; 7] {
    let half = ws.half[level];
    if x - half >= 0.0 {
        return poly_means(x, ws, level, n0, len);
    }
    if x + half <= 0.0 {
        return [0.0; 7];
    }
    if level >= ws.k {
        return [f64::NAN; 7]; // only for a NaN x
    }
    let w1 = ws.w[level];
    let hi = tp_means(x + w1 / 2.0, ws, level + 1, n0 + 1, len);
    let lo = tp_means(x - w1 / 2.0, ws, level + 1, n0 + 1, len);
    array::from_fn(|d| (hi[d] - lo[d]) / w1)
}

/// How close to the support's end (relative to its half-width) a point counts as on it for
/// [`density`]: a function's jump there (a box whose edge lies on a `Floor`'s integer, as the
/// voxels of a power-of-two grid do on cells of a power-of-two size) has no mass on either side,
/// yet rounding put it inside or outside by a few ulps, depending on how the sum was formed:
/// `Floor(4y)²` over y in [1/2, 2/3] took the density there and came out 4.0833 for 4 (the
/// linear part of a jump with no mass; the GPU's `sp_density` has the same rule).
pub(crate) const EDGE: f64 = 1e-12;

/// The density of `S` at `u`, `p_S(u) = d/du P(u + S >= 0)`: one step of (D) one order down,
/// `(P(x + w_1/2 + S' >= 0) − P(x − w_1/2 + S' >= 0)) / w_1`, at `x = −|u|` (`p_S` is even; on
/// that side the second probability is the smaller, so both keep their relative accuracy into
/// the tails). 0 on and outside the support's boundary (within [`EDGE`]); a point: `inf` at 0,
/// else 0.
fn density_s(u: f64, ws: &Widths) -> f64 {
    if ws.k == 0 {
        return if u == 0.0 { f64::INFINITY } else { 0.0 };
    }
    let x = -u.abs();
    if x + ws.half[0] <= EDGE * ws.half[0] {
        return 0.0;
    }
    let w1 = ws.w[0];
    (tp_means(x + w1 / 2.0, ws, 1, 0, 1)[0] - tp_means(x - w1 / 2.0, ws, 1, 0, 1)[0]) / w1
}

/// `E[(X)₊^d / d!]` with `X = t + S` (truncated power; `(x)₊^0` = 1 for `x >= 0`, 0 below),
/// `d <= 6`.
///
/// Exact (nested (D), module docs). Unbounded spread: `1/2` for `d = 0` (the limit of wide
/// symmetric spreads), `+inf` above. NaN `t` gives NaN.
///
/// # Panics
/// If `d > 6`.
pub fn ramp_mean(t: f64, s: &Spread, d: u32) -> f64 {
    assert!(d <= 6, "ramp_mean: degree {d} > 6");
    if t.is_nan() {
        return f64::NAN;
    }
    if s.unbounded {
        return if d == 0 { 0.5 } else { f64::INFINITY };
    }
    tp_means(t, &Widths::new(s), 0, 0, d as usize + 1)[d as usize]
}

/// `E[X^d / d!]`, `d <= 6`, by (P): exact, no cancellation at any `t`.
///
/// Unbounded spread (limits of wide symmetric spreads): `1` for `d = 0`, `t` for `d = 1`,
/// `+inf` for even `d >= 2`, `sign(t) · inf` (0 at `t = 0`) for odd `d >= 3`.
///
/// # Panics
/// If `d > 6`.
pub fn power_mean(t: f64, s: &Spread, d: u32) -> f64 {
    assert!(d <= 6, "power_mean: degree {d} > 6");
    if t.is_nan() {
        return f64::NAN;
    }
    if s.unbounded {
        return match d {
            0 => 1.0,
            1 => t,
            _ if d.is_multiple_of(2) => f64::INFINITY,
            _ if t == 0.0 => 0.0,
            _ => t.signum() * f64::INFINITY,
        };
    }
    poly_means(t, &Widths::new(s), 0, 0, d as usize + 1)[d as usize]
}

/// The density of `X` at 0 (`d/dt` of `P(X >= 0)`), `p_S(−t) = p_S(t)`, by one step of (D)
/// (module docs). For a point spread 0 unless `t == 0`, then `f64::INFINITY`; 0 for an
/// unbounded spread; 0 on the support's boundary (where, for one width, the density jumps),
/// and within `EDGE` (10⁻¹² of the half-width) of it. NaN `t` gives NaN.
pub fn density(t: f64, s: &Spread) -> f64 {
    if t.is_nan() {
        return f64::NAN;
    }
    if s.unbounded {
        return 0.0;
    }
    density_s(t, &Widths::new(s))
}

/// `Σ_i c_i u^i` by Horner, from the highest non-zero coefficient (so a constant stays exactly
/// itself at any `u`, infinite included).
fn horner(c: &[f64], u: f64) -> f64 {
    let Some(last) = c.iter().rposition(|&a| a != 0.0) else {
        return 0.0;
    };
    c[..last].iter().rev().fold(c[last], |acc, &a| acc * u + a)
}

/// The Taylor coefficients at `u0` of the cubic with coefficients `a` (in `u`):
/// `b_d = a^{(d)}(u0) / d!`.
pub(crate) fn taylor_at(a: [f64; 4], u0: f64) -> [f64; 4] {
    [
        horner(&a, u0),
        horner(&[a[1], 2.0 * a[2], 3.0 * a[3]], u0),
        horner(&[a[2], 3.0 * a[3]], u0),
        a[3],
    ]
}

/// A piecewise polynomial of degree <= 3 (see [`Piecewise::new`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Piecewise {
    knots: Vec<f64>,
    polys: Vec<[f64; 4]>,
}

impl Piecewise {
    /// A piecewise polynomial of degree <= 3: `knots` sorted non-decreasing (`c_1..c_n`,
    /// `n >= 0`, finite); `polys` has `n + 1` entries, `polys[0]` on `(-inf, c_1)`, `polys[i]` on
    /// `[c_i, c_{i+1})`, `polys[n]` on `[c_n, +inf)`; each as coefficients `[a0, a1, a2, a3]` of
    /// `a0 + a1 u + a2 u² + a3 u³` in the local variable `u = x − anchor`, anchor `c_i` for
    /// `i >= 1` and `c_1` for `i = 0` (0 if `n = 0`). Jumps at knots are allowed; a repeated
    /// knot makes an empty piece.
    ///
    /// # Panics
    /// If `polys.len() != knots.len() + 1`, or a knot is not finite, or the knots decrease.
    pub fn new(knots: Vec<f64>, polys: Vec<[f64; 4]>) -> Piecewise {
        assert_eq!(
            polys.len(),
            knots.len() + 1,
            "Piecewise: {} knots need {} pieces",
            knots.len(),
            knots.len() + 1
        );
        assert!(
            knots.iter().all(|c| c.is_finite()),
            "Piecewise: a knot is not finite"
        );
        assert!(
            knots.windows(2).all(|c| c[0] <= c[1]),
            "Piecewise: knots must be sorted non-decreasing"
        );
        Piecewise { knots, polys }
    }

    /// The same function with each knot dropped where the pieces on its two sides are one
    /// polynomial (within 1e-12 of the coefficients' scale): a ramp's collinear stops, equal
    /// constant stops. Fewer knots, the same values (the rules' cost grows with the knots a
    /// support covers).
    pub fn simplified(self) -> Piecewise {
        let (mut knots, mut polys) = (Vec::new(), vec![self.polys[0]]);
        for (i, &c) in self.knots.iter().enumerate() {
            let before = polys[polys.len() - 1];
            // Piece 0 keeps its given anchor (the first original knot) until the end.
            let anchor_before = knots.last().copied().unwrap_or(self.knots[0]);
            let continued = taylor_at(before, c - anchor_before);
            let next = self.polys[i + 1];
            let scale = continued
                .iter()
                .chain(&next)
                .fold(0.0f64, |m, a| m.max(a.abs()));
            let same = (0..4).all(|d| (continued[d] - next[d]).abs() <= 1e-12 * scale);
            if !same {
                knots.push(c);
                polys.push(next);
            }
        }
        // Piece 0 was given anchored at the first original knot: re-anchor it at the first
        // knot kept (or 0 without knots).
        let first_old = self.knots.first().copied().unwrap_or(0.0);
        let first_new = knots.first().copied().unwrap_or(0.0);
        polys[0] = taylor_at(self.polys[0], first_new - first_old);
        Piecewise { knots, polys }
    }

    /// The line this function is over `[lo, hi]` (finite), where it is one to within
    /// `1e-7` of its largest value there (no jump, every piece there of degree <= 1 and on the
    /// chord between the ends: a ramp whose stops were written to 8 digits, seed 003's steps of
    /// 1/7, is a line to 4e-9), continued past the interval's ends (`filter/ranges.rs`: for a
    /// value that cannot leave the interval, `f(X)` is then that line of `X`, its mean the line
    /// at `E X` and its variance the slope squared times `Var X`, where the rules' spread, which
    /// leaks past the interval, saw the clamped ends). `None` where it is not a line there, it
    /// has no knot to leave out, or the interval is a point, unbounded or not an interval. A
    /// function of several lines over the interval is left as it is: a clamped input holds a
    /// point mass at an end, which the clamped ends price right and a continued piece would not.
    pub fn restricted(&self, lo: f64, hi: f64) -> Option<Piecewise> {
        const TOL: f64 = 1e-7;
        if !(lo.is_finite() && hi.is_finite() && lo < hi) || self.knots.is_empty() {
            return None;
        }
        // Pieces `a..=b` meet (lo, hi): knots[a - 1] <= lo < knots[a], knots[b - 1] < hi.
        let a = self.knots.partition_point(|&c| c <= lo);
        let b = self.knots.partition_point(|&c| c < hi);
        let value = |i: usize, x: f64| horner(&self.polys[i], x - anchor(&self.knots, i));
        let (ya, yb) = (value(a, lo), value(b, hi));
        let slope = (yb - ya) / (hi - lo);
        let chord = |x: f64| ya + slope * (x - lo);
        let mut ends = Vec::with_capacity(2 * (b - a + 1));
        for i in a..=b {
            if self.polys[i][2] != 0.0 || self.polys[i][3] != 0.0 {
                return None;
            }
            let x0 = if i == a { lo } else { self.knots[i - 1] };
            let x1 = if i == b { hi } else { self.knots[i] };
            ends.extend([(x0, value(i, x0)), (x1, value(i, x1))]);
        }
        let scale = ends.iter().fold(0.0f64, |m, &(_, y)| m.max(y.abs()));
        let on_chord = ends
            .iter()
            .all(|&(x, y)| (y - chord(x)).abs() <= TOL * scale);
        (on_chord && slope.is_finite()).then(|| Piecewise {
            knots: Vec::new(),
            polys: vec![[ya - slope * lo, slope, 0.0, 0.0]],
        })
    }

    /// The piece at `x`: its anchor and local coefficients (`f(x) = Σ a_i (x − anchor)^i`).
    pub fn piece(&self, x: f64) -> (f64, [f64; 4]) {
        let j = self.knots.partition_point(|&c| c <= x);
        (anchor(&self.knots, j), self.polys[j])
    }

    /// The knots.
    pub fn knots(&self) -> &[f64] {
        &self.knots
    }

    /// The pieces' coefficients (see [`Piecewise::new`]).
    pub fn polys(&self) -> &[[f64; 4]] {
        &self.polys
    }

    /// `f` at a point (the point evaluation, used when the spread is a point). NaN gives NaN.
    pub fn eval(&self, x: f64) -> f64 {
        if x.is_nan() {
            return f64::NAN;
        }
        let j = self.knots.partition_point(|&c| c <= x);
        horner(&self.polys[j], x - anchor(&self.knots, j))
    }

    /// [`Piecewise::moments`] of several piecewise polynomials over one spread, sharing the
    /// work where they have the same knots (a ramp's channels).
    pub fn moments_of<const C: usize>(fs: [&Piecewise; C], t: f64, s: &Spread) -> [Moments; C] {
        let knots = &fs[0].knots;
        if fs.iter().all(|f| &f.knots == knots) {
            piecewise_moments_shared(knots, fs.map(|f| f.polys.as_slice()), t, s)
        } else {
            fs.map(|f| f.moments(t, s))
        }
    }

    /// Mean, variance (`E[(f − mean)²]`, clamped >= 0) and slope of `f(X)`, exact (module docs,
    /// "Piecewise polynomials"). A point spread gives exactly `eval(t)`, variance 0 and the
    /// piece's derivative at `t` (the right piece's at a knot). An unbounded spread gives, when
    /// both end pieces are constants `L` and `R`, mean `(L + R)/2`, variance `(L − R)²/4` (each
    /// end with probability 1/2) and slope 0; otherwise NaN for all three. NaN `t` gives NaN.
    pub fn moments(&self, t: f64, s: &Spread) -> Moments {
        piecewise_moments(&self.knots, &self.polys, t, s)
    }

    /// Value and slope where `f` is one line over `t ± half` (the piece holding `t` a line, no
    /// knot inside), as [`Piecewise::moments`] finds it first; `None` otherwise.
    pub fn line_around(&self, t: f64, half: f64) -> Option<(f64, f64)> {
        line_around(&self.knots, &self.polys, t, half)
    }
}

/// The anchor of piece `i`: `c_i` for `i >= 1`, `c_1` for `i = 0`, 0 without knots.
fn anchor(knots: &[f64], i: usize) -> f64 {
    match i {
        0 => knots.first().copied().unwrap_or(0.0),
        _ => knots[i - 1],
    }
}

/// Gauss–Legendre with 5 nodes on `[-1, 1]`: nodes `0, ±sqrt(5 ∓ 2 sqrt(10/7)) / 3`, weights
/// `128/225, (322 ± 13 sqrt 70) / 900`; exact for polynomials of degree <= 9.
const GL5: [(f64, f64); 5] = [
    (-0.906_179_845_938_664, 0.236_926_885_056_189_1),
    (-0.538_469_310_105_683_1, 0.478_628_670_499_366_5),
    (0.0, 128.0 / 225.0),
    (0.538_469_310_105_683_1, 0.478_628_670_499_366_5),
    (0.906_179_845_938_664, 0.236_926_885_056_189_1),
];

/// How one piece's partial mean `E[Q(X) 1{X in piece}]` is computed (module docs,
/// "Piecewise polynomials").
enum Part {
    /// The piece covers the support: `Σ_d Q_d(t) E[S^d]`.
    Full,
    /// `E[Q(X) 1{X >= c}] = Σ_d Q^{(d)}(c) E[T_d(X − c)]`; `tp = E[T_d(X − c)]`.
    Upper { c: f64, tp: [f64; 7] },
    /// `E[Q(X) 1{X < c}] = Σ_d Q^{(d)}(c) (−1)^d E[T_d(c − X)]`; `tp = E[T_d(c − X)]`.
    Lower { c: f64, tp: [f64; 7] },
    /// `Σ weight · Q(y)` over the nodes `nodes[start..end]` (`weight` includes the density).
    Quadrature { start: usize, end: usize },
}

/// The polynomial whose partial means are taken, from a piece `P`: the mean's, the slope's and
/// the variance's integrands.
#[derive(Clone, Copy)]
enum Integrand {
    Value,
    Derivative,
    /// `(P − m)²`.
    CentredSquare(f64),
}

impl Integrand {
    /// Taylor coefficients at `x0` of the integrand for the piece `poly` anchored at `anchor`:
    /// the piece is re-expanded at `x0` first, then shifted and squared (so no large values
    /// cancel).
    fn taylor(self, poly: [f64; 4], anchor: f64, x0: f64) -> [f64; 7] {
        let b = taylor_at(poly, x0 - anchor);
        match self {
            Integrand::Value => [b[0], b[1], b[2], b[3], 0.0, 0.0, 0.0],
            Integrand::Derivative => [b[1], 2.0 * b[2], 3.0 * b[3], 0.0, 0.0, 0.0, 0.0],
            Integrand::CentredSquare(m) => {
                let c = [b[0] - m, b[1], b[2], b[3]];
                let mut out = [0.0; 7];
                for (i, ci) in c.iter().enumerate() {
                    for (j, cj) in c.iter().enumerate() {
                        out[i + j] += ci * cj;
                    }
                }
                out
            }
        }
    }
}

/// The pieces of a piecewise polynomial that meet the support, each with its [`Part`]s (and a
/// sign: an interior piece can be a difference of two), plus the quadrature nodes. On the
/// stack for the usual few pieces (no heap allocation per call, issue 47); a support over many
/// knots spills to the heap.
struct Plan {
    parts: smallvec::SmallVec<[(usize, f64, Part); 6]>,
    nodes: smallvec::SmallVec<[(f64, f64); 20]>,
}

/// Chooses how each piece meeting the support `[t − Σw/2, t + Σw/2]` is integrated.
fn plan(knots: &[f64], polys: &[&[[f64; 4]]], t: f64, ws: &Widths) -> Plan {
    let (sum, n) = (ws.sum(), knots.len());
    let (xl, xr) = (t - ws.half[0], t + ws.half[0]);
    let lo_of = |i: usize| {
        if i == 0 {
            f64::NEG_INFINITY
        } else {
            knots[i - 1]
        }
    };
    let hi_of = |i: usize| if i == n { f64::INFINITY } else { knots[i] };
    let first = knots.partition_point(|&c| c <= xl);
    let last = knots.partition_point(|&c| c < xr).max(first);
    // The orders the integrands need: up to twice the pieces' degree (the centred square).
    let degree = (first..=last)
        .flat_map(|i| {
            polys
                .iter()
                .map(move |p| p[i].iter().rposition(|&a| a != 0.0).unwrap_or(0))
        })
        .max()
        .unwrap_or(3);
    let len = 2 * degree + 1;
    let upper = |c: f64| Part::Upper {
        c,
        tp: tp_means(t - c, ws, 0, 0, len),
    };
    let lower = |c: f64| Part::Lower {
        c,
        tp: tp_means(c - t, ws, 0, 0, len),
    };
    let mut plan = Plan {
        parts: smallvec::SmallVec::new(),
        nodes: smallvec::SmallVec::new(),
    };
    let (corners, n_corners) = ws.corners();
    for i in first..=last {
        let (lo, hi) = (lo_of(i), hi_of(i));
        if lo >= hi {
            continue; // an empty piece (a repeated knot)
        }
        match (lo > xl, hi < xr) {
            (false, false) => plan.parts.push((i, 1.0, Part::Full)),
            (true, false) => plan.parts.push((i, 1.0, upper(lo))),
            (false, true) => plan.parts.push((i, 1.0, lower(hi))),
            (true, true) if hi - lo >= sum / 2.0 => {
                // A long interior piece: the difference on the side of the shorter tail.
                if xr - hi <= lo - xl {
                    plan.parts.push((i, 1.0, upper(lo)));
                    plan.parts.push((i, -1.0, upper(hi)));
                } else {
                    plan.parts.push((i, 1.0, lower(hi)));
                    plan.parts.push((i, -1.0, lower(lo)));
                }
            }
            (true, true) => {
                // A short interior piece: Gauss–Legendre between the density's breakpoints.
                let start = plan.nodes.len();
                let mut a = lo;
                let inner = corners[..n_corners].iter().map(|&c| t + c);
                for b in inner.filter(|&b| b > lo && b < hi).chain([hi]) {
                    let (mid, h) = ((a + b) / 2.0, (b - a) / 2.0);
                    for (x, wt) in GL5 {
                        let y = mid + h * x;
                        plan.nodes.push((y, h * wt * density_s(y - t, ws)));
                    }
                    a = b;
                }
                let end = plan.nodes.len();
                plan.parts.push((i, 1.0, Part::Quadrature { start, end }));
            }
        }
    }
    plan
}

/// `Σ sign · E[Q(X) 1{X in piece}]` over the plan, `Q` the integrand of each piece.
fn plan_mean(
    plan: &Plan,
    knots: &[f64],
    polys: &[[f64; 4]],
    t: f64,
    ws: &Widths,
    integrand: Integrand,
) -> f64 {
    let e = &ws.series[0];
    let mut total = 0.0;
    for &(i, sign, ref part) in &plan.parts {
        let q = |x0: f64| integrand.taylor(polys[i], anchor(knots, i), x0);
        let value = match *part {
            Part::Full => {
                let b = q(t);
                (0..7)
                    .step_by(2)
                    .map(|d| b[d] * FACT[d] * e[d])
                    .sum::<f64>()
            }
            Part::Upper { c, tp } => {
                let b = q(c);
                (0..7).map(|d| b[d] * FACT[d] * tp[d]).sum::<f64>()
            }
            Part::Lower { c, tp } => {
                let b = q(c);
                let sign = |d: usize| if d.is_multiple_of(2) { 1.0 } else { -1.0 };
                (0..7)
                    .map(|d| sign(d) * b[d] * FACT[d] * tp[d])
                    .sum::<f64>()
            }
            Part::Quadrature { start, end } => plan.nodes[start..end]
                .iter()
                .map(|&(y, wt)| wt * q(y)[0])
                .sum::<f64>(),
        };
        total += sign * value;
    }
    total
}

/// [`Piecewise::moments`] over slices (also used by [`fract_moments`] with stack arrays).
pub(super) fn piecewise_moments(knots: &[f64], polys: &[[f64; 4]], t: f64, s: &Spread) -> Moments {
    let [m] = piecewise_moments_shared(knots, [polys], t, s);
    m
}

/// [`piecewise_moments`] of several piecewise polynomials on the same knots (a ramp's
/// channels) over one spread: the moment series, the plan (its truncated-power means at each
/// knot) and the densities at the knots computed once for all.
pub(super) fn piecewise_moments_shared<const C: usize>(
    knots: &[f64],
    polys: [&[[f64; 4]]; C],
    t: f64,
    s: &Spread,
) -> [Moments; C] {
    let early: [Option<Moments>; C] = polys.map(|p| piecewise_early(knots, p, t, s));
    if early.iter().all(Option::is_some) {
        return early.map(|m| m.unwrap_or(Moments::NAN));
    }
    let ws = Widths::new(s);
    let plan = plan(knots, &polys, t, &ws);
    let (xl, xr) = (t - ws.half[0], t + ws.half[0]);
    // The density of X at each knot inside the support (0 outside), on the stack for the
    // usual few knots (this runs per rule application).
    let (mut stack, mut heap) = ([0.0; 16], Vec::new());
    let densities: &mut [f64] = if knots.len() <= stack.len() {
        &mut stack[..knots.len()]
    } else {
        heap.resize(knots.len(), 0.0);
        &mut heap
    };
    for (d, &c) in densities.iter_mut().zip(knots) {
        if c > xl && c < xr {
            *d = density_s(c - t, &ws);
        }
    }
    std::array::from_fn(|k| {
        if let Some(m) = early[k] {
            return m;
        }
        let polys = polys[k];
        let mean = plan_mean(&plan, knots, polys, t, &ws, Integrand::Value);
        let mut slope = plan_mean(&plan, knots, polys, t, &ws, Integrand::Derivative);
        // The Dirac terms of f' at its jumps inside the support.
        for (i, &c) in knots.iter().enumerate() {
            if densities[i] != 0.0 {
                let jump = polys[i + 1][0] - horner(&polys[i], c - anchor(knots, i));
                slope += jump * densities[i];
            }
        }
        let variance = plan_mean(&plan, knots, polys, t, &ws, Integrand::CentredSquare(mean));
        Moments {
            mean,
            variance: variance.max(0.0),
            slope,
        }
    })
}

/// The cases of [`piecewise_moments`] that need no plan: NaN, an unbounded spread, and a line
/// with no knot inside the support (the common case of a sharp noise octave through `abs`).
fn piecewise_early(knots: &[f64], polys: &[[f64; 4]], t: f64, s: &Spread) -> Option<Moments> {
    if t.is_nan() {
        return Some(Moments::NAN);
    }
    if s.unbounded {
        let (l, r) = (polys[0], polys[polys.len() - 1]);
        let constant = |a: [f64; 4]| a[1] == 0.0 && a[2] == 0.0 && a[3] == 0.0;
        if !constant(l) || !constant(r) {
            return Some(Moments::NAN);
        }
        let half_gap = (l[0] - r[0]) / 2.0;
        return Some(Moments {
            mean: (l[0] + r[0]) / 2.0,
            variance: half_gap * half_gap,
            slope: 0.0,
        });
    }
    let (mean, b) = line_around(knots, polys, t, s.half_support())?;
    Some(Moments {
        mean,
        variance: b * b * s.variance(),
        slope: b,
    })
}

/// The value and slope at `t` where the piece holding `t` is a line and no knot lies within
/// `half` of `t`: over a support of half-width `half` the function is that line.
fn line_around(knots: &[f64], polys: &[[f64; 4]], t: f64, half: f64) -> Option<(f64, f64)> {
    let j = knots.partition_point(|&c| c <= t);
    let line = polys[j][2] == 0.0 && polys[j][3] == 0.0;
    (line && !knots.iter().any(|&c| c > t - half && c < t + half))
        .then(|| (horner(&polys[j], t - anchor(knots, j)), polys[j][1]))
}

/// `B_n(u) / n!` (`n <= 10`).
fn bernoulli_over_factorial(n: usize, u: f64) -> f64 {
    // B_n's leading coefficient (of u^n) is 1: its row up to n holds every non-zero one.
    horner(&BERNOULLI[n][..=n], u) / FACT[n]
}

/// `Φ_n(x) = E[B_n(fract(x + S_level))] / n!` for `n >= 1`, `S_level` over the widths
/// `w[level..]`: the nested evaluation of the periodic (D) (module docs, "fract").
fn periodic_mean(x: f64, ws: &Widths, level: usize, n: usize) -> f64 {
    // Φ_n is 1-periodic: reduce x first, so that `m += 1.0` below always moves (at |x| ≥ 2^53
    // it would not, and x ± w/2 reaches that for huge widths).
    let x = x - x.floor();
    let half = ws.half[level];
    let m0 = (x - half).floor();
    let hi = x + half;
    if hi <= m0 + 1.0 || 2.0 * half <= LOCAL_SPAN {
        // B_n(x − m0)/n! continued over the support, minus T_{n−1}(x − m) at each integer m in it.
        let e = &ws.series[level];
        let u = x - m0;
        let mut acc = (0..=n)
            .step_by(2)
            .map(|i| bernoulli_over_factorial(n - i, u) * e[i])
            .sum::<f64>();
        let mut m = m0 + 1.0;
        while m <= hi {
            acc -= tp_means(x - m, ws, level, n - 1, 1)[0];
            m += 1.0;
        }
        return acc;
    }
    if level >= ws.k {
        return f64::NAN; // only for a NaN x
    }
    let w1 = ws.w[level];
    let plus = periodic_mean(x + w1 / 2.0, ws, level + 1, n + 1);
    let minus = periodic_mean(x - w1 / 2.0, ws, level + 1, n + 1);
    (plus - minus) / w1
}

/// `|X|` over `X = t + S` where the support holds 0 (else `None`: a line, which
/// `Piecewise::moments` takes directly; and for an unbounded spread): by (D) over all corners at
/// once, `E[X₊] = (Π w)^{-1} Σ_σ (Π σ) T_{k+1}(t + Σ σ_j w_j/2)`, `P(X ≥ 0)` the same one order
/// down, `E|X| = 2E[X₊] − t`, slope `2P(X ≥ 0) − 1`, variance `t² + Var S − (E|X|)²`. With 0
/// inside the support `|t| <= Σw/2`, so the corner sum loses at most about `ε (Σw)^k / Π w`
/// relative to the mean: taken only where that factor is at most 1e6 (`None` beyond: widths of
/// very different sizes). A noise octave through `abs` (turbulence) takes this at every lane:
/// the general plan costs several times as much.
pub fn abs_moments(t: f64, s: &Spread) -> Option<Moments> {
    let (w, half) = (s.active(), s.half_support());
    let inside = t.abs() < half; // false for a NaN t
    if s.unbounded || w.is_empty() || !inside {
        return None;
    }
    let k = w.len();
    let product: f64 = w.iter().product();
    // The corner sum's terms are about (Σw)^k / Π w times the result: past 1e6 (widths of very
    // different sizes) the nested plan, which takes one width at a time, instead.
    let conditioned = (2.0 * half).powi(k as i32) / product <= 1e6; // false for NaN
    if !conditioned {
        return None;
    }
    let (mut plus, mut above) = (0.0, 0.0);
    for corner in 0..1usize << k {
        let mut x = t;
        let mut sign = 1.0;
        for (j, &wj) in w.iter().enumerate() {
            if corner >> j & 1 == 1 {
                x += wj / 2.0;
            } else {
                x -= wj / 2.0;
                sign = -sign;
            }
        }
        if x > 0.0 {
            let p = power_series(x, k + 2);
            plus += sign * p[k + 1];
            above += sign * p[k];
        }
    }
    let (plus, above) = (plus / product, above / product);
    let mean = 2.0 * plus - t;
    Some(Moments {
        mean,
        variance: (t * t + s.variance() - mean * mean).max(0.0),
        slope: 2.0 * above - 1.0,
    })
}

/// The periodic means `Φ_n(x) = E[P_n(x + S)] / n!` of a bounded spread (module docs,
/// "fract"), for any 1-periodic piecewise polynomial (`periodic.rs`, which writes one as a sum of
/// shifted `P_n`).
pub struct PeriodicMeans {
    ws: Widths,
}

impl PeriodicMeans {
    /// `None` for an unbounded or point spread (no `Φ_n` is needed there).
    pub fn new(s: &Spread) -> Option<PeriodicMeans> {
        let ws = Widths::new(s);
        (!s.unbounded && ws.k > 0).then_some(PeriodicMeans { ws })
    }

    /// Half the support of `S`: `Σ w / 2`.
    pub fn half(&self) -> f64 {
        self.ws.half[0]
    }

    /// `Φ_n(x)` for `1 <= n <= 7`.
    pub fn phi(&self, x: f64, n: usize) -> f64 {
        debug_assert!((1..=7).contains(&n));
        periodic_mean(x, &self.ws, 0, n)
    }

    /// `d/dx Φ_1(x) = E[P_1'(x + S)]` (`P_1' = 1 − Σ_m δ(· − m)`): the one-width step of (D)
    /// over the largest width.
    pub fn phi1_slope(&self, x: f64) -> f64 {
        let w1 = self.ws.w[0];
        (periodic_mean(x + w1 / 2.0, &self.ws, 1, 1) - periodic_mean(x - w1 / 2.0, &self.ws, 1, 1))
            / w1
    }
}

/// `fract(x) = x − floor(x)`: its mean, variance and slope over `X = t + S`, exact (module docs,
/// "fract"): bounded and as accurate at `|t| = 1e8` and widths `1e6` as near 0.
///
/// A point spread gives exactly `t − floor(t)`, variance 0, slope 1. An unbounded spread gives
/// the global means: `1/2`, `1/12`, slope 0. A NaN or infinite `t` gives NaN.
pub fn fract_moments(t: f64, s: &Spread) -> Moments {
    if !t.is_finite() {
        return Moments::NAN;
    }
    if s.unbounded {
        return Moments {
            mean: 0.5,
            variance: 1.0 / 12.0,
            slope: 0.0,
        };
    }
    // fract is 1-periodic: work at x = t − floor(t) ∈ [0, 1] (exact, but for a tiny negative t,
    // whose 1 + t may round to 1.0: an error below 1.2e-16).
    let x = t - t.floor();
    let ws = Widths::new(s);
    if ws.k == 0 {
        return Moments {
            mean: x,
            variance: 0.0,
            slope: 1.0,
        };
    }
    let half = ws.half[0];
    let m0 = (x - half).floor();
    let hi = x + half;
    if hi <= m0 + 1.0 {
        // No integer inside: fract(X) = X − m0.
        return Moments {
            mean: x - m0,
            variance: s.variance(),
            slope: 1.0,
        };
    }
    if ws.sum() <= LOCAL_SPAN {
        // fract(x) = x − m0 − Σ_m (x − m)₊^0 over the integers m in (m0, hi] (at most 3).
        let mut knots = [0.0; 3];
        let mut polys = [[1.0, 1.0, 0.0, 0.0]; 4];
        let mut n = 0;
        let mut m = m0 + 1.0;
        while m <= hi && n < knots.len() {
            knots[n] = m;
            polys[n + 1] = [0.0, 1.0, 0.0, 0.0];
            n += 1;
            m += 1.0;
        }
        return piecewise_moments(&knots[..n], &polys[..=n], x, s);
    }
    let phi1 = periodic_mean(x, &ws, 0, 1);
    let phi2 = periodic_mean(x, &ws, 0, 2);
    let w1 = ws.w[0];
    let slope =
        (periodic_mean(x + w1 / 2.0, &ws, 1, 1) - periodic_mean(x - w1 / 2.0, &ws, 1, 1)) / w1;
    Moments {
        mean: 0.5 + phi1,
        variance: (1.0 / 12.0 + 2.0 * phi2 - phi1 * phi1).max(0.0),
        slope,
    }
}

#[cfg(test)]
mod tests {
    //! Every moment is checked against an independent reference: nested Gauss–Legendre
    //! quadrature (order 8, exact for the polynomials of degree <= 15 met here) over each smooth
    //! piece of the integrand, split at every breakpoint, one level per width — no truncated
    //! power, Bernoulli polynomial or moment formula of the code under test. The reference
    //! slope is the derivative of the box mean along the largest width (the fundamental theorem
    //! of calculus, `d/dt ∫ g(t + w u) du = (g(t + w/2) − g(t − w/2)) / w`), each side again by
    //! quadrature.

    use super::*;

    /// xorshift64* with a fixed seed per test (no rand crate).
    struct Rng(u64);

    impl Rng {
        fn next_u64(&mut self) -> u64 {
            let mut x = self.0;
            x ^= x >> 12;
            x ^= x << 25;
            x ^= x >> 27;
            self.0 = x;
            x.wrapping_mul(0x2545_F491_4F6C_DD1D)
        }

        fn unit(&mut self) -> f64 {
            (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
        }

        fn range(&mut self, a: f64, b: f64) -> f64 {
            a + (b - a) * self.unit()
        }

        fn below(&mut self, n: u64) -> usize {
            (self.next_u64() % n) as usize
        }

        fn log_uniform(&mut self, a: f64, b: f64) -> f64 {
            self.range(a.ln(), b.ln()).exp()
        }
    }

    /// 0–3 non-zero widths log-uniform in [1e-9, 1e3] (sometimes equal, one sometimes
    /// negative, in random order) and a residual variance, 0 or log-uniform in [1e-20, 1e5].
    fn random_spread(rng: &mut Rng) -> Spread {
        let count = [0, 1, 1, 2, 2, 3, 3, 3][rng.below(8)];
        let mut w = [0.0; 3];
        for x in w.iter_mut().take(count) {
            *x = rng.log_uniform(1e-9, 1e3);
        }
        if count >= 2 && rng.below(4) == 0 {
            w[1] = w[0];
        }
        if count == 3 && rng.below(4) == 0 {
            w[2] = w[1];
        }
        if rng.below(8) == 0 {
            w[0] = -w[0];
        }
        w.swap(0, rng.below(3));
        let residual = if rng.below(3) == 0 {
            rng.log_uniform(1e-20, 1e5)
        } else {
            0.0
        };
        Spread::new(w, residual)
    }

    /// One to three widths in [0.5, 2] (for the far-from-origin cases).
    fn unit_spread(rng: &mut Rng) -> Spread {
        let count = 1 + rng.below(3);
        let w = array::from_fn(|i| if i < count { rng.range(0.5, 2.0) } else { 0.0 });
        Spread::new(w, 0.0)
    }

    /// Gauss–Legendre order 8 on [-1, 1]: the positive nodes and their weights.
    const GL_X: [f64; 4] = [
        0.183_434_642_495_649_8,
        0.525_532_409_916_329,
        0.796_666_477_413_626_7,
        0.960_289_856_497_536_3,
    ];
    const GL_W: [f64; 4] = [
        0.362_683_783_378_362,
        0.313_706_645_877_887_3,
        0.222_381_034_453_374_5,
        0.101_228_536_290_376_3,
    ];

    fn gauss(a: f64, b: f64, g: impl Fn(f64) -> f64) -> f64 {
        let (c, h) = ((a + b) / 2.0, (b - a) / 2.0);
        let sum: f64 = GL_X
            .iter()
            .zip(GL_W)
            .map(|(&x, wt)| wt * (g(c - h * x) + g(c + h * x)))
            .sum();
        h * sum
    }

    /// The sums `Σ ±w_j/2`: the breakpoints of the density of `Σ w_j U_j`.
    fn corners(w: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0];
        for &x in w {
            out = out
                .iter()
                .flat_map(|&s| [s - x / 2.0, s + x / 2.0])
                .collect();
        }
        out
    }

    /// A piecewise-polynomial test function (degree <= 6 on each piece) and its breakpoints,
    /// repeated with `period` when given.
    #[derive(Clone, Copy)]
    struct Target<'a> {
        f: &'a dyn Fn(f64) -> f64,
        breaks: &'a [f64],
        period: Option<f64>,
    }

    impl Target<'_> {
        /// `E[f(t + o + Σ w_k U_k)]`, integrating over each `w_k U_k` in its own variable (so no
        /// width is lost to the rounding of a larger `t` or `o`).
        fn mean(&self, t: f64, o: f64, w: &[f64]) -> f64 {
            match w.split_first() {
                None => (self.f)(t + o),
                Some((&w1, rest)) => self.integral(t, o, -w1 / 2.0, w1 / 2.0, rest) / w1,
            }
        }

        /// `∫_a^b E[f(t + o + u + Σ rest_k U_k)] du`; a periodic `f` as whole periods plus the
        /// rest.
        fn integral(&self, t: f64, o: f64, a: f64, b: f64, rest: &[f64]) -> f64 {
            if let Some(p) = self.period {
                let n = ((b - a) / p).floor();
                if n >= 1.0 {
                    let whole = self.pieces(t, o, a, a + p, rest);
                    return n * whole + self.pieces(t, o, a + n * p, b, rest);
                }
            }
            self.pieces(t, o, a, b, rest)
        }

        /// The same by Gauss–Legendre on each piece between the breakpoints
        /// `u = c − t − o − s` of the integrand (`c` a break of `f`, `s` a corner of `rest`).
        fn pieces(&self, t: f64, o: f64, a: f64, b: f64, rest: &[f64]) -> f64 {
            let mut pts = vec![a, b];
            for s in corners(rest) {
                for &c in self.breaks {
                    match self.period {
                        None => {
                            let u = (c - t) - o - s;
                            if u > a && u < b {
                                pts.push(u);
                            }
                        }
                        Some(p) => {
                            // c + m p − t is exact for the integers m near t.
                            let mut m = ((a + s + o + t - c) / p).floor() - 1.0;
                            loop {
                                let u = (c + m * p - t) - o - s;
                                if u >= b {
                                    break;
                                }
                                if u > a {
                                    pts.push(u);
                                }
                                m += 1.0;
                            }
                        }
                    }
                }
            }
            pts.sort_by(f64::total_cmp);
            pts.dedup();
            pts.windows(2)
                .map(|ab| gauss(ab[0], ab[1], |u| self.mean(t, o + u, rest)))
                .sum()
        }
    }

    fn positive_widths(s: &Spread) -> Vec<f64> {
        s.widths().into_iter().filter(|&w| w > 0.0).collect()
    }

    /// The reference mean, variance (of `f − f(t)`, then shifted) and slope (NaN when the
    /// largest width is below `1e-6 · max(1, |t|)`, where the difference quotient would lose
    /// more than `1e-10 · scale` to the rounding of `t + o`).
    fn reference(target: Target, t: f64, s: &Spread) -> Moments {
        let w = positive_widths(s);
        let f = target.f;
        let c = f(t);
        let centred = |x: f64| f(x) - c;
        let squared = |x: f64| (f(x) - c) * (f(x) - c);
        let m1 = Target {
            f: &centred,
            ..target
        }
        .mean(t, 0.0, &w);
        let m2 = Target {
            f: &squared,
            ..target
        }
        .mean(t, 0.0, &w);
        let slope = match w.split_first() {
            Some((&w1, rest)) if w1 >= 1e-6 * t.abs().max(1.0) => {
                (target.mean(t, w1 / 2.0, rest) - target.mean(t, -w1 / 2.0, rest)) / w1
            }
            _ => f64::NAN,
        };
        Moments {
            mean: c + m1,
            variance: m2 - m1 * m1,
            slope,
        }
    }

    /// `max |f|` over the support (sampled, knots included).
    fn scale(target: Target, t: f64, s: &Spread) -> f64 {
        let half = s.widths().iter().sum::<f64>() / 2.0;
        let (a, b) = (t - half, t + half);
        let grid = (0..=64).map(|i| a + (b - a) * i as f64 / 64.0);
        let knots = target.breaks.iter().copied().filter(|&c| c > a && c < b);
        grid.chain(knots)
            .map(|x| (target.f)(x).abs())
            .fold(0.0, f64::max)
    }

    fn assert_close(what: &str, got: f64, want: f64, tol: f64) {
        assert!(
            (got - want).abs() <= tol,
            "{what}: got {got:e}, want {want:e} (diff {:e} > {tol:e})",
            (got - want).abs()
        );
    }

    /// Compares moments with the reference: mean and variance to `1e-7 · max(1, scale)`, the
    /// slope the same plus `1e-9` relative (a step's slope is a density, up to 1e6 here).
    fn check(what: &str, got: Moments, target: Target, t: f64, s: &Spread) {
        let want = reference(target, t, s);
        let tol = 1e-7 * scale(target, t, s).max(1.0);
        let what = format!("{what} at t = {t:e}, widths {:?}", s.widths());
        assert_close(&format!("{what}: mean"), got.mean, want.mean, tol);
        assert_close(
            &format!("{what}: variance"),
            got.variance,
            want.variance,
            tol,
        );
        if want.slope.is_finite() {
            let tol = tol + 1e-9 * want.slope.abs();
            assert_close(&format!("{what}: slope"), got.slope, want.slope, tol);
        }
    }

    /// A piecewise test function: its [`Piecewise`], an independent closure and its knots.
    struct Case {
        name: &'static str,
        pw: Piecewise,
        f: Box<dyn Fn(f64) -> f64>,
        knots: Vec<f64>,
    }

    impl Case {
        fn target(&self) -> Target<'_> {
            Target {
                f: &*self.f,
                breaks: &self.knots,
                period: None,
            }
        }
    }

    fn abs_case() -> Case {
        Case {
            name: "abs",
            pw: Piecewise::new(vec![0.0], vec![[0.0, -1.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]]),
            f: Box::new(f64::abs),
            knots: vec![0.0],
        }
    }

    fn step_case() -> Case {
        Case {
            name: "step",
            pw: Piecewise::new(vec![0.0], vec![[0.0; 4], [1.0, 0.0, 0.0, 0.0]]),
            f: Box::new(|x| if x >= 0.0 { 1.0 } else { 0.0 }),
            knots: vec![0.0],
        }
    }

    fn clamp_case() -> Case {
        Case {
            name: "clamp(0, 1)",
            pw: Piecewise::new(
                vec![0.0, 1.0],
                vec![[0.0; 4], [0.0, 1.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]],
            ),
            f: Box::new(|x| x.clamp(0.0, 1.0)),
            knots: vec![0.0, 1.0],
        }
    }

    fn smoothstep_case() -> Case {
        Case {
            name: "smoothstep",
            pw: Piecewise::new(
                vec![0.0, 1.0],
                vec![[0.0; 4], [0.0, 0.0, 3.0, -2.0], [1.0, 0.0, 0.0, 0.0]],
            ),
            f: Box::new(|x| {
                let s = x.clamp(0.0, 1.0);
                s * s * (3.0 - 2.0 * s)
            }),
            knots: vec![0.0, 1.0],
        }
    }

    const RAMP_KNOTS: [f64; 6] = [-2.0, -1.0, 0.0, 0.5, 1.0, 2.0];
    const RAMP_VALUES: [f64; 6] = [0.3, 1.0, -1.0, 2.0, 2.0, 0.5];

    /// Linear interpolation of `RAMP_VALUES`, clamped to the end values.
    fn linear_ramp(x: f64) -> f64 {
        let (k, v) = (RAMP_KNOTS, RAMP_VALUES);
        if x < k[0] {
            return v[0];
        }
        for i in 0..5 {
            if x < k[i + 1] {
                return v[i] + (v[i + 1] - v[i]) * (x - k[i]) / (k[i + 1] - k[i]);
            }
        }
        v[5]
    }

    fn linear_ramp_case() -> Case {
        let (k, v) = (RAMP_KNOTS, RAMP_VALUES);
        let mut polys = vec![[v[0], 0.0, 0.0, 0.0]];
        for i in 0..5 {
            polys.push([v[i], (v[i + 1] - v[i]) / (k[i + 1] - k[i]), 0.0, 0.0]);
        }
        polys.push([v[5], 0.0, 0.0, 0.0]);
        Case {
            name: "6-knot linear ramp",
            pw: Piecewise::new(k.to_vec(), polys),
            f: Box::new(linear_ramp),
            knots: k.to_vec(),
        }
    }

    const STAIR_KNOTS: [f64; 4] = [-1.0, 0.0, 0.5, 2.0];
    const STAIR_VALUES: [f64; 4] = [0.2, -0.7, 1.5, 0.4];

    fn constant_ramp_case() -> Case {
        let v = STAIR_VALUES;
        let mut polys = vec![[v[0], 0.0, 0.0, 0.0]];
        polys.extend(v.iter().map(|&a| [a, 0.0, 0.0, 0.0]));
        Case {
            name: "4-knot constant ramp",
            pw: Piecewise::new(STAIR_KNOTS.to_vec(), polys),
            f: Box::new(|x| {
                let i = STAIR_KNOTS.iter().filter(|&&c| c <= x).count();
                STAIR_VALUES[i.saturating_sub(1)]
            }),
            knots: STAIR_KNOTS.to_vec(),
        }
    }

    const HERMITE_KNOTS: [f64; 3] = [-1.0, 0.0, 1.5];
    const HERMITE_VALUES: [f64; 3] = [0.5, -1.0, 2.0];
    const HERMITE_TANGENTS: [f64; 3] = [0.0, 3.0, -1.0];

    /// The cubic Hermite interpolant by its basis functions, constant beyond the ends.
    fn hermite(x: f64) -> f64 {
        let (k, v, m) = (HERMITE_KNOTS, HERMITE_VALUES, HERMITE_TANGENTS);
        if x < k[0] {
            return v[0];
        }
        if x >= k[2] {
            return v[2];
        }
        let i = usize::from(x >= k[1]);
        let h = k[i + 1] - k[i];
        let s = (x - k[i]) / h;
        let h00 = 2.0 * s.powi(3) - 3.0 * s * s + 1.0;
        let h10 = s.powi(3) - 2.0 * s * s + s;
        let h01 = -2.0 * s.powi(3) + 3.0 * s * s;
        let h11 = s.powi(3) - s * s;
        h00 * v[i] + h10 * h * m[i] + h01 * v[i + 1] + h11 * h * m[i + 1]
    }

    fn hermite_case() -> Case {
        let (k, v, m) = (HERMITE_KNOTS, HERMITE_VALUES, HERMITE_TANGENTS);
        let mut polys = vec![[v[0], 0.0, 0.0, 0.0]];
        for i in 0..2 {
            let (h, dv) = (k[i + 1] - k[i], v[i + 1] - v[i]);
            polys.push([
                v[i],
                m[i],
                3.0 * dv / (h * h) - (2.0 * m[i] + m[i + 1]) / h,
                -2.0 * dv / (h * h * h) + (m[i] + m[i + 1]) / (h * h),
            ]);
        }
        polys.push([v[2], 0.0, 0.0, 0.0]);
        Case {
            name: "clamped cubic Hermite",
            pw: Piecewise::new(k.to_vec(), polys),
            f: Box::new(hermite),
            knots: k.to_vec(),
        }
    }

    fn all_cases() -> Vec<Case> {
        vec![
            abs_case(),
            step_case(),
            clamp_case(),
            smoothstep_case(),
            linear_ramp_case(),
            constant_ramp_case(),
            hermite_case(),
        ]
    }

    /// The pieces agree with the closures (so the closures are a valid reference).
    /// The corner sum for `|X|` agrees with the general piecewise rule wherever the support
    /// holds 0 (random spreads of every shape, widths from 1e-9 to 1e3).
    #[test]
    fn abs_by_corners_agrees_with_the_plan() {
        let abs = Piecewise::new(vec![0.0], vec![[0.0, -1.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]]);
        let mut rng = Rng(0xab5);
        let mut checked = 0;
        for _ in 0..4000 {
            let s = random_spread(&mut rng);
            let half = s.half_support();
            let t = rng.range(-half, half);
            let Some(fast) = abs_moments(t, &s) else {
                continue;
            };
            checked += 1;
            let exact = abs.moments(t, &s);
            let scale = half.max(1e-300);
            assert!(
                (fast.mean - exact.mean).abs() <= 1e-9 * scale,
                "{s:?} t {t}: {fast:?} {exact:?}"
            );
            assert!(
                (fast.slope - exact.slope).abs() <= 1e-9,
                "{s:?} t {t}: {fast:?} {exact:?}"
            );
            assert!(
                (fast.variance - exact.variance).abs() <= 1e-8 * scale * scale,
                "{s:?} t {t}: {fast:?} {exact:?}"
            );
        }
        assert!(checked > 1000, "{checked}");
    }

    /// Dropping knots between pieces of one polynomial keeps every value.
    #[test]
    fn simplified_keeps_the_function() {
        // A ramp with collinear stops, equal constants, and one real corner and jump.
        let f = Piecewise::new(
            vec![0.0, 0.25, 0.5, 0.75, 1.0],
            vec![
                [0.0, 0.0, 0.0, 0.0],
                [0.0, 2.0, 0.0, 0.0],
                [0.5, 2.0, 0.0, 0.0],
                [1.0, 0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0, 0.0],
                [3.0, 0.0, 0.0, 0.0],
            ],
        );
        let g = f.clone().simplified();
        assert_eq!(g.knots, [0.0, 0.5, 1.0]);
        let mut x = -0.3;
        while x < 1.3 {
            assert!((f.eval(x) - g.eval(x)).abs() < 1e-15, "at {x}");
            x += 0.01;
        }
    }

    #[test]
    fn piecewise_eval_matches_the_functions() {
        let mut rng = Rng(11);
        for case in all_cases() {
            let mut xs: Vec<f64> = (0..200).map(|_| rng.range(-4.0, 4.0)).collect();
            xs.extend(&case.knots);
            for x in xs {
                let (got, want) = (case.pw.eval(x), (case.f)(x));
                assert_close(&format!("{} at {x}", case.name), got, want, 1e-13);
            }
        }
    }

    /// Each piecewise function over random spreads near its knots, against the reference.
    fn check_case(case: &Case, seed: u64, count: usize) {
        let mut rng = Rng(seed);
        for _ in 0..count {
            let t = rng.range(-3.0, 3.0);
            let s = random_spread(&mut rng);
            check(case.name, case.pw.moments(t, &s), case.target(), t, &s);
        }
    }

    #[test]
    fn piecewise_abs() {
        check_case(&abs_case(), 1, 150);
    }

    #[test]
    fn piecewise_step() {
        check_case(&step_case(), 2, 150);
    }

    #[test]
    fn piecewise_clamp() {
        check_case(&clamp_case(), 3, 150);
    }

    #[test]
    fn piecewise_smoothstep() {
        check_case(&smoothstep_case(), 4, 150);
    }

    #[test]
    fn piecewise_linear_ramp() {
        check_case(&linear_ramp_case(), 5, 100);
    }

    #[test]
    fn piecewise_constant_ramp() {
        check_case(&constant_ramp_case(), 6, 100);
    }

    #[test]
    fn piecewise_hermite() {
        check_case(&hermite_case(), 7, 100);
    }

    /// A repeated knot (a hard edge, as a spline makes): its empty piece is never used.
    #[test]
    fn piecewise_repeated_knot() {
        let case = Case {
            name: "repeated knot",
            pw: Piecewise::new(
                vec![0.0, 0.0, 1.0],
                vec![
                    [0.0, 0.5, 0.0, 0.0],
                    [5.0, 0.0, 0.0, 0.0],
                    [1.0, -1.0, 1.0, 0.0],
                    [2.0, 0.0, 0.0, 0.0],
                ],
            ),
            f: Box::new(|x| match x {
                x if x < 0.0 => 0.5 * x,
                x if x < 1.0 => 1.0 - x + x * x,
                _ => 2.0,
            }),
            knots: vec![0.0, 1.0],
        };
        assert_eq!(case.pw.eval(0.0), 1.0);
        check_case(&case, 20, 60);
    }

    /// abs far from its knot (t = ±1e3, ±1e8), where adding the knot's truncated power as a full
    /// polynomial would cancel.
    #[test]
    fn abs_far_from_the_origin() {
        let case = abs_case();
        let mut rng = Rng(8);
        for base in [1e3, -1e3, 1e8, -1e8] {
            for _ in 0..10 {
                let t = base + rng.range(-3.0, 3.0);
                let s = unit_spread(&mut rng);
                check("abs", case.pw.moments(t, &s), case.target(), t, &s);
            }
        }
    }

    /// Widths up to 1e6 and `t` up to ±1e8, for every piecewise case and fract.
    #[test]
    fn huge_widths_and_offsets() {
        let mut rng = Rng(19);
        for i in 0..60 {
            let count = 1 + rng.below(3);
            let w = array::from_fn(|k| {
                if k < count {
                    rng.log_uniform(1e-2, 1e6)
                } else {
                    0.0
                }
            });
            let s = Spread::new(w, 0.0);
            let t = match i % 3 {
                0 => rng.range(-1e8, 1e8),
                1 => rng.range(-1e4, 1e4),
                _ => rng.range(-3.0, 3.0),
            };
            for case in all_cases() {
                check(case.name, case.pw.moments(t, &s), case.target(), t, &s);
            }
            check("fract", fract_moments(t, &s), fract_target(), t, &s);
        }
    }

    fn fract_target() -> Target<'static> {
        Target {
            f: &|x: f64| x - x.floor(),
            breaks: &[0.0],
            period: Some(1.0),
        }
    }

    #[test]
    fn fract_matches_reference() {
        let mut rng = Rng(9);
        for _ in 0..200 {
            let t = rng.range(-3.0, 3.0);
            let s = random_spread(&mut rng);
            check("fract", fract_moments(t, &s), fract_target(), t, &s);
        }
        for base in [1e3, -1e3, 1e8, -1e8] {
            for _ in 0..10 {
                let t = base + rng.range(-3.0, 3.0);
                let s = unit_spread(&mut rng);
                check("fract", fract_moments(t, &s), fract_target(), t, &s);
            }
        }
    }

    #[test]
    fn ramp_mean_matches_reference() {
        let mut rng = Rng(10);
        for _ in 0..100 {
            let t = rng.range(-3.0, 3.0);
            let s = random_spread(&mut rng);
            for d in 0..=6 {
                let f = move |x: f64| {
                    if x >= 0.0 {
                        x.powi(d) / FACT[d as usize]
                    } else {
                        0.0
                    }
                };
                let target = Target {
                    f: &f,
                    breaks: &[0.0],
                    period: None,
                };
                let want = target.mean(t, 0.0, &positive_widths(&s));
                let tol = 1e-7 * scale(target, t, &s).max(1.0);
                let what = format!("ramp_mean(t = {t:e}, {:?}, d = {d})", s.widths());
                assert_close(&what, ramp_mean(t, &s, d as u32), want, tol);
            }
        }
    }

    #[test]
    fn power_mean_matches_reference() {
        let mut rng = Rng(12);
        for i in 0..100 {
            let t = if i % 10 == 0 {
                rng.range(-1e8, 1e8)
            } else {
                rng.range(-3.0, 3.0)
            };
            let s = random_spread(&mut rng);
            for d in 0..=6 {
                let f = move |x: f64| x.powi(d) / FACT[d as usize];
                let target = Target {
                    f: &f,
                    breaks: &[],
                    period: None,
                };
                let want = target.mean(t, 0.0, &positive_widths(&s));
                // All terms of the exact mean have one sign: relative accuracy.
                let tol = 1e-12 * want.abs().max(1e-300);
                let what = format!("power_mean(t = {t:e}, {:?}, d = {d})", s.widths());
                assert_close(&what, power_mean(t, &s, d as u32), want, tol);
            }
        }
    }

    #[test]
    fn density_matches_reference() {
        let step = |x: f64| if x >= 0.0 { 1.0 } else { 0.0 };
        let target = Target {
            f: &step,
            breaks: &[0.0],
            period: None,
        };
        let mut rng = Rng(13);
        let mut checked = 0;
        for _ in 0..200 {
            let s = random_spread(&mut rng);
            let w = positive_widths(&s);
            let Some((&w1, rest)) = w.split_first() else {
                continue;
            };
            if w1 < 1e-6 {
                continue;
            }
            // Mostly inside the support.
            let t = rng.range(-0.6, 0.6) * w.iter().sum::<f64>();
            let want = (target.mean(t, w1 / 2.0, rest) - target.mean(t, -w1 / 2.0, rest)) / w1;
            let what = format!("density(t = {t:e}, {:?})", s.widths());
            assert_close(&what, density(t, &s), want, 1e-9 * want.abs().max(1.0 / w1));
            checked += 1;
        }
        assert!(checked > 100, "{checked}");
    }

    /// Three widths at ratios just above 1e-4 (the flat difference formula would lose 1e-4).
    #[test]
    fn extreme_width_ratios() {
        let s = Spread::new([1.0, 1.00001e-4, 1.00002e-8], 0.0);
        assert_eq!(positive_widths(&s).len(), 3);
        let mut rng = Rng(14);
        for _ in 0..20 {
            let t = rng.range(-0.55, 0.55);
            for d in 0..=3 {
                let f = move |x: f64| {
                    if x >= 0.0 {
                        x.powi(d) / FACT[d as usize]
                    } else {
                        0.0
                    }
                };
                let target = Target {
                    f: &f,
                    breaks: &[0.0],
                    period: None,
                };
                let want = target.mean(t, 0.0, &positive_widths(&s));
                assert_close(
                    &format!("ramp {d} at {t}"),
                    ramp_mean(t, &s, d as u32),
                    want,
                    1e-12,
                );
            }
            let step = step_case();
            check("step", step.pw.moments(t, &s), step.target(), t, &s);
            let s3 = Spread::new([3.0, 3.00003e-4, 3.00006e-8], 0.0);
            check("fract", fract_moments(t, &s3), fract_target(), t, &s3);
            let s1 = Spread::new([0.5, 0.50001e-4, 0.50002e-8], 0.0);
            check("fract", fract_moments(t, &s1), fract_target(), t, &s1);
        }
    }

    /// `restricted` gives the line a function is over an interval without a knot inside, and
    /// nothing where there is a knot inside, a cubic piece, or nothing to leave out.
    #[test]
    fn restricted_is_the_line_over_the_interval() {
        // A clamped ramp 0 -> 0.875 on [0, 1] with a cubic bump on [0.5, 0.7].
        let f = Piecewise::new(
            vec![0.0, 0.5, 0.7, 1.0],
            vec![
                [0.0; 4],
                [0.0, 0.875, 0.0, 0.0],
                [0.4375, 0.875, 1.0, -2.0],
                [0.6365, 0.875, 0.0, 0.0],
                [0.875, 0.0, 0.0, 0.0],
            ],
        );
        for (lo, hi) in [
            (0.0, 0.5),
            (0.1, 0.3),
            (0.7, 0.95),
            (-3.0, -1.0),
            (1.0, 4.0),
        ] {
            let r = f.restricted(lo, hi).expect("a line over the interval");
            assert!(r.knots().is_empty(), "[{lo}, {hi}]");
            for k in 0..=40 {
                let x = lo + (hi - lo) * f64::from(k) / 40.0;
                if x == hi {
                    continue; // the right-continuous value of a jump at the end
                }
                let (a, b) = (r.eval(x), f.eval(x));
                assert!((a - b).abs() < 1e-12, "[{lo}, {hi}] at {x}: {a} vs {b}");
            }
        }
        // Past the ends the line continues: [0, 0.5]'s line at -0.2.
        let r = f.restricted(0.0, 0.5).unwrap();
        assert!((r.eval(-0.2) + 0.175).abs() < 1e-12);
        // Stops within 1e-8 of one line are that line; 1e-5 off is not.
        for (off, line) in [(1e-8, true), (1e-5, false)] {
            let g = Piecewise::new(
                vec![0.0, 0.4, 1.0],
                vec![
                    [0.0; 4],
                    [0.0, 1.0, 0.0, 0.0],
                    [0.4 + off, 1.0, 0.0, 0.0],
                    [1.0, 0.0, 0.0, 0.0],
                ],
            );
            assert_eq!(g.restricted(0.0, 1.0).is_some(), line, "{off}");
        }
        // A knot inside, the cubic piece, a point, a reversed or NaN interval.
        for (lo, hi) in [
            (0.0, 1.0),
            (-1.0, 0.5),
            (0.55, 0.65),
            (0.3, 0.3),
            (0.6, 0.3),
            (0.0, f64::INFINITY),
        ] {
            assert!(f.restricted(lo, hi).is_none(), "[{lo}, {hi}]");
        }
        assert!(f.restricted(f64::NAN, 1.0).is_none());
        assert!(Piecewise::new(vec![], vec![[1.0, 2.0, 0.0, 0.0]])
            .restricted(0.0, 1.0)
            .is_none());
    }

    #[test]
    fn spread_new_normalises() {
        assert_eq!(Spread::new([1.0, 3.0, 2.0], 0.0).widths(), [3.0, 2.0, 1.0]);
        assert_eq!(Spread::new([-1.0, 0.0, 2.0], 0.0).widths(), [2.0, 1.0, 0.0]);
        assert_eq!(Spread::point().widths(), [0.0; 3]);
        assert_eq!(Spread::point(), Spread::new([0.0; 3], 0.0));
        assert_eq!(Spread::new([0.0; 3], -1.0), Spread::point());
        // The residual is two more uniforms of half its variance each.
        let r: f64 = 0.37;
        let c = (6.0 * r).sqrt();
        assert_eq!(
            Spread::new([3.0, 0.0, 0.0], r).widths(),
            Spread::new([3.0, c, c], 0.0).widths()
        );
        let s = Spread::new([0.0; 3], r).widths();
        assert_eq!(s, [c, c, 0.0]);
        // Five widths: the two smallest merged by variance, twice.
        // (`sqrt(a² + b²)` to rounding: within a few ulps of libm's hypot.)
        let close = |a: [f64; 3], b: [f64; 3]| {
            let near = a
                .iter()
                .zip(&b)
                .all(|(x, y)| (x - y).abs() <= 1e-15 * y.abs());
            assert!(near, "{a:?} vs {b:?}");
        };
        let s = Spread::new([3.0, 2.0, 1.0], 2.0 / 12.0);
        close(s.widths(), [3.0, 2.0, 1f64.hypot(1.0).hypot(1.0)]);
        let s = Spread::new([1.5, 2.0, 0.5], 2.0 / 12.0);
        close(s.widths(), [2.0, 1.5, 1f64.hypot(1.0).hypot(0.5)]);
        // Widths below 1e-4 of the previous merged into it, and the rest shifted.
        let s = Spread::new([1.0, 5e-5, 0.0], 0.0);
        close(s.widths(), [1f64.hypot(5e-5), 0.0, 0.0]);
        let s = Spread::new([1.0, 2e-4, 1e-8], 0.0);
        close(s.widths(), [1.0, 2e-4f64.hypot(1e-8), 0.0]);
        let s = Spread::new([1.0, 5e-5, 4e-5], 0.0);
        close(s.widths(), [1f64.hypot(5e-5).hypot(4e-5), 0.0, 0.0]);
        // Far from 1 (the squares would overflow or underflow): still the merged width.
        let s = Spread::new([3e200, 4e200, 0.0], 0.0);
        close(s.widths(), [4e200, 3e200, 0.0]);
        let s = Spread::new([1.0, 1e-200, 0.0], 0.0);
        close(s.widths(), [1.0, 0.0, 0.0]);
        let s = Spread::new([3e-200, 4e-200, 1e-210], 0.0);
        close(s.widths(), [4e-200, 3e-200, 0.0]);
        // Unbounded.
        for s in [
            Spread::new([f64::INFINITY, 1.0, 0.0], 0.0),
            Spread::new([f64::NAN, 1.0, 0.0], 0.0),
            Spread::new([1.0, 1.0, 0.0], f64::NAN),
            Spread::new([1.0, 1.0, 0.0], f64::INFINITY),
        ] {
            assert!(s.is_unbounded());
            assert_eq!(s.variance(), f64::INFINITY);
        }
        assert!(!Spread::new([1e300, 1.0, 0.0], 0.0).is_unbounded());
        // Subnormal widths count as 0.
        assert_eq!(Spread::new([1e-310, 0.0, 0.0], 0.0), Spread::point());
        // Invariants and the variance over random inputs.
        let mut rng = Rng(15);
        for _ in 0..1000 {
            let w: [f64; 3] = array::from_fn(|_| rng.log_uniform(1e-12, 1e3));
            let r = rng.log_uniform(1e-20, 1e4);
            let s = Spread::new(w, r);
            let v = w.iter().map(|x| x * x / 12.0).sum::<f64>() + r;
            assert!((s.variance() - v).abs() <= 1e-14 * v, "{w:?} {r}");
            let sw = s.widths();
            for i in 1..3 {
                assert!(sw[i] <= sw[i - 1], "{sw:?}");
                assert!(sw[i] == 0.0 || sw[i] >= RATIO * sw[i - 1], "{sw:?}");
                assert!(sw[i - 1] > 0.0 || sw[i] == 0.0, "{sw:?}");
            }
        }
    }

    /// The tests' 8-node rule (exact to degree 15) and the code's 5-node rule (to degree 9).
    #[test]
    fn gauss_legendre_tables_are_exact() {
        assert!((GL_W.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        for n in 0..=15 {
            let got = gauss(0.0, 1.0, |x| x.powi(n));
            assert!((got - 1.0 / f64::from(n + 1)).abs() < 1e-15, "x^{n}: {got}");
        }
        for n in 0..=9 {
            let got: f64 = GL5
                .iter()
                .map(|&(x, w)| w * ((x + 1.0) / 2.0).powi(n))
                .sum();
            assert!(
                (got / 2.0 - 1.0 / f64::from(n + 1)).abs() < 1e-15,
                "x^{n}: {got}"
            );
        }
    }

    #[test]
    fn bernoulli_table() {
        for n in 1..=6 {
            for v in [-0.7, 0.0, 0.3, 1.2] {
                // B_n(v + 1) − B_n(v) = n v^{n−1}
                let diff = horner(&BERNOULLI[n], v + 1.0) - horner(&BERNOULLI[n], v);
                assert!(
                    (diff - n as f64 * v.powi(n as i32 - 1)).abs() < 1e-13,
                    "{n} {v}"
                );
                // B_n' = n B_{n−1}
                let h = 1e-5;
                let deriv =
                    (horner(&BERNOULLI[n], v + h) - horner(&BERNOULLI[n], v - h)) / (2.0 * h);
                let want = n as f64 * horner(&BERNOULLI[n - 1], v);
                assert!((deriv - want).abs() < 1e-8, "{n} {v}");
            }
            // Zero mean over a period (n >= 1).
            let mean = gauss(0.0, 1.0, |u| horner(&BERNOULLI[n], u));
            assert!(mean.abs() < 1e-15, "{n}");
        }
    }

    #[test]
    fn moment_series_matches_closed_forms() {
        let w = [0.9, 0.4, 0.25];
        let v: [f64; 3] = array::from_fn(|k| w[k] * w[k] / 12.0);
        let f: [f64; 3] = array::from_fn(|k| w[k].powi(4) / 80.0);
        let s2 = v.iter().sum::<f64>();
        let s4 = f.iter().sum::<f64>() + 6.0 * (v[0] * v[1] + v[0] * v[2] + v[1] * v[2]);
        // Σ_{i≠j} (w_i⁴/80)(w_j²/12) = (Σ f)(Σ v) − Σ f_i v_i.
        let cross = f.iter().sum::<f64>() * s2 - f.iter().zip(&v).map(|(a, b)| a * b).sum::<f64>();
        let s6 = w.iter().map(|x| x.powi(6) / 448.0).sum::<f64>()
            + 15.0 * cross
            + 90.0 * v[0] * v[1] * v[2];
        let e = moment_series(&w);
        assert!((e[2] * 2.0 - s2).abs() < 1e-15);
        assert!((e[4] * 24.0 - s4).abs() < 1e-15);
        assert!((e[6] * 720.0 - s6).abs() < 1e-15);
        assert!(e.iter().skip(1).step_by(2).all(|&x| x == 0.0));
    }

    #[test]
    fn point_spread_gives_point_values() {
        let p = Spread::point();
        let mut rng = Rng(16);
        for case in all_cases() {
            let mut ts: Vec<f64> = (0..50).map(|_| rng.range(-3.0, 3.0)).collect();
            ts.extend(&case.knots);
            for t in ts {
                let m = case.pw.moments(t, &p);
                assert_eq!(m.mean, case.pw.eval(t), "{} at {t}", case.name);
                assert_eq!(m.variance, 0.0);
                if !case.knots.contains(&t) {
                    let h = 1e-6;
                    let fd = (case.pw.eval(t + h) - case.pw.eval(t - h)) / (2.0 * h);
                    assert_close(case.name, m.slope, fd, 1e-7);
                }
            }
        }
        for t in [-2.5, -1.0, -1e-20, 0.0, 0.3, 1e8 + 0.25, -1e8 - 0.75] {
            let m = fract_moments(t, &p);
            assert_eq!(m.mean, t - t.floor());
            assert_eq!((m.variance, m.slope), (0.0, 1.0));
            for d in 0..=6 {
                let want = if t >= 0.0 {
                    t.powi(d) / FACT[d as usize]
                } else {
                    0.0
                };
                assert_close("ramp", ramp_mean(t, &p, d as u32), want, 1e-15 * want.abs());
                let want = t.powi(d) / FACT[d as usize];
                assert_close(
                    "power",
                    power_mean(t, &p, d as u32),
                    want,
                    1e-15 * want.abs(),
                );
            }
        }
        assert_eq!(ramp_mean(0.0, &p, 0), 1.0);
        assert_eq!(density(0.0, &p), f64::INFINITY);
        assert_eq!(density(0.5, &p), 0.0);
    }

    #[test]
    fn unbounded_and_wide_spreads_give_global_means() {
        let inf = Spread::new([f64::INFINITY, 0.0, 0.0], 0.0);
        let m = fract_moments(0.3, &inf);
        assert_eq!((m.mean, m.variance, m.slope), (0.5, 1.0 / 12.0, 0.0));
        let m = smoothstep_case().pw.moments(0.3, &inf);
        assert_eq!((m.mean, m.variance, m.slope), (0.5, 0.25, 0.0));
        let m = constant_ramp_case().pw.moments(7.0, &inf);
        assert_close("stairs", m.mean, 0.3, 1e-15);
        assert_close("stairs", m.variance, 0.01, 1e-15);
        assert!(abs_case().pw.moments(0.0, &inf).mean.is_nan());
        // An infinite t with constant end pieces: the end value.
        let s = Spread::new([1.0, 0.5, 0.0], 0.0);
        let m = smoothstep_case().pw.moments(f64::INFINITY, &s);
        assert_eq!((m.mean, m.variance, m.slope), (1.0, 0.0, 0.0));
        let m = smoothstep_case().pw.moments(f64::NEG_INFINITY, &s);
        assert_eq!((m.mean, m.variance, m.slope), (0.0, 0.0, 0.0));
        assert_eq!(ramp_mean(1.0, &inf, 0), 0.5);
        assert_eq!(ramp_mean(1.0, &inf, 2), f64::INFINITY);
        assert_eq!(power_mean(2.0, &inf, 1), 2.0);
        assert_eq!(density(1.0, &inf), 0.0);
        // Finite but wide: close to the global means.
        let wide = Spread::new([1e6, 7e5, 0.0], 0.0);
        let m = fract_moments(0.3, &wide);
        assert_close("fract mean", m.mean, 0.5, 1e-9);
        assert_close("fract variance", m.variance, 1.0 / 12.0, 1e-9);
        assert_close("fract slope", m.slope, 0.0, 1e-9);
        let m = smoothstep_case().pw.moments(0.3, &wide);
        assert_close("smoothstep mean", m.mean, 0.5, 1e-5);
        assert_close("smoothstep variance", m.variance, 0.25, 1e-5);
        assert_close("step", ramp_mean(0.3, &wide, 0), 0.5, 1e-5);
    }

    #[test]
    fn nan_t_gives_nan() {
        let mut rng = Rng(17);
        for _ in 0..20 {
            let s = random_spread(&mut rng);
            for m in [
                fract_moments(f64::NAN, &s),
                hermite_case().pw.moments(f64::NAN, &s),
                step_case().pw.moments(f64::NAN, &s),
            ] {
                assert!(
                    m.mean.is_nan() && m.variance.is_nan() && m.slope.is_nan(),
                    "{m:?}"
                );
            }
            assert!(density(f64::NAN, &s).is_nan());
            for d in 0..=6 {
                assert!(ramp_mean(f64::NAN, &s, d).is_nan());
                assert!(power_mean(f64::NAN, &s, d).is_nan());
            }
        }
        assert!(abs_case().pw.eval(f64::NAN).is_nan());
    }

    /// Widths of 1e-12 agree with a point (away from knots): no blow-up as widths vanish.
    #[test]
    fn tiny_widths_are_continuous_with_a_point() {
        let mut rng = Rng(18);
        let tiny = [
            Spread::new([1e-12, 0.0, 0.0], 0.0),
            Spread::new([1e-12, 1e-12, 1e-12], 0.0),
            Spread::new([1e-12, 0.7e-12, 0.0], 1e-25),
        ];
        let p = Spread::point();
        for _ in 0..100 {
            let t = rng.range(-3.0, 3.0);
            for s in &tiny {
                for case in all_cases() {
                    if case.knots.iter().any(|c| (c - t).abs() < 1e-3) {
                        continue;
                    }
                    let (a, b) = (case.pw.moments(t, s), case.pw.moments(t, &p));
                    assert_close(case.name, a.mean, b.mean, 1e-9);
                    assert_close(case.name, a.variance, b.variance, 1e-9);
                    assert_close(case.name, a.slope, b.slope, 1e-9);
                }
                if (t - t.round()).abs() > 1e-3 {
                    let (a, b) = (fract_moments(t, s), fract_moments(t, &p));
                    assert_close("fract", a.mean, b.mean, 1e-9);
                    assert_close("fract", a.variance, b.variance, 1e-9);
                    assert_close("fract", a.slope, b.slope, 1e-9);
                }
                if t.abs() > 1e-3 {
                    for d in 0..=6 {
                        let (a, b) = (ramp_mean(t, s, d), ramp_mean(t, &p, d));
                        assert_close("ramp", a, b, 1e-9 * b.abs().max(1.0));
                    }
                    assert_eq!(density(t, s), 0.0);
                }
            }
        }
    }

    #[test]
    #[should_panic(expected = "sorted")]
    fn piecewise_rejects_unsorted_knots() {
        let _ = Piecewise::new(vec![1.0, 0.0], vec![[0.0; 4]; 3]);
    }

    #[test]
    #[should_panic(expected = "pieces")]
    fn piecewise_rejects_a_missing_piece() {
        let _ = Piecewise::new(vec![0.0], vec![[0.0; 4]]);
    }
}
