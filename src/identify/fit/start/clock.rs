//! The clock offset between the IMU and the mocap, before anything else is known: the angular
//! speed ‖ω‖ does not depend on how the IMU is mounted against the markers (‖R·ω‖ = ‖ω‖ for any
//! rotation R) nor on the mocap world's tilt (body rates do not see the world), so the gyro's
//! ‖ω_imu(t)‖ and the mocap's ‖ω̂(t_p)‖, from neighbouring poses (the angle of q_k⁻¹·q_{k+1} over
//! their interval, at its midpoint), are the same signal shifted by the offset τ: the pose
//! stamped t_p (mocap clock) was taken at IMU time t_p − τ. τ has the mocap delay's sign: a
//! mocap that is late, or whose clock runs ahead, has τ > 0.
//!
//! Both speeds go onto grids of [`BIN_S`] (averaged over a bin where a stream is denser,
//! interpolated to the bin's centre where it is sparser, left empty across a gap of more than
//! three of its intervals), are smoothed by a Gaussian (σ the larger of 20 ms and the sparser
//! stream's interval), and the Pearson correlation of the overlapping bins is computed at every
//! lag at once by FFT (six correlations: the counts, sums and sums of squares over the overlap).
//! The lag of the highest correlation inside the window, refined by the parabola through it
//! and its neighbours, is the offset; its precision is a few milliseconds, which the fine fit's
//! delay takes from there.
//!
//! The window is where the offset may be: ±[`DEFAULT_HALF_WIDTH_S`] around 0 unless the user says
//! otherwise (`--clock-offset`). When no lag inside it overlaps half of the shorter stream (clocks
//! days apart: a mocap PC's epoch against an IMU's boot time), every lag that does is searched,
//! and the result says so. The best peak outside the main lobe (beyond the minima on either side
//! of the peak) is kept as the runner-up: a motion that repeats can put a second peak almost as
//! high, and then the offset is not determined by this log (the runner-up must leave at least
//! twice the unexplained variance 1 − ρ² of the best).

use super::fft::{correlate, spectrum};
use nalgebra::{UnitQuaternion, Vector3};

/// The grid's step (s).
pub const BIN_S: f64 = 0.01;
/// The default window: the offset is searched within ±this around 0 (s).
pub const DEFAULT_HALF_WIDTH_S: f64 = 5.0;
/// The longest stretch of a stream the search grids (s): 2²⁰ bins, 2.9 h.
pub const MAX_SPAN_S: f64 = (1u64 << 20) as f64 * BIN_S;
/// A stream sampled less often than this (its median interval, s) is not searched.
pub const MAX_INTERVAL_S: f64 = 1.0;
/// A lag is searched only where at least this fraction of the shorter stream's bins overlap.
const MIN_OVERLAP: f64 = 0.5;
/// The correlation at the offset must reach this for the offset to be determined.
pub const MIN_CORRELATION: f64 = 0.5;
/// A runner-up peak that leaves less than this many times the best's unexplained variance
/// (1 − ρ², the share of ‖ω‖'s variance the lag does not explain) leaves the offset
/// undetermined: a motion that repeats explains itself almost as well one period later.
pub const MIN_UNEXPLAINED_RATIO: f64 = 2.0;

/// Where the clock offset is searched: centre ± half-width (s), in the mocap delay's sign.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ClockWindow {
    /// The centre (s): a known coarse offset, 0 by default.
    pub centre_s: f64,
    /// The half-width (s).
    pub half_width_s: f64,
}

impl Default for ClockWindow {
    fn default() -> Self {
        ClockWindow { centre_s: 0.0, half_width_s: DEFAULT_HALF_WIDTH_S }
    }
}

/// A peak of the correlation.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Peak {
    /// The offset there (s).
    pub offset_s: f64,
    /// The correlation of ‖ω_imu‖ with ‖ω̂‖ there.
    pub correlation: f64,
}

/// What the search found.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ClockStart {
    /// The best peak: the offset (s; the pose stamped t_p was taken at IMU time t_p − offset) and
    /// its correlation.
    pub best: Peak,
    /// The best peak outside the main lobe, if the searched range has one.
    pub runner_up: Option<Peak>,
    /// The range of offsets searched (s).
    pub searched_s: [f64; 2],
    /// The window held no lag that overlaps half of the shorter stream (clocks far apart), so
    /// every lag that does was searched.
    pub widened: bool,
    /// The best peak lies on the edge of the searched range: the offset may lie beyond it.
    pub at_edge: bool,
    /// Seconds of the two streams that overlap at the best peak.
    pub overlap_s: f64,
}

impl ClockStart {
    /// The offset is determined: the peak correlates well ([`MIN_CORRELATION`]), every other
    /// peak leaves at least [`MIN_UNEXPLAINED_RATIO`] times its unexplained variance, and it is
    /// not on the edge of the range searched.
    pub fn determined(&self) -> bool {
        let unexplained = |r: f64| 1.0 - r.clamp(-1.0, 1.0).powi(2);
        self.best.correlation >= MIN_CORRELATION
            && !self.at_edge
            && self.runner_up.is_none_or(|r| {
                unexplained(r.correlation) >= MIN_UNEXPLAINED_RATIO * unexplained(self.best.correlation)
            })
    }
}

/// Samples of an angular speed (rad/s) at times on one stream's clock (s).
#[derive(Clone, Debug, Default)]
pub(crate) struct Speeds {
    pub(crate) t_s: Vec<f64>,
    pub(crate) speed: Vec<f64>,
}

impl Speeds {
    /// The gyro's ‖ω‖ at its samples.
    pub(crate) fn of_gyro(t: &[f64], gyro: &[Vector3<f64>]) -> Speeds {
        Speeds { t_s: t.to_vec(), speed: gyro.iter().map(|w| w.norm()).collect() }
    }

    /// The mocap's ‖ω̂‖ between neighbouring seen poses: the angle of q_k⁻¹·q_{k+1} over their
    /// interval, at its midpoint (a pose not seen breaks the pair).
    pub(crate) fn of_poses(t: &[f64], att: &[UnitQuaternion<f64>], seen: &[bool]) -> Speeds {
        let mut out = Speeds::default();
        for k in 1..t.len() {
            let dt = t[k] - t[k - 1];
            if seen[k] && seen[k - 1] && dt > 0.0 {
                out.t_s.push(0.5 * (t[k] + t[k - 1]));
                out.speed.push(att[k - 1].angle_to(&att[k]) / dt);
            }
        }
        out
    }

    fn median_interval(&self) -> f64 {
        crate::log::median_interval(&self.t_s).unwrap_or(BIN_S)
    }
}

/// A stream's speed on the grid: the first bin's centre (s, its own clock) and one value per
/// bin (NaN: no data).
struct Grid {
    t0: f64,
    v: Vec<f64>,
}

/// `x` on a grid of [`BIN_S`]: the mean of a bin's samples where the stream is denser than the
/// grid, the linear interpolation at the bin's centre where it is sparser; across a gap of more
/// than three of the stream's intervals, empty. Only the first [`MAX_SPAN_S`] of the stream is
/// gridded: the grid and its spectra grow with the span, not with the samples, and a stamp
/// years after the others (a corrupted row) would otherwise ask for more memory than exists.
fn to_grid(x: &Speeds) -> Option<Grid> {
    let first = *x.t_s.first()?;
    let kept = x.t_s.partition_point(|t| *t - first <= MAX_SPAN_S);
    let x = &Speeds { t_s: x.t_s[..kept].to_vec(), speed: x.speed[..kept].to_vec() };
    let last = *x.t_s.last()?;
    let dt = x.median_interval();
    let n = ((last - first) / BIN_S).floor() as usize + 1;
    let t0 = first + 0.5 * BIN_S;
    let mut v = vec![f64::NAN; n];
    let gap = 3.0 * dt;
    if dt < BIN_S {
        let mut sum = vec![0.0; n];
        let mut count = vec![0usize; n];
        for (t, s) in x.t_s.iter().zip(&x.speed) {
            let b = (((t - first) / BIN_S).floor() as usize).min(n - 1);
            sum[b] += s;
            count[b] += 1;
        }
        for b in 0..n {
            if count[b] > 0 {
                v[b] = sum[b] / count[b] as f64;
            }
        }
        // an empty bin between two filled ones less than a gap apart is their interpolation
        let filled: Vec<usize> = (0..n).filter(|b| count[*b] > 0).collect();
        for w in filled.windows(2) {
            let (a, b) = (w[0], w[1]);
            if b > a + 1 && (b - a) as f64 * BIN_S <= gap {
                for k in a + 1..b {
                    let f = (k - a) as f64 / (b - a) as f64;
                    v[k] = v[a] * (1.0 - f) + v[b] * f;
                }
            }
        }
    } else {
        let mut j = 0;
        for (b, slot) in v.iter_mut().enumerate() {
            let t = t0 + b as f64 * BIN_S;
            while j + 1 < x.t_s.len() && x.t_s[j + 1] < t {
                j += 1;
            }
            if j + 1 < x.t_s.len() && x.t_s[j] <= t && x.t_s[j + 1] - x.t_s[j] <= gap {
                let f = (t - x.t_s[j]) / (x.t_s[j + 1] - x.t_s[j]);
                *slot = x.speed[j] * (1.0 - f) + x.speed[j + 1] * f;
            }
        }
    }
    Some(Grid { t0, v })
}

/// A Gaussian of σ `sigma_bins` over the bins that hold data (normalised convolution); a bin
/// whose kernel sees data for less than half its weight is empty.
fn smooth(v: &[f64], sigma_bins: f64) -> Vec<f64> {
    let k = crate::identify::fit::design::gaussian_kernel(sigma_bins);
    let h = (k.len() / 2) as isize;
    let n = v.len() as isize;
    (0..n)
        .map(|i| {
            let (mut s, mut w) = (0.0, 0.0);
            for (j, kj) in k.iter().enumerate() {
                let m = i + j as isize - h;
                if m >= 0 && m < n && v[m as usize].is_finite() {
                    s += kj * v[m as usize];
                    w += kj;
                }
            }
            if w >= 0.5 { s / w } else { f64::NAN }
        })
        .collect()
}

/// The offset at which the gyro's speed `imu` and the mocap's `mocap` agree best inside
/// `window`; `mocap_origin_s` is where the mocap clock's zero lies on the IMU clock's (s: 0 when
/// both streams' times are already on one clock). `None` when either stream has no speed or
/// is sampled less often than every [`MAX_INTERVAL_S`].
pub(crate) fn search(imu: &Speeds, mocap: &Speeds, mocap_origin_s: f64, window: &ClockWindow) -> Option<ClockStart> {
    let sigma_s = 0.02f64.max(mocap.median_interval()).max(imu.median_interval());
    // a speed sampled once a second or less says nothing of an offset of a fraction of one, and
    // its smoothing kernel would span the grid
    if sigma_s > MAX_INTERVAL_S {
        return None;
    }
    let (gi, gm) = (to_grid(imu)?, to_grid(mocap)?);
    let (a, b) = (smooth(&gi.v, sigma_s / BIN_S), smooth(&gm.v, sigma_s / BIN_S));
    let (na, nb) = (a.len(), b.len());
    let n = (na + nb).next_power_of_two();
    let mask = |x: &[f64]| x.iter().map(|v| f64::from(u8::from(v.is_finite()))).collect::<Vec<f64>>();
    let value = |x: &[f64], p: i32| x.iter().map(|v| if v.is_finite() { v.powi(p) } else { 0.0 }).collect::<Vec<f64>>();
    let (ma, xa, xa2) = (spectrum(&mask(&a), n), spectrum(&value(&a, 1), n), spectrum(&value(&a, 2), n));
    let (mb, yb, yb2) = (spectrum(&mask(&b), n), spectrum(&value(&b, 1), n), spectrum(&value(&b, 2), n));
    let (count, sx, sy) = (correlate(&ma, &mb), correlate(&xa, &mb), correlate(&ma, &yb));
    let (sxx, syy, sxy) = (correlate(&xa2, &mb), correlate(&ma, &yb2), correlate(&xa, &yb));
    // lag L pairs IMU bin i with mocap bin i + L: τ = (mocap t0 on the IMU clock) − IMU t0 + L·h
    let tau0 = gm.t0 + mocap_origin_s - gi.t0;
    let at = |l: isize| l.rem_euclid(n as isize) as usize;
    let shorter = mask(&a).iter().sum::<f64>().min(mask(&b).iter().sum::<f64>());
    let lags: Vec<isize> = (-(na as isize - 1)..nb as isize).collect();
    let overlapping = |l: isize| count[at(l)].round() >= (MIN_OVERLAP * shorter).max(2.0);
    let (lo, hi) = (window.centre_s - window.half_width_s, window.centre_s + window.half_width_s);
    let in_window = |l: isize| {
        let tau = tau0 + l as f64 * BIN_S;
        tau >= lo && tau <= hi
    };
    let mut allowed: Vec<isize> = lags.iter().copied().filter(|l| in_window(*l) && overlapping(*l)).collect();
    let widened = allowed.is_empty();
    if widened {
        allowed = lags.iter().copied().filter(|l| overlapping(*l)).collect();
    }
    let pearson = |l: isize| -> f64 {
        let k = at(l);
        let m = count[k].round();
        let vx = sxx[k] - sx[k] * sx[k] / m;
        let vy = syy[k] - sy[k] * sy[k] / m;
        let c = sxy[k] - sx[k] * sy[k] / m;
        if vx > 0.0 && vy > 0.0 { c / (vx * vy).sqrt() } else { 0.0 }
    };
    let (first, last) = (*allowed.first()?, *allowed.last()?);
    let r: Vec<f64> = (first..=last).map(pearson).collect();
    let ok = |l: isize| l >= first && l <= last && allowed.binary_search(&l).is_ok();
    let rr = |l: isize| r[(l - first) as usize];
    let best = allowed.iter().copied().max_by(|x, y| rr(*x).total_cmp(&rr(*y)).then(y.cmp(x)))?;
    // the parabola through the peak and its neighbours
    let frac = if ok(best - 1) && ok(best + 1) {
        let (m, z, p) = (rr(best - 1), rr(best), rr(best + 1));
        let d = m - 2.0 * z + p;
        if d < 0.0 { (0.5 * (m - p) / d).clamp(-0.5, 0.5) } else { 0.0 }
    } else {
        0.0
    };
    // the main lobe: down from the peak to the minima on either side
    let (mut left, mut right) = (best, best);
    while ok(left - 1) && rr(left - 1) <= rr(left) {
        left -= 1;
    }
    while ok(right + 1) && rr(right + 1) <= rr(right) {
        right += 1;
    }
    let runner_up = allowed
        .iter()
        .copied()
        .filter(|l| {
            (*l < left || *l > right) && (!ok(l - 1) || rr(l - 1) <= rr(*l)) && (!ok(l + 1) || rr(l + 1) <= rr(*l))
        })
        .max_by(|x, y| rr(*x).total_cmp(&rr(*y)))
        .map(|l| Peak { offset_s: tau0 + l as f64 * BIN_S, correlation: rr(l) });
    let tau = |l: f64| tau0 + l * BIN_S;
    Some(ClockStart {
        best: Peak { offset_s: tau(best as f64 + frac), correlation: rr(best) },
        runner_up,
        searched_s: [tau(first as f64), tau(last as f64)],
        widened,
        at_edge: !ok(best - 1) || !ok(best + 1),
        overlap_s: count[at(best)].round() * BIN_S,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand's angular speed: 1 rad/s plus twelve tones of 0.2–3 Hz and 0.1 rad/s each, their
    /// frequencies and phases from a fixed linear congruential sequence (no two lags of a
    /// minute repeat the sum).
    fn speed(t: f64) -> f64 {
        let mut state = 12_345u64;
        let mut next = || {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        1.0 + (0..12)
            .map(|_| {
                let (f, p) = (0.2 + 2.8 * next(), std::f64::consts::TAU * next());
                0.1 * (std::f64::consts::TAU * f * t + p).sin()
            })
            .sum::<f64>()
    }

    fn streams(offset_s: f64, mocap_origin_s: f64) -> (Speeds, Speeds) {
        // IMU at 400 Hz for 60 s; mocap at 120 Hz, its stamps t_p = t + offset on its own clock,
        // whose zero is mocap_origin_s on the IMU's
        let imu_t: Vec<f64> = (0..24_000).map(|i| i as f64 / 400.0).collect();
        let imu = Speeds { speed: imu_t.iter().map(|t| speed(*t)).collect(), t_s: imu_t };
        let mocap_t: Vec<f64> = (0..7_200).map(|i| i as f64 / 120.0).collect();
        // the mocap sample stamped t_p (its clock) on the IMU clock is mocap_origin_s + t_p, and
        // was taken at IMU time mocap_origin_s + t_p − offset
        let mocap =
            Speeds { speed: mocap_t.iter().map(|t| speed(mocap_origin_s + t - offset_s)).collect(), t_s: mocap_t };
        (imu, mocap)
    }

    /// A sample stamped 6·10⁹ s after the rest (a corrupted row of a mapped log) adds no bins:
    /// the grid ends at the last sample within [`MAX_SPAN_S`] (2²⁰ bins of 10 ms, 10,485.76 s) of
    /// the first, 6,000 bins for a minute, where gridding the stamp would ask for 6·10¹¹ (4.8 TB,
    /// an abort), and the offset of the minute is still found. A sample 3 h in is beyond the
    /// limit too (a limit of 2²⁰ s would take it in).
    #[test]
    fn a_stamp_years_after_the_rest_does_not_grow_the_grid() {
        assert_eq!(MAX_SPAN_S, 10_485.76);
        let (mut imu, mocap) = streams(0.2, 0.0);
        imu.t_s.extend([10_800.0, 6e9]);
        imu.speed.extend([1.0, 1.0]);
        assert_eq!(to_grid(&imu).unwrap().v.len(), 6_000);
        let c = search(&imu, &mocap, 0.0, &ClockWindow::default()).unwrap();
        assert!((c.best.offset_s - 0.2).abs() < 0.1 * BIN_S && c.determined(), "{c:?}");
    }

    /// A stream whose samples lie 10⁹ s apart is not searched (`None`): its smoothing kernel,
    /// 3σ each side with σ its interval, would hold 6·10¹¹ taps (an abort); at a second apart
    /// it still is.
    #[test]
    fn a_stream_sampled_years_apart_is_not_searched() {
        let (imu, _) = streams(0.0, 0.0);
        let sparse =
            |dt: f64| Speeds { t_s: (0..5).map(|i| i as f64 * dt).collect(), speed: vec![1.0, 2.0, 1.5, 0.5, 1.0] };
        assert_eq!(search(&imu, &sparse(1e9), 0.0, &ClockWindow::default()), None);
        assert!(search(&imu, &sparse(MAX_INTERVAL_S), 0.0, &ClockWindow::default()).is_some());
    }

    /// Offsets of 0.2 s, −3.17 s and 12 ms are found to a tenth of the grid, with a clear
    /// runner-up margin; the searched range is the window.
    #[test]
    fn the_offset_is_the_lag_of_the_best_correlation() {
        for offset in [0.2, -3.17, 0.012] {
            let (imu, mocap) = streams(offset, 0.0);
            let c = search(&imu, &mocap, 0.0, &ClockWindow::default()).unwrap();
            assert!((c.best.offset_s - offset).abs() < 0.1 * BIN_S, "{offset}: {c:?}");
            assert!(c.best.correlation > 0.99 && c.determined() && !c.widened, "{c:?}");
            assert!((c.searched_s[0] + 5.0).abs() <= BIN_S && (c.searched_s[1] - 5.0).abs() <= BIN_S, "{c:?}");
        }
    }

    /// The offset outside the window is not found inside it: a 7 s offset searched within ±5 s
    /// peaks on the edge, and says so (not determined); the window centred on 7 finds it.
    #[test]
    fn an_offset_beyond_the_window_is_not_taken_for_one_inside() {
        let (imu, mocap) = streams(7.0, 0.0);
        let c = search(&imu, &mocap, 0.0, &ClockWindow::default()).unwrap();
        assert!(!c.determined(), "{c:?}");
        let c = search(&imu, &mocap, 0.0, &ClockWindow { centre_s: 7.0, half_width_s: 1.0 }).unwrap();
        assert!((c.best.offset_s - 7.0).abs() < 0.1 * BIN_S && c.determined(), "{c:?}");
    }

    /// Clocks 10⁶ s apart (the mocap's zero 10⁶ s after the IMU's, the mocap 0.25 s late on
    /// top): no lag in the default window overlaps, so every overlapping lag is searched.
    #[test]
    fn clocks_far_apart_widen_the_search() {
        let (imu, mocap) = streams(0.25, 0.0);
        // the same mocap samples, stamped on a clock whose zero lies 10⁶ s later
        let c = search(&imu, &mocap, 1e6, &ClockWindow::default()).unwrap();
        assert!(c.widened && c.determined(), "{c:?}");
        assert!((c.best.offset_s - (1e6 + 0.25)).abs() < 0.1 * BIN_S, "{c:?}");
    }

    /// A motion that repeats every 2 s correlates as well at ±2 s as at the offset: the
    /// runner-up is as high as the best, and the offset is not determined.
    #[test]
    fn a_repeating_motion_leaves_the_offset_undetermined() {
        let periodic = |t: f64| 1.0 + 0.6 * (std::f64::consts::PI * t).sin();
        let imu_t: Vec<f64> = (0..24_000).map(|i| i as f64 / 400.0).collect();
        let imu = Speeds { speed: imu_t.iter().map(|t| periodic(*t)).collect(), t_s: imu_t };
        let mocap_t: Vec<f64> = (0..7_200).map(|i| i as f64 / 120.0).collect();
        let mocap = Speeds { speed: mocap_t.iter().map(|t| periodic(t - 0.3)).collect(), t_s: mocap_t };
        let c = search(&imu, &mocap, 0.0, &ClockWindow::default()).unwrap();
        let r = c.runner_up.unwrap();
        assert!(1.0 - r.correlation.powi(2) < MIN_UNEXPLAINED_RATIO * (1.0 - c.best.correlation.powi(2)), "{c:?}");
        assert!(!c.determined(), "{c:?}");
    }

    /// A gap in the mocap (3 s not seen) is left empty, not bridged: the offset still comes out.
    #[test]
    fn a_gap_in_the_mocap_is_not_bridged() {
        let (imu, mut mocap) = streams(-0.4, 0.0);
        let keep: Vec<bool> = mocap.t_s.iter().map(|t| !(20.0..23.0).contains(t)).collect();
        let pick = |v: &[f64]| v.iter().zip(&keep).filter(|x| *x.1).map(|x| *x.0).collect::<Vec<f64>>();
        mocap = Speeds { t_s: pick(&mocap.t_s), speed: pick(&mocap.speed) };
        let g = to_grid(&mocap).unwrap();
        let empty = g.v.iter().filter(|v| v.is_nan()).count() as f64 * BIN_S;
        assert!((empty - 3.0).abs() < 0.05, "{empty}");
        let c = search(&imu, &mocap, 0.0, &ClockWindow::default()).unwrap();
        assert!((c.best.offset_s + 0.4).abs() < 0.1 * BIN_S, "{c:?}");
    }
}
