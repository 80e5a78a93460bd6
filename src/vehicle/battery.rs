//! The flight battery: a LiPo pack whose terminal voltage falls with the charge drawn and sags
//! under load, and the thrust the motors lose with it.
//!
//! **Pack** (SI units; n cells in series, capacity Q in A·h, charge drawn q in A·h):
//!
//! ```text
//! V_oc(q) = n·(v_full − (v_full − v_empty)·q/Q)        open-circuit voltage, linear in q
//! P_mech  = Σ k_m·k_f·Ω_i³                              rotor shaft power (τ_i·Ω_i, τ_i = k_m·k_f·Ω_i²)
//! P_e     = P_mech/η                                    electrical power the motors draw
//! V       = (V_oc + √(V_oc² − 4·R·P_e))/2               terminal voltage: V = V_oc − R·I with V·I = P_e
//! I       = P_e/V,   q̇ = I/3600                         current (A), charge drawn (A·h per s)
//! ```
//!
//! When the pack cannot deliver P_e at all (V_oc² < 4·R·P_e) it sits at its maximum-power point
//! V = V_oc/2. The linear V_oc(q) is the crudest LiPo curve; over the 1–15 % of charge a flight in
//! the arena draws it is the local slope, which is what matters here.
//!
//! **Thrust against voltage.** The motor drivers turn a speed command into a duty cycle that was
//! calibrated at the reference voltage V_ref; at another voltage the motor settles at
//! Ω = Ω_cmd·√(1 + c·(V − V_ref)), so its thrust k_f·Ω² is the commanded one times
//! (1 + c·(V − V_ref)). c (1/V) is the undeclared `thrust_voltage_per_v`; the Crazyflie stand fit
//! ([`super::params::PwmThrustMap`]) gives c = b·u·/(a·u² + b·u·V + c₀) ≈ 0.14 /V at hover. The
//! declared model has c = 0: `identify`'s candidate `thrust_voltage` is this c.

/// A battery pack (declared: the station and `identify` know it).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct BatteryParams {
    /// Cells in series.
    pub cells: u32,
    /// Capacity Q (A·h).
    pub capacity_ah: f64,
    /// Open-circuit voltage of a full and of an empty cell (V).
    pub v_full_cell: f64,
    /// Open-circuit voltage of an empty cell (V).
    pub v_empty_cell: f64,
    /// Internal resistance of the pack and its wiring, R (Ω).
    pub resistance_ohm: f64,
    /// Motor and driver efficiency η: P_mech/P_e.
    pub efficiency: f64,
    /// State of charge at take-off, 1 − q₀/Q.
    pub charge_start: f64,
    /// The voltage the declared thrust model refers to, V_ref = n·3.7 V (V).
    pub v_ref: f64,
}

impl BatteryParams {
    /// The X3D's 3-cell 2100 mA·h pack (AscTec's stock battery); R = 60 mΩ with wiring, η = 0.5.
    /// At hover (47 W of shaft power) it draws ≈ 8 A and sags ≈ 0.5 V.
    pub fn x3d() -> Self {
        BatteryParams {
            cells: 3,
            capacity_ah: 2.1,
            v_full_cell: 4.2,
            v_empty_cell: 3.5,
            resistance_ohm: 0.06,
            efficiency: 0.5,
            charge_start: 0.9,
            v_ref: 3.0 * 3.7,
        }
    }
    /// The Crazyflie 2.1's 1-cell 250 mA·h pack, R and η fitted to the thrust stand
    /// `crazyflie-thrust-stand/cf2.1-stock-prop.csv`: R = 0.22 Ω from vbat = a + d·row − R·i
    /// (least squares, 0.216 Ω), η = 0.45 from k_m·T·Ω/(V·I) at 25–45 g of thrust (median 0.459,
    /// with the preset's k_m = 0.006 m). At hover (3.9 W of shaft power) it draws ≈ 2.4 A (the
    /// stand: 2.66 A at 34 g) and sags ≈ 0.55 V. Test `crazyflie21_battery_is_the_stand_fit`.
    pub fn crazyflie21() -> Self {
        BatteryParams {
            cells: 1,
            capacity_ah: 0.25,
            v_full_cell: 4.2,
            v_empty_cell: 3.5,
            resistance_ohm: 0.22,
            efficiency: 0.45,
            charge_start: 0.9,
            v_ref: 3.7,
        }
    }
    /// Open-circuit voltage after drawing `q_ah` (V).
    pub fn open_circuit_v(&self, q_ah: f64) -> f64 {
        self.cells as f64 * (self.v_full_cell - (self.v_full_cell - self.v_empty_cell) * q_ah / self.capacity_ah)
    }
    /// Terminal voltage (V) while the motors deliver `p_mech_w` of shaft power with `q_ah` drawn.
    pub fn terminal_v(&self, q_ah: f64, p_mech_w: f64) -> f64 {
        let v_oc = self.open_circuit_v(q_ah);
        let p_e = p_mech_w.max(0.0) / self.efficiency;
        let disc = v_oc * v_oc - 4.0 * self.resistance_ohm * p_e;
        (v_oc + disc.max(0.0).sqrt()) / 2.0
    }
}

/// The pack in flight: charge drawn so far and the last terminal voltage.
#[derive(Clone, Copy, Debug)]
pub struct Battery {
    p: BatteryParams,
    drawn_ah: f64,
    voltage_v: f64,
}

impl Battery {
    /// A pack at its starting charge, at rest.
    pub fn new(p: BatteryParams) -> Self {
        let drawn_ah = (1.0 - p.charge_start) * p.capacity_ah;
        Battery { p, drawn_ah, voltage_v: p.open_circuit_v(drawn_ah) }
    }
    /// The pack's parameters.
    pub fn params(&self) -> &BatteryParams {
        &self.p
    }
    /// Terminal voltage at the last step (V).
    pub fn voltage_v(&self) -> f64 {
        self.voltage_v
    }
    /// Charge drawn since it was full (A·h).
    pub fn drawn_ah(&self) -> f64 {
        self.drawn_ah
    }
    /// Delivers `p_mech_w` of shaft power for `dt_s`: the terminal voltage at the start of the
    /// step is returned (and kept), the charge advances by I·dt (explicit Euler; q changes by
    /// < 10⁻⁶ of Q per millisecond).
    pub fn step(&mut self, p_mech_w: f64, dt_s: f64) -> f64 {
        let v = self.p.terminal_v(self.drawn_ah, p_mech_w);
        let current = p_mech_w.max(0.0) / self.p.efficiency / v;
        self.drawn_ah += current * dt_s / 3600.0;
        self.voltage_v = v;
        v
    }
}

/// The speed factor √(1 + c·(V − V_ref)) the motors reach against their command at voltage `v`
/// (exactly 1 when c = 0; never negative).
pub fn speed_factor(c_per_v: f64, v: f64, v_ref: f64) -> f64 {
    if c_per_v == 0.0 {
        return 1.0;
    }
    (1.0 + c_per_v * (v - v_ref)).max(0.0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vehicle::params::{GRAVITY, VehicleParams};

    /// The declared thrust model's reference voltage is the pack's nominal one, 3.7 V per Li-ion
    /// cell: 11.1 V for the X3D's three cells, 3.7 V for the Crazyflie's one; and it lies
    /// between the empty and the full pack.
    #[test]
    fn the_reference_voltage_is_the_nominal_pack_voltage() {
        for (p, want) in [(BatteryParams::x3d(), 11.1), (BatteryParams::crazyflie21(), 3.7)] {
            assert!((p.v_ref - want).abs() < 1e-12 && (p.v_ref - 3.7 * p.cells as f64).abs() < 1e-12, "{p:?}");
            assert!(p.cells as f64 * p.v_empty_cell < p.v_ref && p.v_ref < p.cells as f64 * p.v_full_cell);
        }
    }

    /// Closed forms: V_oc is n·v_full full and n·v_empty empty; with no load V = V_oc; the
    /// terminal voltage solves V = V_oc − R·P_e/V (checked by substitution); past the maximum
    /// power V_oc²/(4R) it stays at V_oc/2.
    #[test]
    fn terminal_voltage_solves_the_circuit() {
        let p = BatteryParams::x3d();
        assert!((p.open_circuit_v(0.0) - 12.6).abs() < 1e-12);
        assert!((p.open_circuit_v(2.1) - 10.5).abs() < 1e-12);
        assert_eq!(p.terminal_v(0.3, 0.0), p.open_circuit_v(0.3));
        for p_mech in [10.0, 47.0, 200.0] {
            let v = p.terminal_v(0.21, p_mech);
            let i = p_mech / p.efficiency / v;
            assert!((v - (p.open_circuit_v(0.21) - p.resistance_ohm * i)).abs() < 1e-9, "{p_mech} W: {v} V");
        }
        let v_oc = p.open_circuit_v(0.21);
        let p_max_mech = v_oc * v_oc / (4.0 * p.resistance_ohm) * p.efficiency;
        assert!((p.terminal_v(0.21, 2.0 * p_max_mech) - v_oc / 2.0).abs() < 1e-12);
    }

    /// The X3D at hover: four rotors at Ω_h = √(m·g/(4k_f)) = 441.6 rad/s give
    /// P = 4·k_m·k_f·Ω_h³ = 4·0.016·1.6677 N·441.6 rad/s = 47.1 W; the pack at 90 % charge
    /// (V_oc = 3·(4.2 − 0.07) = 12.39 V) then sits at (V_oc + √(V_oc² − 4·0.06·94.3))/2 = 11.92 V
    /// and draws 7.9 A; one minute draws 7.9/60 A·h and V_oc falls by 3·0.7·(0.132/2.1) = 0.132 V.
    #[test]
    fn hover_draw_of_the_x3d_in_closed_form() {
        let vp = VehicleParams::x3d();
        let w = (vp.mass_kg * GRAVITY / (4.0 * vp.k_thrust)).sqrt();
        let p = vp.rotor_power_w(&[w; 4]);
        let by_hand = 4.0 * 0.016 * (0.68 * 9.81 / 4.0) * w;
        assert!((p - by_hand).abs() < 1e-9 && (p - 47.1).abs() < 0.1, "{p} W");
        let mut b = Battery::new(BatteryParams::x3d());
        assert!((b.voltage_v() - 12.39).abs() < 1e-12);
        let v0 = b.step(p, 1e-3);
        let v_oc = 12.39;
        let expected = (v_oc + (v_oc * v_oc - 4.0 * 0.06 * p / 0.5).sqrt()) / 2.0;
        assert!((v0 - expected).abs() < 1e-12 && (v0 - 11.92).abs() < 0.01, "{v0}");
        let mut b = Battery::new(BatteryParams::x3d());
        for _ in 0..60_000 {
            b.step(p, 1e-3);
        }
        let drawn = b.drawn_ah() - 0.21;
        let current = p / 0.5 / v0;
        // the current grows as V_oc falls; over a minute by < 1 %
        assert!((drawn - current / 60.0).abs() < 0.01 * current / 60.0, "{drawn} A·h for {current} A");
        let sag_now = b.params().open_circuit_v(b.drawn_ah());
        assert!((v_oc - sag_now - 3.0 * 0.7 * drawn / 2.1).abs() < 1e-12);
    }

    /// The motors' speed factor: exactly 1 without the effect, √(1 + c·ΔV) with it, so thrust
    /// (∝ Ω²) is scaled by 1 + c·ΔV; never NaN for a deep sag.
    #[test]
    fn speed_factor_scales_thrust_linearly_in_voltage() {
        assert_eq!(speed_factor(0.0, 3.1, 3.7), 1.0);
        let f = speed_factor(0.14, 4.0, 3.7);
        assert!((f * f - (1.0 + 0.14 * 0.3)).abs() < 1e-15);
        assert_eq!(speed_factor(0.5, 1.0, 3.7), 0.0);
    }
}
