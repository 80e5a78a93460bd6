//! Frames, typed so that mixing them does not compile.
//!
//! | frame        | axes                                   | who uses it                          |
//! |--------------|----------------------------------------|--------------------------------------|
//! | [`Nav`]      | North, East, Down, origin on the floor | physics (the truth)                  |
//! | [`Body`]     | x forward, y right, z down (FRD)       | physics, rotors, IMU, onboard loop   |
//! | [`MocapNav`] | the NED frame the Vicon system defines | mocap output, estimator, controller  |
//! | [`MocapBody`]| the frame the stored marker template defines | mocap output                   |
//!
//! `MocapNav` equals `Nav` unless the cameras moved (a camera-system error); `MocapBody` equals
//! `Body` unless the markers moved (the paper's problem). The controller never sees `Body`
//! directly: it sees `Rot<MocapBody, MocapNav>` and must go through an offset estimate
//! `Rot<Body, MocapBody>` to obtain the `Rot<Body, MocapNav>` it needs. Until calibration that
//! estimate is the identity, which is exactly the assumption that makes the vehicle circle.
//!
//! A [`Rot<A, B>`] maps coordinates of a vector expressed in frame `A` to coordinates in frame `B`.
//! The attitude of a vehicle is `Rot<Body, Nav>` (C_b^n); the paper's C_n^b is its inverse.
//!
//! ```
//! use flyarena::frames::{Body, Euler, Nav, Rot, Vec3};
//! let attitude: Rot<Body, Nav> = Rot::from_euler(Euler::from_degrees(0.0, 0.0, 90.0));
//! let forward = Vec3::<Body>::new(1.0, 0.0, 0.0);
//! let in_nav: Vec3<Nav> = attitude.apply(forward); // heading East
//! assert!((in_nav.y() - 1.0).abs() < 1e-12);
//! ```
//!
//! Mixing frames is a compile error:
//!
//! ```compile_fail
//! use flyarena::frames::{Body, Nav, Vec3};
//! let a = Vec3::<Body>::new(1.0, 0.0, 0.0);
//! let b = Vec3::<Nav>::new(1.0, 0.0, 0.0);
//! let _ = a + b; // Body + Nav: no such operation
//! ```
//!
//! ```compile_fail
//! use flyarena::frames::{Body, MocapBody, MocapNav, Rot, Vec3};
//! let measured: Rot<MocapBody, MocapNav> = Rot::identity();
//! let thrust_axis = Vec3::<Body>::new(0.0, 0.0, -1.0);
//! let _ = measured.apply(thrust_axis); // the mocap attitude does not accept true-body vectors
//! ```

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use serde::Serialize;
use std::fmt;
use std::marker::PhantomData;
use std::ops::{Add, AddAssign, Mul, Neg, Sub};

/// A coordinate frame marker.
pub trait Frame: Copy + fmt::Debug + 'static {
    /// The frame's name in messages (`body`, `nav`, ...).
    const NAME: &'static str;
}

macro_rules! frame {
    ($(#[$m:meta])* $name:ident, $label:literal) => {
        $(#[$m])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub struct $name;
        impl Frame for $name {
            const NAME: &'static str = $label;
        }
    };
}
frame!(
    /// True navigation frame: North-East-Down, origin on the arena floor.
    Nav,
    "nav"
);
frame!(
    /// True body frame: x forward, y right, z down, origin at the centre of mass.
    Body,
    "body"
);
frame!(
    /// The NED frame of the motion-capture system (differs from [`Nav`] by camera errors).
    MocapNav,
    "mocap_nav"
);
frame!(
    /// The body frame that the stored marker template defines (differs from [`Body`] when markers move).
    MocapBody,
    "mocap_body"
);

/// A 3-vector whose coordinates are expressed in frame `F` (SI units unless the name says otherwise).
#[derive(Clone, Copy, PartialEq)]
pub struct Vec3<F: Frame> {
    v: Vector3<f64>,
    _f: PhantomData<F>,
}

impl<F: Frame> fmt::Debug for Vec3<F> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}[{}, {}, {}]", F::NAME, self.v.x, self.v.y, self.v.z)
    }
}

impl<F: Frame> Default for Vec3<F> {
    fn default() -> Self {
        Self::zeros()
    }
}

impl<F: Frame> Serialize for Vec3<F> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        [self.v.x, self.v.y, self.v.z].serialize(s)
    }
}

impl<F: Frame> Vec3<F> {
    /// The vector with coordinates (x, y, z) in `F`.
    pub const fn new(x: f64, y: f64, z: f64) -> Self {
        Vec3 { v: Vector3::new(x, y, z), _f: PhantomData }
    }
    /// The zero vector.
    pub const fn zeros() -> Self {
        Self::new(0.0, 0.0, 0.0)
    }
    /// From coordinates `[x, y, z]` in `F`.
    pub fn from_array(a: [f64; 3]) -> Self {
        Self::new(a[0], a[1], a[2])
    }
    /// Wraps raw coordinates; the caller asserts they are expressed in `F`.
    pub fn from_raw(v: Vector3<f64>) -> Self {
        Vec3 { v, _f: PhantomData }
    }
    /// The coordinates, without the frame (for nalgebra).
    pub fn raw(&self) -> &Vector3<f64> {
        &self.v
    }
    /// The coordinates `[x, y, z]`.
    pub fn to_array(self) -> [f64; 3] {
        [self.v.x, self.v.y, self.v.z]
    }
    /// The first coordinate (north in a NED frame, forward in FRD).
    pub fn x(&self) -> f64 {
        self.v.x
    }
    /// The second coordinate (east in NED, right in FRD).
    pub fn y(&self) -> f64 {
        self.v.y
    }
    /// The third coordinate (down in both).
    pub fn z(&self) -> f64 {
        self.v.z
    }
    /// The Euclidean norm.
    pub fn norm(&self) -> f64 {
        self.v.norm()
    }
    /// Horizontal (x–y) norm: for NED frames, the distance over the floor.
    pub fn horizontal_norm(&self) -> f64 {
        self.v.x.hypot(self.v.y)
    }
    /// The dot product with a vector of the same frame.
    pub fn dot(&self, o: &Self) -> f64 {
        self.v.dot(&o.v)
    }
    /// The cross product with a vector of the same frame.
    pub fn cross(&self, o: &Self) -> Self {
        Self::from_raw(self.v.cross(&o.v))
    }
    /// Each coordinate times its factor (per-axis gains).
    pub fn component_mul(&self, k: &[f64; 3]) -> Self {
        Self::new(self.v.x * k[0], self.v.y * k[1], self.v.z * k[2])
    }
    /// Whether every coordinate is finite.
    pub fn is_finite(&self) -> bool {
        self.v.iter().all(|c| c.is_finite())
    }
    /// Reinterprets the coordinates in another frame. Only for frames known to coincide (e.g.
    /// `MocapNav` → `Nav` when the truth says the cameras are perfect); the name makes it greppable.
    pub fn assume_same_as<G: Frame>(self) -> Vec3<G> {
        Vec3::from_raw(self.v)
    }
}

impl<F: Frame> Add for Vec3<F> {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self::from_raw(self.v + o.v)
    }
}
impl<F: Frame> AddAssign for Vec3<F> {
    fn add_assign(&mut self, o: Self) {
        self.v += o.v;
    }
}
impl<F: Frame> Sub for Vec3<F> {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Self::from_raw(self.v - o.v)
    }
}
impl<F: Frame> Neg for Vec3<F> {
    type Output = Self;
    fn neg(self) -> Self {
        Self::from_raw(-self.v)
    }
}
impl<F: Frame> Mul<f64> for Vec3<F> {
    type Output = Self;
    fn mul(self, k: f64) -> Self {
        Self::from_raw(self.v * k)
    }
}

/// Roll φ, pitch θ, yaw ψ in radians, ZYX order (yaw first), as in the paper.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Euler {
    /// φ (rad), about the body x axis.
    pub roll: f64,
    /// θ (rad), about the once-turned y axis.
    pub pitch: f64,
    /// ψ (rad), about the navigation z axis (down).
    pub yaw: f64,
}

impl Euler {
    /// Level, heading north.
    pub const ZERO: Euler = Euler { roll: 0.0, pitch: 0.0, yaw: 0.0 };
    /// From φ, θ, ψ in radians.
    pub fn new(roll: f64, pitch: f64, yaw: f64) -> Self {
        Euler { roll, pitch, yaw }
    }
    /// Degrees are for the YAML/CLI edge only.
    pub fn from_degrees(roll: f64, pitch: f64, yaw: f64) -> Self {
        Euler::new(roll.to_radians(), pitch.to_radians(), yaw.to_radians())
    }
    /// `[φ, θ, ψ]` in degrees, for printing.
    pub fn to_degrees(self) -> [f64; 3] {
        [self.roll.to_degrees(), self.pitch.to_degrees(), self.yaw.to_degrees()]
    }
}

/// Wraps an angle to (−π, π].
pub fn wrap_pi(a: f64) -> f64 {
    let mut x = a % std::f64::consts::TAU;
    if x > std::f64::consts::PI {
        x -= std::f64::consts::TAU;
    } else if x <= -std::f64::consts::PI {
        x += std::f64::consts::TAU;
    }
    x
}

/// A rotation that maps coordinates in frame `A` to coordinates in frame `B`.
#[derive(Clone, Copy, PartialEq)]
pub struct Rot<A: Frame, B: Frame> {
    q: UnitQuaternion<f64>,
    _f: PhantomData<(A, B)>,
}

impl<A: Frame, B: Frame> fmt::Debug for Rot<A, B> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let e = self.euler().to_degrees();
        write!(f, "Rot<{}→{}>(rpy° {:.4}, {:.4}, {:.4})", A::NAME, B::NAME, e[0], e[1], e[2])
    }
}

impl<A: Frame, B: Frame> Rot<A, B> {
    /// The rotation that changes nothing (for frames that coincide).
    pub fn identity() -> Self {
        Self::from_quaternion(UnitQuaternion::identity())
    }
    /// From the unit quaternion that maps `A` coordinates to `B` coordinates.
    pub fn from_quaternion(q: UnitQuaternion<f64>) -> Self {
        Rot { q, _f: PhantomData }
    }
    /// From the rotation matrix whose columns are `A`'s axes expressed in `B`.
    pub fn from_matrix(m: &Matrix3<f64>) -> Self {
        Self::from_quaternion(UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*m)))
    }
    /// R = R_z(ψ)·R_y(θ)·R_x(φ): for an attitude `Rot<Body, Nav>` this is C_b^n of the paper.
    pub fn from_euler(e: Euler) -> Self {
        Self::from_quaternion(UnitQuaternion::from_euler_angles(e.roll, e.pitch, e.yaw))
    }
    /// ZYX Euler angles: φ = atan2(R₃₂, R₃₃), θ = −asin(R₃₁), ψ = atan2(R₂₁, R₁₁).
    pub fn euler(&self) -> Euler {
        let (roll, pitch, yaw) = self.q.euler_angles();
        Euler { roll, pitch, yaw }
    }
    /// The unit quaternion (`A` → `B`).
    pub fn quaternion(&self) -> &UnitQuaternion<f64> {
        &self.q
    }
    /// The rotation matrix, whose columns are `A`'s axes expressed in `B`.
    pub fn matrix(&self) -> Matrix3<f64> {
        *self.q.to_rotation_matrix().matrix()
    }
    /// The vector `v` of `A`, expressed in `B`.
    pub fn apply(&self, v: Vec3<A>) -> Vec3<B> {
        Vec3::from_raw(self.q.transform_vector(&v.v))
    }
    /// The rotation back, `B` → `A`.
    pub fn inverse(&self) -> Rot<B, A> {
        Rot::from_quaternion(self.q.inverse())
    }
    /// Rotation angle of this rotation (rad), i.e. its distance from the identity.
    pub fn angle(&self) -> f64 {
        self.q.angle()
    }
    /// Reinterprets the frames. Only for frames known to coincide; the name makes it greppable.
    pub fn assume_frames<C: Frame, D: Frame>(self) -> Rot<C, D> {
        Rot::from_quaternion(self.q)
    }
}

/// Rotations of a frame relative to itself at another time (attitude increments).
impl<F: Frame> Rot<F, F> {
    /// exp(θ): the rotation by |θ| about θ/|θ| (θ in rad).
    pub fn from_rotation_vector(theta: Vec3<F>) -> Self {
        Self::from_quaternion(UnitQuaternion::from_scaled_axis(theta.v))
    }
    /// log(R): axis times angle (rad), angle in [0, π].
    pub fn rotation_vector(&self) -> Vec3<F> {
        Vec3::from_raw(self.q.scaled_axis())
    }
}

/// Composition: `Rot<B, C> * Rot<A, B> = Rot<A, C>`.
impl<A: Frame, B: Frame, C: Frame> Mul<Rot<A, B>> for Rot<B, C> {
    type Output = Rot<A, C>;
    fn mul(self, rhs: Rot<A, B>) -> Rot<A, C> {
        Rot::from_quaternion(self.q * rhs.q)
    }
}

/// T_w⁻¹ of the paper's (4): maps Euler-angle rates [φ̇ θ̇ ψ̇] (Z-Y-X angles) to body rates
/// [p q r] (rad/s, body frame): [[1, 0, −sin θ], [0, cos φ, cos θ·sin φ], [0, −sin φ, cos θ·cos φ]].
/// Used by the ground controller (3) and by the onboard attitude loop.
pub fn t_w_inv(roll: f64, pitch: f64) -> Matrix3<f64> {
    t_w_inv_sc(roll.sin_cos(), pitch.sin_cos())
}

/// [`t_w_inv`] from (sin φ, cos φ) and (sin θ, cos θ).
pub(crate) fn t_w_inv_sc((sf, cf): (f64, f64), (st, ct): (f64, f64)) -> Matrix3<f64> {
    Matrix3::new(1.0, 0.0, -st, 0.0, cf, ct * sf, 0.0, -sf, ct * cf)
}

/// The paper's direction cosine matrix C_n^b (Sec. III.A) written out element by element.
/// Kept separate from [`Rot`] on purpose: the tests check the two against each other.
pub fn paper_c_n_b(e: Euler) -> Matrix3<f64> {
    let (sf, cf) = e.roll.sin_cos();
    let (st, ct) = e.pitch.sin_cos();
    let (sp, cp) = e.yaw.sin_cos();
    Matrix3::new(
        ct * cp,
        ct * sp,
        -st,
        sf * st * cp - cf * sp,
        sf * st * sp + cf * cp,
        sf * ct,
        cf * st * cp + sf * sp,
        cf * st * sp - sf * cp,
        cf * ct,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn attitude_inverse_is_the_papers_c_n_b() {
        for &(r, p, y) in &[(0.1, -0.2, 0.3), (-1.0, 0.5, 2.9), (0.0, 1.2, -3.0)] {
            let e = Euler::new(r, p, y);
            let c_b_n: Rot<Body, Nav> = Rot::from_euler(e);
            let c_n_b = c_b_n.inverse().matrix();
            assert!((c_n_b - paper_c_n_b(e)).abs().max() < 1e-14);
            let back = c_b_n.euler();
            assert!((back.roll - r).abs() < 1e-12 && (back.pitch - p).abs() < 1e-12);
            assert!((back.yaw - y).abs() < 1e-12);
        }
    }

    #[test]
    fn wrap_pi_keeps_angles_in_range() {
        assert!((wrap_pi(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
        assert!((wrap_pi(-0.5) + 0.5).abs() < 1e-15);
        assert!((wrap_pi(7.0) - (7.0 - std::f64::consts::TAU)).abs() < 1e-12);
    }
}
