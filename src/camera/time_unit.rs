//! Timestamps as recordings write them: units, exact integer clocks, and the
//! kept time window.
//!
//! Recorders write time in many units: seconds (Corbillon et al.), OpenXR's
//! `XrTime` (int64 nanoseconds), .NET `DateTime.Ticks` (100 ns since
//! 0001-01-01, HoloLens/Unity apps such as the Fraunhofer HHI pred6dof
//! traces). Tick values are ≈6.4·10¹⁷, beyond f64's 2⁵³ exact integers:
//! read as f64 they would round to multiples of 128 ticks (12.8 µs) and
//! nearby samples could collapse. Integer timestamps are therefore kept as
//! i64 and differenced exactly before conversion to seconds; times are
//! re-based so that the first sample of the file is at 0.

use std::fmt;

/// The unit of a recording's time column.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum TimeUnit {
    /// Seconds.
    #[value(name = "s")]
    Seconds,
    /// Milliseconds.
    #[value(name = "ms")]
    Milliseconds,
    /// Microseconds.
    #[value(name = "us", alias = "µs")]
    Microseconds,
    /// Nanoseconds (OpenXR `XrTime`).
    #[value(name = "ns")]
    Nanoseconds,
    /// 100-ns ticks (.NET `DateTime.Ticks`, Windows `FILETIME`).
    #[value(name = "ticks")]
    Ticks,
}

impl TimeUnit {
    /// Units per second; every value is exact in f64, so dividing by it is
    /// correctly rounded (multiplying by 1e-9 would not be).
    pub fn per_second(self) -> f64 {
        match self {
            TimeUnit::Seconds => 1.0,
            TimeUnit::Milliseconds => 1e3,
            TimeUnit::Microseconds => 1e6,
            TimeUnit::Nanoseconds => 1e9,
            TimeUnit::Ticks => 1e7,
        }
    }
}

impl fmt::Display for TimeUnit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            TimeUnit::Seconds => "s",
            TimeUnit::Milliseconds => "ms",
            TimeUnit::Microseconds => "µs",
            TimeUnit::Nanoseconds => "ns",
            TimeUnit::Ticks => "100-ns ticks",
        })
    }
}

/// A timestamp as written: an integer (kept exact) or a decimal number.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RawTime {
    /// Written as an integer that fits in i64.
    Int(i64),
    /// Written with a fraction or exponent (or too large for i64).
    Float(f64),
}

impl RawTime {
    /// Parses a timestamp; `None` when `text` is not a number. A decimal
    /// may be non-finite (`nan`, `inf`): callers check [`Self::is_finite`].
    pub fn parse(text: &str) -> Option<RawTime> {
        let digits = text.strip_prefix(['+', '-']).unwrap_or(text);
        if !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit()) {
            if let Ok(i) = text.parse::<i64>() {
                return Some(RawTime::Int(i));
            }
        }
        text.parse::<f64>().ok().map(RawTime::Float)
    }

    /// Whether the value is finite (integers always are).
    pub fn is_finite(self) -> bool {
        match self {
            RawTime::Int(_) => true,
            RawTime::Float(x) => x.is_finite(),
        }
    }

    fn as_f64(self) -> f64 {
        match self {
            RawTime::Int(i) => i as f64,
            RawTime::Float(x) => x,
        }
    }

    /// Seconds from `origin` to `self`: integers are differenced exactly
    /// (in i128) before the one rounding to f64.
    pub fn seconds_since(self, origin: RawTime, unit: TimeUnit) -> f64 {
        let units = match (self, origin) {
            (RawTime::Int(a), RawTime::Int(b)) => (a as i128 - b as i128) as f64,
            _ => self.as_f64() - origin.as_f64(),
        };
        units / unit.per_second()
    }
}

/// The samples to keep: `start ≤ t ≤ end`, `t` in seconds from the first
/// sample of the file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeWindow {
    /// First second kept.
    pub start: f64,
    /// Last second kept; `f64::INFINITY` keeps everything to the end.
    pub end: f64,
}

impl Default for TimeWindow {
    fn default() -> Self {
        Self {
            start: 0.0,
            end: f64::INFINITY,
        }
    }
}

impl TimeWindow {
    /// Whether `t` (seconds from the first sample) is kept.
    pub fn contains(&self, t: f64) -> bool {
        t >= self.start && t <= self.end
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_differenced_exactly() {
        let a = RawTime::parse("637231069485244909").unwrap();
        let b = RawTime::parse("637231069485244910").unwrap();
        assert_eq!(a, RawTime::Int(637231069485244909));
        // One tick apart: 100 ns, which f64 ticks (spacing 128) would lose.
        assert_eq!(b.seconds_since(a, TimeUnit::Ticks), 1e-7);
        let c = RawTime::Int(637231069485244909 + 10_000_000);
        assert_eq!(c.seconds_since(a, TimeUnit::Ticks), 1.0);
        assert_eq!(RawTime::parse("1.5e3"), Some(RawTime::Float(1500.0)));
        assert_eq!(RawTime::parse("x1"), None);
        assert!(!RawTime::parse("nan").unwrap().is_finite());
    }
}
