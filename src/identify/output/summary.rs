//! The ground check's summaries across flights as the multi-flight report prints them: one
//! block per summary, a line per tilt (the numbers are `fit/ground/summary.rs`'s [`SpinUpSummary`],
//! [`LandedSummary`] and [`RestPoseSummary`]).

use crate::identify::fit::ground::{LandedSummary, RestPoseSummary, STILL_POSE_SD_DEG, SpinUpSummary};

/// The spin-up summary: per tilt, the median |difference| at rest and at spin-up, and the sign
/// test of the spin-up moving toward the flight.
pub(crate) fn spin_up(s: &SpinUpSummary) -> String {
    let mut t = format!(
        "\nground check at rest and at spin-up (motors on, still on the floor) against the flight, {} flights:\n",
        s.flights
    );
    for (name, a) in [("roll", &s.roll), ("pitch", &s.pitch)] {
        t += &format!(
            "  {name:<5} median |difference| rest {:.2}°, spin-up {:.2}°; the spin-up moves toward the flight in {} of {} (sign test p = {:.3}){}\n",
            a.median_rest_deg,
            a.median_spin_up_deg,
            a.toward_flight,
            s.flights,
            a.sign_test_p,
            if a.sign_test_p < 0.05 {
                ": the spinning rotors add an offset the flight carries too (rectified vibration, a mount that bends under thrust); in flight it reads as a tilt"
            } else {
                ": the difference is not what spinning rotors add on the floor"
            }
        );
    }
    t
}

/// The rests before and after the flight: how far they differ and which one the flight sits by.
pub(crate) fn landed(s: &LandedSummary) -> String {
    let mut t = format!(
        "\nground check before take-off and after landing against the flight ({} of {} flights have both rests; the reference is their mean, else the rest before):\n",
        s.with_both, s.flights
    );
    for (name, a) in [("roll", &s.roll), ("pitch", &s.pitch)] {
        t += &format!(
            "  {name:<5} the rests differ by a median {:.2}° (at most {:.2}°); median |difference| before {:.2}°, mean of the rests {:.2}°, the flight between the rests in {} of {}; over all {} flights {:.2}°, beyond 1°: {} ({} covered by its interval)\n",
            a.median_change_deg,
            a.max_change_deg,
            a.median_before_deg,
            a.median_bracket_deg,
            a.between,
            s.with_both,
            s.flights,
            a.median_reference_deg,
            a.beyond_1deg,
            a.beyond_1deg_covered
        );
    }
    t
}

/// The still pose's scatter: the ground check's difference where the pose scatters and where it
/// does not, with the Mann–Whitney p that they differ.
pub(crate) fn rest_pose(s: &RestPoseSummary) -> String {
    let mut t = format!(
        "\nground check against the flight where the still pose scatters at rest (roll above {STILL_POSE_SD_DEG}° per sample: {} flights) and where it does not ({} flights):\n",
        s.scattering, s.still
    );
    for (name, a) in [("roll", &s.roll), ("pitch", &s.pitch)] {
        t += &format!(
            "  {name:<5} median |difference| still {:.2}° (beyond 1°: {}, {} covered), scattering {:.2}° (beyond 1°: {}); Mann–Whitney p = {}{}\n",
            a.median_still_deg,
            a.still_beyond_1deg,
            a.still_beyond_1deg_covered,
            a.median_scattering_deg,
            a.scattering_beyond_1deg,
            if a.mann_whitney_p >= 1e-3 {
                format!("{:.3}", a.mann_whitney_p)
            } else {
                format!("{:.0e}", a.mann_whitney_p)
            },
            if a.mann_whitney_p < 0.05 {
                ": a pose the cameras see badly at rest makes the ground check an unreliable reference"
            } else {
                ""
            }
        );
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::fit::ground::{LandedAxisSummary, RestPoseAxisSummary, SpinUpAxisSummary};

    /// Each block as the multi-flight report prints it, from summaries written by hand: the
    /// counts in their places, two decimals for degrees, and the verdict clause on the side of
    /// 0.05 its p-value is on (a p under 10⁻³ in exponent form). A bug it catches: two counts
    /// swapped, or a clause chosen on the wrong side of the level.
    #[test]
    fn each_summary_reads_as_its_block() {
        let spin = |median_rest_deg, toward_flight, sign_test_p| SpinUpAxisSummary {
            median_rest_deg,
            median_spin_up_deg: 0.12,
            toward_flight,
            sign_test_p,
        };
        let s = SpinUpSummary { flights: 10, roll: spin(0.31, 9, 0.0107), pitch: spin(0.2, 4, 0.828) };
        assert_eq!(
            spin_up(&s),
            "\nground check at rest and at spin-up (motors on, still on the floor) against the flight, 10 flights:\n\
             \x20 roll  median |difference| rest 0.31°, spin-up 0.12°; the spin-up moves toward the flight in 9 of 10 (sign test p = 0.011): the spinning rotors add an offset the flight carries too (rectified vibration, a mount that bends under thrust); in flight it reads as a tilt\n\
             \x20 pitch median |difference| rest 0.20°, spin-up 0.12°; the spin-up moves toward the flight in 4 of 10 (sign test p = 0.828): the difference is not what spinning rotors add on the floor\n"
        );
        let axis = LandedAxisSummary {
            median_change_deg: 0.05,
            max_change_deg: 0.12,
            median_before_deg: 0.2,
            median_bracket_deg: 0.15,
            between: 6,
            median_reference_deg: 0.18,
            beyond_1deg: 2,
            beyond_1deg_covered: 1,
        };
        let l = LandedSummary { flights: 10, with_both: 8, roll: axis, pitch: axis };
        let text = landed(&l);
        assert!(
            text.starts_with("\nground check before take-off and after landing against the flight (8 of 10 flights have both rests;")
                && text.contains("  roll  the rests differ by a median 0.05° (at most 0.12°); median |difference| before 0.20°, mean of the rests 0.15°, the flight between the rests in 6 of 8; over all 10 flights 0.18°, beyond 1°: 2 (1 covered by its interval)\n")
                && text.lines().count() == 4,
            "{text}"
        );
        let pose = |mann_whitney_p| RestPoseAxisSummary {
            median_still_deg: 0.15,
            median_scattering_deg: 0.8,
            still_beyond_1deg: 0,
            still_beyond_1deg_covered: 0,
            scattering_beyond_1deg: 1,
            mann_whitney_p,
        };
        let r = RestPoseSummary { scattering: 3, still: 4, roll: pose(1.0 / 35.0), pitch: pose(4e-4) };
        let text = rest_pose(&r);
        assert!(
            text.contains(&format!("(roll above {STILL_POSE_SD_DEG}° per sample: 3 flights) and where it does not (4 flights):\n"))
                && text.contains("  roll  median |difference| still 0.15° (beyond 1°: 0, 0 covered), scattering 0.80° (beyond 1°: 1); Mann–Whitney p = 0.029: a pose the cameras see badly at rest makes the ground check an unreliable reference\n")
                && text.contains("  pitch median |difference| still 0.15° (beyond 1°: 0, 0 covered), scattering 0.80° (beyond 1°: 1); Mann–Whitney p = 4e-4: a pose"),
            "{text}"
        );
        let few = RestPoseSummary { roll: pose(0.1), pitch: pose(0.1), ..r };
        assert!(!rest_pose(&few).contains("see badly"), "{}", rest_pose(&few));
    }
}
