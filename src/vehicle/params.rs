//! Physical parameters of a quadrotor.
//!
//! The `x3d` preset stands for the Ascending Technologies X3D of the paper (and its successor the
//! Hummingbird, whose parameters are published): mass 0.68 kg, inertia diag(0.007, 0.007, 0.012)
//! kg·m², arm 0.17 m, thrust coefficient k_f = 8.54858e-6 N/(rad/s)², drag-torque-to-thrust ratio
//! k_m = 0.016 m, motor time constant 12.5 ms, rotor speed limit 838 rad/s (6.0 N per rotor,
//! 24 N in all, a thrust-to-weight ratio of 3.6). These are the RotorS Hummingbird values; the
//! paper itself gives no numbers.

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
    pub layout: RotorLayout,
    /// Gain of the onboard rate loop per body axis (1/s): τ = J·K_ω·(ω_cmd − ω_gyro).
    pub rate_loop_gain_per_s: [f64; 3],
}

pub const GRAVITY: f64 = 9.81;

impl VehicleParams {
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
