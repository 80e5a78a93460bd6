//! Time-stamped topics joined onto the IMU's clock: the rows that a ROS 2 bag ([`super::ros2`])
//! or a PX4 log ([`super::ulog`]) becomes before it goes through the CSV reader
//! ([`super::mapping`]), so that every route gives one report.
//!
//! One row per IMU message, at its stamp: the pose is interpolated between the two poses around
//! the row (position linearly, attitude by normalised linear interpolation on the shorter arc),
//! or taken as is when a pose has the row's own stamp; a row between two poses further apart
//! than 1.5 median pose intervals (a dropped frame) is a frame in which the vehicle was not seen
//! (empty pose cells). Motors and battery hold their last value; rows before the first of them
//! are left out (said in the repairs). Time is seconds from the first IMU stamp, exact in integer
//! nanoseconds. Columns: `t,px,py,pz,qx,qy,qz,qw,gx,gy,gz,ax,ay,az[,m1..mN][,vbat]`.

use super::read_note::ReadNote;
use std::fmt::Write as _;

/// One decoded stream: stamps (ns) and values.
#[derive(Debug)]
pub(in crate::identify) struct Stream<const N: usize> {
    pub(in crate::identify) t: Vec<i128>,
    pub(in crate::identify) v: Vec<[f64; N]>,
}

impl<const N: usize> Stream<N> {
    pub(in crate::identify) fn new() -> Self {
        Stream { t: Vec::new(), v: Vec::new() }
    }
    /// Appends a message's stamp (ns) and values; a value that is not finite is an error.
    pub(in crate::identify) fn push(&mut self, t: i128, v: [f64; N]) -> Result<(), &'static str> {
        if !v.iter().all(|x| x.is_finite()) {
            return Err("a value is not finite");
        }
        self.t.push(t);
        self.v.push(v);
        Ok(())
    }
    /// Sorted by stamp (stable: messages with one stamp keep their order).
    pub(in crate::identify) fn sorted(mut self) -> Self {
        let mut idx: Vec<usize> = (0..self.t.len()).collect();
        idx.sort_by_key(|&i| self.t[i]);
        self.t = idx.iter().map(|&i| self.t[i]).collect();
        self.v = idx.iter().map(|&i| self.v[i]).collect();
        self
    }
}

/// A log's streams, each on its own clock, before the join: the poses, the IMU, the motors and
/// the battery, decoded (stamps in ns). Built by the readers ([`crate::identify::injected::streams`]
/// reads an ASL folder); joined onto the IMU's clock by `identify`.
pub struct Streams {
    pub(in crate::identify) pose: Stream<7>,
    pub(in crate::identify) imu: Stream<6>,
    pub(in crate::identify) motors: Stream<8>,
    /// The number of motor values per message, the same in every message.
    pub(in crate::identify) n_motors: Option<usize>,
    pub(in crate::identify) battery: Stream<1>,
}

impl Streams {
    /// One CSV row per IMU message: the pose at its stamp (interpolated, or empty across a
    /// dropped frame), the last motor and battery values at or before it. Returns the CSV and the
    /// repairs made.
    pub(in crate::identify) fn join(&self) -> (String, Vec<ReadNote>) {
        self.join_shifted(0)
    }

    /// [`Streams::join`] with the pose the mocap stamped t + `shift_ns` joined to the IMU row
    /// stamped t (the mocap's clock `shift_ns` ahead of the IMU's, or its poses that late).
    pub(in crate::identify) fn join_shifted(&self, shift_ns: i128) -> (String, Vec<ReadNote>) {
        let (has_motors, has_battery) = (self.n_motors.is_some(), !self.battery.t.is_empty());
        let shifted;
        let pose = if shift_ns == 0 {
            &self.pose
        } else {
            shifted = Stream { t: self.pose.t.iter().map(|t| t - shift_ns).collect(), v: self.pose.v.clone() };
            &shifted
        };
        let (imu, motors, battery) = (&self.imu, &self.motors, &self.battery);
        // two poses further apart than 1.5 median intervals have a dropped frame between them:
        // nothing is interpolated across it
        let reach = {
            let mut d: Vec<i128> = pose.t.windows(2).map(|w| w[1] - w[0]).filter(|d| *d > 0).collect();
            d.sort_unstable();
            d.get(d.len() / 2).map_or(0, |m| 3 * m / 2)
        };
        let mut csv = String::from("t,px,py,pz,qx,qy,qz,qw,gx,gy,gz,ax,ay,az");
        for i in 0..self.n_motors.unwrap_or(0) {
            let _ = write!(csv, ",m{}", i + 1);
        }
        if has_battery {
            csv.push_str(",vbat");
        }
        csv.push('\n');
        let mut repairs = Vec::new();
        let (mut skipped, mut p, mut mo, mut ba) = (0usize, 0usize, 0usize, 0usize);
        let t0 = imu.t[0];
        for (t, v) in imu.t.iter().zip(&imu.v) {
            // the last motor and battery values at or before t
            while mo < motors.t.len() && motors.t[mo] <= *t {
                mo += 1;
            }
            while ba < battery.t.len() && battery.t[ba] <= *t {
                ba += 1;
            }
            if (has_motors && mo == 0) || (has_battery && ba == 0) {
                skipped += 1;
                continue;
            }
            // the first pose after t (p), and the one before
            while p < pose.t.len() && pose.t[p] <= *t {
                p += 1;
            }
            let _ = write!(csv, "{}", (*t - t0) as f64 * 1e-9);
            if p > 0 && pose.t[p - 1] == *t {
                for x in &pose.v[p - 1] {
                    let _ = write!(csv, ",{x}");
                }
            } else if p > 0 && p < pose.t.len() && pose.t[p] - pose.t[p - 1] <= reach {
                let f = (*t - pose.t[p - 1]) as f64 / (pose.t[p] - pose.t[p - 1]) as f64;
                for x in interpolate_pose(&pose.v[p - 1], &pose.v[p], f) {
                    let _ = write!(csv, ",{x}");
                }
            } else {
                csv.push_str(",,,,,,,");
            }
            for x in v {
                let _ = write!(csv, ",{x}");
            }
            if let Some(n) = self.n_motors {
                for x in &motors.v[mo - 1][..n] {
                    let _ = write!(csv, ",{x}");
                }
            }
            if has_battery {
                let _ = write!(csv, ",{}", battery.v[ba - 1][0]);
            }
            csv.push('\n');
        }
        if skipped > 0 {
            repairs.push(ReadNote::ImuBeforeOthers { count: skipped });
        }
        (csv, repairs)
    }
}

/// The pose a fraction `f` of the way from `a` to `b` (position, quaternion x, y, z, w):
/// position linear, attitude by nlerp on the shorter arc.
fn interpolate_pose(a: &[f64; 7], b: &[f64; 7], f: f64) -> [f64; 7] {
    let mut out = [0.0; 7];
    for k in 0..3 {
        out[k] = a[k] * (1.0 - f) + b[k] * f;
    }
    let sign = if (3..7).map(|k| a[k] * b[k]).sum::<f64>() < 0.0 { -1.0 } else { 1.0 };
    for k in 3..7 {
        out[k] = a[k] * (1.0 - f) + sign * b[k] * f;
    }
    let norm = out[3..].iter().map(|x| x * x).sum::<f64>().sqrt();
    for x in &mut out[3..] {
        *x /= norm;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pose between two samples whose quaternions lie on opposite hemispheres (q and −q are
    /// one attitude): position halfway, attitude halfway along the shorter arc. From the identity
    /// to −(90° about z), the shorter arc's middle is 45° about z, (0, 0, sin 22.5°, cos 22.5°);
    /// the longer arc would give 135° about −z.
    #[test]
    fn a_pose_is_interpolated_on_the_shorter_arc() {
        let h = std::f64::consts::FRAC_PI_4; // half of 90°
        let a = [0.0, 2.0, -1.0, 0.0, 0.0, 0.0, 1.0];
        let b = [1.0, 4.0, -1.0, 0.0, 0.0, -h.sin(), -h.cos()];
        let m = interpolate_pose(&a, &b, 0.5);
        let want = [0.5, 3.0, -1.0, 0.0, 0.0, (h / 2.0).sin(), (h / 2.0).cos()];
        for k in 0..7 {
            assert!((m[k] - want[k]).abs() < 1e-12, "{m:?}");
        }
        // a quarter of the way, nlerp (not slerp): 2·atan2(f·sin 45°, (1 − f) + f·cos 45°) = 21.6°
        let q = interpolate_pose(&a, &b, 0.25);
        let want = 2.0 * (0.25 * h.sin()).atan2(0.75 + 0.25 * h.cos());
        assert!((2.0 * q[5].atan2(q[6]) - want).abs() < 1e-12 && q[3] == 0.0 && q[4] == 0.0, "{q:?}");
    }

    /// Motors and battery hold their last value; an IMU row before the first of either is left
    /// out and counted in the repairs. IMU every 5 ms from 0, poses every 10 ms, battery from
    /// 0 ms, the motors from 10 ms: the rows at 0 and 5 ms go, the row at 15 ms has the motors
    /// of 10 ms and the pose halfway between 10 and 20 ms, and time still counts from the first
    /// IMU stamp. With the motors from 0 ms nothing goes and no repair is said.
    #[test]
    fn imu_rows_before_the_first_motor_or_battery_message_are_left_out_and_said() {
        let ms = 1_000_000i128;
        let stream = |stamps: &[i128], f: &dyn Fn(usize) -> f64| {
            let mut s = Stream::<7>::new();
            for (i, t) in stamps.iter().enumerate() {
                s.push(t * ms, [f(i), 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]).unwrap();
            }
            s
        };
        let streams = |motors_from: i128| {
            let pose = stream(&[0, 10, 20, 30], &|i| i as f64);
            let imu = stream(&[0, 5, 10, 15, 20, 25], &|_| 0.0);
            let motors = stream(&[motors_from, 20], &|i| 100.0 + i as f64);
            let battery = stream(&[0], &|_| 11.1);
            let six =
                |s: Stream<7>| Stream { t: s.t, v: s.v.iter().map(|v| [v[0], v[1], v[2], v[3], v[4], v[5]]).collect() };
            let eight = |s: Stream<7>| Stream { t: s.t, v: s.v.iter().map(|v| [v[0]; 8]).collect() };
            let one = |s: Stream<7>| Stream { t: s.t, v: s.v.iter().map(|v| [v[0]]).collect() };
            Streams { pose, imu: six(imu), motors: eight(motors), n_motors: Some(1), battery: one(battery) }
        };
        let (csv, repairs) = streams(10).join();
        assert_eq!(repairs, [ReadNote::ImuBeforeOthers { count: 2 }]);
        let rows: Vec<&str> = csv.lines().collect();
        assert_eq!(rows[0], "t,px,py,pz,qx,qy,qz,qw,gx,gy,gz,ax,ay,az,m1,vbat");
        assert_eq!(rows.len(), 1 + 4, "{csv}");
        assert!(rows[1].starts_with("0.01,1,0,0,0,0,0,1,"), "{}", rows[1]);
        let f: Vec<&str> = rows[2].split(',').collect();
        assert!((f[0].parse::<f64>().unwrap() - 0.015).abs() < 1e-12 && f[1] == "1.5", "{}", rows[2]);
        assert!(rows[2].ends_with(",100,11.1"), "{}", rows[2]);
        assert!(rows[3].ends_with(",101,11.1"), "{}", rows[3]);
        let (csv, repairs) = streams(0).join();
        assert!(repairs.is_empty(), "{repairs:?}");
        assert_eq!(csv.lines().count(), 1 + 6);
    }
}
