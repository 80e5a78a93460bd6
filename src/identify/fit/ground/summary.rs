//! Over several flights: the spin-up, the rest after landing and the still pose's scatter
//! summarised per axis, with the rank and sign tests they rest on.

use super::agreement::{CheckAxis, GroundAgreement, LandedAgreement, LandedAxis, SpinUpAgreement, TiltAgreement};
use crate::identify::fit::stats;

/// Over several flights: is the rest or the spin-up the ground check a flight agrees with, per
/// axis? If the spinning rotors add an offset that the flights carry too (in flight it reads as a
/// tilt), the spin-up moves the ground check toward the flight: the sign test counts the flights
/// where spin-up − rest points the way flight − rest does (p: one-sided binomial, ½ under "the
/// change is unrelated to the flight").
#[derive(Clone, Debug, serde::Serialize)]
pub struct SpinUpSummary {
    /// Flights with a spin-up.
    pub flights: usize,
    /// Roll over the flights.
    pub roll: SpinUpAxisSummary,
    /// Pitch over the flights.
    pub pitch: SpinUpAxisSummary,
}

/// One axis of [`SpinUpSummary`] (degrees).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SpinUpAxisSummary {
    /// Median |rest − bias tilt − flight| over the flights with a spin-up.
    pub median_rest_deg: f64,
    /// Median |spin-up − bias tilt − flight|.
    pub median_spin_up_deg: f64,
    /// Flights where the spin-up's change points toward the flight.
    pub toward_flight: usize,
    /// P(≥ toward_flight of `flights` by chance), each flight ½.
    pub sign_test_p: f64,
}

/// The summary over the agreements that have a spin-up; `None` when fewer than 3 do.
pub fn spin_up_summary<'a>(agreements: impl IntoIterator<Item = &'a GroundAgreement>) -> Option<SpinUpSummary> {
    let pairs: Vec<(&GroundAgreement, &SpinUpAgreement)> =
        agreements.into_iter().filter_map(|a| Some((a, a.spin_up.as_ref()?))).collect();
    let n = pairs.len();
    if n < 3 {
        return None;
    }
    let axis = |pick: fn(&GroundAgreement) -> &TiltAgreement, pick_spin: fn(&SpinUpAgreement) -> &CheckAxis| {
        let rest: Vec<f64> = pairs.iter().map(|(a, _)| pick(a).difference_deg.abs()).collect();
        let spin: Vec<f64> = pairs.iter().map(|(_, sp)| pick_spin(sp).difference_deg.abs()).collect();
        // the flight lies at rest − difference: toward it is a change of the opposite sign
        let toward = pairs.iter().filter(|(a, sp)| pick_spin(sp).change_deg * pick(a).difference_deg < 0.0).count();
        SpinUpAxisSummary {
            median_rest_deg: stats::median(rest).unwrap_or(f64::NAN),
            median_spin_up_deg: stats::median(spin).unwrap_or(f64::NAN),
            toward_flight: toward,
            sign_test_p: binomial_upper_tail(n, toward),
        }
    };
    Some(SpinUpSummary { flights: n, roll: axis(|a| &a.roll, |s| &s.roll), pitch: axis(|a| &a.pitch, |s| &s.pitch) })
}

/// Over several flights: the two rests that bracket each flight, against each other and
/// against the flight (degrees). The reference of a flight is the mean of its rests where the
/// log has both, else the rest before take-off.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LandedSummary {
    /// Flights with a ground agreement, and those with a rest after landing too.
    pub flights: usize,
    /// Flights with both rests.
    pub with_both: usize,
    /// Roll over the flights.
    pub roll: LandedAxisSummary,
    /// Pitch over the flights.
    pub pitch: LandedAxisSummary,
}

/// One axis of [`LandedSummary`].
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LandedAxisSummary {
    /// Median and largest |after − before| over the flights with both rests: the ground check's
    /// own repeatability over one flight.
    pub median_change_deg: f64,
    /// Largest |after − before|.
    pub max_change_deg: f64,
    /// Over the flights with both rests: median |before − flight| and |mean of the rests − flight|.
    pub median_before_deg: f64,
    /// Median |mean of the two rests − flight|.
    pub median_bracket_deg: f64,
    /// Flights whose frame tilt lies between their two rests (their differences of opposite sign).
    pub between: usize,
    /// Over every flight, with its reference: median |reference − flight|, how many beyond 1°,
    /// and how many of those the reference's interval covers.
    pub median_reference_deg: f64,
    /// Flights whose |reference − flight| exceeds 1°.
    pub beyond_1deg: usize,
    /// Of those, the ones whose interval covers the difference.
    pub beyond_1deg_covered: usize,
}

/// The summary over the agreements; `None` when fewer than 3 have a rest after landing.
pub fn landed_summary<'a>(agreements: impl IntoIterator<Item = &'a GroundAgreement>) -> Option<LandedSummary> {
    let all: Vec<&GroundAgreement> = agreements.into_iter().collect();
    let both: Vec<(&GroundAgreement, &LandedAgreement)> =
        all.iter().filter_map(|a| Some((*a, a.after_landing.as_ref()?))).collect();
    if both.len() < 3 {
        return None;
    }
    let median = |v: Vec<f64>| stats::median(v).unwrap_or(f64::NAN);
    let axis = |pick: fn(&GroundAgreement) -> &TiltAgreement, pick_l: fn(&LandedAgreement) -> &LandedAxis| {
        let reference = |a: &GroundAgreement| match &a.after_landing {
            Some(l) => (pick_l(l).bracket_difference_deg, pick_l(l).bracket_covers),
            None => (pick(a).difference_deg, pick(a).covers),
        };
        let beyond: Vec<(f64, bool)> = all.iter().map(|a| reference(a)).filter(|(d, _)| d.abs() > 1.0).collect();
        LandedAxisSummary {
            median_change_deg: median(both.iter().map(|(_, l)| pick_l(l).check.change_deg.abs()).collect()),
            max_change_deg: both.iter().map(|(_, l)| pick_l(l).check.change_deg.abs()).fold(0.0, f64::max),
            median_before_deg: median(both.iter().map(|(a, _)| pick(a).difference_deg.abs()).collect()),
            median_bracket_deg: median(both.iter().map(|(_, l)| pick_l(l).bracket_difference_deg.abs()).collect()),
            // before − flight and after − flight of opposite signs
            between: both.iter().filter(|(a, l)| pick(a).difference_deg * pick_l(l).check.difference_deg < 0.0).count(),
            median_reference_deg: median(all.iter().map(|a| reference(a).0.abs()).collect()),
            beyond_1deg: beyond.len(),
            beyond_1deg_covered: beyond.iter().filter(|(_, c)| *c).count(),
        }
    };
    Some(LandedSummary {
        flights: all.len(),
        with_both: both.len(),
        roll: axis(|a| &a.roll, |l| &l.roll),
        pitch: axis(|a| &a.pitch, |l| &l.pitch),
    })
}

/// Over several flights: do the flights whose still pose scatters at rest
/// ([`GroundAgreement::rest_pose_scatters`]) disagree with the ground check more than the
/// others? Per axis, the median |rest − bias tilt − flight| of each group, the flights beyond 1°
/// (and how many of them their interval covers), and the one-sided Mann–Whitney p of "the
/// scattering flights' differences are larger" (normal approximation, ties averaged).
#[derive(Clone, Debug, serde::Serialize)]
pub struct RestPoseSummary {
    /// Flights whose still pose scatters.
    pub scattering: usize,
    /// Flights whose still pose does not.
    pub still: usize,
    /// Roll over the two groups.
    pub roll: RestPoseAxisSummary,
    /// Pitch over the two groups.
    pub pitch: RestPoseAxisSummary,
}

/// One axis of [`RestPoseSummary`] (degrees).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct RestPoseAxisSummary {
    /// Median |difference| over the still flights.
    pub median_still_deg: f64,
    /// Median |difference| over the scattering flights.
    pub median_scattering_deg: f64,
    /// Still flights beyond 1°.
    pub still_beyond_1deg: usize,
    /// Of those, the ones whose interval covers the difference.
    pub still_beyond_1deg_covered: usize,
    /// Scattering flights beyond 1°.
    pub scattering_beyond_1deg: usize,
    /// One-sided Mann–Whitney p (normal approximation, ties averaged).
    pub mann_whitney_p: f64,
}

/// The summary; `None` unless both groups have at least 2 flights.
pub fn rest_pose_summary<'a>(agreements: impl IntoIterator<Item = &'a GroundAgreement>) -> Option<RestPoseSummary> {
    let all: Vec<&GroundAgreement> = agreements.into_iter().collect();
    let (hi, lo): (Vec<&GroundAgreement>, Vec<&GroundAgreement>) = all.iter().partition(|a| a.rest_pose_scatters);
    if hi.len() < 2 || lo.len() < 2 {
        return None;
    }
    let median = |v: Vec<f64>| stats::median(v).unwrap_or(f64::NAN);
    let axis = |pick: fn(&GroundAgreement) -> &TiltAgreement| {
        let d = |g: &[&GroundAgreement]| g.iter().map(|a| pick(a).difference_deg.abs()).collect::<Vec<f64>>();
        let beyond = |g: &[&GroundAgreement]| {
            g.iter().filter(|a| pick(a).difference_deg.abs() > 1.0).map(|a| pick(a).covers).collect::<Vec<bool>>()
        };
        RestPoseAxisSummary {
            median_still_deg: median(d(&lo)),
            median_scattering_deg: median(d(&hi)),
            still_beyond_1deg: beyond(&lo).len(),
            still_beyond_1deg_covered: beyond(&lo).iter().filter(|c| **c).count(),
            scattering_beyond_1deg: beyond(&hi).len(),
            mann_whitney_p: mann_whitney_greater(&d(&hi), &d(&lo)),
        }
    };
    Some(RestPoseSummary { scattering: hi.len(), still: lo.len(), roll: axis(|a| &a.roll), pitch: axis(|a| &a.pitch) })
}

/// Pooled samples up to this size get the exact permutation distribution of U; larger ones the
/// normal approximation (R's `wilcox.test` draws the line at 50 too).
const MANN_WHITNEY_EXACT_MAX_N: usize = 50;

/// One-sided Mann–Whitney test that `a` tends to be larger than `b`: U = R_a − n_a(n_a + 1)/2
/// (R_a the rank sum of `a` in the pooled sample, ties given their average rank); returns
/// P(U′ ≥ U) under "both come from one distribution", where every choice of n_a of the pooled
/// ranks for `a` is equally likely.
///
/// Up to [`MANN_WHITNEY_EXACT_MAX_N`] pooled samples that probability is exact: the number of
/// n_a-subsets of the (mid)ranks with each rank sum, counted by dynamic programming over doubled
/// ranks (integers even with ties), divided by C(n, n_a); 3 against 6 has 84 subsets, so its
/// smallest p is 1/84. Above it, U ~ N(n_a·n_b/2, n_a·n_b·(n + 1)/12 − tie term), P(Z ≥ z) (no
/// continuity correction), through χ²₁: P(Z ≥ z) = ½·P(χ²₁ ≥ z²) for z ≥ 0.
pub(super) fn mann_whitney_greater(a: &[f64], b: &[f64]) -> f64 {
    let (na, nb) = (a.len() as f64, b.len() as f64);
    let mut pooled: Vec<(f64, bool)> = a.iter().map(|x| (*x, true)).chain(b.iter().map(|x| (*x, false))).collect();
    pooled.sort_by(|x, y| x.0.total_cmp(&y.0));
    let (mut rank_a, mut ties) = (0.0, 0.0);
    // doubled ranks, integers: each run of equal values shares the mean of its ranks start + 1 ..= start + t
    let mut ranks2: Vec<usize> = Vec::with_capacity(pooled.len());
    let mut start = 0usize;
    for run in pooled.chunk_by(|x, y| x.0 == y.0) {
        let t = run.len() as f64;
        let rank = start as f64 + (t + 1.0) / 2.0;
        ties += t * t * t - t;
        rank_a += rank * run.iter().filter(|p| p.1).count() as f64;
        ranks2.extend(std::iter::repeat_n(2 * start + run.len() + 1, run.len()));
        start += run.len();
    }
    if a.is_empty() || b.is_empty() {
        return 1.0;
    }
    if pooled.len() <= MANN_WHITNEY_EXACT_MAX_N {
        return exact_rank_sum_tail(&ranks2, a.len(), (2.0 * rank_a).round() as usize);
    }
    let u = rank_a - na * (na + 1.0) / 2.0;
    let nn = na + nb;
    let var = na * nb / 12.0 * ((nn + 1.0) - ties / (nn * (nn - 1.0)));
    if var <= 0.0 {
        return 1.0;
    }
    let z = (u - na * nb / 2.0) / var.sqrt();
    let tail = 0.5 * stats::chi2_sf(z * z, 1.0);
    if z >= 0.0 { tail } else { 1.0 - tail }
}

/// The share of the k-subsets of `ranks2` (doubled ranks) whose sum is at least `observed2`:
/// count[j][s], the number of j-subsets of the ranks seen so far with doubled sum s, grows one
/// rank at a time (count[j][s] += count[j − 1][s − r], j downwards), then the tail is summed.
fn exact_rank_sum_tail(ranks2: &[usize], k: usize, observed2: usize) -> f64 {
    let max_sum: usize = ranks2.iter().sum();
    let mut count = vec![vec![0.0f64; max_sum + 1]; k + 1];
    count[0][0] = 1.0;
    for &r in ranks2 {
        for j in (1..=k).rev() {
            let (lower, upper) = count.split_at_mut(j);
            for s in (r..=max_sum).rev() {
                upper[0][s] += lower[j - 1][s - r];
            }
        }
    }
    let total: f64 = count[k].iter().sum();
    count[k][observed2.min(max_sum + 1)..].iter().sum::<f64>() / total
}

/// P(X ≥ k) for X ~ Binomial(n, ½).
pub(super) fn binomial_upper_tail(n: usize, k: usize) -> f64 {
    let mut c = 1.0f64; // C(n, 0)
    let mut sum = 0.0;
    for i in 0..=n {
        if i >= k {
            sum += c;
        }
        c = c * (n - i) as f64 / (i + 1) as f64;
    }
    sum / 2f64.powi(n as i32)
}
