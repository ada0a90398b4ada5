//! Short, exact-enough numbers in messages: [`Num`] prints an `f64` the way a person reads
//! it in an error message (`1e300`, `0.25`, `1.234568e-7`, `NaN`, `inf`), never as hundreds
//! of decimal digits.

use std::fmt;

/// An `f64` formatted for messages: up to 7 significant digits, in exponent form outside
/// `[1e-4, 1e6)`. Use it in `#[error(...)]` strings: `#[error("t = {}", Num(*t))]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Num(pub f64);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let x = self.0;
        if !x.is_finite() || x == 0.0 {
            return write!(f, "{x}");
        }
        let a = x.abs();
        if (1e-4..1e6).contains(&a) {
            // Shortest of: the exact round-trip form if short, else 7 significant digits.
            let exact = format!("{x}");
            if exact.len() <= 10 {
                return f.write_str(&exact);
            }
            let digits = (6 - a.log10().floor() as i32).max(0) as usize;
            let s = format!("{x:.digits$}");
            let s = if s.contains('.') {
                s.trim_end_matches('0').trim_end_matches('.').to_string()
            } else {
                s
            };
            f.write_str(&s)
        } else {
            let s = format!("{x:.6e}");
            // Trim trailing zeros of the mantissa: 1.500000e3 -> 1.5e3.
            let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
            let m = if m.contains('.') {
                m.trim_end_matches('0').trim_end_matches('.')
            } else {
                m
            };
            write!(f, "{m}e{e}")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Num;

    #[test]
    fn short_forms() {
        assert_eq!(Num(1e300).to_string(), "1e300");
        assert_eq!(Num(-2.5e-200).to_string(), "-2.5e-200");
        assert_eq!(Num(0.25).to_string(), "0.25");
        assert_eq!(Num(1.0 / 3.0).to_string(), "0.3333333");
        assert_eq!(Num(123_456.789_123_4).to_string(), "123456.8");
        assert_eq!(Num(0.0).to_string(), "0");
        assert_eq!(Num(f64::NAN).to_string(), "NaN");
        assert_eq!(Num(f64::NEG_INFINITY).to_string(), "-inf");
        assert_eq!(Num(1.234_567_89e-7).to_string(), "1.234568e-7");
    }
}
