//! The consistency across flights as text: one block per mounting (the agreement of the body
//! offsets, the flights left out and why), then the transfer between flights.

use crate::identify::checks::consistency::{Consistency, OffsetMissing};
use std::fmt::{self, Display, Formatter};

impl Display for OffsetMissing {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            OffsetMissing::NothingFitted { usable, needed } => {
                write!(f, "{usable} usable samples, {needed} needed: nothing was fitted")
            }
            OffsetMissing::NotIdentifiable { axis } => write!(f, "its body offset {axis} is not identifiable"),
            OffsetMissing::NotFitted => f.write_str("no body offset was fitted (use --with body_offset)"),
        }
    }
}

impl serde::Serialize for OffsetMissing {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// The consistency as text (one block per mounting, then the transfer).
pub fn render(c: &Consistency) -> String {
    let mut t = format!(
        "\nconsistency across flights (one mounting: flights whose ground tilts are all within {:.2}° of each other):\n",
        c.link_deg
    );
    for (k, m) in c.mountings.iter().enumerate() {
        let names: Vec<&str> = m.flights.iter().map(|&i| c.flights[i].as_str()).collect();
        t += &format!("  mounting {}: {} (ground spread {:.2}°)\n", k + 1, names.join(", "), m.ground_spread_deg);
        for a in &m.axes {
            t += &format!(
                "    body offset {:<5} mean {:+.2}°, spread {:.2}° over {} flights, χ² {:.1} on {} dof, p {:.2}: {}\n",
                a.axis,
                a.mean_deg,
                a.spread_deg,
                a.flights.len(),
                a.chi2,
                a.dof,
                a.p,
                if a.agree {
                    "agree within their intervals"
                } else {
                    "DISAGREE (p < 0.05): the markers moved between these flights, or an interval is too narrow"
                }
            );
        }
        if m.flights.len() == 1 {
            t += "    one flight: nothing to compare it with\n";
        }
        for (i, why) in &m.left_out {
            t += &format!("    {} left out: {why}\n", c.flights[*i]);
        }
    }
    let pct = |x: Option<f64>| x.map_or("—".to_string(), |v| format!("{:.0} %", 100.0 * v));
    t += &format!(
        "  transfer (accel_kin error cut of one flight's model on another): median {} over {} pairs in one mounting, {} over {} pairs across mountings\n",
        pct(c.within_cut),
        c.within_pairs,
        pct(c.across_cut),
        c.across_pairs
    );
    let pp = |x: Option<f64>| x.map_or("—".to_string(), |v| format!("{:+.0} points", 100.0 * v));
    t += &format!(
        "  the body offset's own share of that cut (with it minus without it): median {} in one mounting (worse in {} of {} pairs), {} across mountings (worse in {} of {})\n",
        pp(c.within_offset_gain),
        c.within_offset_worse,
        c.within_pairs,
        pp(c.across_offset_gain),
        c.across_offset_worse,
        c.across_pairs
    );
    t += &format!(
        "  the mounting's own part of the offset (with it minus with the other flights' mean offset): median {} in one mounting (worse in {} of {} pairs), {} across mountings (worse in {} of {})\n",
        pp(c.within_mounting_gain),
        c.within_mounting_worse,
        c.mounting_pairs.0,
        pp(c.across_mounting_gain),
        c.across_mounting_worse,
        c.mounting_pairs.1
    );
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Why a flight is left out, written out by hand, and its JSON the same sentence.
    #[test]
    fn a_missing_offset_reads_as_its_sentence() {
        let cases = [
            (
                OffsetMissing::NothingFitted { usable: 150, needed: 200 },
                "150 usable samples, 200 needed: nothing was fitted",
            ),
            (OffsetMissing::NotIdentifiable { axis: "yaw" }, "its body offset yaw is not identifiable"),
            (OffsetMissing::NotFitted, "no body offset was fitted (use --with body_offset)"),
        ];
        for (why, want) in cases {
            assert_eq!(why.to_string(), want);
            assert_eq!(serde_json::to_value((3, &why)).unwrap(), serde_json::json!([3, want]));
        }
    }
}
