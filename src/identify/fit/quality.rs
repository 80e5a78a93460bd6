//! The data-quality gate: samples that no flight can produce are cut out before any fit.
//!
//! `identify` fits small effects (a tenth of a degree, a few milliseconds, 0.1 m/s²) by least
//! squares. A stretch of log in which a sensor saturates, hangs or returns garbage, or in which
//! the mocap swaps markers or freezes, would dominate every sum of squares and come out as a
//! confident number. The gate looks, sample by sample, for what no effect in the candidate
//! library can produce, and cuts it out with a margin before anything is fitted:
//!
//! | check | channel | flagged when |
//! |---|---|---|
//! | full scale | accel, gyro | any axis at ≥ 98 % of the preset's IMU full scale ([`crate::vehicle::params::ImuRange`]) |
//! | IMU against mocap | accel | ‖a_imu − f̂‖ > `accel_disagree_m_s2` (4 g); f̂ = Rᵀ(p̈ − g·e_D) from the smoothed mocap |
//! | IMU against mocap | gyro | ‖ω_imu − ω̂‖ > `gyro_disagree_rad_s` (300 °/s); ω̂ from neighbouring mocap attitudes, smoothed |
//! | jump | mocap | ‖p_k − p_{k−1}‖ > `max_speed_m_s`·Δt, or ∠(q_{k−1}, q_k) > 1.5·(gyro full scale)·Δt + 2° |
//! | stuck | accel, gyro | the same reading, all three axes bit for bit, for ≥ max(5, 50 ms) samples, all more than `min_height_m` above the floor (in the air an IMU always shakes by more than its resolution) |
//! | stuck | mocap | the same pose, bit for bit, for ≥ max(5, 50 ms) seen frames while the gyro turns (∫‖ω‖dt > 2°) |
//!
//! Frames: f̂ and ω̂ are in the mocap body frame, a_imu and ω_imu in the IMU's body frame (FRD),
//! compared without any correction: the largest misalignment the library fits (degrees) moves
//! them by a fraction of a g or of a rad/s, far inside the bounds.
//!
//! **Why these bounds.** The largest disagreement between IMU and mocap that a candidate effect
//! explains is of order 1 g and 100 °/s (a 10° body offset at 3 g of specific force is 0.5 g; an
//! accelerometer bias of 0.5 g; a 20 ms mocap delay at 50 rad/s² is 1 rad/s). A 4 g or 300 °/s
//! disagreement is not a model error but a measurement that is not one. On the ten NanoBench
//! flights (Crazyflie 2.1, whose IMU reads 5–7 g of vibration and impact at touchdown) no
//! airborne sample is flagged; touchdowns are flagged and reported as contact with the floor.
//!
//! **What is cut.** Each flagged sample is widened by `margin_s` on both sides, flagged samples
//! closer than `merge_gap_s` are joined into one stretch, and the rows of every stretch are taken
//! out of the log's segments (so the derivative filters never reach across them). The report
//! lists every stretch with its time range (seconds from the log's first sample), channel and
//! findings ([`Finding`]). A stretch whose flagged samples all lie within `min_height_m` of the floor is contact
//! (a touchdown or a bump), not corruption: it is cut and listed the same way but does not make
//! the log unusable.

use super::design::{body_rates, gaussian_kernel, glitches, second_difference, smooth_vec3};
use crate::frames::{Frame, Vec3};
use crate::identify::input::series::{Corrections, Series, correct, floor_z, raw_rots, raw_vecs};
use nalgebra::Vector3;

/// The gate's bounds (see the module documentation for why they are where they are).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct QualityOptions {
    /// A reading at or beyond this fraction of the IMU's full scale is saturated.
    pub full_scale_fraction: f64,
    /// Largest plausible ‖a_imu − f̂‖ (m/s²).
    pub accel_disagree_m_s2: f64,
    /// Largest plausible ‖ω_imu − ω̂‖ (rad/s).
    pub gyro_disagree_rad_s: f64,
    /// No vehicle moves faster (m/s).
    pub max_speed_m_s: f64,
    /// An IMU reading repeated bit for bit this long (s; at least 5 samples) in the air, or a
    /// mocap pose while the gyro turns, is stuck.
    pub stuck_s: f64,
    /// Widening of each flagged sample (s).
    pub margin_s: f64,
    /// Flagged samples closer than this are one stretch (s).
    pub merge_gap_s: f64,
}

impl Default for QualityOptions {
    fn default() -> Self {
        QualityOptions {
            full_scale_fraction: 0.98,
            accel_disagree_m_s2: 4.0 * crate::vehicle::params::GRAVITY,
            gyro_disagree_rad_s: 300f64.to_radians(),
            max_speed_m_s: 30.0,
            stuck_s: 0.05,
            margin_s: 0.2,
            merge_gap_s: 1.0,
        }
    }
}

/// Which measurement a stretch is cut for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum QualityChannel {
    /// The accelerometer.
    Accel,
    /// The gyro.
    Gyro,
    /// The mocap pose.
    Mocap,
}

impl QualityChannel {
    /// The name used in reports and JSON.
    pub fn name(self) -> &'static str {
        match self {
            QualityChannel::Accel => "accel",
            QualityChannel::Gyro => "gyro",
            QualityChannel::Mocap => "mocap",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Kind {
    FullScale,
    Disagrees,
    Jump,
    Stuck,
}

/// One stretch of the log that was cut out.
///
/// Its JSON holds the findings as `reason`, their sentences joined by `; `.
#[derive(Clone, Debug, PartialEq)]
pub struct Cut {
    /// The measurement cut.
    pub channel: QualityChannel,
    /// Seconds from the log's first sample (the margin included).
    pub from_s: f64,
    /// End of the stretch, seconds from the log's first sample (the margin included).
    pub to_s: f64,
    /// Flagged samples inside the stretch.
    pub flagged: usize,
    /// Every flagged sample lies within `min_height_m` of the floor: contact, not corruption.
    pub at_floor: bool,
    /// What was found, one [`Finding`] per kind of defect, each with its worst value and the
    /// bound; `Display` gives the sentence.
    pub findings: Vec<Finding>,
}

/// One kind of defect found in a stretch: how many samples show it, the worst of them and the
/// bound they pass (SI units, radians inside; the sentence gives degrees).
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum Finding {
    /// Accelerometer samples at ≥ `full_scale_fraction` of the preset's full scale.
    AccelFullScale {
        /// Samples flagged.
        count: usize,
        /// The largest axis reading (m/s²).
        worst_m_s2: f64,
        /// The preset's full scale (m/s²).
        range_m_s2: f64,
    },
    /// Gyro samples at ≥ `full_scale_fraction` of the preset's full scale.
    GyroFullScale {
        /// Samples flagged.
        count: usize,
        /// The largest axis reading (rad/s).
        worst_rad_s: f64,
        /// The preset's full scale (rad/s).
        range_rad_s: f64,
    },
    /// Samples where ‖a_imu − f̂‖ passes `accel_disagree_m_s2`.
    AccelDisagrees {
        /// Samples flagged.
        count: usize,
        /// The largest disagreement (m/s²).
        worst_m_s2: f64,
        /// The bound (m/s²).
        bound_m_s2: f64,
    },
    /// Samples where ‖ω_imu − ω̂‖ passes `gyro_disagree_rad_s`.
    GyroDisagrees {
        /// Samples flagged.
        count: usize,
        /// The largest disagreement (rad/s).
        worst_rad_s: f64,
        /// The bound (rad/s).
        bound_rad_s: f64,
    },
    /// Mocap steps no vehicle makes.
    MocapJump {
        /// Samples flagged.
        count: usize,
        /// The largest step as a multiple of the largest possible one.
        worst_ratio: f64,
    },
    /// A mocap pose repeated bit for bit while the gyro turns.
    MocapFrozen {
        /// Samples flagged.
        count: usize,
        /// The largest angle the gyro turned through meanwhile (rad).
        worst_turn_rad: f64,
    },
    /// An IMU reading repeated bit for bit in the air.
    ImuStuck {
        /// Samples flagged.
        count: usize,
        /// The accelerometer or the gyro.
        channel: QualityChannel,
        /// The longest stretch of one value (s).
        worst_s: f64,
    },
}

/// What the gate did to one log.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct DataQuality {
    /// The stretches cut, in time order.
    pub cuts: Vec<Cut>,
    /// Rows taken out of the log (the union of the stretches).
    pub rows_cut: usize,
    /// Rows in the log.
    pub rows: usize,
}

impl DataQuality {
    /// Stretches that are not contact with the floor.
    pub fn corrupted(&self) -> impl Iterator<Item = &Cut> {
        self.cuts.iter().filter(|c| !c.at_floor)
    }
    /// One line per stretch, for messages.
    pub(crate) fn describe(&self) -> Vec<String> {
        self.cuts.iter().map(|c| c.to_string()).collect()
    }
}

struct Flag {
    row: usize,
    channel: QualityChannel,
    kind: Kind,
    value: f64,
}

/// Flags the samples no flight can produce and returns the log with them cut out of its
/// segments, and what was cut. `smoothing_s` is the σ of the mocap smoothing (the same as the
/// design's), `min_height_m` the height under which a flag counts as contact with the floor.
/// `start` is the global start's corrections ([`crate::identify::start::Start::corrections`]): the IMU
/// is compared with the mocap as they turn and shift it (a half-turn of the IMU makes every
/// sample "disagree" until it is taken out); the identity compares them as logged.
pub fn gate(
    s: &Series,
    o: &QualityOptions,
    smoothing_s: f64,
    min_height_m: f64,
    start: &Corrections,
) -> (Series, DataQuality) {
    let floor = floor_z(s, &s.pos_mocap_nav.iter().map(|p| p.z()).collect::<Vec<f64>>());
    let flags = flag(s, o, smoothing_s, min_height_m, floor, start);
    let n = s.len();
    let mut quality = DataQuality { cuts: Vec::new(), rows_cut: 0, rows: n };
    if flags.is_empty() {
        return (s.clone(), quality);
    }
    let t0 = s.t_s[0];
    let near_floor = |i: usize| floor.is_some_and(|f| f - s.pos_mocap_nav[i].z() < min_height_m);
    let mut cut_row = vec![false; n];
    for ch in [QualityChannel::Accel, QualityChannel::Gyro, QualityChannel::Mocap] {
        let mine: Vec<&Flag> = flags.iter().filter(|f| f.channel == ch).collect();
        let mut k = 0;
        while k < mine.len() {
            // one stretch: flagged samples no further apart than merge_gap_s
            let mut end = k;
            while end + 1 < mine.len() && s.t_s[mine[end + 1].row] - s.t_s[mine[end].row] <= o.merge_gap_s {
                end += 1;
            }
            let group = &mine[k..=end];
            let (from, to) = (s.t_s[group[0].row] - o.margin_s, s.t_s[group[group.len() - 1].row] + o.margin_s);
            for i in 0..n {
                if s.t_s[i] >= from && s.t_s[i] <= to {
                    cut_row[i] = true;
                }
            }
            quality.cuts.push(Cut {
                channel: ch,
                from_s: (from - t0).max(0.0),
                to_s: (to - t0).min(s.t_s[n - 1] - t0),
                flagged: group.len(),
                at_floor: group.iter().all(|f| near_floor(f.row)),
                findings: findings(group, s, o),
            });
            k = end + 1;
        }
    }
    quality.cuts.sort_by(|a, b| a.from_s.total_cmp(&b.from_s).then(a.channel.cmp(&b.channel)));
    quality.rows_cut = cut_row.iter().filter(|c| **c).count();
    let mut out = s.clone();
    out.segments = Vec::new();
    for &(a, b) in &s.segments {
        let mut start = None;
        for i in a..=b {
            let keep = i < b && !cut_row[i];
            match (keep, start) {
                (true, None) => start = Some(i),
                (false, Some(st)) => {
                    if i - st >= 2 {
                        out.segments.push((st, i));
                    }
                    start = None;
                }
                _ => {}
            }
        }
    }
    (out, quality)
}

/// What a stretch's flags found, one [`Finding`] per kind, in the order of [`Kind`].
fn findings(group: &[&Flag], s: &Series, o: &QualityOptions) -> Vec<Finding> {
    let r = &s.model.imu_range;
    let mut found = Vec::new();
    for kind in [Kind::FullScale, Kind::Disagrees, Kind::Jump, Kind::Stuck] {
        let of: Vec<&&Flag> = group.iter().filter(|f| f.kind == kind).collect();
        if of.is_empty() {
            continue;
        }
        let worst = of.iter().map(|f| f.value).fold(0.0, f64::max);
        let count = of.len();
        let ch = of[0].channel;
        found.push(match (kind, ch) {
            (Kind::FullScale, QualityChannel::Accel) => {
                Finding::AccelFullScale { count, worst_m_s2: worst, range_m_s2: r.accel_m_s2 }
            }
            (Kind::FullScale, _) => Finding::GyroFullScale { count, worst_rad_s: worst, range_rad_s: r.gyro_rad_s },
            (Kind::Disagrees, QualityChannel::Accel) => {
                Finding::AccelDisagrees { count, worst_m_s2: worst, bound_m_s2: o.accel_disagree_m_s2 }
            }
            (Kind::Disagrees, _) => {
                Finding::GyroDisagrees { count, worst_rad_s: worst, bound_rad_s: o.gyro_disagree_rad_s }
            }
            (Kind::Jump, _) => Finding::MocapJump { count, worst_ratio: worst },
            (Kind::Stuck, QualityChannel::Mocap) => Finding::MocapFrozen { count, worst_turn_rad: worst },
            (Kind::Stuck, _) => Finding::ImuStuck { count, channel: ch, worst_s: worst },
        });
    }
    found
}

/// The flagged samples, in row order per channel.
/// `floor` is the log's floor (NED z, m), for telling the air from the ground.
fn flag(
    s: &Series,
    o: &QualityOptions,
    smoothing_s: f64,
    min_height_m: f64,
    floor: Option<f64>,
    start: &Corrections,
) -> Vec<Flag> {
    let mut flags = Vec::new();
    if s.len() < 3 {
        return flags;
    }
    flag_full_scale(s, o, &mut flags);
    let jump = flag_jumps(s, o, &mut flags);
    flag_disagreements(s, o, smoothing_s, &jump, start, &mut flags);
    flag_stuck(s, o, min_height_m, floor, &mut flags);
    flags.sort_by_key(|f| (f.channel, f.row));
    flags
}

/// IMU samples at or beyond `full_scale_fraction` of the sensor's range (saturated).
fn flag_full_scale(s: &Series, o: &QualityOptions, flags: &mut Vec<Flag>) {
    let r = &s.model.imu_range;
    for i in 0..s.len() {
        let a = s.accel_body[i].raw().amax();
        if a >= o.full_scale_fraction * r.accel_m_s2 {
            flags.push(Flag { row: i, channel: QualityChannel::Accel, kind: Kind::FullScale, value: a });
        }
        let w = s.gyro_body[i].raw().amax();
        if w >= o.full_scale_fraction * r.gyro_rad_s {
            flags.push(Flag { row: i, channel: QualityChannel::Gyro, kind: Kind::FullScale, value: w });
        }
    }
}

/// Mocap jumps between consecutive seen frames of a segment: a step faster than `max_speed_m_s`
/// or a turn faster than 1.5 × the gyro's range (+2°). Returns the rows that jumped.
fn flag_jumps(s: &Series, o: &QualityOptions, flags: &mut Vec<Flag>) -> Vec<bool> {
    let r = &s.model.imu_range;
    let max_turn = |dt: f64| 1.5 * r.gyro_rad_s * dt + 2f64.to_radians();
    let mut jump = vec![false; s.len()];
    for &(a, b) in &s.segments {
        for i in a + 1..b {
            if !(s.mocap_ok[i] && s.mocap_ok[i - 1]) {
                continue;
            }
            let dti = s.t_s[i] - s.t_s[i - 1];
            let step = (s.pos_mocap_nav[i] - s.pos_mocap_nav[i - 1]).norm() / (o.max_speed_m_s * dti);
            let turn = s.att_mocap[i].quaternion().angle_to(s.att_mocap[i - 1].quaternion()) / max_turn(dti);
            let worst = step.max(turn);
            if worst > 1.0 {
                jump[i] = true;
                flags.push(Flag { row: i, channel: QualityChannel::Mocap, kind: Kind::Jump, value: worst });
            }
        }
    }
    jump
}

/// The IMU against the smoothed mocap (f̂ = Rᵀ(p̈ − g·e_D), the mocap body rates), where every
/// pose in the filter's reach is seen, clean (no glitch, no jump) and inside the segment. The
/// mocap is read through the `start` corrections (the identity: as logged).
fn flag_disagreements(
    s: &Series,
    o: &QualityOptions,
    smoothing_s: f64,
    jump: &[bool],
    start: &Corrections,
    flags: &mut Vec<Flag>,
) {
    let (n, dt, g) = (s.len(), s.dt(), s.model.gravity_m_s2);
    let kernel = gaussian_kernel(smoothing_s / dt);
    let reach = kernel.len() / 2 + 2;
    let mut clean: Vec<bool> = (0..n).map(|i| s.mocap_ok[i] && !jump[i]).collect();
    let shift = (start.mocap_delay_s / dt).round() as isize;
    for gl in glitches(s) {
        let k = gl as isize - shift;
        if k >= 0 && (k as usize) < n {
            clean[k as usize] = false;
        }
    }
    // the mocap as the start turns and shifts it (bit for bit the log's own at the identity)
    let (pos, att) = if *start == Corrections::default() {
        (raw_vecs(&s.pos_mocap_nav), raw_rots(&s.att_mocap))
    } else {
        let c = correct(s, start);
        for (k, ok) in c.ok.iter().enumerate() {
            clean[k] &= *ok;
        }
        (raw_vecs(&c.pos_nav), raw_rots(&c.att_body))
    };
    let mut usable = vec![false; n];
    for &(a, b) in &s.segments {
        if b - a <= 2 * reach {
            continue;
        }
        // running count of unclean poses in the window
        let mut bad = (a..a + 2 * reach + 1).filter(|&k| !clean[k]).count();
        for i in a + reach..b - reach {
            if i > a + reach {
                bad += usize::from(!clean[i + reach]);
                bad -= usize::from(!clean[i - reach - 1]);
            }
            usable[i] = bad == 0;
        }
    }
    let pos_s = smooth_vec3(&pos, &s.segments, &kernel);
    let omega_s = smooth_vec3(&body_rates(&att, &s.t_s, &s.segments), &s.segments, &kernel);
    for i in 0..n {
        if !usable[i] {
            continue;
        }
        let acc_nav = second_difference(&pos_s, &s.t_s, i);
        let f_hat = att[i].inverse_transform_vector(&(acc_nav - Vector3::new(0.0, 0.0, g)));
        let da = (s.accel_body[i].raw() - f_hat).norm();
        if da > o.accel_disagree_m_s2 {
            flags.push(Flag { row: i, channel: QualityChannel::Accel, kind: Kind::Disagrees, value: da });
        }
        let dw = (s.gyro_body[i].raw() - omega_s[i]).norm();
        if dw > o.gyro_disagree_rad_s {
            flags.push(Flag { row: i, channel: QualityChannel::Gyro, kind: Kind::Disagrees, value: dw });
        }
    }
}

/// Stuck readings: runs of bit-identical IMU samples in the air, and a frozen mocap pose while
/// the gyro turns by more than 2°, each at least `stuck_s` (and 5 samples) long.
fn flag_stuck(s: &Series, o: &QualityOptions, min_height_m: f64, floor: Option<f64>, flags: &mut Vec<Flag>) {
    let dt = s.dt();
    let min_run = ((o.stuck_s / dt).round() as usize).max(5);
    fn same3<F: Frame>(a: &Vec3<F>, b: &Vec3<F>) -> bool {
        a.to_array().map(f64::to_bits) == b.to_array().map(f64::to_bits)
    }
    // an airborne IMU always shakes by more than its resolution (rotor vibration, noise): a
    // reading repeated bit for bit in the air is a sensor or logger that hangs. On the floor
    // a noise-free (simulated) IMU may legitimately repeat itself.
    let airborne = |i: usize| floor.is_none_or(|f| f - s.pos_mocap_nav[i].z() > min_height_m);
    for (ch, x) in [(QualityChannel::Accel, &s.accel_body), (QualityChannel::Gyro, &s.gyro_body)] {
        for (a, b) in runs(&s.segments, |i| same3(&x[i], &x[i - 1])) {
            if b - a >= min_run && (a..b).all(airborne) {
                for row in a..b {
                    flags.push(Flag { row, channel: ch, kind: Kind::Stuck, value: (s.t_s[b - 1] - s.t_s[a]) });
                }
            }
        }
    }
    let frozen = |i: usize| {
        s.mocap_ok[i]
            && s.mocap_ok[i - 1]
            && same3(&s.pos_mocap_nav[i], &s.pos_mocap_nav[i - 1])
            && s.att_mocap[i].quaternion().coords == s.att_mocap[i - 1].quaternion().coords
    };
    for (a, b) in runs(&s.segments, frozen) {
        if b - a < min_run {
            continue;
        }
        let turned: f64 = (a + 1..b).map(|k| s.gyro_body[k].norm() * (s.t_s[k] - s.t_s[k - 1])).sum();
        if turned > 2f64.to_radians() {
            for row in a..b {
                flags.push(Flag { row, channel: QualityChannel::Mocap, kind: Kind::Stuck, value: turned });
            }
        }
    }
}

/// Maximal runs [a, b) of rows inside a segment in which every row after the first satisfies
/// `same(i)` (row i repeats row i − 1).
fn runs(segments: &[(usize, usize)], same: impl Fn(usize) -> bool) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for &(a, b) in segments {
        let mut start = a;
        for i in a + 1..=b {
            if i == b || !same(i) {
                if i - start >= 2 {
                    out.push((start, i));
                }
                start = i;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    /// One accelerometer reading of (0, 0, −60) m/s² in the unit tests' exact swing (X3D preset:
    /// ±6 g = ±58.86 m/s²) at t = 10 s, where sin νt = 0 and the true specific force is
    /// (0, 0, −9.81): it is at full scale (60 ≥ 0.98 × 58.86) and 50.19 m/s² off the mocap's
    /// specific force, more than 4 g. One accelerometer stretch, whose findings are those two, in
    /// that order, with the worst values and bounds as derived. (The swing's gyro reads one
    /// constant rate throughout, which the gate rightly calls stuck: a stretch of its own.)
    #[test]
    fn a_saturated_reading_is_cut_with_what_was_found() {
        let mut s = Series::swing_for_tests(UnitQuaternion::identity(), 0.0);
        s.accel_body[2000] = Vec3::new(0.0, 0.0, -60.0);
        let (_, q) = gate(&s, &QualityOptions::default(), 0.02, 0.15, &Corrections::default());
        let accel: Vec<&Cut> = q.cuts.iter().filter(|c| c.channel == QualityChannel::Accel).collect();
        assert_eq!(accel.len(), 1, "{q:?}");
        let g = crate::vehicle::params::GRAVITY;
        let [
            Finding::AccelFullScale { count: 1, worst_m_s2, range_m_s2 },
            Finding::AccelDisagrees { count: 1, worst_m_s2: off, bound_m_s2 },
        ] = accel[0].findings[..]
        else {
            panic!("{:?}", accel[0].findings)
        };
        assert_eq!((worst_m_s2, range_m_s2, bound_m_s2), (60.0, 6.0 * g, 4.0 * g));
        assert!((off - (60.0 - g)).abs() < 0.01, "{off}");
    }
}
