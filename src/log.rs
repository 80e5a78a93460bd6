//! Flight logs: what a real arena records, as CSV — written by `flyarena run --log`, read back
//! with every defect of a real file either rejected with its line and column or repaired and
//! reported.
//!
//! Format (one header line, then one row per Vicon frame; SI units; frames in the names):
//!
//! | column | unit | meaning |
//! |---|---|---|
//! | `t_s` | s | capture time of the Vicon frame (arena clock) |
//! | `seq` | | Vicon frame number |
//! | `mocap_valid` | 0/1 | 1 if the vehicle was seen (≥ 3 markers); else the pose columns are empty |
//! | `pos_n_m`, `pos_e_m`, `pos_d_m` | m | mocap position, mocap world NED |
//! | `q_w`, `q_x`, `q_y`, `q_z` | | mocap attitude: unit quaternion of `Rot<MocapBody, MocapNav>` (scalar first, Hamilton) |
//! | `gyro_x_rad_s` … `gyro_z_rad_s` | rad/s | IMU angular rate, body FRD |
//! | `acc_x_m_s2` … `acc_z_m_s2` | m/s² | IMU specific force, body FRD (−g on z at rest) |
//! | `cmd_p`, `cmd_q`, `cmd_r`, `cmd_thrust` | counts 0..255 | the last PPM frame sent (empty before the first); in attitude mode the first three carry φ_com, θ_com, ψ̇_com ([`crate::radio`]) |
//! | `vbat_v` | V | battery terminal voltage (optional when reading: logs from before it are read without it) |
//!
//! Reading ([`read_csv`]): missing or misnamed columns, cells that are not numbers, NaN or
//! infinity, timestamps that go backwards, and empty files are errors naming line and column.
//! Repairs, each reported in [`FlightLog::repairs`] as a [`Repair`]: a last line cut short (no
//! newline, too few cells) is dropped; a row repeating the previous timestamp exactly is
//! dropped; a gap longer than 3 × the median sampling interval splits the log into segments.

use crate::engine::VehicleRun;
use std::fmt::Write as _;

/// The columns, in order.
pub const COLUMNS: [&str; 21] = [
    "t_s",
    "seq",
    "mocap_valid",
    "pos_n_m",
    "pos_e_m",
    "pos_d_m",
    "q_w",
    "q_x",
    "q_y",
    "q_z",
    "gyro_x_rad_s",
    "gyro_y_rad_s",
    "gyro_z_rad_s",
    "acc_x_m_s2",
    "acc_y_m_s2",
    "acc_z_m_s2",
    "cmd_p",
    "cmd_q",
    "cmd_r",
    "cmd_thrust",
    "vbat_v",
];

/// The columns a log may lack (they read as empty cells).
const OPTIONAL: [&str; 1] = ["vbat_v"];

/// Writes the log of one vehicle (the run must have been made with `trace: true`).
pub fn write_csv(v: &VehicleRun, mocap_period_s: f64) -> String {
    let mut s = COLUMNS.join(",");
    s.push('\n');
    for (k, r) in v.trace.iter().enumerate() {
        let t = r.t.as_secs_f64();
        // an undeclared mocap delay: the logging host stamps each pose that much late
        let captured = k.checked_sub(v.log_delay_frames).and_then(|j| v.trace[j].captured);
        let seq = captured.map_or((t / mocap_period_s).round() as u64, |f| f.seq as u64);
        let _ = write!(s, "{t},{seq}");
        match captured {
            Some(f) => {
                let q = f.att.quaternion();
                let _ = write!(s, ",1,{},{},{},{},{},{},{}", f.pos.x(), f.pos.y(), f.pos.z(), q.w, q.i, q.j, q.k);
            }
            None => s.push_str(",0,,,,,,,"),
        }
        // an undeclared gyro delay: the logger stamps each gyro sample that much late (the
        // first rows repeat the first sample: the vehicle is at rest there)
        let (g, a) = (v.trace[k.saturating_sub(v.gyro_log_delay_frames)].imu.gyro, r.imu.specific_force);
        let _ = write!(s, ",{},{},{},{},{},{}", g.x(), g.y(), g.z(), a.x(), a.y(), a.z());
        match r.ppm {
            Some(p) => {
                let _ = write!(s, ",{},{},{},{}", p.channels[0], p.channels[1], p.channels[2], p.channels[3]);
            }
            None => s.push_str(",,,,"),
        }
        let _ = write!(s, ",{}", r.vbat_v);
        s.push('\n');
    }
    s
}

/// A log read back: one `Vec<Option<f64>>` per column (`None` = empty cell), in [`COLUMNS`] order.
#[derive(Clone, Debug, PartialEq)]
pub struct FlightLog {
    /// The cells, column by column.
    pub columns: Vec<Vec<Option<f64>>>,
    /// Row ranges [start, end) of the segments between gaps.
    pub segments: Vec<(usize, usize)>,
    /// What was repaired, in the order found; `Display` gives each one's sentence.
    pub repairs: Vec<Repair>,
}

/// A defect of a log's rows that the reader repaired rather than rejected: data to match on;
/// `Display` gives the sentence a report prints. Lines count from 1, the header being line 1.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum Repair {
    /// A row whose time equals the previous row's was dropped; `t_s` is that time (s) where the
    /// reader names it.
    RepeatedTime {
        /// The dropped row's line.
        line: usize,
        /// The repeated time (s).
        t_s: Option<f64>,
    },
    /// The last line, without its newline, has fewer cells than the header (a write cut short)
    /// and was dropped.
    LastLineCut {
        /// Its line.
        line: usize,
        /// Cells it has.
        cells: usize,
        /// Columns of the header.
        columns: usize,
    },
    /// The time jumps by more than 3 × the median interval: the log is split into segments there.
    Gap {
        /// The time before the gap (s).
        after_s: f64,
        /// Its length (s).
        length_s: f64,
        /// The median interval between rows (s).
        median_interval_s: f64,
    },
}

impl std::fmt::Display for Repair {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Repair::RepeatedTime { line, t_s: Some(t) } => {
                write!(f, "line {line}: repeats the time {t} s of the previous row and was dropped")
            }
            Repair::RepeatedTime { line, t_s: None } => {
                write!(f, "line {line}: repeats the time of the previous row and was dropped")
            }
            Repair::LastLineCut { line, cells, columns } => write!(
                f,
                "line {line}: the last line is cut short ({cells} of {columns} cells, no newline) and was dropped"
            ),
            Repair::Gap { after_s, length_s, median_interval_s } => write!(
                f,
                "a gap of {length_s:.3} s after t = {after_s} s (median interval {median_interval_s:.4} s): the log is split into segments there"
            ),
        }
    }
}

impl FlightLog {
    /// Rows read.
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, Vec::len)
    }
    /// The column named `name` (one of [`COLUMNS`]).
    pub fn column(&self, name: &str) -> Option<&[Option<f64>]> {
        COLUMNS.iter().position(|c| *c == name).map(|i| self.columns[i].as_slice())
    }
}

/// A flight log that does not read, with the file, line and column of the defect.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum LogError {
    /// No header, or fewer than two rows.
    #[error("{file}: the log is empty: it needs the header line `{}` and at least two rows", COLUMNS.join(","))]
    Empty {
        /// The log.
        file: String,
    },
    /// The header is not flyarena's (a missing, unknown or misspelled column).
    #[error("{file}:1: {message}")]
    Header {
        /// The log.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// A cell that is not a number of its column.
    #[error("{file}:{line}: column `{column}`: {message}")]
    Cell {
        /// The log.
        file: String,
        /// The line (1 is the header).
        line: usize,
        /// The column's name.
        column: String,
        /// What is wrong.
        message: String,
    },
    /// A row as a whole (cell count, time order).
    #[error("{file}:{line}: {message}")]
    Row {
        /// The log.
        file: String,
        /// The line (1 is the header).
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// Reads a log written by [`write_csv`] (columns may come in any order; extra columns are
/// ignored, a row with more non-empty cells than the header has columns is an error, a UTF-8
/// byte-order mark before the header is skipped). `file` is used in messages.
pub fn read_csv(text: &str, file: &str) -> Result<FlightLog, LogError> {
    let f = || file.to_string();
    // a byte-order mark before the header (a spreadsheet's UTF-8 export) is no part of it
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines: Vec<&str> = text.split('\n').collect();
    // a file that ends with a newline has an empty last piece
    let ends_cleanly = text.ends_with('\n');
    if ends_cleanly {
        lines.pop();
    }
    let lines: Vec<&str> = lines.into_iter().map(|l| l.strip_suffix('\r').unwrap_or(l)).collect();
    let Some(header) = lines.first().filter(|h| !h.trim().is_empty()) else {
        return Err(LogError::Empty { file: f() });
    };
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let index = column_index(&names, file)?;
    let mut columns: Vec<Vec<Option<f64>>> = vec![Vec::new(); COLUMNS.len()];
    let mut repairs = Vec::new();
    let mut last_t: Option<f64> = None;
    for (i, line) in lines.iter().enumerate().skip(1) {
        let lineno = i + 1;
        if line.trim().is_empty() {
            continue;
        }
        let last_cut_short = i == lines.len() - 1 && !ends_cleanly;
        let cells = row_cells(line, names.len(), last_cut_short, lineno, &mut repairs)
            .map_err(|message| LogError::Row { file: f(), line: lineno, message })?;
        let Some(cells) = cells else { break };
        let (t, row) = parse_row(&cells, &index, file, lineno)?;
        match last_t {
            Some(p) if t < p => {
                return Err(LogError::Row {
                    file: f(),
                    line: lineno,
                    message: format!("time goes backwards ({t} s after {p} s); sort the log or fix its clock"),
                });
            }
            Some(p) if t == p => {
                repairs.push(Repair::RepeatedTime { line: lineno, t_s: Some(t) });
                continue;
            }
            _ => {}
        }
        last_t = Some(t);
        for (c, x) in columns.iter_mut().zip(row) {
            c.push(x);
        }
    }
    let n = columns[0].len();
    if n < 2 {
        return Err(LogError::Empty { file: f() });
    }
    let t: Vec<f64> = columns[0].iter().map(|x| x.unwrap_or(f64::NAN)).collect();
    let segments = split_at_gaps(&t, &mut repairs);
    Ok(FlightLog { columns, segments, repairs })
}

/// Where each of [`COLUMNS`] sits in the header (`usize::MAX` for an absent optional column),
/// or a header error naming the first required column missing.
fn column_index(names: &[&str], file: &str) -> Result<[usize; COLUMNS.len()], LogError> {
    let mut index = [0usize; COLUMNS.len()];
    let required: Vec<&str> = COLUMNS.iter().copied().filter(|c| !OPTIONAL.contains(c)).collect();
    for (k, col) in COLUMNS.iter().enumerate() {
        match names.iter().position(|n| n == col) {
            Some(i) => index[k] = i,
            None if OPTIONAL.contains(col) => index[k] = usize::MAX,
            None => {
                let unknown: Vec<&str> = names.iter().copied().filter(|n| !COLUMNS.contains(n)).collect();
                let hint = crate::scenario::error::closest(col, unknown.iter().copied(), 3)
                    .map_or(String::new(), |u| format!(" (is `{u}` meant to be `{col}`?)"));
                return Err(LogError::Header {
                    file: file.to_string(),
                    message: format!("column `{col}` is missing{hint}; the log needs {}", required.join(",")),
                });
            }
        }
    }
    Ok(index)
}

/// A data line's cells, for this log and for a log read through a mapping: `None` for a last
/// line cut short (no newline; added to `repairs` and dropped), and the message of a row with too
/// few cells or a non-empty cell beyond the header's `columns`.
pub(crate) fn row_cells<'a, R: From<Repair>>(
    line: &'a str,
    columns: usize,
    last_cut_short: bool,
    lineno: usize,
    repairs: &mut Vec<R>,
) -> Result<Option<Vec<&'a str>>, String> {
    let cells: Vec<&str> = line.split(',').collect();
    if cells.len() < columns && last_cut_short {
        repairs.push(Repair::LastLineCut { line: lineno, cells: cells.len(), columns }.into());
        return Ok(None);
    }
    // cells beyond the header's columns belong to no column: only empty ones (a trailing
    // comma) are allowed
    if cells.len() < columns || cells[columns..].iter().any(|c| !c.trim().is_empty()) {
        return Err(format!("{} cells for {columns} columns", cells.len()));
    }
    Ok(Some(cells))
}

/// One data row's time and its cells as numbers, by column of [`COLUMNS`], or its located error:
/// a cell that is not a finite number, a `mocap_valid` other than 0 or 1, a valid pose with empty
/// cells, or no time.
fn parse_row(
    cells: &[&str],
    index: &[usize; COLUMNS.len()],
    file: &str,
    lineno: usize,
) -> Result<(f64, [Option<f64>; COLUMNS.len()]), LogError> {
    let mut row = [None; COLUMNS.len()];
    for (k, col) in COLUMNS.iter().enumerate() {
        let Some(cell) = cells.get(index[k]).map(|c| c.trim()) else { continue };
        if cell.is_empty() {
            continue;
        }
        let cell_err =
            |message: String| LogError::Cell { file: file.to_string(), line: lineno, column: col.to_string(), message };
        let x: f64 = cell.parse().map_err(|_| cell_err(format!("`{cell}` is not a number")))?;
        if !x.is_finite() {
            return Err(cell_err(format!("`{cell}` is not a finite number")));
        }
        row[k] = Some(x);
    }
    let pose_cells = row[3..10].iter().filter(|x| x.is_some()).count();
    match row[2] {
        Some(v) if v == 1.0 && pose_cells != 7 => {
            return Err(LogError::Row {
                file: file.to_string(),
                line: lineno,
                message: format!("mocap_valid is 1 but {} of the 7 pose cells are empty", 7 - pose_cells),
            });
        }
        Some(v) if v != 0.0 && v != 1.0 => {
            return Err(LogError::Cell {
                file: file.to_string(),
                line: lineno,
                column: "mocap_valid".into(),
                message: format!("{v} is neither 0 nor 1"),
            });
        }
        _ => {}
    }
    let Some(t) = row[0] else {
        return Err(LogError::Cell {
            file: file.to_string(),
            line: lineno,
            column: "t_s".into(),
            message: "every row needs a time".into(),
        });
    };
    Ok((t, row))
}

/// The median interval between increasing timestamps (s); `None` for fewer than two.
pub(crate) fn median_interval(t: &[f64]) -> Option<f64> {
    let mut dt: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    dt.sort_by(f64::total_cmp);
    dt.get(dt.len() / 2).copied()
}

/// Row ranges [start, end) between gaps longer than 3 × the median interval, each gap reported
/// in `repairs` (flyarena's logs and mapped logs alike).
pub(crate) fn split_at_gaps<R: From<Repair>>(t: &[f64], repairs: &mut Vec<R>) -> Vec<(usize, usize)> {
    let n = t.len();
    let Some(median) = median_interval(t) else { return vec![(0, n)] };
    let mut segments = Vec::new();
    let mut start = 0;
    for k in 1..n {
        if t[k] - t[k - 1] > 3.0 * median {
            repairs
                .push(Repair::Gap { after_s: t[k - 1], length_s: t[k] - t[k - 1], median_interval_s: median }.into());
            segments.push((start, k));
            start = k;
        }
    }
    segments.push((start, n));
    segments
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A log of the required columns, in reverse order (the reader finds them by name), with
    /// `rows` after the header; every row's values are its column's position in [`COLUMNS`].
    fn log_of(rows: &[&str]) -> String {
        let header: Vec<&str> = COLUMNS.iter().rev().copied().filter(|c| !OPTIONAL.contains(c)).collect();
        let mut text = header.join(",") + "\n";
        for r in rows {
            text += r;
            text.push('\n');
        }
        text
    }

    /// One row in the reversed header's order: t, then `mocap_valid` and the pose given, the
    /// other cells k (the column's index).
    fn row(t: &str, valid: &str, pose: &[&str; 7]) -> String {
        let cells: Vec<String> = (0..COLUMNS.len() - 1)
            .rev()
            .map(|k| match k {
                0 => t.to_string(),
                2 => valid.to_string(),
                3..=9 => pose[k - 3].to_string(),
                k => k.to_string(),
            })
            .collect();
        cells.join(",")
    }

    const POSE: [&str; 7] = ["1", "2", "-1", "1", "0", "0", "0"];

    /// Columns are found by name in any order; an absent optional column reads as empty cells;
    /// a row without a pose is allowed when `mocap_valid` is 0.
    #[test]
    fn columns_are_read_by_name_and_the_optional_one_may_be_absent() {
        let text = log_of(&[&row("0.5", "1", &POSE), &row("0.505", "0", &[""; 7])]);
        let log = read_csv(&text, "x.csv").unwrap();
        assert_eq!(log.rows(), 2);
        assert_eq!(log.columns[0], [Some(0.5), Some(0.505)]);
        assert_eq!(log.columns[1], [Some(1.0), Some(1.0)]); // seq, column 1
        assert_eq!(log.columns[3], [Some(1.0), None]); // pos_n_m, then no pose
        assert_eq!(log.columns[19], [Some(19.0), Some(19.0)]); // cmd_thrust
        assert_eq!(log.columns[20], [None, None]); // vbat_v, not in the header
    }

    /// Each defect of a row is refused at its line and column with why, never turned into a number.
    #[test]
    fn a_defective_row_is_a_located_error() {
        let cases: [(String, &str); 6] = [
            (
                row("0.5", "1", &["1", "", "-1", "1", "0", "0", "0"]),
                "x.csv:3: mocap_valid is 1 but 1 of the 7 pose cells are empty",
            ),
            (row("0.5", "2", &POSE), "x.csv:3: column `mocap_valid`: 2 is neither 0 nor 1"),
            (row("", "1", &POSE), "x.csv:3: column `t_s`: every row needs a time"),
            (
                row("0.5", "1", &["1", "abc", "-1", "1", "0", "0", "0"]),
                "x.csv:3: column `pos_e_m`: `abc` is not a number",
            ),
            (
                row("0.5", "1", &["1", "2", "inf", "1", "0", "0", "0"]),
                "x.csv:3: column `pos_d_m`: `inf` is not a finite number",
            ),
            (
                row("0.4", "1", &POSE),
                "x.csv:3: time goes backwards (0.4 s after 0.45 s); sort the log or fix its clock",
            ),
        ];
        for (bad, want) in cases {
            let text = log_of(&[&row("0.45", "1", &POSE), &bad]);
            let got = read_csv(&text, "x.csv").map(|_| ()).unwrap_err().to_string();
            assert_eq!(got, want);
        }
    }

    /// A required column missing is a header error naming it (and the misspelling it is closest to).
    #[test]
    fn a_missing_required_column_is_named() {
        let text = log_of(&[&row("0.5", "1", &POSE), &row("0.505", "1", &POSE)]).replacen("cmd_q", "cmd_qq", 1);
        let got = read_csv(&text, "x.csv").map(|_| ()).unwrap_err().to_string();
        assert!(got.starts_with("x.csv:1: column `cmd_q` is missing (is `cmd_qq` meant to be `cmd_q`?)"), "{got}");
    }

    /// A data line's width (flyarena's log and mapped logs alike): a full last line is kept with
    /// or without its newline, a short one is dropped (and said) only when it is the last and
    /// lacks its newline, an empty trailing cell is allowed and a filled one beyond the header is
    /// not.
    #[test]
    fn a_row_has_the_header_width_and_only_a_cut_last_line_is_dropped() {
        let mut repairs: Vec<Repair> = Vec::new();
        assert_eq!(row_cells("1,2,3", 3, true, 9, &mut repairs), Ok(Some(vec!["1", "2", "3"])));
        assert_eq!(row_cells("1,2,3,", 3, false, 9, &mut repairs), Ok(Some(vec!["1", "2", "3", ""])));
        assert!(repairs.is_empty());
        assert_eq!(row_cells("1,2", 3, true, 9, &mut repairs), Ok(None));
        assert_eq!(repairs, [Repair::LastLineCut { line: 9, cells: 2, columns: 3 }]);
        assert_eq!(row_cells("1,2", 3, false, 9, &mut repairs), Err("2 cells for 3 columns".to_string()));
        assert_eq!(row_cells("1,2,3,4", 3, true, 9, &mut repairs), Err("4 cells for 3 columns".to_string()));
    }

    /// Each repair's sentence, written out by hand: the line, the cells, the gap's length to the
    /// millisecond and the median interval to a tenth of one.
    #[test]
    fn a_repair_reads_as_its_sentence() {
        let cases = [
            (
                Repair::RepeatedTime { line: 7, t_s: Some(0.25) },
                "line 7: repeats the time 0.25 s of the previous row and was dropped",
            ),
            (
                Repair::RepeatedTime { line: 7, t_s: None },
                "line 7: repeats the time of the previous row and was dropped",
            ),
            (
                Repair::LastLineCut { line: 12, cells: 4, columns: 21 },
                "line 12: the last line is cut short (4 of 21 cells, no newline) and was dropped",
            ),
            (
                Repair::Gap { after_s: 1.5, length_s: 0.12345, median_interval_s: 0.00499 },
                "a gap of 0.123 s after t = 1.5 s (median interval 0.0050 s): the log is split into segments there",
            ),
        ];
        for (repair, want) in cases {
            assert_eq!(repair.to_string(), want);
        }
    }

    /// A gap longer than 3 × the median interval splits the rows there and is reported with the
    /// time before it, its length and the median; a gap of exactly 3 × does not.
    #[test]
    fn a_gap_over_three_median_intervals_splits_the_log() {
        let t = [0.0, 1.0, 2.0, 5.0, 6.0, 11.0, 12.0];
        let mut repairs = Vec::new();
        assert_eq!(split_at_gaps(&t, &mut repairs), [(0, 5), (5, 7)]);
        let [Repair::Gap { after_s, length_s, median_interval_s }] = repairs[..] else { panic!("{repairs:?}") };
        assert_eq!((after_s, length_s, median_interval_s), (6.0, 5.0, 1.0));
    }
}
