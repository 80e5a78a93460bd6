//! The Vicon system: markers, camera errors, noise, occlusions and the rigid-body fit.
//!
//! At each frame (200 Hz) the actual marker positions are
//!
//! ```text
//! y_i = R_w·(p + R·b_i) + t_w + n_i,     n_i ~ N(0, σ²·I)  (m, MocapNav)
//! ```
//!
//! with the true pose (R = C_b^n, p), the mounted markers b_i (body frame), the camera-system
//! error (R_w, t_w: Nav → MocapNav, identity when the cameras are calibrated) and per-marker noise.
//! The pose is the [rigid fit](fit::rigid_fit) of the *template* onto the visible y_i, so
//! displaced markers produce the attitude offset by themselves, as in the arena. With fewer than
//! three visible markers the vehicle is lost for that frame and no packet is sent.

pub mod fit;
pub mod markers;

pub use fit::{RigidFit, rigid_fit, rigid_fit_near};
pub use markers::{MarkerSet, TrueOffset, builtin_pattern, patterns_confusable};

use crate::clock::Nanos;
use crate::frames::{Body, MocapBody, MocapNav, Nav, Rot, Vec3};
use crate::rng::Stream;
use crate::vehicle::State;

/// A time window during which one marker is invisible to all cameras.
#[derive(Clone, Copy, Debug)]
pub struct Occlusion {
    /// The marker's index in the template.
    pub marker: usize,
    /// Hidden from…
    pub from: Nanos,
    /// …until (exclusive).
    pub to: Nanos,
}

/// The camera system's calibration error: the mocap world is Nav rotated and shifted.
#[derive(Clone, Copy, Debug)]
pub struct CameraError {
    /// The mocap world's rotation against true NED.
    pub rotation: Rot<Nav, MocapNav>,
    /// The true origin in the mocap world (m).
    pub translation: Vec3<MocapNav>,
}

impl CameraError {
    /// A perfectly calibrated camera system.
    pub fn none() -> Self {
        CameraError { rotation: Rot::identity(), translation: Vec3::zeros() }
    }
    /// Maps a true position into mocap-world coordinates.
    pub fn to_mocap(&self, p: Vec3<Nav>) -> Vec3<MocapNav> {
        self.rotation.apply(p) + self.translation
    }
    /// Maps a mocap-world position back into the true frame.
    pub fn to_nav(&self, p: Vec3<MocapNav>) -> Vec3<Nav> {
        self.rotation.inverse().apply(p - self.translation)
    }
}

/// One pose as the Vicon system sends it.
#[derive(Clone, Copy, Debug)]
pub struct MocapFrame {
    /// Frame number, +1 per camera frame (also when the vehicle was not seen).
    pub seq: u32,
    /// When the cameras exposed this frame.
    pub t_capture: Nanos,
    /// The rigid body's origin (m, mocap NED).
    pub pos: Vec3<MocapNav>,
    /// Its attitude: the template's frame in the mocap world.
    pub att: Rot<MocapBody, MocapNav>,
    /// Markers seen (at least 3, or there is no frame).
    pub visible_markers: u8,
}

/// The camera system of one vehicle: marker observation, rigid fit, frame numbers.
#[derive(Clone, Debug)]
pub struct Mocap {
    markers: MarkerSet,
    occlusions: Vec<Occlusion>,
    camera: CameraError,
    noise_m: f64,
    rng: Stream,
    seq: u32,
    /// The last fitted attitude (the next fit's starting point); `None` after a lost frame.
    last_attitude: Option<Rot<MocapBody, MocapNav>>,
    // scratch buffers, allocated once
    observed: Vec<Vec3<MocapNav>>,
    visible: Vec<bool>,
}

impl Mocap {
    /// Cameras with this calibration error and marker noise (σ, m), seeing these markers except
    /// during the occlusions.
    pub fn new(markers: MarkerSet, occlusions: Vec<Occlusion>, camera: CameraError, noise_m: f64, rng: Stream) -> Self {
        let n = markers.template.len();
        Mocap {
            markers,
            occlusions,
            camera,
            noise_m,
            rng,
            seq: 0,
            last_attitude: None,
            observed: vec![Vec3::zeros(); n],
            visible: vec![true; n],
        }
    }

    /// The markers.
    pub fn markers(&self) -> &MarkerSet {
        &self.markers
    }

    /// The calibration error.
    pub fn camera(&self) -> &CameraError {
        &self.camera
    }

    /// Marker positions as the cameras saw them in the last frame (MocapNav), with visibility.
    pub fn last_observation(&self) -> (&[Vec3<MocapNav>], &[bool]) {
        (&self.observed, &self.visible)
    }

    /// The sequence number the next [`Mocap::capture`] takes.
    pub fn next_seq(&self) -> u32 {
        self.seq
    }

    /// Captures one frame of the true state at time `t`. `None` when the vehicle is lost
    /// (fewer than three visible markers); the sequence number advances either way.
    pub fn capture(&mut self, t: Nanos, truth: &State) -> Option<MocapFrame> {
        let seq = self.seq;
        self.seq = self.seq.wrapping_add(1);
        // y_i = R_w·(p + R·b_i) + t_w = (R_w·p + t_w) + (R_w·R)·b_i: one rotation per marker
        let origin = self.camera.to_mocap(truth.pos);
        let body_to_mocap: Rot<Body, MocapNav> = self.camera.rotation * truth.att;
        for (i, b) in self.markers.mounted.iter().enumerate() {
            let mut y = origin + body_to_mocap.apply(*b);
            if self.noise_m > 0.0 {
                let s = self.noise_m;
                y += Vec3::new(s * self.rng.normal(), s * self.rng.normal(), s * self.rng.normal());
            }
            self.observed[i] = y;
            self.visible[i] = !self.occlusions.iter().any(|o| o.marker == i && t >= o.from && t < o.to);
        }
        // the last frame's attitude starts the fit (Newton, three steps instead of Kabsch's ~8)
        let fit = rigid_fit_near(&self.markers.template, &self.observed, &self.visible, self.last_attitude.take())?;
        self.last_attitude = Some(fit.rotation);
        Some(MocapFrame {
            seq,
            t_capture: t,
            pos: fit.translation,
            att: fit.rotation,
            visible_markers: self.visible.iter().filter(|v| **v).count() as u8,
        })
    }
}

/// Shorthand used by tests: the ideal measured attitude R_w·R·R_off.
pub fn ideal_measured_attitude(
    camera: &CameraError,
    truth: Rot<Body, Nav>,
    offset: Rot<MocapBody, Body>,
) -> Rot<MocapBody, MocapNav> {
    camera.rotation * truth * offset
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames::Euler;
    use crate::rng::Component;

    /// A noise-free frame is the truth seen through the camera error and the marker offset: the
    /// attitude R_w·R·R_off, the position R_w·(p + R·t_off) + t_w.
    #[test]
    fn noiseless_capture_equals_truth_composed_with_offset() {
        let ms =
            MarkerSet::displaced(builtin_pattern(2).to_vec(), Euler::from_degrees(2.0, -1.0, 4.0), &[Vec3::zeros(); 4]);
        let off = ms.true_offset().unwrap();
        let cam = CameraError {
            rotation: Rot::from_euler(Euler::from_degrees(0.5, 0.0, 1.0)),
            translation: Vec3::new(0.01, 0.0, 0.0),
        };
        let mut m = Mocap::new(ms, vec![], cam, 0.0, Stream::new(1, Component::MocapNoise, 0));
        let truth = State {
            pos: Vec3::new(1.0, 2.0, -1.0),
            vel: Vec3::zeros(),
            att: Rot::from_euler(Euler::new(0.1, 0.05, 1.0)),
            omega: Vec3::zeros(),
            rotor_speed: [0.0; 4],
        };
        let f = m.capture(Nanos(0), &truth).unwrap();
        let ideal = ideal_measured_attitude(&cam, truth.att, off.rotation);
        assert!((f.att.inverse() * ideal).angle() < 1e-12);
        // the template origin by hand, y = R_w·(p + R·t_off) + t_w (not through `to_mocap`: a `to_mocap` returning zero would pass a test whose expectation was computed with it), and
        // back into the true frame by `to_nav`
        let origin_nav = truth.pos + truth.att.apply(off.translation);
        let p_ideal = cam.rotation.apply(origin_nav) + cam.translation;
        assert!((f.pos - p_ideal).norm() < 1e-12, "{:?} vs {p_ideal:?}", f.pos);
        assert!((cam.to_nav(f.pos) - origin_nav).norm() < 1e-12);
    }

    /// An occlusion hides its marker over [from, to): the frame at `from` sees 3 markers, the one
    /// at `to` all 4 again; a second occlusion hides its own marker in its own window. Two markers hidden at once leave 2: no frame, but the frame number
    /// still advances (the receiver sees the gap).
    #[test]
    fn an_occlusion_hides_its_marker_from_its_start_until_before_its_end() {
        let ms =
            MarkerSet::displaced(builtin_pattern(0).to_vec(), Euler::from_degrees(0.0, 0.0, 0.0), &[Vec3::zeros(); 4]);
        let hide = |marker, from, to| Occlusion { marker, from: Nanos::from_millis(from), to: Nanos::from_millis(to) };
        let mut m = Mocap::new(
            ms,
            vec![hide(1, 100, 200), hide(2, 300, 310)],
            CameraError::none(),
            0.0,
            Stream::new(1, Component::MocapNoise, 0),
        );
        let truth = State {
            pos: Vec3::new(0.0, 0.0, -1.0),
            vel: Vec3::zeros(),
            att: Rot::identity(),
            omega: Vec3::zeros(),
            rotor_speed: [0.0; 4],
        };
        let seen =
            |m: &mut Mocap, ms: i64| m.capture(Nanos::from_millis(ms), &truth).map(|f| (f.seq, f.visible_markers));
        assert_eq!(seen(&mut m, 95), Some((0, 4)));
        assert_eq!(seen(&mut m, 100), Some((1, 3)));
        // the cameras' last view: all four markers, the hidden one flagged (a bug it catches: the
        // view as two empty slices)
        assert_eq!((m.last_observation().0.len(), m.last_observation().1), (4, &[true, false, true, true][..]));
        assert_eq!(seen(&mut m, 195), Some((2, 3)));
        assert_eq!(seen(&mut m, 200), Some((3, 4)));
        assert_eq!(seen(&mut m, 305), Some((4, 3)), "the second occlusion, of another marker");
        let mut two = Mocap::new(
            m.markers().clone(),
            vec![hide(1, 0, 10), hide(2, 0, 10)],
            CameraError::none(),
            0.0,
            Stream::new(1, Component::MocapNoise, 0),
        );
        assert_eq!(seen(&mut two, 5), None);
        assert_eq!(seen(&mut two, 10), Some((1, 4)));
    }
}
