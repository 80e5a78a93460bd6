//! Physical parameters of a quadrotor.
//!
//! The `x3d` preset stands for the Ascending Technologies X3D of the paper (and its successor the
//! Hummingbird, whose parameters are published): mass 0.68 kg, inertia diag(0.007, 0.007, 0.012)
//! kg·m², arm 0.17 m, thrust coefficient k_f = 8.54858e-6 N/(rad/s)², drag-torque-to-thrust ratio
//! k_m = 0.016 m, motor time constant 12.5 ms, rotor speed limit 838 rad/s (6.0 N per rotor,
//! 24 N in all, a thrust-to-weight ratio of 3.6). These are the RotorS Hummingbird values; the
//! paper itself gives no numbers.

use super::battery::BatteryParams;

/// Rotor arrangement. The X3D flies "+" (rotors on the body axes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RotorLayout {
    /// Rotors at front (+x), right (+y), back (−x), left (−y); front/back spin counter-clockwise
    /// seen from above (their drag torque yaws the body clockwise, i.e. +z down: positive),
    /// left/right clockwise.
    Plus,
}

/// Parameters of the rigid body and its rotors (SI units).
#[derive(Clone, Debug, serde::Serialize)]
pub struct VehicleParams {
    /// Mass m (kg).
    pub mass_kg: f64,
    /// Principal moments of inertia about body x, y, z (kg·m²).
    pub inertia_kg_m2: [f64; 3],
    /// Distance from the centre of mass to each rotor axis (m).
    pub arm_m: f64,
    /// Thrust per rotor f = k_f·Ω² (N per (rad/s)²).
    pub k_thrust: f64,
    /// Drag torque per rotor τ = k_m·f (m).
    pub k_torque_m: f64,
    /// First-order motor time constant (s): Ω̇ = (Ω_cmd − Ω)/τ_m.
    pub motor_tau_s: f64,
    /// Rotor speed limit (rad/s).
    pub rotor_speed_max: f64,
    /// Rotor drag: specific force −k·v along body x and y, (1/s). Zero in the nominal X3D.
    pub rotor_drag_per_s: [f64; 2],
    /// Where the rotors sit and which way they spin.
    pub layout: RotorLayout,
    /// Gain of the onboard rate loop per body axis (1/s): τ = J·K_ω·(ω_cmd − ω_gyro).
    pub rate_loop_gain_per_s: [f64; 3],
    /// Integral gain of the onboard rate loop per body axis (1/s²): τ += J·K_I·∫(ω_cmd − ω_gyro)dt.
    /// Zero in the presets (the X3D's loop is proportional).
    pub rate_loop_integral_per_s2: [f64; 3],
    /// What the onboard controller tracks: body rates (the paper's X3D, the presets) or angles
    /// ([`super::attitude_loop`]).
    pub onboard_mode: super::OnboardMode,
    /// Gains [K_φ, K_θ, K_ψ] of the onboard attitude loop (1/s), used in attitude mode: well
    /// below the rate loop's 25 1/s, and above the ground's 6 1/s, which has the radio's latency
    /// in its loop and this one has not.
    pub attitude_loop_gain_per_s: [f64; 3],
    /// Full scale of the onboard IMU: no flight of this vehicle reads beyond it.
    pub imu_range: ImuRange,
    /// Rotor radius r (m), for the ground effect.
    pub rotor_radius_m: f64,
    /// Ground effect c_g (see [`super::dynamics`]): thrust T·(1 + c_g·(r/4h)²) at height h ≥ r.
    /// Zero in the presets.
    pub ground_effect: f64,
    /// The flight battery (see [`super::battery`]).
    pub battery: BatteryParams,
    /// Thrust against battery voltage c (1/V, see [`super::battery`]): thrust × (1 + c·(V − V_ref)).
    /// Zero in the presets.
    pub thrust_voltage_per_v: f64,
}

/// Full scale of an IMU, per axis: the largest reading the sensor can give, as configured.
/// `identify`'s data-quality gate treats a reading at or beyond it as not a measurement.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ImuRange {
    /// Accelerometer full scale per axis (m/s²).
    pub accel_m_s2: f64,
    /// Gyro full scale per axis (rad/s).
    pub gyro_rad_s: f64,
}

impl ImuRange {
    /// The Crazyflie 2.1's BMI088 as its firmware configures it: ±24 g and ±2000 °/s.
    pub fn crazyflie21() -> Self {
        ImuRange { accel_m_s2: 24.0 * GRAVITY, gyro_rad_s: 2000f64.to_radians() }
    }
    /// The X3D's AutoPilot board: ADXRS610-class gyros (±300 °/s) and a ±6 g accelerometer.
    /// These are flyarena's preset values (the paper gives none); the X3D's 3.6 thrust-to-weight
    /// ratio stays well inside them.
    pub fn x3d() -> Self {
        ImuRange { accel_m_s2: 6.0 * GRAVITY, gyro_rad_s: 300f64.to_radians() }
    }
    /// An IMU of unknown make on a rig that is not a vehicle: ±16 g and ±2000 °/s, the widest
    /// setting of the common MEMS parts (BMI088's gyro, ICM-20602, MPU-6000), so that the
    /// data-quality gate's saturation check flags only what such a part cannot read.
    pub fn wide_mems() -> Self {
        ImuRange { accel_m_s2: 16.0 * GRAVITY, gyro_rad_s: 2000f64.to_radians() }
    }
}

/// Standard gravity used throughout (m/s²).
pub const GRAVITY: f64 = 9.81;

/// Rotor radius of the X3D preset's 8-inch propellers (m).
pub const X3D_ROTOR_RADIUS_M: f64 = 0.1;

/// Rotor radius of the Crazyflie 2.1's 46 mm stock propellers (m).
pub const CRAZYFLIE21_ROTOR_RADIUS_M: f64 = 0.0235;

/// Thrust of one Crazyflie motor from its PWM command u ∈ [0, 65535] and the battery voltage V:
///
/// ```text
/// T_4(u, V) = a·(u/65535)² + b·(u/65535)·V + c     (grams-force, all four motors at u)
/// T_motor   = max(0, T_4)/4 · g/1000                (N), and 0 at u = 0
/// ```
///
/// fitted by least squares to the thrust stand `crazyflie-thrust-stand/cf2.1-stock-prop.csv`
/// (2,573 rows, PWM 0–65,500, 2.96–3.90 V, tare −1.17 g removed; RMS residual 1.67 g, which
/// includes the transients between steps). The test `crazyflie21_thrust_map_is_the_stand_fit`
/// refits it from the data.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct PwmThrustMap {
    /// Quadratic coefficient a (grams-force, all four motors).
    pub a_g: f64,
    /// Coefficient b of the PWM·voltage term (grams-force per volt).
    pub b_g_per_v: f64,
    /// Constant c (grams-force).
    pub c_g: f64,
    /// The voltage the thrust–voltage effect is referred to (V).
    pub vbat_ref_v: f64,
}

impl PwmThrustMap {
    /// The stand fit of the Crazyflie 2.1 with stock propellers.
    pub fn crazyflie21() -> Self {
        PwmThrustMap { a_g: 35.407_020_21, b_g_per_v: 5.922_264_62, c_g: -0.075_526_67, vbat_ref_v: 3.7 }
    }
    /// Thrust of one motor (N).
    pub fn thrust_n(&self, pwm: f64, vbat_v: f64) -> f64 {
        if pwm <= 0.0 {
            return 0.0;
        }
        let u = pwm / 65535.0;
        (self.a_g * u * u + self.b_g_per_v * u * vbat_v + self.c_g).max(0.0) / 4.0 * GRAVITY / 1000.0
    }
}

impl VehicleParams {
    /// Shaft power of the rotors at speeds `omega` (rad/s), in W: Σ k_m·k_f·Ω_i³ (each rotor's
    /// drag torque k_m·k_f·Ω² times its speed).
    pub fn rotor_power_w(&self, omega: &[f64; 4]) -> f64 {
        omega.iter().map(|w| self.k_torque_m * self.k_thrust * w * w * w.abs()).sum()
    }

    /// The Ascending Technologies X3D of the paper.
    pub fn x3d() -> Self {
        VehicleParams {
            mass_kg: 0.68,
            inertia_kg_m2: [0.007, 0.007, 0.012],
            arm_m: 0.17,
            k_thrust: 8.54858e-6,
            k_torque_m: 0.016,
            motor_tau_s: 0.0125,
            rotor_speed_max: 838.0,
            rotor_drag_per_s: [0.0, 0.0],
            layout: RotorLayout::Plus,
            rate_loop_gain_per_s: [25.0, 25.0, 10.0],
            rate_loop_integral_per_s2: [0.0; 3],
            onboard_mode: super::OnboardMode::Rate,
            attitude_loop_gain_per_s: [8.0, 8.0, 3.0],
            imu_range: ImuRange::x3d(),
            rotor_radius_m: X3D_ROTOR_RADIUS_M,
            ground_effect: 0.0,
            battery: BatteryParams::x3d(),
            thrust_voltage_per_v: 0.0,
        }
    }
    /// The Bitcraze Crazyflie 2.1 (NanoBench's vehicle): 34 g with markers, inertia
    /// diag(1.66, 1.66, 2.93)·10⁻⁵ kg·m² (Förster 2015), arm 46 mm, rotor speed limit 2500 rad/s
    /// and k_f = 2.245·10⁻⁸ N/(rad/s)² so that full throttle gives the stand's 57 g at 3.7 V
    /// ([`PwmThrustMap::crazyflie21`]), k_m = 0.006 m, motor time constant 20 ms. flyarena
    /// flies it in the "+" layout; the real one flies "×", which changes only the mixer.
    pub fn crazyflie21() -> Self {
        VehicleParams {
            mass_kg: 0.034,
            inertia_kg_m2: [1.66e-5, 1.66e-5, 2.93e-5],
            arm_m: 0.046,
            k_thrust: 2.245e-8,
            k_torque_m: 0.006,
            motor_tau_s: 0.02,
            rotor_speed_max: 2500.0,
            rotor_drag_per_s: [0.0, 0.0],
            layout: RotorLayout::Plus,
            rate_loop_gain_per_s: [25.0, 25.0, 10.0],
            rate_loop_integral_per_s2: [0.0; 3],
            onboard_mode: super::OnboardMode::Rate,
            attitude_loop_gain_per_s: [8.0, 8.0, 3.0],
            imu_range: ImuRange::crazyflie21(),
            rotor_radius_m: CRAZYFLIE21_ROTOR_RADIUS_M,
            ground_effect: 0.0,
            battery: BatteryParams::crazyflie21(),
            thrust_voltage_per_v: 0.0,
        }
    }
    /// Maximum thrust of one rotor (N).
    pub fn rotor_thrust_max(&self) -> f64 {
        self.k_thrust * self.rotor_speed_max * self.rotor_speed_max
    }
    /// Maximum collective thrust (N).
    pub fn thrust_max(&self) -> f64 {
        4.0 * self.rotor_thrust_max()
    }
    /// Thrust needed to hover, m·g (N).
    pub fn hover_thrust(&self) -> f64 {
        self.mass_kg * GRAVITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The PWM thrust map by hand, T = max(0, a·u² + b·u·V + c)/4 · g/1000 with u = pwm/65535: a =
    /// 40 g, b = 10 g/V, c = −1 g at u = ½ and V = 4 V gives (10 + 20 − 1)/4 = 7.25 g a motor; at u
    /// = 0.01 the sum is negative (0.004 + 0.4 − 1) and the thrust 0; and 0 at pwm 0. The Crazyflie
    /// 2.1 stand fit's intercept is below zero: at 3.7 V its thrust starts at u = (−bV + √((bV)² −
    /// 4ac))/(2a) = 0.003428, pwm 224.6. A bug it catches: the intercept's sign and every operator
    /// of `thrust_n`.
    #[test]
    fn pwm_thrust_by_hand_and_the_stand_fits_dead_band() {
        let map = PwmThrustMap { a_g: 40.0, b_g_per_v: 10.0, c_g: -1.0, vbat_ref_v: 3.7 };
        let close = |got: f64, want: f64| assert!((got - want).abs() < 1e-12, "{got} N for {want} N");
        close(map.thrust_n(65535.0 / 2.0, 4.0), 7.25 * GRAVITY / 1000.0);
        assert_eq!(map.thrust_n(655.35, 4.0), 0.0);
        assert_eq!(PwmThrustMap { c_g: 1.0, ..map }.thrust_n(0.0, 4.0), 0.0, "no command, no thrust");
        let cf = PwmThrustMap::crazyflie21();
        assert_eq!(cf.thrust_n(224.0, 3.7), 0.0);
        assert!(cf.thrust_n(225.5, 3.7) > 0.0);
    }

    /// The presets' IMU ranges against their sources, in SI: the BMI088 at ±24 g = 235.44 m/s²
    /// and ±2000 °/s = 34.9066 rad/s (Crazyflie firmware settings), the X3D at ±6 g = 58.86 m/s²
    /// and ±300 °/s = 5.23599 rad/s (flyarena's values). The data-quality gate cuts at 98 % of
    /// these, so a wrong range either cuts real flight or lets saturation through.
    #[test]
    fn imu_ranges_are_the_sensors_full_scales_in_si() {
        let cf = VehicleParams::crazyflie21().imu_range;
        assert!((cf.accel_m_s2 - 235.44).abs() < 1e-9 && (cf.gyro_rad_s - 34.906_585).abs() < 1e-6, "{cf:?}");
        let x3d = VehicleParams::x3d().imu_range;
        assert!((x3d.accel_m_s2 - 58.86).abs() < 1e-9 && (x3d.gyro_rad_s - 5.235_988).abs() < 1e-6, "{x3d:?}");
    }
}
