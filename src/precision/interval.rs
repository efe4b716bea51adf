//! Interval arithmetic for the range analysis: closed intervals of f64 that may be unbounded.
//! A result that would be NaN (∞ − ∞, 0 · ∞ of unknown sign) widens to the whole line, so an
//! interval always contains every value the operation can take.

/// `[lo, hi]`, `lo <= hi`; either end may be infinite.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    pub lo: f64,
    pub hi: f64,
}

// Named methods, not the operator traits: `a.mul(b)` reads as interval arithmetic and keeps
// `Interval` from mixing silently with f64 expressions.
#[allow(clippy::should_implement_trait)]
impl Interval {
    /// The whole line: nothing is known.
    pub const TOP: Interval = Interval {
        lo: f64::NEG_INFINITY,
        hi: f64::INFINITY,
    };

    /// `[lo, hi]`; a NaN end (or a reversed pair) gives [`Interval::TOP`].
    pub fn new(lo: f64, hi: f64) -> Interval {
        if lo.is_nan() || hi.is_nan() || lo > hi {
            Interval::TOP
        } else {
            Interval { lo, hi }
        }
    }

    pub fn point(v: f64) -> Interval {
        Interval::new(v, v)
    }

    /// The largest magnitude in the interval.
    pub fn magnitude(self) -> f64 {
        self.lo.abs().max(self.hi.abs())
    }

    /// The smallest magnitude (0 when the interval contains 0).
    pub fn least_magnitude(self) -> f64 {
        if self.lo <= 0.0 && self.hi >= 0.0 {
            0.0
        } else {
            self.lo.abs().min(self.hi.abs())
        }
    }

    pub fn contains_zero(self) -> bool {
        self.lo <= 0.0 && self.hi >= 0.0
    }

    pub fn hull(self, other: Interval) -> Interval {
        Interval::new(self.lo.min(other.lo), self.hi.max(other.hi))
    }

    /// The image under a non-decreasing function.
    pub fn increasing(self, f: impl Fn(f64) -> f64) -> Interval {
        Interval::new(f(self.lo), f(self.hi))
    }

    pub fn add(self, b: Interval) -> Interval {
        Interval::new(self.lo + b.lo, self.hi + b.hi)
    }

    pub fn neg(self) -> Interval {
        Interval::new(-self.hi, -self.lo)
    }

    pub fn sub(self, b: Interval) -> Interval {
        self.add(b.neg())
    }

    pub fn mul(self, b: Interval) -> Interval {
        // 0 · ∞ is 0 here: a factor that is exactly zero keeps the product zero.
        let times = |x: f64, y: f64| if x == 0.0 || y == 0.0 { 0.0 } else { x * y };
        let c = [
            times(self.lo, b.lo),
            times(self.lo, b.hi),
            times(self.hi, b.lo),
            times(self.hi, b.hi),
        ];
        Interval::new(
            c.iter().copied().fold(f64::INFINITY, f64::min),
            c.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        )
    }

    pub fn div(self, b: Interval) -> Interval {
        if b.contains_zero() {
            return Interval::TOP;
        }
        self.mul(Interval::new(1.0 / b.hi, 1.0 / b.lo))
    }

    pub fn abs(self) -> Interval {
        if self.contains_zero() {
            Interval::new(0.0, self.magnitude())
        } else {
            Interval::new(self.least_magnitude(), self.magnitude())
        }
    }

    pub fn min(self, b: Interval) -> Interval {
        Interval::new(self.lo.min(b.lo), self.hi.min(b.hi))
    }

    pub fn max(self, b: Interval) -> Interval {
        Interval::new(self.lo.max(b.lo), self.hi.max(b.hi))
    }

    /// `[-m, m]`.
    pub fn symmetric(m: f64) -> Interval {
        Interval::new(-m, m)
    }

    /// The values common to both; [`Interval::TOP`] if none (which an enclosure of the same
    /// quantity cannot give).
    pub fn intersect(self, b: Interval) -> Interval {
        Interval::new(self.lo.max(b.lo), self.hi.min(b.hi))
    }

    /// sin over an interval of radians: the ends' values, widened to ±1 where the interval
    /// holds a peak (π/2 + 2kπ) or a trough (−π/2 + 2kπ), and by 1e-12 for the rounding of
    /// the ends' sines.
    pub fn sin(self) -> Interval {
        use std::f64::consts::{FRAC_PI_2, TAU};
        if !(self.lo.is_finite() && self.hi.is_finite()) || self.hi - self.lo >= TAU {
            return Interval::symmetric(1.0);
        }
        let holds = |c: f64| c + ((self.lo - c) / TAU).ceil() * TAU <= self.hi;
        let (a, b) = (self.lo.sin(), self.hi.sin());
        let hi = if holds(FRAC_PI_2) { 1.0 } else { a.max(b) };
        let lo = if holds(-FRAC_PI_2) { -1.0 } else { a.min(b) };
        Interval::new((lo - 1e-12).max(-1.0), (hi + 1e-12).min(1.0))
    }

    /// cos over an interval of radians (sin shifted by π/2).
    pub fn cos(self) -> Interval {
        self.add(Interval::point(std::f64::consts::FRAC_PI_2)).sin()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sines_and_cosines_contain_every_sampled_value() {
        let mut state = 7u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..2000 {
            let lo = 40.0 * next() - 20.0;
            let hi = lo + 7.0 * next() * next();
            let i = Interval::new(lo, hi);
            let (s, c) = (i.sin(), i.cos());
            for k in 0..=64 {
                let x = lo + (hi - lo) * k as f64 / 64.0;
                assert!(s.lo <= x.sin() && x.sin() <= s.hi, "sin {x} not in {s:?}");
                assert!(c.lo <= x.cos() && x.cos() <= c.hi, "cos {x} not in {c:?}");
            }
            // Tight where no extremum is inside: the ends' values.
            if hi - lo < 0.5 && s.lo > -1.0 && s.hi < 1.0 {
                assert!(s.hi - s.lo <= (hi - lo) + 3e-12, "{i:?}: {s:?}");
            }
        }
        let quarter = Interval::new(0.1, 0.2).sin();
        assert!(
            (quarter.lo - 0.1f64.sin()).abs() < 1e-11 && (quarter.hi - 0.2f64.sin()).abs() < 1e-11
        );
        assert_eq!(Interval::new(1.0, 2.0).sin().hi, 1.0);
        assert_eq!(Interval::new(3.0, 3.5).cos().lo, -1.0);
    }

    #[test]
    fn products_and_quotients_contain_every_value() {
        let a = Interval::new(-2.0, 3.0);
        let b = Interval::new(4.0, 5.0);
        assert_eq!(a.mul(b), Interval::new(-10.0, 15.0));
        assert_eq!(a.div(b), Interval::new(-0.5, 0.75));
        assert_eq!(b.div(a), Interval::TOP);
        assert_eq!(
            Interval::point(0.0).mul(Interval::TOP),
            Interval::point(0.0)
        );
        assert_eq!(Interval::TOP.sub(Interval::TOP), Interval::TOP);
        assert_eq!(a.abs(), Interval::new(0.0, 3.0));
        assert_eq!(b.neg().abs(), b);
    }
}
