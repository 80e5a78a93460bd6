//! Residual channels of the nominal model and the regressors of the candidate effects.
//!
//! ## Derivative filter
//! Everything compared is first smoothed by the same zero-phase Gaussian kernel
//! (σ = `smoothing_s`, truncated at `reach_sigmas`·σ (3σ unless set), −3 dB at 0.1325/σ: 6.6 Hz for the default 20 ms), then
//! differentiated by central differences of the smoothed samples (velocity (p₊ − p₋)/2Δt,
//! acceleration (p₊ − 2p + p₋)/Δt², response 1 − (ωΔt)²/12: −0.8 % at 5 Hz and 100 Hz sampling).
//! Mocap rates come from the relative rotation of neighbouring poses, ω_k = Log(q_{k−1}⁻¹q_{k+1})/2Δt
//! (body frame), smoothed by the same kernel; the IMU is smoothed by the same kernel, so both
//! sides of every residual see the same filter. Samples closer than the kernel's reach + 1 to a segment edge, a
//! missing pose, or the ground are left out. The smoothed channels are then decimated to one
//! sample per σ (20 ms by default): the kernel is the anti-alias filter, and what remains of
//! the residual's colour is left to the AR prewhitening of [`super::select`].
//!
//! ## Channels (body FRD; nav NED, g·e_D = (0, 0, g))
//! - `accel_kin` (m/s²): a_imu − f̂, f̂ = Rᵀ(p̈ − g·e_D): the accelerometer against the specific
//!   force the mocap trajectory implies (no force model involved).
//! - `gyro` (rad/s): ω_imu − ω̂, ω̂ from the mocap attitude.
//! - `force` (m/s², only with a thrust model): a_imu − f_m, f_m = (−k_x·v_x, −k_y·v_y, −T/m) with
//!   the declared drag k and the thrust T the commands imply: the accelerometer against the force model.
//!
//! ## Effects (linearised at the current corrections; regressor blocks per channel)
//! The rotation and delay regressors use the (smoothed) IMU signals: to first order they equal
//! the mocap ones, and they are far less noisy (noise in a regressor biases least squares
//! towards zero: with twice-differentiated mocap the delay came out 30 % short).
//! | effect | parameters | regressor |
//! |---|---|---|
//! | body offset R_off = exp(\[δ\]×) | δ (rad) | accel_kin: e_j × f_imu; gyro: e_j × ω_imu |
//! | mocap world tilt R_w = exp(\[τ\]×) | τ_x, τ_y (rad) | accel_kin: Rᵀ(g·e_D × e_j) |
//! | mocap delay τ_d | τ_d (s) | accel_kin: df_imu/dt; gyro: dω_imu/dt |
//! | accelerometer bias | b_a (m/s²) | accel_kin and force: e_j |
//! | gyro bias | b_g (rad/s) | gyro: e_j |
//! | rotor drag | k_x, k_y (1/s) | force: −v_x e_x, −v_y e_y (body velocity) |
//! | constant force (wind, CG) | F (N, nav) | force: Rᵀe_j/m |
//! | thrust scale | s − 1 | force: −T/m·e_z |
//! | thrust vs battery | c (1/V) | force: −T/m·(V − V_ref)·e_z |
//! | ground effect | c_g | force: −T/m·(r/4h)²·e_z (Cheeseman–Bennett, h ≥ r) |
//! | lever arm, mocap origin → IMU | r (m, body) | accel_kin: ω̇_imu × e_j + ω_imu × (ω_imu × e_j) |
//! | gyro delay vs accelerometer τ_g | τ_g (s) | gyro: −dω_imu/dt (the gyro reads ω(t − τ_g) ≈ ω − τ_g·ω̇) |
//! | accelerometer turned against the gyro and the airframe ε | ε_x, ε_y (rad) | accel_kin: e_j × f_imu (the body offset's accel_kin column without its gyro column); force: e_j × f_m |
//! | accelerometer z scale factor s_z | s_z (fraction) | accel_kin: f̂_z·e_z; force: f_m,z·e_z = −T/m·e_z (the channel's prediction, not the accelerometer: regressed on its own axis the residual's noise is the regressor's) |
//! | thrust axis tilted against the accelerometer t | t_x, t_y (rad) | force: T/m·(e_y for t_x, −e_x for t_y) (thrust along exp(\[t\]×)·(−e_z)) |
//! | mocap–IMU clock drift ρ | ρ (s/s) | accel_kin: (t − t̄)·df_imu/dt; gyro: (t − t̄)·dω_imu/dt (a delay τ_d + ρ·(t − t̄), t̄ the log's mid-time) |
//! | lever arm, centre of mass → IMU r_c | r_c (m, body) | force: ω̇_imu × e_j + ω_imu × (ω_imu × e_j) |
//!
//! The lever arm: the mocap tracks the marker template's origin, the IMU sits at r from it. A
//! rigid body's point r has the specific force of the tracked point plus ω̇×r + ω×(ω×r), so the
//! accelerometer reads that much more than the mocap implies. Like the rotations and the delay
//! it is then folded into the [`Corrections`]: the corrected trajectory is the IMU's point
//! (p + R·r), whose velocity is also what the drag columns see. Only the difference IMU − tracked
//! point is seen by `accel_kin`. The force channel compares the IMU with the force model, which
//! gives the centre of mass's specific force, so it sees the IMU's offset r_c from the centre of
//! mass instead, with the same columns (`imu_offset`, additive: exact in r_c at the measured ω).
//! In flyarena's simulator the IMU sits at `imu.position_mm` = r_c from the centre of mass and
//! the markers' origin at `markers.displacement_mm` = d, so the lever arm is r = r_c − d.

use crate::effects::{Channel, Effect};
use crate::frames::{Body, Frame, Nav, Vec3};
use crate::identify::input::series::{Corrected, Corrections, Series, correct, raw_rots, raw_vecs};
use nalgebra::{UnitQuaternion, Vector3};

/// Where an effect's columns sit in the full design.
pub fn column_offsets() -> [usize; Effect::ALL.len() + 1] {
    let mut o = [0; Effect::ALL.len() + 1];
    for (i, e) in Effect::ALL.iter().enumerate() {
        o[i + 1] = o[i] + e.n_params();
    }
    o
}
/// Number of columns of the full design: every candidate's parameters, in [`column_offsets`] order
/// (computed from [`Effect::params`], so that a new effect cannot leave it behind).
pub const N_COLUMNS: usize = {
    let mut n = 0;
    let mut i = 0;
    while i < Effect::ALL.len() {
        n += Effect::ALL[i].n_params();
        i += 1;
    }
    n
};

/// One regressor column: its index in the full design and its samples.
pub type Column = (usize, Vec<f64>);

/// The built problem at one set of corrections: per channel and axis the measured signal, the
/// nominal prediction, and every candidate column; `ok` marks usable samples. The default is
/// the empty design (no samples, no channels, no signals).
#[derive(Default)]
pub struct Design {
    /// Samples (after decimation).
    pub n: usize,
    /// Sample times (s), after decimation.
    pub t: Vec<f64>,
    /// The sample is usable: airborne above `min_height_m`, away from gaps, glitches and the
    /// filter's edges.
    pub ok: Vec<bool>,
    /// \[channel\]\[axis\] → samples
    pub measured: [[Vec<f64>; 3]; 3],
    /// \[channel\]\[axis\] → what the nominal model predicts for the measured samples.
    pub predicted: [[Vec<f64>; 3]; 3],
    /// \[channel\]\[axis\] → (column, samples) for the columns that touch it
    pub columns: [[Vec<Column>; 3]; 3],
    /// The log has a thrust (commands or motor) column: the force channel exists.
    pub has_force: bool,
    /// The log has the battery voltage: the thrust–voltage effect has a column.
    pub has_vbat: bool,
    /// Circular standard deviation of the yaw over the usable samples (rad).
    pub yaw_spread_rad: f64,
    /// Mocap glitches found: runs of consecutive glitch poses ([`glitches`]), each counted once
    /// (every pose in a run leaves out the filter's reach around it).
    pub outliers: usize,
    /// Measured signals a leftover residual may follow (name, samples): the leads of "what is
    /// left". Time (a drift), speed and body velocity (drag), body rates and their derivative
    /// (an IMU lever arm), specific force (accelerometer scale and cross-axis), thrust and
    /// battery (motor-speed effects), height (ground effect). Empty unless built by
    /// [`build_with_signals`].
    pub signals: Vec<Signal>,
}

/// A measured signal, decimated like the channels, and the channel axes (channel index, axis)
/// it is no lead for because it carries their own measurement.
#[derive(Clone, Debug)]
pub struct Signal {
    /// Name with its unit, as the report prints it.
    pub name: &'static str,
    /// Samples at the design's (decimated) times.
    pub samples: Vec<f64>,
    /// Channel axes (channel index, axis) this signal is no lead for.
    pub excludes: Vec<(usize, usize)>,
    /// A measurement's own error rather than a state of the flight (the mocap attitude against
    /// the gyro's integral): a residual that follows it has reached that measurement's floor,
    /// which no effect of the vehicle removes.
    pub floor: bool,
}

/// Poses this many robust standard deviations off the midpoint of their neighbours are glitches.
pub(crate) const GLITCH_SIGMAS: f64 = 20.0;

/// Glitch events among sorted glitch rows: a run of consecutive rows counts once. A pose that
/// jumps by J also moves its neighbours' midpoint by J/2, so one glitched frame flags three
/// rows ([`glitches`]), and a glitch of two frames four.
fn glitch_events(rows: &[usize]) -> usize {
    rows.iter().enumerate().filter(|&(k, &r)| k == 0 || rows[k - 1] + 1 != r).count()
}

/// Rows whose pose jumps away from the midpoint of its neighbours and back (sorted).
pub fn glitches(s: &Series) -> Vec<usize> {
    let n = s.len();
    let mut jp = vec![f64::NAN; n];
    let mut jq = vec![f64::NAN; n];
    for &(a, b) in &s.segments {
        for i in a + 1..b.saturating_sub(1) {
            if s.mocap_ok[i - 1] && s.mocap_ok[i] && s.mocap_ok[i + 1] {
                let mid = (s.pos_mocap_nav[i - 1] + s.pos_mocap_nav[i + 1]) * 0.5;
                jp[i] = (s.pos_mocap_nav[i] - mid).norm();
                let between =
                    crate::identify::input::series::interpolate_attitude(&s.att_mocap[i - 1], &s.att_mocap[i + 1], 0.5);
                jq[i] = s.att_mocap[i].quaternion().angle_to(between.quaternion());
            }
        }
    }
    let limit = |x: &[f64], floor: f64| -> f64 {
        let mut v: Vec<f64> = x.iter().copied().filter(|x| x.is_finite()).collect();
        if v.len() < 10 {
            return f64::INFINITY;
        }
        v.sort_by(f64::total_cmp);
        let med = v[v.len() / 2];
        let mut dev: Vec<f64> = v.iter().map(|x| (x - med).abs()).collect();
        dev.sort_by(f64::total_cmp);
        (med + GLITCH_SIGMAS * 1.4826 * dev[dev.len() / 2]).max(floor)
    };
    let (lp, lq) = (limit(&jp, 1e-3), limit(&jq, 0.5f64.to_radians()));
    (0..n).filter(|&i| jp[i] > lp || jq[i] > lq).collect()
}

impl Design {
    /// Measured − predicted on channel `c`, axis `a`: the residual of the nominal model.
    pub fn residual(&self, c: usize, a: usize) -> Vec<f64> {
        self.measured[c][a].iter().zip(&self.predicted[c][a]).map(|(m, p)| m - p).collect()
    }
}

/// A zero-phase Gaussian kernel of σ = `sigma_samples`, truncated at 3σ and normalised.
pub(crate) fn gaussian_kernel(sigma_samples: f64) -> Vec<f64> {
    gaussian_kernel_to(sigma_samples, DEFAULT_REACH_SIGMAS)
}

/// [`gaussian_kernel`] truncated at `reach_sigmas`·σ. The truncation leaves a step of
/// exp(−reach²/2) of the peak at each end, whose response falls only as 1/f: at 3σ (1.1 % of the
/// peak) it passes about 10⁻³ of a signal at 100 Hz, which is nothing for a smooth signal and a
/// lot for a mocap's position noise twice differentiated (its density grows as f⁴), which then
/// folds, on decimation, into the band the calibration reads (see [`DesignOptions::reach_sigmas`]).
pub(crate) fn gaussian_kernel_to(sigma_samples: f64, reach_sigmas: f64) -> Vec<f64> {
    let h = (reach_sigmas * sigma_samples).ceil().max(1.0) as isize;
    let mut k: Vec<f64> =
        (-h..=h).map(|j| (-(j as f64).powi(2) / (2.0 * sigma_samples * sigma_samples)).exp()).collect();
    let s: f64 = k.iter().sum();
    k.iter_mut().for_each(|x| *x /= s);
    k
}

/// Zero-phase smoothing inside [a, b); samples nearer than the half-width to an edge stay raw
/// (they are masked out anyway).
fn smooth_into(x: &[f64], segs: &[(usize, usize)], kernel: &[f64], out: &mut [f64]) {
    let h = kernel.len() / 2;
    out.copy_from_slice(x);
    for &(a, b) in segs {
        if b - a <= 2 * h {
            continue;
        }
        for i in a + h..b - h {
            let mut s = 0.0;
            for (j, w) in kernel.iter().enumerate() {
                s += w * x[i + j - h];
            }
            out[i] = s;
        }
    }
}

/// [`smooth_vec3`] evaluated only at the rows that decimation keeps (i % stride == 0); the
/// other rows keep their raw values and must not be read. For signals that are not
/// differentiated afterwards, this saves (stride − 1)/stride of the work.
fn smooth_vec3_kept(x: &[Vector3<f64>], segs: &[(usize, usize)], kernel: &[f64], stride: usize) -> Vec<Vector3<f64>> {
    smooth_vec3_rows(x, segs, kernel, |i| i % stride == 0)
}

/// [`smooth_vec3`] evaluated at the kept rows and their two neighbours, all that a central
/// difference at the kept rows reads.
fn smooth_vec3_kept_and_neighbours(
    x: &[Vector3<f64>],
    segs: &[(usize, usize)],
    kernel: &[f64],
    stride: usize,
) -> Vec<Vector3<f64>> {
    smooth_vec3_rows(x, segs, kernel, |i| {
        let r = i % stride;
        r == 0 || r == 1 || r == stride - 1
    })
}

/// [`smooth_vec3`] at the rows where `need` holds (same sums in the same order, so the same
/// bits); the other rows keep their raw values.
pub(crate) fn smooth_vec3_rows(
    x: &[Vector3<f64>],
    segs: &[(usize, usize)],
    kernel: &[f64],
    need: impl Fn(usize) -> bool,
) -> Vec<Vector3<f64>> {
    let h = kernel.len() / 2;
    let mut out = x.to_vec();
    for &(a, b) in segs {
        if b - a <= 2 * h {
            continue;
        }
        for i in (a + h..b - h).filter(|&i| need(i)) {
            let mut s = Vector3::zeros();
            for (j, w) in kernel.iter().enumerate() {
                s += *w * x[i + j - h];
            }
            out[i] = s;
        }
    }
    out
}

/// Zero-phase smoothing of each axis inside each segment ([`smooth_into`] per axis, the same bits).
pub(crate) fn smooth_vec3(x: &[Vector3<f64>], segs: &[(usize, usize)], kernel: &[f64]) -> Vec<Vector3<f64>> {
    smooth_vec3_rows(x, segs, kernel, |_| true)
}

/// Body rates from neighbouring attitudes (body → nav), ω_k = Log(q_{k−1}⁻¹q_{k+1})/(t_{k+1} − t_{k−1})
/// in the body frame, inside each segment (zero at its ends).
pub(crate) fn body_rates(att: &[UnitQuaternion<f64>], t: &[f64], segs: &[(usize, usize)]) -> Vec<Vector3<f64>> {
    let mut omega = vec![Vector3::zeros(); att.len()];
    for &(a, b) in segs {
        for i in a + 1..b.saturating_sub(1) {
            let rel = att[i - 1].inverse() * att[i + 1];
            omega[i] = rel.scaled_axis() / (t[i + 1] - t[i - 1]);
        }
    }
    omega
}

/// The second derivative of p at row i (0 < i < len − 1) by central differences on uneven
/// steps: ((p₊ − p)/(t₊ − t) − (p − p₋)/(t − t₋))·2/(t₊ − t₋).
pub(crate) fn second_difference(p: &[Vector3<f64>], t: &[f64], i: usize) -> Vector3<f64> {
    let (t0, t1, t2) = (t[i - 1], t[i], t[i + 1]);
    let d1 = (p[i + 1] - p[i]) / (t2 - t1);
    let d0 = (p[i] - p[i - 1]) / (t1 - t0);
    (d1 - d0) * (2.0 / (t2 - t0))
}

/// Options of the residual construction.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct DesignOptions {
    /// σ of the Gaussian smoothing (s).
    pub smoothing_s: f64,
    /// Samples below this height above the ground (m) are left out.
    pub min_height_m: f64,
    /// Where the Gaussian is cut, in σ (3 unless set; the samples this near a segment's edge
    /// are left out). Cut at 3σ, the kernel's ends are steps of 1.1 % of its peak, and their
    /// response falls only as 1/f: the mocap's position noise, whose density grows as f⁴ once
    /// twice differentiated, leaks through them above 50 Hz and folds into the band the fit
    /// reads when the channels are decimated. On MoCap2GT's setting (1 mm at 300 Hz) that
    /// costs a calibration's lever arm a fifth of its precision; at 5σ the steps are 4·10⁻⁶ of
    /// the peak and the leak is gone (docs/calibration.md, *what each choice bought*). A
    /// calibration cuts at 5σ ([`Options::calibration`](crate::identify::Options::calibration)).
    /// (Written in a report only when not 3.)
    #[serde(skip_serializing_if = "is_default_reach")]
    pub reach_sigmas: f64,
}

/// Where the Gaussian is cut unless a fit says otherwise ([`DesignOptions::reach_sigmas`]).
pub const DEFAULT_REACH_SIGMAS: f64 = 3.0;

/// Where a calibration cuts its Gaussian ([`DesignOptions::reach_sigmas`]).
pub const CALIBRATION_REACH_SIGMAS: f64 = 5.0;

fn is_default_reach(x: &f64) -> bool {
    *x == DEFAULT_REACH_SIGMAS
}

impl Default for DesignOptions {
    fn default() -> Self {
        DesignOptions { smoothing_s: 0.02, min_height_m: 0.08, reach_sigmas: DEFAULT_REACH_SIGMAS }
    }
}

/// Builds the design of a flight at the given corrections (no lead signals; see
/// [`build_with_signals`]).
pub fn build(s: &Series, corr: &Corrections, opt: &DesignOptions) -> Design {
    build_inner(s, corr, opt, false)
}

/// [`build`], with the measured [`Design::signals`] (the leads of "what is left"; built once, for
/// the final model, not in every fit).
pub fn build_with_signals(s: &Series, corr: &Corrections, opt: &DesignOptions) -> Design {
    build_inner(s, corr, opt, true)
}

fn build_inner(s: &Series, corr: &Corrections, opt: &DesignOptions, with_signals: bool) -> Design {
    let n = s.len();
    let dt = s.dt();
    let kernel = gaussian_kernel_to(opt.smoothing_s / dt, opt.reach_sigmas);
    let h = kernel.len() / 2;
    let Corrected { pos_nav, att_body, ok: mut pose_ok } = correct(s, corr);
    // smoothing and differencing run on plain coordinates; `Smoothed` hands the results back in
    // their frames, and the channels read only body-frame vectors
    let (pos_nav, att_body) = (raw_vecs(&pos_nav), raw_rots(&att_body));
    // mocap glitches (a marker mistaken for another for a frame) become tens of m/s² after two
    // derivatives; they are found in the raw poses, not in a residual, so that no effect can
    // be mistaken for one: a pose further from the midpoint of its neighbours than
    // GLITCH_SIGMAS robust standard deviations (1.4826·MAD) and than 1 mm or 0.5° is dropped
    let glitches = glitches(s);
    let shift = (corr.mocap_delay_s / dt).round() as isize;
    for &g in &glitches {
        let k = g as isize - shift;
        if k >= 0 && (k as usize) < n {
            pose_ok[k as usize] = false;
        }
    }
    let outliers = glitch_events(&glitches);
    // the gyro with its delay against the accelerometer taken out (rows it cannot reach are out)
    let gyro_raw = raw_vecs(&crate::identify::input::series::gyro_advanced(s, corr.gyro_delay_s, &mut pose_ok));
    let (ok, height) = usable_rows(s, opt, &pos_nav, &pose_ok, h + 2);
    // decimation keeps one row per σ (below); what is not differentiated is smoothed only there
    let stride = ((opt.smoothing_s / dt).round() as usize).max(1);
    let x = smoothed(s, opt, &pos_nav, &att_body, &gyro_raw, height, stride);
    let Channels { measured, predicted, columns } = channels(s, &x);
    let has_force = x.thrust_s.is_some();
    let has_vbat = s.vbat_v.is_some();
    let yaw_spread_rad = yaw_spread(&att_body, &ok);
    // decimate to one sample per σ: the smoothing is the anti-alias filter, and neighbouring
    // samples of a smoothed signal carry little new information but a lot of correlation
    let keep: Vec<usize> = (0..n).step_by(stride).collect();
    let pick =
        |v: &Vec<f64>| -> Vec<f64> { if v.is_empty() { Vec::new() } else { keep.iter().map(|&i| v[i]).collect() } };
    let ok: Vec<bool> = keep.iter().map(|&i| ok[i]).collect();
    let t: Vec<f64> = keep.iter().map(|&i| s.t_s[i]).collect();
    let signals = if with_signals {
        lead_signals(s, &x).into_iter().map(|x| Signal { samples: pick(&x.samples), ..x }).collect()
    } else {
        Vec::new()
    };
    let measured = measured.map(|c| c.map(|a| pick(&a)));
    let predicted = predicted.map(|c| c.map(|a| pick(&a)));
    let columns = columns.map(|c| c.map(|a| a.into_iter().map(|(j, v)| (j, pick(&v))).collect::<Vec<_>>()));
    Design {
        n: keep.len(),
        t,
        ok,
        measured,
        predicted,
        columns,
        has_force,
        has_vbat,
        yaw_spread_rad,
        outliers,
        signals,
    }
}

/// The rows a fit may use: inside a segment by more than `reach` (the filter's), every pose in
/// reach valid (`pose_ok`), at least `min_height_m` over the floor and, with a thrust column,
/// the motors at a quarter of the weight or more. Also returns each row's height over the floor
/// (m; infinite without a floor).
fn usable_rows(
    s: &Series,
    opt: &DesignOptions,
    pos_nav: &[Vector3<f64>],
    pose_ok: &[bool],
    reach: usize,
) -> (Vec<bool>, Vec<f64>) {
    let n = s.len();
    let g = s.model.gravity_m_s2;
    let mut ok = vec![false; n];
    for &(a, b) in &s.segments {
        if b - a <= 2 * reach {
            continue;
        }
        for i in a + reach..b - reach {
            ok[i] = (i - reach..=i + reach).all(|k| pose_ok[k]);
        }
    }
    // the floor: the lowest point (largest NED z) while the motors are off; without a thrust
    // column, the lowest point of the first half second (a log is taken to start at rest). A
    // log that starts in the air with the motors on has no floor: nothing is masked for height
    // and the ground-effect regressor is zero.
    let floor_z = crate::identify::input::series::floor_z(s, &pos_nav.iter().map(|p| p.z).collect::<Vec<f64>>());
    let height: Vec<f64> = pos_nav.iter().map(|p| floor_z.map_or(f64::INFINITY, |f| f - p.z)).collect();
    for i in 0..n {
        if height[i] < opt.min_height_m {
            ok[i] = false;
        }
        if let Some(t) = &s.thrust_n
            && t[i] < 0.25 * s.model.mass_kg * g
        {
            ok[i] = false;
        }
    }
    (ok, height)
}

/// The circular standard deviation of the yaw (rad) over the usable rows (for the
/// identifiability note): √(−2 ln R), R the mean resultant length.
fn yaw_spread(att_body: &[UnitQuaternion<f64>], ok: &[bool]) -> f64 {
    let yaws: Vec<f64> = (0..ok.len()).filter(|&i| ok[i]).map(|i| att_body[i].euler_angles().2).collect();
    if yaws.is_empty() {
        return 0.0;
    }
    let (sx, sy) = yaws.iter().fold((0.0, 0.0), |(x, y), a| (x + a.cos(), y + a.sin()));
    let r = (sx * sx + sy * sy).sqrt() / yaws.len() as f64;
    (-2.0 * r.max(1e-12).ln()).sqrt()
}

/// Smooths and differentiates what the channels compare (the derivative filter at the top of
/// this module), rotating into the body frame before smoothing where the IMU does.
fn smoothed(
    s: &Series,
    opt: &DesignOptions,
    pos_nav: &[Vector3<f64>],
    att_body: &[UnitQuaternion<f64>],
    gyro_raw: &[Vector3<f64>],
    height: Vec<f64>,
    stride: usize,
) -> Smoothed {
    let n = s.len();
    let kernel = gaussian_kernel_to(opt.smoothing_s / s.dt(), opt.reach_sigmas);
    let segs = &s.segments;
    let g = s.model.gravity_m_s2;
    let pos_s = smooth_vec3(pos_nav, segs, &kernel);
    let gyro_s = smooth_vec3_kept_and_neighbours(gyro_raw, segs, &kernel, stride);
    let accel_s = smooth_vec3_kept_and_neighbours(&raw_vecs(&s.accel_body), segs, &kernel, stride);
    // mocap body rates from neighbouring poses
    let rates = body_rates(att_body, &s.t_s, segs);
    let omega_s = smooth_vec3_kept(&rates, segs, &kernel, stride);
    let deriv = |x: &[Vector3<f64>]| central_difference(x, &s.t_s, segs);
    let vel_nav = deriv(&pos_s);
    let mut acc_nav = vec![Vector3::zeros(); n];
    for &(a, b) in segs {
        for i in a + 1..b.saturating_sub(1) {
            acc_nav[i] = second_difference(&pos_s, &s.t_s, i);
        }
    }
    let jerk_nav = deriv(&acc_nav);
    let omega_dot = deriv(&gyro_s);
    let rot_t: Vec<nalgebra::Matrix3<f64>> =
        att_body.iter().map(|q: &UnitQuaternion<f64>| q.to_rotation_matrix().matrix().transpose()).collect();
    // Everything body-frame that is compared with the smoothed IMU must be rotated *before* it
    // is smoothed, as the IMU is: the IMU reads K*(Rᵀ(p̈ − g·e_D)). For a Gaussian of σ (s),
    // to second order (Ṙᵀ = −[ω]×Rᵀ, R̈ᵀ = ([ω]×² − [ω̇]×)Rᵀ):
    //   K*(Rᵀx) = Rᵀ(K*x) + σ²·Ṙᵀẋ + (σ²/2)·R̈ᵀx
    //           = Rᵀ(K*x) − σ²·ω×(Rᵀẋ) + (σ²/2)·(ω×(ω×Rᵀx) − ω̇×Rᵀx).
    // Leaving the correction out is not small: for gravity it is g·σ²/2·ω̇ (an apparent lever
    // arm of 2 mm along z at σ = 20 ms), for p̈ it is σ²·ω×(jerk), which the delay column (ḟ)
    // partly absorbs (+0.1–0.2 ms on simulated flights with no delay). Gravity is constant, so
    // its image is smoothed exactly: K*(Rᵀg). For p̈ and v, rotating the raw differences
    // instead would multiply the pose's attitude noise with its own position noise (the two
    // come from the same markers and correlate: a bias of mm/s² in f̂); the correction above
    // takes ω and ω̇ from the IMU, whose noise is independent of the mocap's.
    let sigma2 = opt.smoothing_s * opt.smoothing_s;
    let rotated = |i: usize, x: &Vector3<f64>, x_dot: &Vector3<f64>| -> Vector3<f64> {
        let (w, wd) = (gyro_s[i], omega_dot[i]);
        let rx = rot_t[i] * x;
        rx - sigma2 * w.cross(&(rot_t[i] * x_dot)) + 0.5 * sigma2 * (w.cross(&w.cross(&rx)) - wd.cross(&rx))
    };
    // body-frame images of the nav axes, K*(Rᵀe_j), smoothed after the rotation (exact: the
    // axes are constant); gravity's image and the world-tilt columns are multiples of them:
    // Rᵀ(−g·e_D) = −g·Rᵀe_D, g·e_D × e_N = g·e_E, g·e_D × e_E = −g·e_N
    let nav_axes: [Vec<Vector3<f64>>; 3] = std::array::from_fn(|j| {
        smooth_vec3_kept(&rot_t.iter().map(|r| r * unit(j)).collect::<Vec<_>>(), segs, &kernel, stride)
    });
    let grav_body_s: Vec<Vector3<f64>> = nav_axes[2].iter().map(|v| -g * v).collect();
    let tilt_cols: [Vec<Vector3<f64>>; 2] =
        [nav_axes[1].iter().map(|v| g * v).collect(), nav_axes[0].iter().map(|v| -g * v).collect()];
    // read at the kept rows only (decimation below)
    let at_kept = |f: &dyn Fn(usize) -> Vector3<f64>| -> Vec<Vector3<f64>> {
        (0..n).map(|i| if i % stride == 0 { f(i) } else { Vector3::zeros() }).collect()
    };
    let f_hat = at_kept(&|i| rotated(i, &acc_nav[i], &jerk_nav[i]) + grav_body_s[i]);
    let v_body = at_kept(&|i| rotated(i, &vel_nav[i], &acc_nav[i]));
    // regressors of the rotations and the delay come from the IMU side: to first order
    // f_imu − f̂ = δ × f = τ·ḟ with f the IMU's or the mocap's alike, but the IMU is far less noisy
    // than twice-differentiated mocap, and noise in a regressor biases its parameter towards zero
    let f_dot = deriv(&accel_s);
    let rigid_point = rigid_point_columns(gyro_raw, &omega_dot, segs, &kernel, stride);
    let thrust_s = s.thrust_n.as_ref().map(|t| {
        let mut o = vec![0.0; n];
        smooth_into(t, segs, &kernel, &mut o);
        o
    });

    let attitude_gap = smooth_vec3_kept(&attitude_gap(s, &rates, gyro_raw), segs, &kernel, stride);
    Smoothed {
        accel_s: framed(accel_s),
        gyro_s: framed(gyro_s),
        omega_s: framed(omega_s),
        f_hat: framed(f_hat),
        f_dot: framed(f_dot),
        omega_dot: framed(omega_dot),
        v_body: framed(v_body),
        vel_nav: framed(vel_nav),
        nav_axes: nav_axes.map(framed),
        tilt_cols: tilt_cols.map(framed),
        rigid_point: rigid_point.map(framed),
        thrust_s,
        height,
        attitude_gap: framed(attitude_gap),
    }
}

/// The central difference (xᵢ₊₁ − xᵢ₋₁)/(tᵢ₊₁ − tᵢ₋₁) inside each segment, zero at its ends.
pub(crate) fn central_difference(x: &[Vector3<f64>], t: &[f64], segs: &[(usize, usize)]) -> Vec<Vector3<f64>> {
    let mut d = vec![Vector3::zeros(); x.len()];
    for &(a, b) in segs {
        for i in a + 1..b.saturating_sub(1) {
            d[i] = (x[i + 1] - x[i - 1]) / (t[i + 1] - t[i - 1]);
        }
    }
    d
}

/// The columns of a lever arm along each body axis e_j: a rigid body's point at e_j from another
/// feels ω̇×e_j + ω×(ω×e_j) more (the IMU against the tracked point, and against the centre of
/// mass). The centripetal part is quadratic in ω: smoothed after the product, as the IMU smooths
/// it (the product of smoothed rates misses K*(ω×(ω×r)) by the rates' own high-frequency content).
fn rigid_point_columns(
    gyro_raw: &[Vector3<f64>],
    omega_dot: &[Vector3<f64>],
    segs: &[(usize, usize)],
    kernel: &[f64],
    stride: usize,
) -> [Vec<Vector3<f64>>; 3] {
    std::array::from_fn(|j| {
        let centripetal = smooth_vec3_kept(
            &gyro_raw.iter().map(|w| w.cross(&w.cross(&unit(j)))).collect::<Vec<_>>(),
            segs,
            kernel,
            stride,
        );
        omega_dot.iter().zip(&centripetal).map(|(wd, c)| wd.cross(&unit(j)) + c).collect()
    })
}

/// The signals every channel and column is built from, at the log's rate (smoothed; the ones
/// compared with the IMU filled only at the rows decimation keeps). Each carries its frame: the
/// true body frame (FRD, the IMU's: the corrections have turned the mocap's body onto it), or
/// nav (NED) for the one velocity that stays there; the smoothing and differencing above run on
/// plain coordinates and hand over here.
struct Smoothed {
    /// The accelerometer and the gyro (delay taken out), smoothed (m/s², rad/s).
    accel_s: Vec<Vec3<Body>>,
    gyro_s: Vec<Vec3<Body>>,
    /// The mocap's body rates (rad/s).
    omega_s: Vec<Vec3<Body>>,
    /// The specific force the mocap implies, f̂ = Rᵀ(p̈ − g·e_D) (m/s²), and the IMU's own ḟ.
    f_hat: Vec<Vec3<Body>>,
    f_dot: Vec<Vec3<Body>>,
    /// The gyro's derivative (rad/s²).
    omega_dot: Vec<Vec3<Body>>,
    /// Velocity in the body frame and in nav (m/s).
    v_body: Vec<Vec3<Body>>,
    vel_nav: Vec<Vec3<Nav>>,
    /// K*(Rᵀe_j) for the nav axes, and the world tilt's columns (multiples of them).
    nav_axes: [Vec<Vec3<Body>>; 3],
    tilt_cols: [Vec<Vec3<Body>>; 2],
    /// ω̇×e_j + K*(ω×(ω×e_j)): the lever arms' columns (per unit of r along e_j, m/s² per m).
    rigid_point: [Vec<Vec3<Body>>; 3],
    /// Collective thrust from the commands (N), if known.
    thrust_s: Option<Vec<f64>>,
    /// Height above the floor (m; infinite without a floor).
    height: Vec<f64>,
    /// The mocap attitude against the gyro's integral, high-passed (rad, body): a lead for the
    /// mocap's own attitude error, which f̂ carries as −δθ × f.
    attitude_gap: Vec<Vec3<Body>>,
}

/// Over this window the gyro's integral holds the attitude (s): the attitude gap is the
/// integral of ω_mocap − ω_gyro less its moving average over it.
pub const ATTITUDE_GAP_WINDOW_S: f64 = 0.5;

/// δθ = ∫(ω_mocap − ω_gyro)dt (ω_mocap: `rates`, from neighbouring poses), per segment, less its centred moving average over
/// [`ATTITUDE_GAP_WINDOW_S`]: the mocap attitude's error at frequencies the gyro's integral
/// holds (plus the gyro's own high-frequency error).
fn attitude_gap(s: &Series, rates: &[Vector3<f64>], gyro_raw: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
    let n = s.len();
    let dt = s.dt();
    let half = (0.5 * ATTITUDE_GAP_WINDOW_S / dt).round() as usize;
    let mut gap = vec![Vector3::zeros(); n];
    for &(a, b) in &s.segments {
        // the integral and its prefix sums over the segment
        let mut cum = Vec::with_capacity(b - a);
        let mut acc = Vector3::zeros();
        for i in a..b {
            acc += (rates[i] - gyro_raw[i]) * dt;
            cum.push(acc);
        }
        let mut prefix = vec![Vector3::zeros(); cum.len() + 1];
        for (k, c) in cum.iter().enumerate() {
            prefix[k + 1] = prefix[k] + c;
        }
        for k in 0..cum.len() {
            let (lo, hi) = (k.saturating_sub(half), (k + half + 1).min(cum.len()));
            gap[a + k] = cum[k] - (prefix[hi] - prefix[lo]) / (hi - lo) as f64;
        }
    }
    gap
}

/// Per channel and axis: what is measured, what the nominal model predicts, and the columns.
struct Channels {
    measured: [[Vec<f64>; 3]; 3],
    predicted: [[Vec<f64>; 3]; 3],
    columns: [[Vec<Column>; 3]; 3],
}

fn unit(j: usize) -> Vector3<f64> {
    Vector3::from_fn(|r, _| if r == j { 1.0 } else { 0.0 })
}

/// Plain coordinates handed over in frame `F`.
fn framed<F: Frame>(v: Vec<Vector3<f64>>) -> Vec<Vec3<F>> {
    v.into_iter().map(Vec3::from_raw).collect()
}

/// Component `a` of each body-frame vector: a channel's axis or a column along it. Every
/// channel is a residual in the body frame, so a signal in nav cannot reach one unturned.
fn component(v: &[Vec3<Body>], a: usize) -> Vec<f64> {
    v.iter().map(|x| axis(x, a)).collect()
}

/// Component `a` of a body-frame vector.
fn axis(v: &Vec3<Body>, a: usize) -> f64 {
    v.raw()[a]
}

/// The channels and the candidates' regressors (the table at the top of this module).
fn channels(s: &Series, x: &Smoothed) -> Channels {
    let empty3 = || [Vec::new(), Vec::new(), Vec::new()];
    let mut ch = Channels {
        measured: [empty3(), empty3(), empty3()],
        predicted: [empty3(), empty3(), empty3()],
        columns: Default::default(),
    };
    let cols = Cols::new(s);
    for a in 0..3 {
        accel_kin_axis(s, x, &cols, a, &mut ch);
        gyro_axis(s, x, &cols, a, &mut ch);
    }
    if let Some(thrust) = &x.thrust_s {
        // the nominal specific thrust T/m (m/s²), shared by the three axes
        let spec: Vec<f64> = thrust.iter().map(|t| t / s.model.mass_kg).collect();
        for a in 0..3 {
            force_axis(s, x, &spec, &cols, a, &mut ch);
        }
    }
    ch
}

/// Where each effect's parameters sit among all columns, and the clock drift's reference time.
struct Cols {
    offsets: [usize; Effect::ALL.len() + 1],
    /// The log's mid-time (s): the drift's delay there is τ_d.
    t_mid: f64,
}

impl Cols {
    fn new(s: &Series) -> Cols {
        let t_mid = match (s.t_s.first(), s.t_s.last()) {
            (Some(a), Some(b)) => 0.5 * (a + b),
            _ => 0.0,
        };
        Cols { offsets: column_offsets(), t_mid }
    }
    /// The column of parameter `j` of effect `e`.
    fn of(&self, e: Effect, j: usize) -> usize {
        self.offsets[e as usize] + j
    }
}

/// accel_kin, axis `a`: the accelerometer against the mocap's f̂ = Rᵀ(p̈ − g·e_D), and the
/// columns of the frame, delay, bias, misalignment, z-scale and lever-arm effects.
fn accel_kin_axis(s: &Series, x: &Smoothed, cols: &Cols, a: usize, ch: &mut Channels) {
    let n = s.len();
    let Smoothed { accel_s, f_hat, f_dot, tilt_cols, rigid_point, .. } = x;
    let (col, t_mid) = (|e: Effect, j: usize| cols.of(e, j), cols.t_mid);
    let c = Channel::AccelKin.index();
    ch.measured[c][a] = component(accel_s, a);
    ch.predicted[c][a] = component(f_hat, a);
    for j in 0..3 {
        ch.columns[c][a]
            .push((col(Effect::BodyOffset, j), accel_s.iter().map(|f| unit(j).cross(f.raw())[a]).collect()));
    }
    for j in 0..2 {
        ch.columns[c][a].push((col(Effect::WorldTilt, j), component(&tilt_cols[j], a)));
    }
    ch.columns[c][a].push((col(Effect::MocapDelay, 0), component(f_dot, a)));
    ch.columns[c][a]
        .push((col(Effect::ClockDrift, 0), (0..n).map(|i| (s.t_s[i] - t_mid) * axis(&f_dot[i], a)).collect()));
    ch.columns[c][a].push((col(Effect::AccelBias, a), vec![1.0; n]));
    ch.columns[c][a].push((col(Effect::AccelBiasDrift, a), (0..n).map(|i| s.t_s[i] - t_mid).collect()));
    // the accelerometer's own frame: turned against the gyro's (the gyro carries the body
    // offset), and its z scaled
    for j in 0..2 {
        ch.columns[c][a]
            .push((col(Effect::AccelMisalignment, j), accel_s.iter().map(|f| unit(j).cross(f.raw())[a]).collect()));
    }
    // the z scale's regressor is the mocap's f̂_z: in flight it swings by metres per second
    // squared against a noise of a few hundredths, so the errors-in-variables bias is small
    if a == 2 {
        ch.columns[c][a].push((col(Effect::AccelScale, 0), component(f_hat, a)));
    }
    // the IMU at r from the point the mocap tracks (body FRD): it feels the rotation's
    // acceleration ω̇×r + ω×(ω×r) that the tracked point does not (linear in r)
    for j in 0..3 {
        ch.columns[c][a].push((col(Effect::LeverArm, j), component(&rigid_point[j], a)));
    }
}

/// gyro, axis `a`: the gyro against the mocap's body rates, and the columns of the frame,
/// delay, bias and gyro-delay effects.
fn gyro_axis(s: &Series, x: &Smoothed, cols: &Cols, a: usize, ch: &mut Channels) {
    let n = s.len();
    let Smoothed { gyro_s, omega_dot, omega_s, .. } = x;
    let (col, t_mid) = (|e: Effect, j: usize| cols.of(e, j), cols.t_mid);
    let c = Channel::Gyro.index();
    ch.measured[c][a] = component(gyro_s, a);
    ch.predicted[c][a] = component(omega_s, a);
    for j in 0..3 {
        ch.columns[c][a].push((col(Effect::BodyOffset, j), gyro_s.iter().map(|w| unit(j).cross(w.raw())[a]).collect()));
    }
    ch.columns[c][a].push((col(Effect::MocapDelay, 0), component(omega_dot, a)));
    ch.columns[c][a]
        .push((col(Effect::ClockDrift, 0), (0..n).map(|i| (s.t_s[i] - t_mid) * axis(&omega_dot[i], a)).collect()));
    ch.columns[c][a].push((col(Effect::GyroBias, a), vec![1.0; n]));
    ch.columns[c][a].push((col(Effect::GyroBiasDrift, a), (0..n).map(|i| s.t_s[i] - t_mid).collect()));
    // the gyro's samples τ_g later than the accelerometer's: ω(t − τ_g) ≈ ω − τ_g·ω̇
    ch.columns[c][a].push((col(Effect::GyroDelay, 0), omega_dot.iter().map(|v| -axis(v, a)).collect()));
}

/// force, axis `a`: the accelerometer against the nominal force model (thrust −T/m along z, rotor
/// drag −k·v on x and y; `spec` is T/m), and the columns of the force effects.
fn force_axis(s: &Series, x: &Smoothed, spec: &[f64], cols: &Cols, a: usize, ch: &mut Channels) {
    let n = s.len();
    let m = &s.model;
    let Smoothed { accel_s, v_body, nav_axes, height, rigid_point, .. } = x;
    let (col, t_mid) = (|e: Effect, j: usize| cols.of(e, j), cols.t_mid);
    let c = Channel::Force.index();
    ch.measured[c][a] = component(accel_s, a);
    ch.predicted[c][a] = (0..n)
        .map(|i| match a {
            2 => -spec[i],
            _ => -m.rotor_drag_per_s[a] * axis(&v_body[i], a),
        })
        .collect();
    ch.columns[c][a].push((col(Effect::AccelBias, a), vec![1.0; n]));
    ch.columns[c][a].push((col(Effect::AccelBiasDrift, a), (0..n).map(|i| s.t_s[i] - t_mid).collect()));
    if a == 2 {
        ch.columns[c][a].push((col(Effect::AccelScale, 0), ch.predicted[c][a].clone()));
    }
    // the accelerometer turned by ε against the gyro and the airframe reads exp([ε]×)·f_m
    for j in 0..2 {
        let e_j = unit(j);
        ch.columns[c][a].push((
            col(Effect::AccelMisalignment, j),
            (0..n)
                .map(|i| {
                    e_j.cross(&Vector3::new(
                        -m.rotor_drag_per_s[0] * v_body[i].x(),
                        -m.rotor_drag_per_s[1] * v_body[i].y(),
                        -spec[i],
                    ))[a]
                })
                .collect(),
        ));
    }
    // thrust along exp([t]×)(−e_z) ≈ −e_z − t × e_z = (−t_y, t_x, −1)
    match a {
        0 => ch.columns[c][a].push((col(Effect::ThrustTilt, 1), spec.iter().map(|x| -x).collect())),
        1 => ch.columns[c][a].push((col(Effect::ThrustTilt, 0), spec.to_vec())),
        _ => {}
    }
    for j in 0..3 {
        ch.columns[c][a]
            .push((col(Effect::ConstantForce, j), nav_axes[j].iter().map(|v| axis(v, a) / m.mass_kg).collect()));
    }
    // the IMU at r from the centre of mass (body FRD): it feels ω̇×r + ω×(ω×r) that the force
    // model's centre-of-mass acceleration lacks (linear in r)
    for j in 0..3 {
        ch.columns[c][a].push((col(Effect::ImuOffset, j), component(&rigid_point[j], a)));
    }
    if a < 2 {
        ch.columns[c][a].push((col(Effect::RotorDrag, a), v_body.iter().map(|v| -axis(v, a)).collect()));
    } else {
        ch.columns[c][a].push((col(Effect::ThrustScale, 0), spec.iter().map(|x| -x).collect()));
        if let Some(vb) = &s.vbat_v {
            ch.columns[c][a]
                .push((col(Effect::ThrustVoltage, 0), (0..n).map(|i| -spec[i] * (vb[i] - m.vbat_ref_v)).collect()));
        }
        let r = m.rotor_radius_m;
        ch.columns[c][a].push((
            col(Effect::GroundEffect, 0),
            (0..n).map(|i| -spec[i] * (r / (4.0 * height[i].max(r))).powi(2)).collect(),
        ));
    }
}

/// The measured signals a leftover residual may follow (see [`Design::signals`]), at the log's
/// rate.
fn lead_signals(s: &Series, x: &Smoothed) -> Vec<Signal> {
    let Smoothed { accel_s, gyro_s, omega_dot, v_body, vel_nav, thrust_s, height, attitude_gap, .. } = x;
    // a signal that carries a channel's own measurement on an axis is no lead for that axis:
    // it correlates with the residual through the sensor's noise (and is the residual itself
    // when the prediction is flat)
    let ka = Channel::AccelKin.index();
    let kf = Channel::Force.index();
    let kg = Channel::Gyro.index();
    let sig = |name: &'static str, v: Vec<f64>, excludes: Vec<(usize, usize)>| Signal {
        name,
        samples: v,
        excludes,
        floor: false,
    };
    let mut signals: Vec<Signal> = vec![
        sig("time (s)", s.t_s.clone(), vec![]),
        sig("speed (m/s)", vel_nav.iter().map(|v| v.norm()).collect(), vec![]),
        sig("body velocity x (m/s)", v_body.iter().map(|v| v.x()).collect(), vec![]),
        sig("body velocity y (m/s)", v_body.iter().map(|v| v.y()).collect(), vec![]),
        sig("body velocity z (m/s)", v_body.iter().map(|v| v.z()).collect(), vec![]),
        sig("body rate norm (rad/s)", gyro_s.iter().map(|w| w.norm()).collect(), vec![(kg, 0), (kg, 1), (kg, 2)]),
        sig("body rate x (rad/s)", gyro_s.iter().map(|w| w.x()).collect(), vec![(kg, 0)]),
        sig("body rate y (rad/s)", gyro_s.iter().map(|w| w.y()).collect(), vec![(kg, 1)]),
        sig("body rate z (rad/s)", gyro_s.iter().map(|w| w.z()).collect(), vec![(kg, 2)]),
        sig("angular acceleration x (rad/s²)", omega_dot.iter().map(|w| w.x()).collect(), vec![]),
        sig("angular acceleration y (rad/s²)", omega_dot.iter().map(|w| w.y()).collect(), vec![]),
        sig("angular acceleration z (rad/s²)", omega_dot.iter().map(|w| w.z()).collect(), vec![]),
        sig("specific force x (m/s²)", accel_s.iter().map(|f| f.x()).collect(), vec![(ka, 0), (kf, 0)]),
        sig("specific force y (m/s²)", accel_s.iter().map(|f| f.y()).collect(), vec![(ka, 1), (kf, 1)]),
        sig("specific force z (m/s²)", accel_s.iter().map(|f| f.z()).collect(), vec![(ka, 2), (kf, 2)]),
        sig("height (m)", height.iter().map(|h| if h.is_finite() { *h } else { 0.0 }).collect(), vec![]),
        // the mocap pose's own error: its attitude error reads in f̂ as −δθ × f (the residual
        // gains (−g·δθ_y, g·δθ_x) in flight), and a pose's position and attitude errors come
        // from the same markers; it carries the gyro's measurement, so it is no lead for the gyro
        Signal {
            floor: true,
            ..sig(
                "mocap attitude − gyro integral x (rad)",
                attitude_gap.iter().map(|v| v.x()).collect(),
                vec![(kg, 0), (kg, 1), (kg, 2)],
            )
        },
        Signal {
            floor: true,
            ..sig(
                "mocap attitude − gyro integral y (rad)",
                attitude_gap.iter().map(|v| v.y()).collect(),
                vec![(kg, 0), (kg, 1), (kg, 2)],
            )
        },
    ];
    if let Some(t) = &thrust_s {
        signals.push(sig("thrust (N)", t.clone(), vec![]));
    }
    if let Some(v) = &s.vbat_v {
        signals.push(sig("battery (V)", v.clone(), vec![]));
    }
    signals
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run of consecutive glitch rows is one glitch: one frame flags three rows, two frames
    /// four; rows two apart are two glitches.
    #[test]
    fn consecutive_glitch_rows_count_once() {
        assert_eq!(glitch_events(&[]), 0);
        assert_eq!(glitch_events(&[5]), 1);
        assert_eq!(glitch_events(&[4, 5, 6]), 1);
        assert_eq!(glitch_events(&[4, 5, 6, 7]), 1);
        assert_eq!(glitch_events(&[1, 3]), 2);
        assert_eq!(glitch_events(&[0, 1, 2, 9, 10, 11, 40]), 3);
    }

    /// A rigid body turning at a constant yaw rate Ω while it swings along north
    /// ([`Series::swing_for_tests`] without its alternation), p(t) = (A·sin νt, 0, −1) m,
    /// R = R_z(Ωt); the IMU reads the exact specific force Rᵀ(p̈ − g·e_D) and rate (0, 0, Ω),
    /// no noise. The smoothed IMU is K*(Rᵀ(p̈ − g·e_D)); the
    /// mocap side must be the same to second order in σ. Rotating the smoothed p̈ instead
    /// (Rᵀ(K*p̈)) misses σ²·ω×(Rᵀ·jerk) + (σ²/2)·ω×(ω×Rᵀp̈): with A = 0.5 m, ν = 2π rad/s,
    /// Ω = 2 rad/s and σ = 20 ms that is 4·10⁻⁴·2·124 ≈ 0.1 m/s². What remains is the second
    /// difference's own error (νΔt)²/12·Aν² ≈ 1.6·10⁻³ m/s² and O(σ⁴) terms.
    #[test]
    fn the_mocap_specific_force_is_rotated_before_it_is_smoothed() {
        let s = Series::swing_for_tests(UnitQuaternion::identity(), 0.0);
        let d = build(&s, &Corrections::default(), &DesignOptions::default());
        let c = Channel::AccelKin.index();
        let mut worst: f64 = 0.0;
        for ax in 0..3 {
            let r = d.residual(c, ax);
            for i in (0..d.n).filter(|&i| d.ok[i]) {
                worst = worst.max(r[i].abs());
            }
        }
        assert!(d.ok.iter().filter(|x| **x).count() > 900, "too few usable samples");
        assert!(worst < 5e-3, "accel_kin residual of an exact rigid body {worst} m/s²");
    }

    /// What a truncated Gaussian passes far above its band, in closed form. Summed by parts,
    /// H(ω) = Σ_{|j|≤h} k_j·e^{iωj} is the response of the two end steps, k_h·sin((2h+1)ω/2) /
    /// sin(ω/2), plus that of the kernel's differences, whose own end steps are h/σ² of k_h
    /// (0.3 at 3σ, 0.5 at 5σ) and add at most (h/σ²)/(2·sin(ω/2)) of the first term: its
    /// envelope is k_h/sin(ω/2) within 45 %, with k_h = e^{−c²/2}/(σ√(2π)) at a cut of c·σ. For
    /// σ = 10 samples (20 ms at 500 Hz) near 100 Hz (ω = 0.4π), that is 7.5·10⁻⁴ at 3σ and
    /// 2.5·10⁻⁷ at 5σ, where the Gaussian itself passes e^{−79}. A cut left at 3σ whatever
    /// `reach_sigmas` says, or a kernel not normalised, moves these by orders of magnitude or
    /// by its sum.
    #[test]
    fn a_cut_gaussian_passes_its_end_steps_above_its_band() {
        let sigma = 10.0;
        let response = |k: &[f64], w: f64| -> f64 {
            let h = (k.len() / 2) as f64;
            k.iter().enumerate().map(|(j, kj)| kj * (w * (j as f64 - h)).cos()).sum::<f64>().abs()
        };
        for (cut, want) in [(3.0, 7.5e-4), (5.0, 2.5e-7)] {
            let k = gaussian_kernel_to(sigma, cut);
            assert_eq!(k.len(), 2 * (cut * sigma) as usize + 1);
            let end = (-cut * cut / 2.0f64).exp() / (sigma * std::f64::consts::TAU.sqrt());
            let envelope = |w: f64| end / (w / 2.0).sin();
            // over 90–110 Hz, more than one period of sin((2h + 1)ω/2), the largest response
            // reaches the envelope at 100 Hz
            let peak = (0..=200)
                .map(|i| std::f64::consts::TAU * (90.0 + 0.1 * i as f64) / 500.0)
                .map(|w| response(&k, w))
                .fold(0.0, f64::max);
            let at_100 = envelope(std::f64::consts::TAU * 100.0 / 500.0);
            assert!((at_100 / want - 1.0).abs() < 0.02, "cut {cut}σ: envelope {at_100:e}, by hand {want:e}");
            assert!((peak / at_100 - 1.0).abs() < 0.45, "cut {cut}σ: peak {peak:e} against the envelope {at_100:e}");
        }
        assert_eq!(gaussian_kernel(sigma), gaussian_kernel_to(sigma, 3.0));
    }

    /// The vector smoothing (all rows, or only some) gives the scalar smoothing's bits on every
    /// axis, and rows outside `need` keep their raw values.
    #[test]
    fn row_smoothing_matches_the_scalar_smoothing_bit_for_bit() {
        let n = 500;
        let x: Vec<Vector3<f64>> = (0..n)
            .map(|i| Vector3::new((i as f64 * 0.37).sin(), (i as f64 * 0.11).cos() * 3.3, i as f64 * 1e-3))
            .collect();
        let (k, segs) = (gaussian_kernel(4.0), [(0, 200), (200, n)]);
        let all = smooth_vec3(&x, &segs, &k);
        let some = smooth_vec3_rows(&x, &segs, &k, |i| i % 3 == 0);
        for c in 0..3 {
            let col: Vec<f64> = x.iter().map(|v| v[c]).collect();
            let mut want = vec![0.0; n];
            smooth_into(&col, &segs, &k, &mut want);
            for i in 0..n {
                assert_eq!(all[i][c].to_bits(), want[i].to_bits(), "row {i} axis {c}");
                let expect = if i % 3 == 0 { want[i] } else { x[i][c] };
                assert_eq!(some[i][c].to_bits(), expect.to_bits(), "row {i} axis {c} (some rows)");
            }
        }
    }
}
