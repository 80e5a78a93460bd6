//! From a checked scenario to what the engine runs on: milliseconds and degrees become
//! [`Nanos`] and radians, millimetres metres, the undeclared effects join the true model.

use super::schema::{PhaseCfg, Scenario};
use super::spec::{ArenaSpec, CalibrationSettings, FailsafeSettings, MocapSpec, PHYSICS, TelemetrySpec, VehicleSpec};
use crate::clock::{Nanos, Rate};
use crate::control::Gains;
use crate::frames::{Euler, MocapBody, Rot, Vec3};
use crate::guidance::{Phase, Plan};
use crate::link::LinkParams;
use crate::mocap::{CameraError, MarkerSet, Occlusion, TrueOffset};
use crate::radio::RadioParams;
use crate::vehicle::{Disturbance, ImuParams, OnboardMode, VehicleParams};

/// The scenario's rates that passed: each with the physics ticks of one of its periods.
pub(super) struct Rates {
    pub mocap: (Rate, u64),
    pub radio: (Rate, u64),
    pub telemetry: (Rate, u64),
}

/// What the checks of one vehicle derived: its declared model, its marker template, the
/// markers as mounted and the offset that mounting makes.
pub(super) struct Checked {
    pub params: VehicleParams,
    pub template: Vec<Vec3<MocapBody>>,
    pub markers: MarkerSet,
    pub truth: TrueOffset,
}

/// The arena of a scenario whose checks passed (`rates` and `vehicles` are what they derived):
/// milliseconds and degrees become [`Nanos`] and radians, millimetres metres.
pub(super) fn arena(s: &Scenario, rates: Rates, vehicles: Vec<Checked>) -> ArenaSpec {
    let cam = &s.mocap.camera_error;
    let camera = CameraError {
        rotation: Rot::from_euler(Euler::from_degrees(cam.rotation_deg[0], cam.rotation_deg[1], cam.rotation_deg[2])),
        translation: Vec3::from_array(cam.translation_mm.map(|x| x * 1e-3)),
    };
    let tm = &s.telemetry;
    let phases: Vec<Phase> = s.plan().iter().map(PhaseCfg::to_phase).collect();
    let end = Plan::schedule(&phases, Vec3::zeros(), 0.0).end();
    let mocap = MocapSpec {
        rate: rates.mocap.0,
        every: rates.mocap.1,
        latency: ms(s.mocap.latency_ms),
        noise_m: s.mocap.noise_mm * 1e-3,
        noise_in_loop: s.mocap.noise_in_loop,
        camera,
    };
    let telemetry = TelemetrySpec {
        rate: rates.telemetry.0,
        every: rates.telemetry.1 as u32,
        link: LinkParams { latency: ms(tm.latency_ms), jitter: ms(tm.jitter_ms), loss: tm.loss.model() },
        clock_offset: ms(tm.clock.offset_ms),
        clock_drift_ppm: tm.clock.drift_ppm,
    };
    let vehicles = vehicles.into_iter().enumerate().map(|(i, c)| vehicle(s, i, c, &mocap, &telemetry)).collect();
    ArenaSpec {
        name: s.name.clone(),
        seed: s.seed,
        physics: PHYSICS,
        run_time: Nanos::from_secs_f64(s.duration_s.unwrap_or(end.as_secs_f64() + 1.0)),
        mocap,
        radio_rate: rates.radio.0,
        radio_every: rates.radio.1,
        link: LinkParams { latency: ms(s.link.latency_ms), jitter: ms(s.link.jitter_ms), loss: s.link.loss.model() },
        outages: s.link.outages().map(|o| (Nanos::from_secs_f64(o.from_s), o.to_s.map(Nanos::from_secs_f64))).collect(),
        telemetry,
        phases,
        vehicles,
    }
}

/// Vehicle `i` of `s`, from what its checks derived.
fn vehicle(s: &Scenario, i: usize, checked: Checked, mocap: &MocapSpec, telemetry: &TelemetrySpec) -> VehicleSpec {
    let Checked { params, template, markers, truth } = checked;
    let v = s.vehicle(i);
    let (c, cal) = (&s.controller, &s.calibration);
    let thrust_max = s.radio.thrust_max_n.unwrap_or(params.thrust_max());
    let u = &v.undeclared;
    // the truth: the declared parameters with the undeclared effects added
    let mut true_params = params.clone();
    true_params.k_thrust *= u.thrust_scale;
    true_params.ground_effect += u.ground_effect;
    true_params.thrust_voltage_per_v += u.thrust_voltage_per_v;
    true_params.rotor_drag_per_s =
        [params.rotor_drag_per_s[0] + u.rotor_drag_per_s[0], params.rotor_drag_per_s[1] + u.rotor_drag_per_s[1]];
    let frames = |delay_ms: f64| (delay_ms * mocap.rate.hz() as f64 / 1000.0).round() as usize;
    VehicleSpec {
        name: v.name.clone(),
        station: v.station,
        radio: RadioParams {
            channels: s.radio.channels() as usize,
            latency: ms(s.radio.latency_ms),
            rate_scale_rad_s: s.radio.rate_scale_deg_s.to_radians(),
            angle_scale_rad: s.radio.angle_scale_deg.to_radians(),
            thrust_max_n: thrust_max,
            mode: params.onboard_mode,
        },
        gains: Gains {
            k_x: c.k_x,
            k_v: c.k_v,
            k_att: c.k_att,
            max_tilt: [c.max_tilt_deg.to_radians(); 2],
            thrust_max_n: thrust_max,
            mass_kg: params.mass_kg,
        },
        calibration: CalibrationSettings {
            apply: cal.apply,
            compensation: c.compensation,
            eps_yaw: cal.validity_max_mean_yaw_deg.to_radians(),
            eps_roll: cal.validity_max_mean_roll_deg.to_radians(),
            rls_min_spread_m: cal.rls_min_spread_m,
            mocap_period: mocap.rate.period(),
            telemetry_period: telemetry.rate.period(),
            estimate_telemetry_clock: s.telemetry.clock.estimate,
            hover_trim: cal.hover_trim && params.onboard_mode == OnboardMode::Attitude,
        },
        failsafe: FailsafeSettings {
            timeout: ms(c.failsafe_timeout_ms),
            thrust_fraction: c.failsafe_thrust_fraction,
            motors_off_after: Nanos::from_secs_f64(c.failsafe_motors_off_s),
        },
        velocity_cutoff_hz: c.velocity_cutoff_hz,
        imu: ImuParams {
            gyro_noise_rad_s: v.imu.gyro_noise_deg_s.to_radians(),
            accel_noise_m_s2: v.imu.accel_noise_m_s2,
            gyro_bias_rad_s: v.imu.gyro_bias_deg_s.map(f64::to_radians),
            accel_bias_m_s2: v.imu.accel_bias_m_s2,
            position_m: v.imu.position_mm.map(|x| x * 1e-3),
        },
        disturbance: Disturbance { force_nav_n: v.disturbance.force_n, torque_body_nm: v.disturbance.torque_nm },
        occlusions: v
            .markers
            .occlusions()
            .map(|o| Occlusion {
                marker: o.marker as usize,
                from: Nanos::from_secs_f64(o.from_s),
                to: Nanos::from_secs_f64(o.to_s),
            })
            .collect(),
        home: Vec3::new(v.home_m[0], v.home_m[1], 0.0),
        yaw0_rad: v.yaw0_deg.to_radians(),
        mocap_latency: ms(s.mocap.latency_ms + u.mocap_delay_ms),
        log_delay_frames: frames(u.mocap_delay_ms),
        gyro_log_delay_frames: frames(u.gyro_delay_ms),
        params,
        true_params,
        template,
        markers,
        truth,
    }
}

/// Milliseconds as [`Nanos`].
fn ms(x: f64) -> Nanos {
    Nanos::from_secs_f64(x * 1e-3)
}

#[cfg(test)]
mod tests {
    use crate::Scenario;
    use crate::clock::Nanos;
    use crate::vehicle::VehicleParams;
    use std::f64::consts::{FRAC_PI_2, PI};

    /// Each conversion by hand: milliseconds to nanoseconds, degrees to radians (90°, 18°/s, 9°/s), millimetres
    /// to metres, rates to physics ticks (1000/200 = 5, 1000/50 = 20, 1000/100 = 10), undeclared
    /// delays to mocap frames (10 ms at 200 Hz = 2), the undeclared effects onto the true model
    /// only (a scale multiplies, the rest add), the run time without `duration_s`, the markers' 3° roll as the true offset,
    /// and a marker's displacement in millimetres as metres.
    #[test]
    fn the_spec_is_the_scenario_in_si_units_and_ticks() {
        let yaml = "
name: units
duration_s: 7.5
mocap: { latency_ms: 12, noise_mm: 0.4, camera_error: { translation_mm: [5, 0, -2] } }
link: { latency_ms: 3, outages: [{ from_s: 1, to_s: 2 }] }
radio: { rate_scale_deg_s: 18 }
vehicles:
  - name: a
    yaw0_deg: 90
    home_m: [1, -2]
    markers: { rotation_deg: [3, 0, 0] }
    imu: { gyro_bias_deg_s: [0, 9, 0], position_mm: [10, 0, 0] }
    undeclared: { mocap_delay_ms: 10, gyro_delay_ms: 5, thrust_scale: 1.1, ground_effect: 0.5, thrust_voltage_per_v: 0.1, rotor_drag_per_s: [0.2, 0.3] }
  - name: b
    home_m: [3, 0]
    markers: { pattern: 1, displacement_mm: [[10, 0, -4], [0, 0, 0], [0, 0, 0], [0, 0, 0]] }
plan:
  - hover: { duration_s: 1 }
";
        let s = Scenario::parse(yaml, "units.yaml".as_ref()).unwrap();
        let spec = s.spec();
        assert_eq!((spec.name.as_str(), spec.seed, spec.run_time), ("units", 1, Nanos(7_500_000_000)));
        assert_eq!((spec.mocap.every, spec.radio_every, spec.telemetry.every), (5, 20, 10));
        assert_eq!((spec.mocap.latency, spec.link.latency), (Nanos(12_000_000), Nanos(3_000_000)));
        assert!((spec.mocap.noise_m - 4e-4).abs() < 1e-15);
        assert_eq!(spec.mocap.camera.translation.to_array(), [0.005, 0.0, -0.002]);
        assert_eq!(spec.outages, vec![(Nanos(1_000_000_000), Some(Nanos(2_000_000_000)))]);
        let v = &spec.vehicles[0];
        assert!((v.yaw0_rad - FRAC_PI_2).abs() < 1e-15);
        assert_eq!((v.home.x(), v.home.y(), v.home.z()), (1.0, -2.0, 0.0));
        assert!((v.radio.rate_scale_rad_s - PI / 10.0).abs() < 1e-15);
        assert!((v.imu.gyro_bias_rad_s[1] - PI / 20.0).abs() < 1e-15);
        assert_eq!(v.imu.position_m, [0.01, 0.0, 0.0]);
        assert_eq!((v.mocap_latency, v.log_delay_frames, v.gyro_log_delay_frames), (Nanos(22_000_000), 2, 1));
        let x3d = VehicleParams::x3d();
        assert_eq!(v.params.k_thrust, x3d.k_thrust);
        assert!((v.true_params.k_thrust / x3d.k_thrust - 1.1).abs() < 1e-12);
        assert_eq!(
            (v.params.ground_effect, v.params.thrust_voltage_per_v, v.params.rotor_drag_per_s),
            (x3d.ground_effect, x3d.thrust_voltage_per_v, x3d.rotor_drag_per_s)
        );
        assert_eq!(
            (v.true_params.ground_effect, v.true_params.thrust_voltage_per_v),
            (x3d.ground_effect + 0.5, x3d.thrust_voltage_per_v + 0.1)
        );
        assert_eq!(v.true_params.rotor_drag_per_s, [x3d.rotor_drag_per_s[0] + 0.2, x3d.rotor_drag_per_s[1] + 0.3]);
        assert!(
            (v.truth.euler.roll - 3f64.to_radians()).abs() < 1e-9 && v.truth.euler.pitch.abs() < 1e-9,
            "{:?}",
            v.truth.euler
        );
        assert_eq!(v.template.len(), 4);
        // a marker displaced by (10, 0, −4) mm sits 1 cm forward and 4 mm up of its template's place
        let b = &s.spec().vehicles[1].markers;
        let moved =
            b.mounted[0].to_array().iter().zip(b.template[0].to_array()).map(|(m, t)| m - t).collect::<Vec<_>>();
        assert!(moved.iter().zip([0.01, 0.0, -0.004]).all(|(m, want)| (m - want).abs() < 1e-15), "{moved:?}");
        // without `duration_s`: the plan's end (a 1 s hover) plus 1 s
        let s =
            Scenario::parse("name: d\nvehicles: [{name: a}]\nplan: [{hover: {duration_s: 1}}]\n", "d.yaml".as_ref())
                .unwrap();
        assert_eq!(s.spec().run_time, Nanos(2_000_000_000));
    }
}
