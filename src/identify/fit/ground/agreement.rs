//! One flight's ground checks against its fitted model: the rest before take-off, the spin-up
//! and the rest after landing, each a tilt with its 95 % interval.

use super::rest::{GroundCheck, SpinUp, UpAxis};

/// One axis of [`GroundAgreement`] (degrees at this edge).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct TiltAgreement {
    /// The ground check as measured.
    pub ground_deg: f64,
    /// The tilt that the fitted accelerometer bias reads as at rest (b_y/g for roll, −b_x/g for
    /// pitch; 0 when no bias was fitted).
    pub bias_tilt_deg: f64,
    /// The ground check with the fitted bias removed: the accelerometer's tilt against the markers.
    pub ground_corrected_deg: f64,
    /// The flight's frame tilt at rest: its body offset plus its world tilt as seen at the rest
    /// yaw (0 when neither was selected: the model then says "no offset").
    pub flight_deg: f64,
    /// ground_corrected − flight = ground − (offset + bias tilt).
    pub difference_deg: f64,
    /// 95 % half-width of the difference: the ground's scatter and the flight's covariance of
    /// offset + bias tilt (the combination a hover determines, far better than either part),
    /// widened where the flight cannot tell two models apart.
    pub ci95_deg: f64,
    /// |difference| ≤ ci95, and the bias tilt is one a sensor can have (|bias tilt| ≤
    /// asin(2 m/s² / g) = 11.8°): a rotation of 100° at rest never agrees because a bias of 1.6 g
    /// explains it away.
    pub covers: bool,
}

/// The largest tilt an accelerometer bias can read as at rest (deg): asin(b_max/g) for the
/// largest bias a sensor has ([`MAX_ACCEL_BIAS_M_S2`](crate::effects::MAX_ACCEL_BIAS_M_S2)).
pub fn max_bias_tilt_deg() -> f64 {
    (crate::effects::MAX_ACCEL_BIAS_M_S2 / crate::vehicle::params::GRAVITY).asin().to_degrees()
}

/// The ground check against the flight's model. At rest the accelerometer reads
/// f = −g·C·e_D + b, so the ground check sees the frame tilt (body offset δ, and a world tilt
/// turned by the rest yaw) *plus* the tilt b/g of a bias: the two are compared as ground − b/g
/// against the frame tilt (equivalently ground against frame tilt + b/g).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct GroundAgreement {
    /// Roll: ground − bias tilt against the flight's frame tilt.
    pub roll: TiltAgreement,
    /// Pitch: ground − bias tilt against the flight's frame tilt.
    pub pitch: TiltAgreement,
    /// A body offset or a world tilt was selected (or forced).
    pub frame_fitted: bool,
    /// An accelerometer bias was selected (its tilt b/g is removed from the ground check).
    pub accel_bias_fitted: bool,
    /// The same comparison with the spin-up (motors on, still on the floor) as the ground check,
    /// when the log has one.
    pub spin_up: Option<SpinUpAgreement>,
    /// The rest after landing against the rest before and against the flight, when the log has
    /// one.
    pub after_landing: Option<LandedAgreement>,
    /// The still vehicle's mocap tilt scatter at rest, roll and pitch (deg per sample;
    /// [`GroundCheck::mocap_sd_deg`]).
    pub rest_pose_sd_deg: [f64; 2],
    /// The still pose scatters in roll by more than [`STILL_POSE_SD_DEG`]: the cameras see the
    /// markers badly at rest, and the rest's tilt is not a reliable reference.
    pub rest_pose_scatters: bool,
    /// The body axis nearest the vertical at rest: roll and pitch are the tilts about the other
    /// two ([`UpAxis::level`]; left out of the JSON when it is z).
    #[serde(skip_serializing_if = "UpAxis::is_z")]
    pub up_axis: UpAxis,
}

/// A still vehicle's mocap roll that scatters by more than this per sample (deg) is a pose the
/// cameras see badly at rest: a marker hidden near the floor, the fit flickering between
/// subsets of markers. On the ten shared NanoBench flights a clear view scatters by
/// 0.005–0.014°, and the three flights above 0.09° were the ones whose two rests both disagree
/// with the flight in roll. The threshold was set there; on 68 held-out flights (docs/nanobench.md, *A still
/// pose that scatters*, with its caveat) the ground check disagrees with the flight by a median
/// 0.33° in roll above it and 0.08° below it, one-sided Mann–Whitney p = 1·10⁻⁴.
pub const STILL_POSE_SD_DEG: f64 = 0.02;

/// The rest after landing: a second ground check that brackets the flight with the first.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct LandedAgreement {
    /// Rows averaged after landing.
    pub samples: usize,
    /// Roll after landing.
    pub roll: LandedAxis,
    /// Pitch after landing.
    pub pitch: LandedAxis,
}

/// One axis of [`LandedAgreement`] (degrees at this edge): the second rest checked as the
/// spin-up is ([`CheckAxis`]), and the two rests' mean against the flight.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LandedAxis {
    /// The tilt after landing against the rest before take-off and against the flight. Its
    /// change, after − before, is how far the accelerometer's tilt against the markers moved
    /// over the flight (a bias that drifts as the IMU warms, a mount that creeps, markers
    /// bumped).
    #[serde(flatten)]
    pub check: CheckAxis,
    /// The two rests' mean − flight: the reference for a tilt that moves between the rests (a
    /// monotonic drift puts the flight's average between them).
    pub bracket_difference_deg: f64,
    /// 95 % half-width: the two means' and the flight's scatter, plus half the change (the
    /// flight's tilt may sit anywhere between the rests), plus the flight's widening.
    pub bracket_ci95_deg: f64,
    /// The bracket's interval covers zero.
    pub bracket_covers: bool,
}

/// The spin-up against the rest and against the flight.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct SpinUpAgreement {
    /// Mean thrust over the spin-up as a fraction of the weight.
    pub thrust_fraction: f64,
    /// Length of the spin-up rows (s).
    pub duration_s: f64,
    /// Roll during the spin-up.
    pub roll: CheckAxis,
    /// Pitch during the spin-up.
    pub pitch: CheckAxis,
}

/// One axis of a ground check other than the rest before take-off (the spin-up, the rest
/// after landing), against that rest and against the flight (degrees at this edge).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CheckAxis {
    /// The check's tilt with the fitted bias removed.
    pub ground_corrected_deg: f64,
    /// Check − rest before take-off: for the spin-up what the spinning rotors add to the
    /// accelerometer's tilt, after landing what moved over the flight.
    pub change_deg: f64,
    /// 95 % half-width of the change (the two means' standard errors).
    pub change_ci95_deg: f64,
    /// Check − flight frame tilt.
    pub difference_deg: f64,
    /// 95 % half-width of that difference, built as the rest's.
    pub ci95_deg: f64,
    /// The interval covers zero: the check agrees with the flight.
    pub covers: bool,
}

impl CheckAxis {
    /// A check's tilt `on` (its standard error `on_se`) against the rest before take-off
    /// (`rest`, standard error `rest_se`) and the flight, whose frame tilt scatters by
    /// `sd_flight` and is widened by `widen` (degrees).
    fn new(on: f64, on_se: f64, rest: &TiltAgreement, rest_se: f64, sd_flight: f64, widen: f64) -> CheckAxis {
        let difference = on - rest.flight_deg;
        let ci95 = (Z * on_se).hypot(Z * sd_flight) + widen;
        CheckAxis {
            ground_corrected_deg: on,
            change_deg: on - rest.ground_corrected_deg,
            change_ci95_deg: Z * on_se.hypot(rest_se),
            difference_deg: difference,
            ci95_deg: ci95,
            covers: difference.abs() <= ci95,
        }
    }
}

/// Z_{0.975}
const Z: f64 = 1.959963984540054;

/// The flight's side of the agreement: its frame tilt at rest (body offset + world tilt, roll and
/// pitch), what it fitted.
#[derive(Clone, Copy, Debug)]
pub struct FlightTilt {
    /// The frame tilt (rad).
    pub offset_rad: [f64; 2],
    /// Standard deviation of offset + bias tilt (rad).
    pub sd_rad: [f64; 2],
    /// Extra half-width from models the flight cannot tell apart (rad).
    pub widen_rad: [f64; 2],
    /// A body offset or a world tilt was fitted.
    pub frame_fitted: bool,
    /// An accelerometer bias was fitted.
    pub accel_bias_fitted: bool,
}

/// Builds the agreement from the raw ground check, the bias-corrected one, the flight's tilt, and
/// the spin-up and the rest after landing (both bias-corrected), where the log has them.
pub fn agreement(
    raw: &GroundCheck,
    corrected: &GroundCheck,
    flight: &FlightTilt,
    spin: Option<&SpinUp>,
    landed: Option<&GroundCheck>,
) -> GroundAgreement {
    let FlightTilt { offset_rad, sd_rad, widen_rad, frame_fitted, accel_bias_fitted } = *flight;
    let axis = |k: usize| {
        let ((g, se), (gc, _)) = (raw.axis(k), corrected.axis(k));
        let flight = offset_rad[k].to_degrees();
        let difference = gc - flight;
        let ci95 = (Z * se).hypot(Z * sd_rad[k].to_degrees()) + widen_rad[k].to_degrees();
        TiltAgreement {
            ground_deg: g,
            bias_tilt_deg: g - gc,
            ground_corrected_deg: gc,
            flight_deg: flight,
            difference_deg: difference,
            ci95_deg: ci95,
            covers: difference.abs() <= ci95 && (g - gc).abs() <= max_bias_tilt_deg(),
        }
    };
    let (roll, pitch) = (axis(0), axis(1));
    let spin_up = spin.map(|sp| {
        let spin_axis = |k: usize, rest: &TiltAgreement| {
            let ((on, on_se), (_, rest_se)) = (sp.check.axis(k), corrected.axis(k));
            CheckAxis::new(on, on_se, rest, rest_se, sd_rad[k].to_degrees(), widen_rad[k].to_degrees())
        };
        SpinUpAgreement {
            thrust_fraction: sp.thrust_fraction,
            duration_s: sp.duration_s,
            roll: spin_axis(0, &roll),
            pitch: spin_axis(1, &pitch),
        }
    });
    let after_landing = landed.map(|l| {
        let landed_axis = |k: usize, rest: &TiltAgreement| {
            let ((after, after_se), (_, rest_se)) = (l.axis(k), corrected.axis(k));
            let (sd_flight, widen) = (sd_rad[k].to_degrees(), widen_rad[k].to_degrees());
            let check = CheckAxis::new(after, after_se, rest, rest_se, sd_flight, widen);
            let bracket = 0.5 * (after + rest.ground_corrected_deg) - rest.flight_deg;
            let bracket_ci95 =
                (Z * 0.5 * after_se.hypot(rest_se)).hypot(Z * sd_flight) + 0.5 * check.change_deg.abs() + widen;
            LandedAxis {
                check,
                bracket_difference_deg: bracket,
                bracket_ci95_deg: bracket_ci95,
                bracket_covers: bracket.abs() <= bracket_ci95,
            }
        };
        LandedAgreement { samples: l.samples, roll: landed_axis(0, &roll), pitch: landed_axis(1, &pitch) }
    });
    GroundAgreement {
        roll,
        pitch,
        frame_fitted,
        accel_bias_fitted,
        spin_up,
        after_landing,
        rest_pose_sd_deg: raw.mocap_sd_deg,
        rest_pose_scatters: raw.mocap_sd_deg[0] > STILL_POSE_SD_DEG,
        up_axis: raw.up_axis,
    }
}
