//! Streams in files of their own, each on its own clock. Poses: the TUM trajectory format
//! (`t x y z qx qy qz qw`, whitespace between, `#` comments; t in seconds, the quaternion body →
//! world with the scalar last, as the TUM RGB-D benchmark and `evo` define it) and the ASL
//! (EuRoC) pose CSV (`timestamp [ns], p_x, p_y, p_z, q_w, q_x, q_y, q_z[, …]`), read into the
//! stream the join takes ([`Stream<7>`]: stamps in integer nanoseconds, position, quaternion
//! x, y, z, w). The IMU: the ASL IMU CSV (`timestamp [ns], w_x, w_y, w_z, a_x, a_y, a_z`), or any
//! CSV through a column mapping ([`super::mapping`]). Stamps are parsed as decimals, digit by digit, so that a stamp of 10⁹ s keeps
//! its nanoseconds (an f64 keeps 0.24 µs there).
//!
//! A row whose values are not finite (a mocap that lost the body: `nan`) is a frame not seen: it
//! is left out, and the join leaves the IMU rows around it without a pose. Anything else that is
//! not a number is an error naming the file, the line and the column.

use super::error::InputError;
use super::joined::Stream;
use std::path::Path;

/// The decimal `cell` in a unit of `unit_ns` nanoseconds (1 for ns, 10⁹ for s), as integer
/// nanoseconds: the digits read exactly, a fraction finer than a nanosecond rounded half away
/// from zero; an exponent (`1.4e9`) read through f64. `None` for anything else.
pub(crate) fn decimal_ns(cell: &str, unit_ns: i128) -> Option<i128> {
    let c = cell.trim();
    if c.contains(['e', 'E']) {
        let x = c.parse::<f64>().ok().filter(|x| x.is_finite())?;
        return Some((x * unit_ns as f64).round() as i128);
    }
    let (neg, c) = match c.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, c.strip_prefix('+').unwrap_or(c)),
    };
    let (int, frac) = c.split_once('.').unwrap_or((c, ""));
    if int.is_empty() && frac.is_empty()
        || !int.bytes().all(|b| b.is_ascii_digit())
        || !frac.bytes().all(|b| b.is_ascii_digit())
        || int.len() > 30
    {
        return None;
    }
    let int_v: i128 = if int.is_empty() { 0 } else { int.parse().ok()? };
    // the fraction in units of unit_ns / 10^len, kept to the nanosecond
    let mut ns = int_v.checked_mul(unit_ns)?;
    let mut scale = unit_ns;
    let mut below = None;
    for d in frac.bytes().map(|d| i128::from(d - b'0')) {
        if scale >= 10 {
            scale /= 10;
            ns = ns.checked_add(d * scale)?;
        } else if below.is_none() {
            // the first digit below a nanosecond decides the rounding (half away from zero)
            below = Some(d);
        }
    }
    if below.is_some_and(|d| d >= 5) {
        ns += 1;
    }
    Some(if neg { -ns } else { ns })
}

/// Where a quaternion's x, y, z and w sit among its four cells: [0, 1, 2, 3] for x, y, z, w
/// (TUM, ROS), [1, 2, 3, 0] for w, x, y, z (ASL, Eigen's constructor).
pub(crate) type QuatCells = [usize; 4];
/// The scalar last.
pub(crate) const XYZW: QuatCells = [0, 1, 2, 3];
/// The scalar first.
pub(crate) const WXYZ: QuatCells = [1, 2, 3, 0];

/// One row's cells, located for its errors: the file, the line and the columns' names.
struct Row<'a> {
    file: &'a str,
    line: usize,
    cells: Vec<&'a str>,
    names: &'a [&'a str],
}

impl Row<'_> {
    /// An error at this row, in column `j` when given.
    fn error(&self, j: Option<usize>, message: String) -> InputError {
        InputError::Row {
            file: self.file.to_string(),
            line: self.line,
            column: j.map(|j| self.names[j].to_string()),
            message,
        }
    }

    /// The stamp in cell 0, in units of `unit_ns` nanoseconds.
    fn stamp(&self, unit_ns: i128) -> Result<i128, InputError> {
        decimal_ns(self.cells[0], unit_ns)
            .ok_or_else(|| self.error(Some(0), format!("`{}` is not a time stamp", self.cells[0].trim())))
    }

    /// Cells 1..=N as numbers (NaN and infinities pass: the caller decides what they mean).
    fn numbers<const N: usize>(&self) -> Result<[f64; N], InputError> {
        let mut v = [0.0; N];
        for (j, x) in v.iter_mut().enumerate() {
            let c = self.cells[j + 1].trim();
            *x = c.parse::<f64>().map_err(|_| self.error(Some(j + 1), format!("`{c}` is not a number")))?;
        }
        Ok(v)
    }
}

/// The rows of a stream file into a stream: comment (`#`) and blank lines skipped, each row
/// split by `split` and needing the columns `names` (`what` names a row in the error), then
/// `parse` gives its stamp and values, or nothing for a row to leave out. Stamps must increase;
/// fewer than two rows is an error.
fn read_rows<const N: usize>(
    path: &Path,
    split: fn(&str) -> Vec<&str>,
    names: &[&str],
    what: &str,
    mut parse: impl FnMut(&Row) -> Result<Option<(i128, [f64; N])>, InputError>,
) -> Result<Stream<N>, InputError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| InputError::io(&file, e))?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let mut out = Stream::new();
    for (k, line) in text.lines().enumerate() {
        let l = line.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let row = Row { file: &file, line: k + 1, cells: split(l), names };
        if row.cells.len() < names.len() {
            let message = format!("{} values, and {what} needs {} ({})", row.cells.len(), names.len(), names.join(" "));
            return Err(row.error(None, message));
        }
        let Some((t, v)) = parse(&row)? else { continue };
        if out.t.last().is_some_and(|last| *last >= t) {
            return Err(row.error(None, "time stamps must increase (this row's is not after the row before)".into()));
        }
        out.push(t, v).map_err(|m| row.error(None, m.to_string()))?;
    }
    if out.t.len() < 2 {
        return Err(InputError::log(&file, format!("fewer than two rows of {what}")));
    }
    Ok(out)
}

/// The poses of one file: the stamp (in units of `unit_ns`), three position cells (times
/// `pos_factor` to m), four quaternion cells laid out as `order` says; a row that is not all
/// finite is a frame the mocap did not see, left out.
fn read_poses(
    path: &Path,
    split: fn(&str) -> Vec<&str>,
    names: [&str; 8],
    unit_ns: i128,
    order: QuatCells,
    pos_factor: f64,
) -> Result<Stream<7>, InputError> {
    read_rows(path, split, &names, "a pose", |row| {
        let t = row.stamp(unit_ns)?;
        let v: [f64; 7] = row.numbers()?;
        if !v.iter().all(|x| x.is_finite()) {
            // a frame the mocap did not see
            return Ok(None);
        }
        let q = order.map(|k| v[3 + k]);
        let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
        if (norm - 1.0).abs() > 0.01 {
            let m = format!("the quaternion has norm {norm:.4}, not 1: check the mapping's quaternion `order`");
            return Err(row.error(None, m));
        }
        Ok(Some((t, [v[0] * pos_factor, v[1] * pos_factor, v[2] * pos_factor, q[0], q[1], q[2], q[3]])))
    })
}

/// A TUM trajectory file: `t x y z qx qy qz qw` (t in seconds; `order` for a file that lays
/// the quaternion out otherwise; positions times `pos_factor` to metres).
pub(in crate::identify) fn read_tum(path: &Path, order: QuatCells, pos_factor: f64) -> Result<Stream<7>, InputError> {
    let mut names = ["timestamp", "tx", "ty", "tz", "", "", "", ""];
    for (k, n) in ["qx", "qy", "qz", "qw"].into_iter().enumerate() {
        names[4 + order[k]] = n;
    }
    read_poses(path, |l| l.split_whitespace().collect(), names, 1_000_000_000, order, pos_factor)
}

/// An ASL (EuRoC) pose CSV: `timestamp [ns], p_x, p_y, p_z, q_w, q_x, q_y, q_z` (`order` for a
/// file that lays the quaternion out otherwise), and any columns after them (a ground-truth
/// estimate's velocities and biases) left unread.
pub(in crate::identify) fn read_asl_poses(
    path: &Path,
    order: QuatCells,
    pos_factor: f64,
) -> Result<Stream<7>, InputError> {
    let mut names = ["timestamp", "p_x", "p_y", "p_z", "", "", "", ""];
    for (k, n) in ["q_x", "q_y", "q_z", "q_w"].into_iter().enumerate() {
        names[4 + order[k]] = n;
    }
    read_poses(path, |l| l.split(',').collect(), names, 1, order, pos_factor)
}

/// An ASL (EuRoC) IMU CSV: `timestamp [ns], w_x, w_y, w_z, a_x, a_y, a_z` into the IMU stream
/// the join takes (gyro then accelerometer, SI). A value that is not a finite number is an
/// error: an IMU sample is never a dropout.
pub(in crate::identify) fn read_asl_imu(path: &Path) -> Result<Stream<6>, InputError> {
    let names = ["timestamp", "w_x", "w_y", "w_z", "a_x", "a_y", "a_z"];
    read_rows(
        path,
        |l| l.split(',').collect(),
        &names,
        "an IMU sample",
        |row| {
            let t = row.stamp(1)?;
            let v: [f64; 6] = row.numbers()?;
            if let Some(j) = v.iter().position(|x| !x.is_finite()) {
                return Err(row.error(Some(j + 1), format!("`{}` is not a finite number", row.cells[j + 1].trim())));
            }
            Ok(Some((t, v)))
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(name: &str, text: &str) -> std::path::PathBuf {
        let p = std::env::temp_dir().join(format!("flyarena-streams-{}-{name}", std::process::id()));
        std::fs::write(&p, text).unwrap();
        p
    }

    /// A TUM file as written by hand: comments and blank lines skipped, a frame the mocap lost
    /// (`nan`) left out, stamps to the nanosecond, the quaternion's cells as `order` lays them
    /// out (x, y, z, w by default; w, x, y, z when the file says so), positions in mm scaled.
    #[test]
    fn a_tum_file_reads_its_poses_and_leaves_out_what_was_not_seen() {
        let p = file(
            "poses.tum",
            "# t x y z qx qy qz qw\n\n1.000000001 1 2 3 0 0 0 1\n1.01 nan nan nan nan nan nan nan\n1.02 4 5 6 0 0 0.6 0.8\n",
        );
        let s = read_tum(&p, XYZW, 1.0).unwrap();
        assert_eq!(s.t, vec![1_000_000_001, 1_020_000_000]);
        assert_eq!(s.v[1], [4.0, 5.0, 6.0, 0.0, 0.0, 0.6, 0.8]);
        let p = file("wxyz.tum", "1 1000 0 0 0.8 0 0.6 0\n2 0 0 0 1 0 0 0\n");
        let s = read_tum(&p, WXYZ, 1e-3).unwrap();
        assert_eq!(s.v[0], [1.0, 0.0, 0.0, 0.0, 0.6, 0.0, 0.8]);
    }

    /// What is not a pose is an error naming the file, the line and the column: a word where a
    /// number goes, a quaternion that is not unit (a wrong `order`), stamps that go back, and an
    /// ASL IMU sample that is not finite (an IMU sample is never a dropout).
    #[test]
    fn what_is_not_a_pose_or_a_sample_is_a_located_error() {
        let err = |text: &str| read_tum(&file("bad.tum", text), XYZW, 1.0).unwrap_err().to_string();
        let e = err("1 0 0 0 0 0 0 1\n2 0 x 0 0 0 0 1\n");
        assert!(e.contains("bad.tum:2:") && e.contains("`ty`") && e.contains("`x`"), "{e}");
        let e = err("1 0 0 0 0 0 0 2\n");
        assert!(e.contains("norm 2.0000") && e.contains("order"), "{e}");
        let e = err("2 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n");
        assert!(e.contains("bad.tum:2:") && e.contains("increase"), "{e}");
        let imu = file("imu.csv", "#timestamp [ns],w_x,w_y,w_z,a_x,a_y,a_z\n5,0,0,0,0,0,9.8\n6,0,inf,0,0,0,9.8\n");
        let e = read_asl_imu(&imu).unwrap_err().to_string();
        assert!(e.contains("imu.csv:3:") && e.contains("`w_y`") && e.contains("not a finite number"), "{e}");
    }

    /// Stamps read digit by digit: 1403636579.763555527 s is 1403636579763555527 ns exactly
    /// (an f64 would give …555584), a tenth of a nanosecond rounds, a unit of 1 ns takes the
    /// integer, a negative stamp and an exponent read too, and a word is no stamp.
    #[test]
    fn stamps_are_read_to_the_nanosecond() {
        let s = 1_000_000_000;
        assert_eq!(decimal_ns("1403636579.763555527", s), Some(1_403_636_579_763_555_527));
        assert_eq!(decimal_ns("0.0000000016", s), Some(2));
        assert_eq!(decimal_ns("0.0000000014", s), Some(1));
        assert_eq!(decimal_ns(" 1403636579763555527 ", 1), Some(1_403_636_579_763_555_527));
        assert_eq!(decimal_ns("-1.5", s), Some(-1_500_000_000));
        assert_eq!(decimal_ns("1.5e3", s), Some(1_500_000_000_000));
        assert_eq!(decimal_ns("12.", s), Some(12_000_000_000));
        assert_eq!(decimal_ns("abc", s), None);
        assert_eq!(decimal_ns("", s), None);
        assert_eq!(decimal_ns("1.2.3", s), None);
    }
}
