//! The global start, before the fine fit: where the clocks and frames of a log lie, found in
//! closed form whatever they are, so that the fine fit (linearised around its start) starts
//! inside its reach.
//!
//! ```text
//! clock   ‖ω_imu‖ against ‖ω̂‖ (mount- and tilt-free), cross-correlated   clock.rs
//! frames  R_off by Wahba on the rates at that offset; gravity's direction  frames.rs
//!         in the mocap world, the lever arm and the biases by one linear
//!         solve at that R
//! ```
//!
//! **What is applied.** The fine fit re-linearises its corrections a few times from where it
//! starts, and from the identity it converges for a body offset or a world tilt of up to
//! [`ROTATION_REACH_DEG`] and a clock offset of up to [`CLOCK_REACH_S`], with a margin (on a real
//! hand-held trial it still converged from 50 ms and lost the lever arm from 120 ms:
//! docs/calibration.md, *The global start*). A start beyond those, and
//! determined (the clock's peak clear of every other; the rotation's spread below
//! [`ROTATION_SD_MAX_DEG`] and its residual below [`ROTATION_RESIDUAL_MAX`] of the gyro's rms;
//! gravity's magnitude within [`GRAVITY_TOLERANCE`] of g), is applied:
//! its corrections are the fine fit's start, and the effects it set are fitted, untested, from
//! there (a half-turn of the IMU is not a hypothesis to be tested, it is how the rig is built).
//! A start inside the reach changes nothing: the fine fit starts from the identity as it always
//! has, and the report gives the start beside the result.
//!
//! The lever arm and the biases of the start are reported, not applied: the fine fit holds them
//! linearly, so its result does not depend on where they start.

mod clock;
mod fft;
mod frames;

pub use clock::{BIN_S, ClockStart, ClockWindow, DEFAULT_HALF_WIDTH_S, MIN_CORRELATION, MIN_UNEXPLAINED_RATIO, Peak};
pub(crate) use clock::{Speeds, search};
pub use frames::FrameStart;

use crate::effects::Effect;
use crate::frames::{Frame, Rot};
use crate::identify::input::error::InputError;
use crate::identify::input::joined::Streams;
use crate::identify::input::mapping::Mapping;
use crate::identify::input::series::{Corrections, Series, raw_rots, raw_vecs};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

/// The fine fit converges from the identity for rotations up to this (deg).
pub const ROTATION_REACH_DEG: f64 = 10.0;
/// The fine fit's delay converges from zero for clock offsets up to this (s).
pub const CLOCK_REACH_S: f64 = 0.020;
/// A rotation start whose spread about any axis exceeds this (deg) is not determined.
pub const ROTATION_SD_MAX_DEG: f64 = 1.0;
/// A rotation start that leaves more than this share of the gyro's rms unexplained is not
/// determined: the rates are mostly noise (a hover), and noise fitted to noise gives any
/// rotation, with a spread that looks small.
pub const ROTATION_RESIDUAL_MAX: f64 = 0.2;
/// The start's ‖g⃗‖ must lie within this fraction of g for its world tilt to be applied (a rig
/// that stays near one attitude puts a few per cent of the vertical bias into it; an
/// accelerometer read in the wrong unit, or a position in millimetres read as metres, far more).
pub const GRAVITY_TOLERANCE: f64 = 0.25;

/// A rotation as JSON: its quaternion (w, x, y, z) and its angle (deg).
pub(crate) fn serialize_rot<A: Frame, B: Frame, S: serde::Serializer>(r: &Rot<A, B>, s: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeStruct;
    let q = r.quaternion();
    let mut st = s.serialize_struct("Rot", 2)?;
    st.serialize_field("quaternion_wxyz", &[q.w, q.i, q.j, q.k])?;
    st.serialize_field("angle_deg", &q.angle().to_degrees())?;
    st.end()
}

/// Which parts of the start the fine fit starts from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Applied {
    /// The clock offset (through the join of two streams, or as the mocap delay's start).
    pub clock: bool,
    /// The rotation mocap body → IMU.
    pub rotation: bool,
    /// The world's tilt.
    pub tilt: bool,
}

/// The global start of one log.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Start {
    /// The clock search (`None`: a stream without speeds to correlate).
    pub clock: Option<ClockStart>,
    /// The clock offset the series' rows still hold (s): the search's, less what the join
    /// already applied.
    pub clock_left_s: f64,
    /// The frames at that offset (`None`: too few usable samples).
    pub frames: Option<FrameStart>,
    /// What the fine fit starts from.
    pub applied: Applied,
}

impl Start {
    /// The corrections the fine fit starts from: the applied parts, the rest at the identity.
    pub fn corrections(&self) -> Corrections {
        let mut c = Corrections::default();
        if self.applied.clock {
            c.mocap_delay_s = self.clock_left_s;
        }
        if let Some(f) = &self.frames {
            if self.applied.rotation {
                c.body_offset = f.body_offset;
            }
            if self.applied.tilt {
                c.world_tilt = f.world_tilt;
            }
        }
        c
    }

    /// The effects the applied start sets, fitted untested from there (the join's shift of the
    /// poses among them: it leaves a delay to report).
    pub fn forced(&self) -> Vec<Effect> {
        let mut v = Vec::new();
        if self.applied.rotation {
            v.push(Effect::BodyOffset);
        }
        if self.applied.tilt {
            v.push(Effect::WorldTilt);
        }
        if self.applied.clock {
            v.push(Effect::MocapDelay);
        }
        v
    }
}

/// The clock search on a joined series: the gyro at every row, the mocap's speed between
/// neighbouring seen rows of a segment.
fn search_series(s: &Series, window: &ClockWindow) -> Option<ClockStart> {
    let (mut it, mut ig, mut pt, mut ps) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (gyro, att) = (raw_vecs(&s.gyro_body), raw_rots(&s.att_mocap));
    for &(a, b) in &s.segments {
        it.extend_from_slice(&s.t_s[a..b]);
        ig.extend_from_slice(&gyro[a..b]);
        let speeds = Speeds::of_poses(&s.t_s[a..b], &att[a..b], &s.mocap_ok[a..b]);
        pt.extend(speeds.t_s);
        ps.extend(speeds.speed);
    }
    let imu = Speeds::of_gyro(&it, &ig);
    search(&imu, &Speeds { t_s: pt, speed: ps }, 0.0, window)
}

/// The angular speeds of two streams on clocks of their own, each from its first stamp, and
/// where the mocap's first stamp lies on the IMU's clock (s).
fn speeds_of(streams: &Streams) -> (Speeds, Speeds, f64) {
    let (t0, p0) = (streams.imu.t[0], streams.pose.t[0]);
    let secs = |t: &[i128], origin: i128| t.iter().map(|x| (x - origin) as f64 * 1e-9).collect::<Vec<f64>>();
    let gyro: Vec<Vector3<f64>> = streams.imu.v.iter().map(|v| Vector3::new(v[0], v[1], v[2])).collect();
    let att: Vec<UnitQuaternion<f64>> = streams
        .pose
        .v
        .iter()
        .map(|v| UnitQuaternion::from_quaternion(Quaternion::new(v[6], v[3], v[4], v[5])))
        .collect();
    let pose_t = secs(&streams.pose.t, p0);
    let mocap = Speeds::of_poses(&pose_t, &att, &vec![true; att.len()]);
    (Speeds::of_gyro(&secs(&streams.imu.t, t0), &gyro), mocap, (p0 - t0) as f64 * 1e-9)
}

/// Two streams on clocks of their own (an ASL folder, an IMU log beside a pose file), joined
/// onto the IMU's clock once the clock search has found how they stand: the poses are joined at
/// the search's offset when it lies beyond the fine fit's reach and is determined, or when the
/// streams do not overlap at all without it (then there is nothing else to join them at);
/// otherwise as stamped. The series keeps the search ([`Clocks::search`](crate::identify::input::series::Clocks::search)), so that the global
/// start reads the clock from the streams and not from the joined rows. `file` names it.
///
/// # Errors
/// The reader's, were the joined rows malformed (they are not for streams that were read).
pub(in crate::identify) fn joined(
    map: &Mapping,
    streams: &Streams,
    window: &ClockWindow,
    file: &str,
) -> Result<Series, InputError> {
    let (imu, mocap, origin) = speeds_of(streams);
    let clock = search(&imu, &mocap, origin, window);
    let shift_s = clock
        .filter(|c| (c.determined() && c.best.offset_s.abs() > CLOCK_REACH_S) || c.widened)
        .map_or(0.0, |c| c.best.offset_s);
    let mut s = map.read_joined_streams(streams, (shift_s * 1e9).round() as i128, file)?;
    s.clocks.search = clock;
    Ok(s)
}

/// The global start of `s`: its clock (the join's search, or one on its rows), then its frames
/// at the offset its rows still hold, and what of it lies beyond the fine fit's reach.
pub fn start(s: &Series, window: &ClockWindow, smoothing_s: f64) -> Start {
    let clock = s.clocks.search.or_else(|| search_series(s, window));
    let clock_left_s = clock.map_or(0.0, |c| c.best.offset_s - s.clocks.pose_shift_s);
    let apply_clock = clock.is_some_and(|c| c.determined()) && clock_left_s.abs() > CLOCK_REACH_S;
    let frames = frames::frames(s, if apply_clock { clock_left_s } else { 0.0 }, smoothing_s);
    let g = s.model.gravity_m_s2;
    let applied = Applied {
        clock: apply_clock || s.clocks.pose_shift_s != 0.0,
        rotation: frames
            .is_some_and(|f| f.body_offset.angle().to_degrees() > ROTATION_REACH_DEG && f.rotation_determined()),
        tilt: frames.is_some_and(|f| {
            f.world_tilt.angle().to_degrees() > ROTATION_REACH_DEG
                && (f.gravity_m_s2 - g).abs() <= GRAVITY_TOLERANCE * g
                && f.rotation_determined()
        }),
    };
    Start { clock, clock_left_s, frames, applied }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn half_turn() -> UnitQuaternion<f64> {
        UnitQuaternion::from_scaled_axis(Vector3::new(1.0, 0.0, 1.0).normalize() * std::f64::consts::PI)
    }

    /// The case real labs meet, in closed form on an exact rig: markers at a half-turn about
    /// (1, 0, 1)/√2 from the IMU, a mocap world tilted 30° about x and its stream 0.2 s late. The
    /// start finds the offset within 1 ms, R_off within 0.05°, gravity's direction in the mocap
    /// world (R_w·e_D) within 0.2° and its magnitude within 1 % of g, and applies all three: each
    /// lies far beyond the fine fit's reach and is determined.
    #[test]
    fn a_half_turn_a_tilt_and_a_fifth_of_a_second_are_found_in_closed_form() {
        let r_w = UnitQuaternion::from_euler_angles(30f64.to_radians(), 0.0, 0.0);
        let s = Series::rig_for_tests(half_turn(), r_w, 0.2);
        let st = start(&s, &ClockWindow::default(), 0.02);
        let c = st.clock.unwrap();
        assert!((c.best.offset_s - 0.2).abs() < 1e-3 && c.determined(), "{c:?}");
        let f = st.frames.unwrap();
        assert!(f.body_offset.quaternion().angle_to(&half_turn()).to_degrees() < 0.05, "{:?}", f.body_offset);
        let down = |q: &UnitQuaternion<f64>| q * Vector3::z();
        let tilt_err = down(f.world_tilt.quaternion()).angle(&down(&r_w)).to_degrees();
        assert!(tilt_err < 0.2 && (f.gravity_m_s2 - 9.81).abs() < 0.01 * 9.81, "{tilt_err}° {}", f.gravity_m_s2);
        assert!(f.rotation_determined(), "{f:?}");
        assert_eq!(st.applied, Applied { clock: true, rotation: true, tilt: true });
        let c = st.corrections();
        assert!((c.mocap_delay_s - st.clock_left_s).abs() < 1e-15 && c.body_offset == f.body_offset);
        assert_eq!(st.forced(), vec![Effect::BodyOffset, Effect::WorldTilt, Effect::MocapDelay]);
    }

    /// A rig within the fine fit's reach (markers 3° off, a 2° tilt, 5 ms late) gets a start
    /// that is reported and not applied: the fit starts at the identity, as it always did.
    #[test]
    fn a_start_within_the_reach_is_not_applied() {
        let r_off = UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.5, 0.8).normalize() * 3f64.to_radians());
        let r_w = UnitQuaternion::from_euler_angles(0.0, 2f64.to_radians(), 0.0);
        let s = Series::rig_for_tests(r_off, r_w, 0.005);
        let st = start(&s, &ClockWindow::default(), 0.02);
        assert!((st.clock.unwrap().best.offset_s - 0.005).abs() < 1e-3, "{:?}", st.clock);
        assert!(st.frames.unwrap().body_offset.quaternion().angle_to(&r_off).to_degrees() < 0.05);
        assert_eq!(st.applied, Applied::default());
        assert_eq!(st.corrections(), Corrections::default());
        assert!(st.forced().is_empty());
    }

    /// What makes a rotation start determined, by hand: a spread over
    /// [`ROTATION_SD_MAX_DEG`] about any axis, or a residual over [`ROTATION_RESIDUAL_MAX`] of the
    /// gyro's rms, and it is not.
    #[test]
    fn a_rotation_start_is_determined_by_its_spread_and_its_residual() {
        let s = Series::rig_for_tests(half_turn(), UnitQuaternion::identity(), 0.0);
        let f = frames::frames(&s, 0.0, 0.02).unwrap();
        let deg = 1f64.to_radians();
        let with = |sd: [f64; 3], res: f64| FrameStart {
            body_offset_sd_rad: sd,
            gyro_residual_rad_s: res,
            gyro_rms_rad_s: 1.0,
            ..f
        };
        assert!(with([0.5 * deg; 3], 0.19).rotation_determined());
        assert!(!with([0.5 * deg, 1.01 * deg, 0.5 * deg], 0.1).rotation_determined());
        assert!(!with([0.5 * deg; 3], 0.21).rotation_determined());
    }
}
