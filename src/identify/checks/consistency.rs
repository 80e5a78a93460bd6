//! Consistency across flights: flights that share a marker mounting must give the same body
//! offset, and one flight's model must lower the other's error where the mounting is shared
//! (and not where it is not).
//!
//! ## Mountings from the ground check
//! The ground check (see [`crate::identify::fit::ground`]) reads the tilt between the accelerometer and the
//! markers at rest, independently of the flight fit. Two flights belong to one mounting when
//! their ground tilts (roll, pitch) are within `link_deg` of each other, and a mounting is a
//! group of flights *every two* of which are (complete linkage: the groups do not depend on the
//! order of the flights, and each reports its largest ground distance). Connected links (single
//! linkage) chained 55 of 69 held-out NanoBench flights into one group spanning 2.7°, whose
//! offsets then disagreed: the ground tilt there jumps between a few states from one flight to
//! the next, and a chain of close flights joined them all. The default 0.5° is about the ground tilt that an accelerometer
//! offset change of 0.085 m/s² (8.7 mg, a turn-on-to-turn-on repeatability of MEMS
//! accelerometers) produces: closer than that, the ground check cannot tell two mountings
//! apart. Flights without a ground check are in no group.
//!
//! ## Agreement inside a mounting
//! Per axis (roll, pitch, yaw of the body offset, degrees), with σ_i = half-width_i / 1.96:
//!   x̄ = Σ x_i/σ_i² / Σ 1/σ_i²,   χ² = Σ ((x_i − x̄)/σ_i)²,   p = P(χ²_{k−1} > χ²).
//! The offsets agree within their intervals when p ≥ 0.05. A flight whose offset is not
//! identifiable (no interval) or not fitted is left out of that test and named.
//!
//! ## Transfer
//! From the cross-validation matrix (the model fitted on flight i applied to flight j, the cut
//! of flight j's accel_kin error; j's samples are not in i's fit): the median cut over pairs
//! i ≠ j in the same mounting against the median over pairs in different mountings. The whole
//! model transfers partly everywhere (a lever arm, a delay are properties of the vehicle), so
//! the offset's own share is measured too: the cut of i's model minus the cut of i's model
//! without its body offset, on flight j. Inside a mounting it should be positive (one flight's
//! offset lowers another's error); across mountings it need not be negative, because a part of
//! every offset may be common to all mountings (an IMU board tilted against the marker plane
//! the same way whatever the markers do). So the mounting's own part is measured as well: the
//! cut of i's model minus the cut of i's model with the *fleet's* offset in place of its own,
//! the mean rotation vector of the other fitted flights' offsets (flight j left out of that
//! mean, so that j's own offset cannot help). Inside a mounting it should be positive, across
//! mountings not: i's offset beats the fleet's only where i and j share the markers (across
//! mountings that are really one marker state split by the link, about zero).

use crate::effects::Effect;
use crate::frames::{Body, MocapBody, Rot};
use crate::identify::fit::select::{MIN_TRAIN_SAMPLES, Report};
use crate::identify::fit::stats::median;
use crate::identify::fit::stats::{Z_975, chi2_sf};

/// Ground tilts closer than this (deg) are one mounting, by default.
pub(crate) const LINK_DEG: f64 = 0.5;
/// Offsets agree inside a mounting when the χ² test gives p at least this.
pub const AGREE_P: f64 = 0.05;

/// One axis of the body offset inside one mounting.
#[derive(Clone, Debug, serde::Serialize)]
pub struct AxisAgreement {
    /// "roll", "pitch" or "yaw".
    pub axis: &'static str,
    /// Flights that entered the test (index into the flights).
    pub flights: Vec<usize>,
    /// Inverse-variance weighted mean (deg).
    pub mean_deg: f64,
    /// Largest minus smallest offset (deg).
    pub spread_deg: f64,
    /// χ² of the offsets about their weighted mean, Σ (x_i − x̄)²/σ_i².
    pub chi2: f64,
    /// Degrees of freedom of the χ² (flights − 1).
    pub dof: usize,
    /// P(χ²_dof ≥ chi2): the chance of a spread this large if every flight has the same offset.
    pub p: f64,
    /// p ≥ [`AGREE_P`]: the offsets agree within their intervals.
    pub agree: bool,
}

/// One mounting: a group of flights whose ground tilts link.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Mounting {
    /// Its flights (indices into [`Consistency::flights`]).
    pub flights: Vec<usize>,
    /// Largest ground-tilt distance between two of its flights (deg).
    pub ground_spread_deg: f64,
    /// Per axis of the body offset, when at least two flights have an interval on it.
    pub axes: Vec<AxisAgreement>,
    /// Flights left out of the agreement test, and why.
    pub left_out: Vec<(usize, OffsetMissing)>,
}

/// Why a flight of a mounting has no body offset to compare: data to match on; `Display` gives
/// the sentence (the JSON holds it too).
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum OffsetMissing {
    /// Too few usable samples to fit anything.
    NothingFitted {
        /// Usable training samples.
        usable: usize,
        /// Samples needed ([`MIN_TRAIN_SAMPLES`]).
        needed: usize,
    },
    /// The offset about this axis was fitted but has no interval.
    NotIdentifiable {
        /// `roll`, `pitch` or `yaw`.
        axis: &'static str,
    },
    /// The fit has no body offset (it was neither selected nor named with `--with`).
    NotFitted,
}

/// The consistency report of a cross-validation.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Consistency {
    /// Two flights share a mounting when their ground tilts are closer than this (deg).
    pub link_deg: f64,
    /// The flights, by source name, in input order.
    pub flights: Vec<String>,
    /// The mountings of two or more flights.
    pub mountings: Vec<Mounting>,
    /// Median accel_kin cut over ordered pairs inside one mounting, and the number of pairs
    /// (flights with too few samples to fit are neither model nor test).
    pub within_cut: Option<f64>,
    /// Ordered pairs inside one mounting that entered [`Consistency::within_cut`].
    pub within_pairs: usize,
    /// Median over ordered pairs in different mountings (flights of no mounting excluded).
    pub across_cut: Option<f64>,
    /// Ordered pairs that entered [`Consistency::across_cut`].
    pub across_pairs: usize,
    /// The body offset's own share of the cut (with it minus without it), medians inside one
    /// mounting and across mountings, over the same pairs.
    pub within_offset_gain: Option<f64>,
    /// The offset's own share across mountings (see [`Consistency::within_offset_gain`]).
    pub across_offset_gain: Option<f64>,
    /// Pairs in which the offset makes the other flight's error worse (gain < 0), inside one
    /// mounting and across mountings.
    pub within_offset_worse: usize,
    /// Pairs across mountings in which the offset makes the other flight's error worse.
    pub across_offset_worse: usize,
    /// The mounting's own part of the offset: the cut with i's offset minus the cut with the
    /// fleet's mean offset (flight j left out of the mean), medians inside one mounting and across.
    pub within_mounting_gain: Option<f64>,
    /// The mounting's own part across mountings (see [`Consistency::within_mounting_gain`]).
    pub across_mounting_gain: Option<f64>,
    /// Pairs inside one mounting in which i's offset does worse than the fleet's.
    pub within_mounting_worse: usize,
    /// Pairs across mountings in which i's offset does worse than the fleet's.
    pub across_mounting_worse: usize,
    /// Pairs that entered the mounting's own part, inside one mounting and across.
    pub mounting_pairs: (usize, usize),
}

/// The transfer matrices of a cross-validation, indexed `[i][j]`: model of flight i on flight j.
pub struct Transfer<'a> {
    /// The cut of j's accel_kin error by i's model.
    pub cut: &'a [Vec<Option<f64>>],
    /// Cut with i's body offset minus cut without it.
    pub offset_gain: &'a [Vec<Option<f64>>],
    /// Cut with i's body offset minus cut with the fleet's mean offset (j left out of the mean).
    pub mounting_gain: &'a [Vec<Option<f64>>],
}

/// Groups of points every two of which are closer than `link` (Euclidean): complete linkage.
/// From single points, the two groups whose farthest members are nearest merge while that
/// distance is under `link` (a tie goes to the lower indices). Each group sorted, the groups
/// ordered by their first member; `None` points are in no group. Unlike connected links (single
/// linkage), a chain of close points cannot join two distant ones, however many flights there
/// are.
fn link_groups(points: &[Option<(f64, f64)>], link: f64) -> Vec<Vec<usize>> {
    let d = |i: usize, j: usize| match (points[i], points[j]) {
        (Some(a), Some(b)) => (a.0 - b.0).hypot(a.1 - b.1),
        _ => f64::INFINITY,
    };
    let mut groups: Vec<Vec<usize>> = (0..points.len()).filter(|&i| points[i].is_some()).map(|i| vec![i]).collect();
    loop {
        let mut best: Option<(f64, usize, usize)> = None;
        for a in 0..groups.len() {
            for b in a + 1..groups.len() {
                let far = groups[a].iter().flat_map(|&i| groups[b].iter().map(move |&j| d(i, j))).fold(0.0, f64::max);
                if far < link && best.is_none_or(|(x, _, _)| far < x) {
                    best = Some((far, a, b));
                }
            }
        }
        let Some((_, a, b)) = best else { break };
        let moved = groups.remove(b);
        groups[a].extend(moved);
    }
    for g in &mut groups {
        g.sort_unstable();
    }
    groups.sort_by_key(|g| g[0]);
    groups
}

/// The χ² agreement of values with 95 % half-widths (see the module doc); `None` below two.
pub fn agreement(axis: &'static str, values: &[(usize, f64, f64)]) -> Option<AxisAgreement> {
    if values.len() < 2 {
        return None;
    }
    let w: Vec<f64> = values.iter().map(|v| (Z_975 / v.2).powi(2)).collect();
    let mean = values.iter().zip(&w).map(|(v, w)| v.1 * w).sum::<f64>() / w.iter().sum::<f64>();
    let chi2: f64 = values.iter().zip(&w).map(|(v, w)| (v.1 - mean).powi(2) * w).sum();
    let dof = values.len() - 1;
    let p = chi2_sf(chi2, dof as f64);
    let (lo, hi) = values.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v.1), hi.max(v.1)));
    Some(AxisAgreement {
        axis,
        flights: values.iter().map(|v| v.0).collect(),
        mean_deg: mean,
        spread_deg: hi - lo,
        chi2,
        dof,
        p,
        agree: p >= AGREE_P,
    })
}

/// The report's model without its body offset (the correction set to identity and its linear
/// columns to zero); `None` when it has none.
pub(crate) fn without_body_offset(r: &Report) -> Option<Report> {
    r.effect(Effect::BodyOffset)?;
    let mut bare = r.clone();
    bare.corrections.body_offset = Rot::identity();
    let offs = crate::identify::fit::design::column_offsets();
    let at = Effect::BodyOffset as usize;
    for k in offs[at]..offs[at + 1] {
        if let Some(x) = bare.theta.get_mut(k) {
            *x = 0.0;
        }
    }
    Some(bare)
}

/// The fleet's body offset seen from flight `j`: the mean rotation vector of the fitted body
/// offsets of every flight but `j` (small rotations: the mean of the vectors is the rotation
/// nearest to all of them to second order); `None` when no other flight has one.
pub(crate) fn fleet_offset_without(reports: &[(String, Report)], j: usize) -> Option<Rot<MocapBody, Body>> {
    let v: Vec<nalgebra::Vector3<f64>> = reports
        .iter()
        .enumerate()
        .filter(|(k, (_, r))| *k != j && fitted(r) && r.effect(Effect::BodyOffset).is_some())
        .map(|(_, (_, r))| r.corrections.body_offset.quaternion().scaled_axis())
        .collect();
    if v.is_empty() {
        return None;
    }
    Some(Rot::from_quaternion(nalgebra::UnitQuaternion::from_scaled_axis(
        v.iter().sum::<nalgebra::Vector3<f64>>() / v.len() as f64,
    )))
}

/// Whether a parameter enters the χ²: identifiable, with a finite interval (a parameter the
/// flight cannot tell from another effect's claims none, and would weigh in with a made-up one).
fn has_interval(p: &crate::identify::fit::select::Param) -> bool {
    p.identifiable && p.ci95 > 0.0 && p.ci95.is_finite()
}

/// Whether the flight had enough usable samples for a fit (a flight without is neither a model
/// nor a test of one).
fn fitted(r: &Report) -> bool {
    crate::identify::fit::select::enough_to_select(r.train_samples)
}

/// The consistency of flights `reports` (name, report) with their accel_kin cross-validation
/// matrices (see [`Transfer`]).
pub fn consistency(reports: &[(String, Report)], t: &Transfer, link_deg: f64) -> Consistency {
    let (cross, offset_gain) = (t.cut, t.offset_gain);
    let ground: Vec<Option<(f64, f64)>> =
        reports.iter().map(|(_, r)| r.ground_check.map(|g| (g.roll_deg, g.pitch_deg))).collect();
    let groups = link_groups(&ground, link_deg);
    let mut of = vec![None; reports.len()];
    for (g, members) in groups.iter().enumerate() {
        for &i in members {
            of[i] = Some(g);
        }
    }
    let mountings = groups
        .iter()
        .map(|members| {
            let mut ground_spread_deg: f64 = 0.0;
            for &a in members {
                for &b in members {
                    let (pa, pb) = (ground[a].expect("grouped"), ground[b].expect("grouped"));
                    ground_spread_deg = ground_spread_deg.max((pa.0 - pb.0).hypot(pa.1 - pb.1));
                }
            }
            let mut left_out = Vec::new();
            let mut axes = Vec::new();
            for axis in ["roll", "pitch", "yaw"] {
                let mut values = Vec::new();
                for &i in members {
                    let r = &reports[i].1;
                    if !fitted(r) {
                        if axis == "roll" {
                            let why =
                                OffsetMissing::NothingFitted { usable: r.train_samples, needed: MIN_TRAIN_SAMPLES };
                            left_out.push((i, why));
                        }
                        continue;
                    }
                    match r.effect(Effect::BodyOffset).and_then(|f| f.params.iter().find(|p| p.name == axis)) {
                        Some(p) if has_interval(p) => values.push((i, p.value, p.ci95)),
                        Some(_) => left_out.push((i, OffsetMissing::NotIdentifiable { axis })),
                        None if axis == "roll" => left_out.push((i, OffsetMissing::NotFitted)),
                        None => {}
                    }
                }
                axes.extend(agreement(axis, &values));
            }
            Mounting { flights: members.clone(), ground_spread_deg, axes, left_out }
        })
        .collect();
    let (mut within, mut across, mut within_gain, mut across_gain) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut within_m, mut across_m) = (Vec::new(), Vec::new());
    for (i, row) in cross.iter().enumerate() {
        for (j, cut) in row.iter().enumerate() {
            if !fitted(&reports[i].1) || !fitted(&reports[j].1) {
                continue;
            }
            if let (true, Some(c), Some(gi), Some(gj)) = (i != j, cut, of[i], of[j]) {
                let gain = offset_gain.get(i).and_then(|r| r.get(j)).copied().flatten();
                let mounting = t.mounting_gain.get(i).and_then(|r| r.get(j)).copied().flatten();
                let (cuts, gains, own) = if gi == gj {
                    (&mut within, &mut within_gain, &mut within_m)
                } else {
                    (&mut across, &mut across_gain, &mut across_m)
                };
                cuts.push(*c);
                gains.extend(gain);
                own.extend(mounting);
            }
        }
    }
    Consistency {
        link_deg,
        flights: reports.iter().map(|(n, _)| n.clone()).collect(),
        mountings,
        within_pairs: within.len(),
        across_pairs: across.len(),
        within_cut: median(within),
        across_cut: median(across),
        within_offset_worse: within_gain.iter().filter(|g| **g < 0.0).count(),
        across_offset_worse: across_gain.iter().filter(|g| **g < 0.0).count(),
        within_offset_gain: median(within_gain),
        across_offset_gain: median(across_gain),
        within_mounting_worse: within_m.iter().filter(|g| **g < 0.0).count(),
        across_mounting_worse: across_m.iter().filter(|g| **g < 0.0).count(),
        mounting_pairs: (within_m.len(), across_m.len()),
        within_mounting_gain: median(within_m),
        across_mounting_gain: median(across_m),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Five points by hand: A–B 0.3 apart, B–C 0.4 (so C joins A through B, although A–C is
    /// 0.7), D alone at 2, E without a point.
    #[test]
    fn groups_hold_points_all_within_the_link_in_any_order() {
        // 0.7 apart, 0 and 2 cannot share a group though each is within 0.5 of 1: 1 joins 0
        // (0.3 away) rather than 2 (0.4 away)
        let pts = [Some((0.0, 0.0)), Some((0.3, 0.0)), Some((0.7, 0.0)), Some((2.0, 2.0)), None];
        assert_eq!(link_groups(&pts, 0.5), vec![vec![0, 1], vec![2], vec![3]]);
        // reversed input: the same groups, renumbered
        let rev: Vec<_> = pts.iter().rev().copied().collect();
        assert_eq!(link_groups(&rev, 0.5), vec![vec![1], vec![2], vec![3, 4]]);
        // a link must be closer than the threshold
        assert_eq!(link_groups(&pts[..2], 0.3), vec![vec![0], vec![1]]);
        // a chain of close points (0.35, 0.45, 0.4 apart) is two groups, not one
        let chain = [Some((0.0, 0.0)), Some((0.35, 0.0)), Some((0.8, 0.0)), Some((1.2, 0.0))];
        assert_eq!(link_groups(&chain, 0.5), vec![vec![0, 1], vec![2, 3]]);
        // only distances count: the same points moved by (5, −3) group alike
        let moved: Vec<_> = chain.iter().map(|p| p.map(|(x, y)| (x + 5.0, y - 3.0))).collect();
        assert_eq!(link_groups(&moved, 0.5), vec![vec![0, 1], vec![2, 3]]);
        // a tie goes to the lower indices: 1 is as close to 0 as to 2
        let tie = [Some((0.0, 0.0)), Some((1.0, 0.0)), Some((2.0, 0.0))];
        assert_eq!(link_groups(&tie, 1.5), vec![vec![0, 1], vec![2]]);
        // the whole group within the link: three points pairwise 0.4 apart are one
        let tri = [Some((0.0, 0.0)), Some((0.4, 0.0)), Some((0.2, 0.3464))];
        assert_eq!(link_groups(&tri, 0.5), vec![vec![0, 1, 2]]);
    }

    /// Two values 1.0 ± 0.196 and 2.0 ± 0.392 (σ = 0.1, 0.2): x̄ = (1/0.01 + 2/0.04)/(1/0.01 +
    /// 1/0.04) = 150/125 = 1.2, χ² = (0.2/0.1)² + (0.8/0.2)² = 4 + 16 = 20 on 1 dof,
    /// p = erfc(√10) ≈ 7.7·10⁻⁶: they disagree. Halving the gap to 0.5 with σ = 0.3 each:
    /// x̄ = 1.25, χ² = 2·(0.25/0.3)² = 1.389, p = erfc(√0.694) ≈ 0.239: they agree.
    #[test]
    fn agreement_is_the_chi2_of_the_weighted_mean() {
        let a = agreement("roll", &[(0, 1.0, 0.1 * Z_975), (3, 2.0, 0.2 * Z_975)]).unwrap();
        assert!((a.mean_deg - 1.2).abs() < 1e-12, "{}", a.mean_deg);
        assert!((a.chi2 - 20.0).abs() < 1e-9, "{}", a.chi2);
        assert_eq!((a.dof, a.flights.clone()), (1, vec![0, 3]));
        assert!((a.p - 7.744e-6).abs() < 1e-8, "{}", a.p);
        assert!(!a.agree);
        assert!((a.spread_deg - 1.0).abs() < 1e-12);
        let b = agreement("roll", &[(0, 1.0, 0.3 * Z_975), (1, 1.5, 0.3 * Z_975)]).unwrap();
        assert!((b.mean_deg - 1.25).abs() < 1e-12);
        assert!((b.chi2 - 1.388_888_9).abs() < 1e-6, "{}", b.chi2);
        assert!((b.p - 0.2386).abs() < 1e-3, "{}", b.p);
        assert!(b.agree);
        assert!(agreement("roll", &[(0, 1.0, 0.1)]).is_none());
    }

    #[test]
    fn only_identifiable_parameters_with_a_finite_interval_enter_the_test() {
        let p = |identifiable: bool, ci95: f64| crate::identify::fit::select::Param {
            name: "roll".into(),
            value: 1.0,
            ci95,
            unit: "deg".into(),
            identifiable,
        };
        assert!(has_interval(&p(true, 0.2)));
        assert!(!has_interval(&p(false, 0.2)), "not identifiable");
        assert!(!has_interval(&p(true, 0.0)), "no interval");
        assert!(!has_interval(&p(true, f64::INFINITY)), "an infinite interval");
        assert!(!has_interval(&p(true, f64::NAN)), "NaN");
    }
}
