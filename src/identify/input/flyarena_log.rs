//! flyarena's own flight logs ([`crate::log`]) as identification data, with the declared model
//! of the scenario that produced them.
//!
//! The thrust the declared model expects at the vehicle is reconstructed from the logged PPM
//! thrust count: T_cmd = count·T_max/255, delayed by the declared radio latency and passed
//! through the declared first-order motor lag τ_m (T follows Ω², whose small-signal lag is τ_m).
//! The logged battery voltage `vbat_v` is passed on with the declared pack's reference voltage
//! V_ref, for the thrust–voltage candidate.

use super::error::InputError;
use super::read_note::ReadNote;
use super::series::{NominalModel, Series};
use crate::frames::{Rot, Vec3};
use crate::log::FlightLog;
use crate::scenario::Scenario;
use crate::vehicle::params::GRAVITY;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

pub use crate::vehicle::params::X3D_ROTOR_RADIUS_M;

/// Relative accuracy (1σ) of the thrust reconstructed from the logged collective command. The
/// engine's rate loop adds per-rotor torque commands δ_i at 1 kHz (gyro noise times the rate
/// gains) that the log does not carry; Ω_i = √(f_i/k) is convex in f_i and the motor lag
/// filters Ω, so the mean thrust kΣΩ_i² falls short of the collective by about Σ var_hf(δ_i)/(4f_i):
/// thrust-scale estimates on 16 simulated flights with nothing hidden ran from −2.6·10⁻⁴ (x3d,
/// which sits at −0.4 to −2.6·10⁻⁴) to +1.3·10⁻⁴ (crazyflie21), each ±1.5·10⁻⁴ statistically
/// (test `identify::thrust_model_resolution_covers_the_rate_loop_jitter`). σ_T = 2·10⁻⁴ takes
/// that spread as one standard deviation of a systematic error.
pub const THRUST_REL_SD: f64 = 2e-4;

/// A flyarena log of vehicle `vehicle` of the scenario `s` as identification data (`source`
/// names it in errors and the report). The commanded thrust goes through the radio latency and
/// the motor lag of the scenario's model.
pub fn series(log: &FlightLog, s: &Scenario, vehicle: usize, source: &str) -> Result<Series, InputError> {
    let spec = &s.spec().vehicles[vehicle];
    let p = &spec.params;
    let col =
        |name: &str| log.column(name).ok_or_else(|| InputError::log(source, format!("the log has no column `{name}`")));
    let n = log.rows();
    let t: Vec<f64> = col("t_s")?.iter().map(|x| x.unwrap_or(f64::NAN)).collect();
    let valid = col("mocap_valid")?;
    let get =
        |name: &str| -> Result<Vec<f64>, InputError> { Ok(col(name)?.iter().map(|x| x.unwrap_or(f64::NAN)).collect()) };
    let (pn, pe, pd) = (get("pos_n_m")?, get("pos_e_m")?, get("pos_d_m")?);
    let (qw, qx, qy, qz) = (get("q_w")?, get("q_x")?, get("q_y")?, get("q_z")?);
    let g: Vec<Vec<f64>> =
        ["gyro_x_rad_s", "gyro_y_rad_s", "gyro_z_rad_s"].iter().map(|c| get(c)).collect::<Result<_, _>>()?;
    let a: Vec<Vec<f64>> =
        ["acc_x_m_s2", "acc_y_m_s2", "acc_z_m_s2"].iter().map(|c| get(c)).collect::<Result<_, _>>()?;
    let thrust_count = col("cmd_thrust")?;
    let mut pos = Vec::with_capacity(n);
    let mut att = Vec::with_capacity(n);
    let mut ok = Vec::with_capacity(n);
    let mut last = (Vector3::zeros(), UnitQuaternion::identity());
    for i in 0..n {
        let seen = valid[i] == Some(1.0);
        if seen {
            last = (
                Vector3::new(pn[i], pe[i], pd[i]),
                UnitQuaternion::from_quaternion(Quaternion::new(qw[i], qx[i], qy[i], qz[i])),
            );
        }
        // a flyarena log's pose is the mocap's (NED, the markers' body frame)
        pos.push(Vec3::from_raw(last.0));
        att.push(Rot::from_quaternion(last.1));
        ok.push(seen);
    }
    let dt = crate::log::median_interval(&t).unwrap_or(0.005);
    let t_max = spec.radio.thrust_max_n;
    let shift = (s.radio.latency_ms * 1e-3 / dt).round() as usize;
    let alpha = (-dt / p.motor_tau_s).exp();
    let mut thrust = Vec::with_capacity(n);
    let mut lagged = 0.0;
    for i in 0..n {
        let cmd = i.checked_sub(shift).and_then(|j| thrust_count[j]).unwrap_or(0.0) * t_max / 255.0;
        lagged = alpha * lagged + (1.0 - alpha) * cmd;
        thrust.push(lagged);
    }
    let v = s.vehicle(vehicle);
    // the battery voltage, where every row has it (logs from before it was logged have none)
    let vbat: Option<Vec<f64>> = log.column("vbat_v").and_then(|c| c.iter().copied().collect());
    Ok(Series {
        source: source.to_string(),
        t_s: t,
        pos_mocap_nav: pos,
        att_mocap: att,
        mocap_ok: ok,
        gyro_body: (0..n).map(|i| Vec3::new(g[0][i], g[1][i], g[2][i])).collect(),
        accel_body: (0..n).map(|i| Vec3::new(a[0][i], a[1][i], a[2][i])).collect(),
        thrust_n: Some(thrust),
        vbat_v: vbat,
        segments: log.segments.clone(),
        model: NominalModel {
            vehicle: format!("{} ({:?} preset)", v.name, v.model.preset).to_lowercase(),
            mass_kg: p.mass_kg,
            rotor_drag_per_s: p.rotor_drag_per_s,
            rotor_radius_m: p.rotor_radius_m,
            vbat_ref_v: p.battery.v_ref,
            gravity_m_s2: GRAVITY,
            thrust_rel_sd: THRUST_REL_SD,
            imu_range: p.imu_range,
            rigid_body: false,
        },
        repairs: log.repairs.iter().cloned().map(ReadNote::from).collect(),
        clocks: Default::default(),
    })
}

/// Runs a scenario and returns its flight log for vehicle `vehicle` as identification data,
/// through the same CSV text a `run --log` writes (so the two routes cannot drift apart).
pub fn run_and_log(
    s: &Scenario,
    vehicle: usize,
    source: &str,
) -> Result<(crate::engine::RunOutput, Series), InputError> {
    let out = crate::engine::run(s.spec(), crate::engine::RunOptions { trace: true, apply_calibration: None });
    let v = out.vehicles.get(vehicle).ok_or_else(|| {
        InputError::log(source, format!("vehicle {vehicle} does not exist (the scenario has {})", out.vehicles.len()))
    })?;
    let text = crate::log::write_csv(v, 1.0 / s.mocap.rate_hz() as f64);
    let log = crate::log::read_csv(&text, source)?;
    let series = series(&log, s, vehicle, source)?;
    Ok((out, series))
}
