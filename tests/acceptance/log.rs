//! Flight logs: written by a run, read back bit for bit; every defect of a real file is an error
//! with line and column or a reported repair (the messages are pinned); fuzzed edits never panic.

use flyarena::engine::{RunOptions, run};
use flyarena::log::{COLUMNS, read_csv, write_csv};
use proptest::prelude::*;

fn flight() -> (flyarena::engine::VehicleRun, String) {
    let s = flyarena::scenario::Scenario::load(&super::root().join("scenarios/lost-marker.yaml")).unwrap();
    let v = run(s.spec(), RunOptions::default()).vehicles.remove(0);
    let csv = write_csv(&v, 0.005);
    (v, csv)
}

#[test]
fn a_log_reads_back_bit_for_bit() {
    let (v, csv) = flight();
    let log = read_csv(&csv, "flight.csv").unwrap();
    assert_eq!(log.rows(), v.trace.len());
    assert!(log.repairs.is_empty(), "{:?}", log.repairs);
    assert_eq!(log.segments, vec![(0, v.trace.len())]);
    // the trace carries the frame the station last sent from the first radio period on (a
    // trace that lost it would write an empty command column and still compare equal below)
    let without = v.trace.iter().filter(|s| s.ppm.is_none()).count();
    assert!(without <= 4, "{without} samples without a PPM frame");
    for (k, s) in v.trace.iter().enumerate() {
        assert_eq!(log.column("t_s").unwrap()[k], Some(s.t.as_secs_f64()));
        assert_eq!(log.column("gyro_z_rad_s").unwrap()[k].map(f64::to_bits), Some(s.imu.gyro.z().to_bits()));
        assert_eq!(log.column("acc_z_m_s2").unwrap()[k].map(f64::to_bits), Some(s.imu.specific_force.z().to_bits()));
        assert_eq!(log.column("pos_n_m").unwrap()[k].map(f64::to_bits), s.captured.map(|f| f.pos.x().to_bits()));
        assert_eq!(log.column("cmd_thrust").unwrap()[k], s.ppm.map(|p| p.channels[3] as f64));
        assert_eq!(log.column("vbat_v").unwrap()[k].map(f64::to_bits), Some(s.vbat_v.to_bits()));
    }
}

/// A log from before the battery voltage was logged (no `vbat_v` column) still reads, with the
/// voltage empty; a required column missing is still an error.
#[test]
fn a_log_without_the_battery_column_reads() {
    let old: String = small_log().lines().map(|l| l.rsplit_once(',').unwrap().0.to_string() + "\n").collect();
    assert!(old.starts_with("t_s,") && !old.contains("vbat"));
    let log = read_csv(&old, "old.csv").unwrap();
    assert_eq!(log.rows(), 6);
    assert!(log.column("vbat_v").unwrap().iter().all(Option::is_none));
    assert_eq!(log.column("cmd_thrust").unwrap()[0], Some(140.0));
    let new = read_csv(&small_log(), "new.csv").unwrap();
    assert!(new.column("vbat_v").unwrap().iter().all(|v| *v == Some(3.9)));
    let no_thrust = old.replacen(",cmd_thrust", ",cmd_thrus", 1);
    assert!(read_csv(&no_thrust, "x.csv").unwrap_err().to_string().contains("column `cmd_thrust` is missing"));
}

fn small_log() -> String {
    let mut s = COLUMNS.join(",") + "\n";
    for k in 0..6 {
        s += &format!("{},{k},1,0.1,0.2,-1,1,0,0,0,0.01,0,0,0,0,-9.81,128,128,128,140,3.9\n", k as f64 * 0.005);
    }
    s
}

/// The message for each defect, pinned for review (insta).
#[test]
fn bad_logs_get_located_errors_or_reported_repairs() {
    let good = small_log();
    let lines: Vec<&str> = good.lines().collect();
    let with_line = |k: usize, new: &str| {
        let mut l: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
        l[k] = new.to_string();
        l.join("\n") + "\n"
    };
    let cases: Vec<(&str, String)> = vec![
        ("empty file", String::new()),
        ("header only", lines[0].to_string() + "\n"),
        ("misnamed column", good.replacen("gyro_x_rad_s", "gyro_x_rads", 1)),
        ("not a number", with_line(3, &lines[3].replacen("0.1,", "abc,", 1))),
        ("NaN", with_line(3, &lines[3].replacen("0.1,", "NaN,", 1))),
        ("infinity", with_line(2, &lines[2].replacen("-9.81", "inf", 1))),
        ("time backwards", with_line(4, &lines[4].replacen("0.015", "0.001", 1))),
        ("too few cells mid-file", with_line(2, "0.005,1,1")),
        ("valid without a pose", with_line(2, &lines[2].replacen("0.1,0.2,-1", ",,", 1))),
        ("duplicated timestamp", good.clone() + lines[6] + "\n"),
        (
            "gap",
            good.clone()
                + &lines[6].replacen("0.025", "0.5", 1)
                + "\n"
                + &lines[6].replacen("0.025", "0.505", 1)
                + "\n",
        ),
        ("truncated last line", good.clone() + "0.03,6,1,0.1,0."),
        ("a cell beyond the header", with_line(3, &(lines[3].to_string() + ",7"))),
        ("trailing commas", good.replace('\n', ",\n")),
        ("byte-order mark", format!("\u{feff}{good}")),
    ];
    let mut out = String::new();
    for (name, text) in cases {
        let msg = match read_csv(&text, "log.csv") {
            Ok(log) => {
                let repairs: Vec<String> = log.repairs.iter().map(ToString::to_string).collect();
                format!("ok, {} rows, segments {:?}, repairs: {repairs:?}", log.rows(), log.segments)
            }
            Err(e) => format!("error: {e}"),
        };
        out += &format!("{name}:\n  {msg}\n");
    }
    insta::with_settings!({ snapshot_path => "../../snapshots", prepend_module_to_snapshot => false }, {
        insta::assert_snapshot!("bad-log-messages", out);
    });
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    /// Random cuts, insertions and replacements in a real log: an error, or a log whose times
    /// increase strictly, whose values are finite and whose segments cover every row.
    #[test]
    fn reader_never_panics(cuts in prop::collection::vec((any::<usize>(), 0usize..40, prop::sample::select(vec!["", ",", "\n", "nan", "-", "1e400", "\r\n", "é", "0.0001", ",,,,"])), 1..5)) {
        let mut text = small_log() + &small_log().lines().skip(1).map(|l| l.replacen("0.0", "0.1", 1) + "\n").collect::<String>();
        for (at, len, ins) in &cuts {
            let chars: Vec<char> = text.chars().collect();
            let a = at % chars.len().max(1);
            let b = (a + len).min(chars.len());
            text = chars[..a].iter().collect::<String>() + ins + &chars[b..].iter().collect::<String>();
        }
        if let Ok(log) = read_csv(&text, "fuzz.csv") {
            let t: Vec<f64> = log.column("t_s").unwrap().iter().map(|x| x.unwrap()).collect();
            prop_assert!(t.windows(2).all(|w| w[1] > w[0]));
            prop_assert!(log.columns.iter().flatten().flatten().all(|x| x.is_finite()));
            prop_assert_eq!(log.segments.first().map(|s| s.0), Some(0));
            prop_assert_eq!(log.segments.last().map(|s| s.1), Some(log.rows()));
        }
    }
}
