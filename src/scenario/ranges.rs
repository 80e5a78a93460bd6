//! Range-checked numbers for the YAML edge. A value outside its range fails *during*
//! deserialisation, so the YAML parser reports the exact line and column of the offending value.
//! Every range here is the documented range of its field (docs/scenarios.md, "Scenario reference").

use serde::{Deserialize, Deserializer, Serialize, Serializer, de::Error};

/// A value or bound as an error message shows it: ±∞ as such, and a number far from 1 (10⁹ or
/// more, or under 10⁻⁴) in exponent form, so that 1e308 is not printed with 308 digits.
fn fmt_bound(x: f64) -> String {
    if x.is_infinite() {
        if x > 0.0 { "∞".into() } else { "−∞".into() }
    } else if x != 0.0 && (x.abs() >= 1e9 || x.abs() < 1e-4) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// A number outside its documented range (or not finite).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}", (format!("{} {unit} is outside the allowed range {}{}, {}]", fmt_bound(*value), if *open_lo { "(" } else { "[" }, fmt_bound(*lo), fmt_bound(*hi))).replace("  ", " "))]
pub struct OutOfRange {
    /// The value given.
    pub value: f64,
    /// Lower bound.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
    /// The lower bound is excluded.
    pub open_lo: bool,
    /// Unit of the value.
    pub unit: String,
}

/// Checks `lo ≤ v ≤ hi` (or `lo < v` when `open_lo`), NaN and infinities rejected.
pub fn check(v: f64, lo: f64, hi: f64, open_lo: bool, unit: &str) -> Result<f64, OutOfRange> {
    let ok = v.is_finite() && (if open_lo { v > lo } else { v >= lo }) && v <= hi;
    if ok { Ok(v) } else { Err(OutOfRange { value: v, lo, hi, open_lo, unit: unit.to_string() }) }
}

macro_rules! ranged {
    ($($name:ident: $lo:expr, $hi:expr, $open:expr, $unit:expr;)*) => {
        $(
            #[doc = concat!("The range of `", stringify!($name), "` (", $unit, ") and its serde functions.")]
            pub mod $name {
                use super::*;
                /// Lower bound.
                pub const LO: f64 = $lo;
                /// Upper bound.
                pub const HI: f64 = $hi;
                /// The lower bound is excluded.
                pub const OPEN_LO: bool = $open;
                /// Checks a value against this range.
                pub fn check(v: f64) -> Result<f64, OutOfRange> {
                    super::check(v, $lo, $hi, $open, $unit)
                }
                /// Writes the value as it is.
                pub fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
                    v.serialize(s)
                }
                /// Reads a value and checks its range.
                pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
                    check(f64::deserialize(d)?).map_err(D::Error::custom)
                }
                /// An optional value.
                pub mod opt {
                    use super::*;
                    /// Writes the value as it is.
                    pub fn serialize<S: Serializer>(v: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
                        v.serialize(s)
                    }
                    /// Reads a value, if given, and checks its range.
                    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
                        Option::<f64>::deserialize(d)?
                            .map(super::check)
                            .transpose()
                            .map_err(D::Error::custom)
                    }
                }
                /// Fixed-size arrays (`[f64; 2]`, `[f64; 3]`): every element in range.
                pub mod arr {
                    use super::*;
                    /// Writes the values as they are.
                    pub fn serialize<S: Serializer, const N: usize>(v: &[f64; N], s: S) -> Result<S::Ok, S::Error>
                    where
                        [f64; N]: Serialize,
                    {
                        v.serialize(s)
                    }
                    /// Reads the values and checks each one's range.
                    pub fn deserialize<'de, D: Deserializer<'de>, const N: usize>(d: D) -> Result<[f64; N], D::Error>
                    where
                        [f64; N]: Deserialize<'de>,
                    {
                        let a = <[f64; N]>::deserialize(d)?;
                        for v in a { super::check(v).map_err(D::Error::custom)?; }
                        Ok(a)
                    }
                }
            }
        )*
    };
}

const INF: f64 = f64::INFINITY;

ranged! {
    probability: 0.0, 1.0, false, "";
    latency_ms: 0.0, 1000.0, false, "ms";
    failsafe_ms: 20.0, 10000.0, false, "ms";
    clock_offset_ms: -40.0, 40.0, false, "ms";
    clock_drift_ppm: -400.0, 400.0, false, "ppm";
    noise_mm: 0.0, 20.0, false, "mm";
    small_angle_deg: -30.0, 30.0, false, "°";
    yaw_angle_deg: -180.0, 180.0, false, "°";
    offset_mm: -1000.0, 1000.0, false, "mm";
    position_m: -100.0, 100.0, false, "m";
    mass_kg: 0.0, 100.0, true, "kg";
    inertia: 0.0, 10.0, true, "kg·m²";
    arm_m: 0.0, 2.0, true, "m";
    positive_coeff: 0.0, INF, true, "";
    nonneg_coeff: 0.0, 100.0, false, "";
    time_constant_s: 0.0, 1.0, true, "s";
    gain_per_s: 0.0, 1000.0, true, "1/s";
    tilt_deg: 0.0, 60.0, true, "°";
    cutoff_hz: 0.0, 500.0, true, "Hz";
    rate_scale_deg_s: 0.0, 20.0, true, "°/s per count";
    angle_scale_deg: 0.0, 5.0, true, "° per count";
    thrust_n: 0.0, 10000.0, true, "N";
    duration_s: 0.0, 3600.0, true, "s";
    settle_s: 0.0, 3600.0, false, "s";
    altitude_m: 0.0, 10.0, true, "m";
    distance_m: 0.0, 100.0, true, "m";
    speed_m_s: 0.0, 10.0, true, "m/s";
    accel_m_s2: 0.0, 20.0, true, "m/s²";
    spin_deg: -3600.0, 3600.0, false, "°";
    time_s: 0.0, 3600.0, false, "s";
    tol_deg: 0.0, 90.0, true, "°";
    tol_m: 0.0, 100.0, true, "m";
    tol_rad: 0.0, 1.0, true, "rad";
    ratio: 0.0, 1.0, true, "";
    force_n: -100.0, 100.0, false, "N";
    torque_nm: -10.0, 10.0, false, "N·m";
    gyro_noise_deg_s: 0.0, 100.0, false, "°/s";
    sample_rate_hz: 0.0, 10000.0, true, "Hz";
    rig_pos_sd_m: 0.0, 0.1, false, "m";
    rig_att_sd_rad: 0.0, 0.1, false, "rad";
    accel_density: 0.0, 1.0, false, "m/s²/√Hz";
    accel_walk: 0.0, 1.0, false, "m/s³/√Hz";
    gyro_density: 0.0, 0.1, false, "rad/s/√Hz";
    gyro_walk: 0.0, 0.1, false, "rad/s²/√Hz";
    accel_drift: -0.1, 0.1, false, "m/s² per s";
    gyro_drift: -0.01, 0.01, false, "rad/s per s";
    gyro_bias_deg_s: -100.0, 100.0, false, "°/s";
    accel_m_s2_signed: -50.0, 50.0, false, "m/s²";
    accel_noise: 0.0, 50.0, false, "m/s²";
    spread_m: 0.0, 100.0, true, "m";
    radius_m: 0.0, 5.0, true, "m";
    period_s: 0.5, 60.0, false, "s";
    turns: 1.0, 100.0, false, "turns";
    timeout_ms: 1.0, 10000.0, false, "ms";
    thrust_fraction: 0.5, 1.0, false, "";
    thrust_scale: 0.5, 1.5, false, "";
    drag_per_s: 0.0, 10.0, false, "1/s";
    delay_ms: 0.0, 200.0, false, "ms";
    ground_effect: 0.0, 5.0, false, "";
    thrust_voltage_per_v: 0.0, 1.0, false, "1/V";
    capacity_mah: 0.0, 100000.0, true, "mA·h";
    resistance_ohm: 0.0, 10.0, false, "Ω";
    charge: 0.0, 1.0, true, "";
    displacement_mm: -200.0, 200.0, false, "mm";
    template_m: -1.0, 1.0, false, "m";
    integral_per_s2: 0.0, 1000.0, false, "1/s²";
    cells: 1.0, 12.0, false, "cells";
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The messages by hand: open and closed lower bounds, no unit, and the values no plain
    /// decimal should print (infinities, NaN, and numbers far from 1 in exponent form).
    #[test]
    fn out_of_range_messages_show_the_value_and_the_range() {
        let msg =
            |v: f64, lo: f64, hi: f64, open: bool, unit: &str| check(v, lo, hi, open, unit).unwrap_err().to_string();
        assert_eq!(msg(-20.0, 0.0, 3600.0, true, "s"), "-20 s is outside the allowed range (0, 3600]");
        assert_eq!(msg(1.5, 0.0, 1.0, false, ""), "1.5 is outside the allowed range [0, 1]");
        assert_eq!(msg(1e308, 0.0, 20.0, false, "mm"), "1e308 mm is outside the allowed range [0, 20]");
        assert_eq!(msg(2e-7, 1e-6, 1.0, false, "s"), "2e-7 s is outside the allowed range [1e-6, 1]");
        assert_eq!(msg(f64::INFINITY, 0.0, f64::INFINITY, false, "m"), "∞ m is outside the allowed range [0, ∞]");
        assert_eq!(msg(f64::NAN, f64::NEG_INFINITY, 5.0, false, "m"), "NaN m is outside the allowed range [−∞, 5]");
        assert_eq!(msg(0.0, 0.0, 1.0, true, "m"), "0 m is outside the allowed range (0, 1]");
        assert_eq!(check(0.0, 0.0, 1.0, false, "m"), Ok(0.0));
        assert_eq!(check(1.0, 0.0, 1.0, true, "m"), Ok(1.0));
    }
}
