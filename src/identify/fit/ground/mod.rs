//! An independent check of the roll/pitch misalignment: the vehicle resting on the floor before
//! take-off. There the accelerometer reads f = −g·C_n^b·e_D in the IMU frame and the mocap
//! predicts f̂ = −g·R_mᵀ·e_D in the marker frame; the rotation from f̂ to f ([`rotation_between`](rest::rotation_between):
//! axis f̂ × f, angle atan2(|f̂ × f|, f̂·f), exact at any size) is the marker offset's tilt (its
//! rotation about the vertical is unobservable at rest). Its two components are about the body
//! axes that are level at rest ([`UpAxis`]: roll and pitch for a vehicle on its legs, z up; a rig
//! may rest with any axis up); a body whose nearest axis is more than [`MAX_REST_OFF_AXIS_DEG`]
//! from the vertical gets no ground check. The flight's side is the same rotation between f̂ and
//! the f the fitted frames predict ([`predicted_tilt`]), so the two compare like with like
//! whatever the sizes of the offset, the world tilt and the bias.
//!
//! It assumes no accelerometer bias: a bias b reads as a tilt of b/g rad (0.1 m/s² ≈ 0.58°), and
//! the check cannot tell them apart. It needs ≥ 0.5 s of rest (thrust zero, or within 1 cm of
//! the floor without a thrust column).
//!
//! Two more readings of the same tilt bracket the flight: the spin-up ([`spin_up`]: motors on,
//! still on the floor) and the rest after landing ([`tilt_after_landing`]: still again, motors
//! off). The rests before and after tell how far the reference itself moves over one flight;
//! their mean is the reference of a tilt that moves between them ([`LandedAxis`]). The mocap's
//! own tilt scatter at rest ([`GroundCheck::mocap_sd_deg`]) tells a still pose that the
//! cameras see badly.
//!
//! One file per job: `rest` finds the rests and reads their tilts, `agreement` holds one
//! flight's checks against its fit, `summary` the checks across flights with the rank and sign
//! tests they rest on.

mod agreement;
mod rest;
mod summary;
#[cfg(test)]
mod tests;

pub use agreement::{
    CheckAxis, FlightTilt, GroundAgreement, LandedAgreement, LandedAxis, STILL_POSE_SD_DEG, SpinUpAgreement,
    TiltAgreement, agreement,
};
pub use rest::{
    GroundCheck, MAX_REST_OFF_AXIS_DEG, Rest, UpAxis, ground_check, predicted_tilt, rest_before_takeoff,
    rest_off_axis_deg, spin_up, tilt_after_landing, tilt_at_rest,
};
pub use summary::{
    LandedAxisSummary, LandedSummary, RestPoseAxisSummary, RestPoseSummary, SpinUpAxisSummary, SpinUpSummary,
    landed_summary, rest_pose_summary, spin_up_summary,
};
