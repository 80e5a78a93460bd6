//! Simulation time as an integer number of nanoseconds.
//!
//! Every scheduling decision in the engine is made on integers, so that a run is bit-identical
//! whatever the platform, the thread count or the order in which floating-point sums are formed.
//! Floating-point seconds appear only where a physical model needs them ([`Nanos::as_secs_f64`]).
//!
//! ```
//! use flyarena::clock::{Nanos, Rate};
//! let physics = Rate::from_hz(1000).unwrap();
//! let vicon = Rate::from_hz(200).unwrap();
//! assert_eq!(vicon.period(), Nanos::from_millis(5));
//! assert_eq!(vicon.ticks_of(physics), Some(5)); // a Vicon frame every 5 physics steps
//! assert_eq!(Rate::from_hz(400).unwrap().ticks_of(physics), None); // 400 Hz does not divide 1 kHz
//! ```

use serde::Serialize;
use std::fmt;
use std::ops::{Add, AddAssign, Sub};

/// A point in simulated time, or a duration, in integer nanoseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
pub struct Nanos(pub i64);

impl Nanos {
    /// The start of a run, or no time.
    pub const ZERO: Nanos = Nanos(0);
    /// Whole milliseconds.
    pub const fn from_millis(ms: i64) -> Self {
        Nanos(ms * 1_000_000)
    }
    /// Whole microseconds.
    pub const fn from_micros(us: i64) -> Self {
        Nanos(us * 1_000)
    }
    /// Rounds seconds to the nearest nanosecond (used only at the YAML edge).
    pub fn from_secs_f64(s: f64) -> Self {
        Nanos((s * 1e9).round() as i64)
    }
    /// In seconds (for printing and physics, not for keeping time).
    pub fn as_secs_f64(self) -> f64 {
        self.0 as f64 * 1e-9
    }
    /// The integer nanoseconds.
    pub const fn as_nanos(self) -> i64 {
        self.0
    }
}

impl Add for Nanos {
    type Output = Nanos;
    fn add(self, o: Nanos) -> Nanos {
        Nanos(self.0 + o.0)
    }
}
impl AddAssign for Nanos {
    fn add_assign(&mut self, o: Nanos) {
        self.0 += o.0;
    }
}
impl Sub for Nanos {
    type Output = Nanos;
    fn sub(self, o: Nanos) -> Nanos {
        Nanos(self.0 - o.0)
    }
}
impl fmt::Display for Nanos {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:.3} s", self.as_secs_f64())
    }
}

/// A periodic rate in whole hertz. Only rates whose period is a whole number of nanoseconds exist.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rate {
    hz: u32,
}

impl Rate {
    /// `None` unless `hz` is positive and divides 1e9 (a whole-nanosecond period).
    pub const fn from_hz(hz: u32) -> Option<Self> {
        if hz > 0 && 1_000_000_000 % hz == 0 { Some(Rate { hz }) } else { None }
    }
    /// The rate (Hz).
    pub const fn hz(self) -> u32 {
        self.hz
    }
    /// One period, exactly.
    pub fn period(self) -> Nanos {
        Nanos(1_000_000_000 / self.hz as i64)
    }
    /// How many periods of `base` make one period of `self`, if `self` divides `base` exactly.
    pub fn ticks_of(self, base: Rate) -> Option<u64> {
        base.hz.is_multiple_of(self.hz).then(|| (base.hz / self.hz) as u64)
    }
}

/// The engine's clock: a tick counter at the physics rate. Time is derived, never accumulated.
#[derive(Clone, Copy, Debug)]
pub struct Clock {
    tick: u64,
    period: Nanos,
}

impl Clock {
    /// A clock at tick 0 ticking at `rate`.
    pub fn new(rate: Rate) -> Self {
        Clock { tick: 0, period: rate.period() }
    }
    /// Ticks so far.
    pub fn tick(&self) -> u64 {
        self.tick
    }
    /// tick·period.
    pub fn now(&self) -> Nanos {
        Nanos(self.tick as i64 * self.period.0)
    }
    /// One tick.
    pub fn period(&self) -> Nanos {
        self.period
    }
    /// The next tick.
    pub fn advance(&mut self) {
        self.tick += 1;
    }
}

/// A component's schedule: fires on ticks 0, `every`, 2·`every`, … (tick mod `every` = 0) when
/// [`Every::fires`] is called once per tick, with a countdown instead of a 64-bit division (two
/// of those per physics tick were 2 % of the loop).
#[derive(Clone, Copy, Debug)]
pub struct Every {
    every: u64,
    countdown: u64,
}

impl Every {
    /// `every` ≥ 1 ticks; starts at tick 0 (fires on the first call).
    pub fn new(every: u64) -> Self {
        Every { every: every.max(1), countdown: 0 }
    }
    /// Call exactly once per tick.
    pub fn fires(&mut self) -> bool {
        if self.countdown == 0 {
            self.countdown = self.every - 1;
            true
        } else {
            self.countdown -= 1;
            false
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_is_derived_from_ticks_without_drift() {
        let mut c = Clock::new(Rate::from_hz(1000).unwrap());
        for _ in 0..3_600_000 {
            c.advance();
        }
        assert_eq!(c.now(), Nanos(3_600_000_000_000)); // exactly one hour
    }

    #[test]
    fn every_fires_on_the_multiples_of_its_period() {
        for every in [1, 5, 20, 7] {
            let (mut c, mut e) = (Clock::new(Rate::from_hz(1000).unwrap()), Every::new(every));
            for _ in 0..1000 {
                assert_eq!(e.fires(), c.tick() % every == 0, "every {every}, tick {}", c.tick());
                c.advance();
            }
        }
    }

    #[test]
    fn rates_must_have_whole_nanosecond_periods() {
        assert!(Rate::from_hz(0).is_none());
        assert!(Rate::from_hz(3).is_none());
        assert_eq!(Rate::from_hz(50).unwrap().period(), Nanos::from_millis(20));
        assert_eq!(Rate::from_hz(50).unwrap().ticks_of(Rate::from_hz(1000).unwrap()), Some(20));
    }
}
