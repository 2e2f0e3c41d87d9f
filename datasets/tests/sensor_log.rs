//! The sensor-log and commands contracts (`millcomp_datasets::contracts`): `millcomp replay` promises
//! the commands of a simulated run bit for bit from its sensor log, so a log written by the table
//! writer must read back with the same bits — every finite reading (subnormals, −0, the last digit),
//! and NaN where a sample had no reading — in CSV and in Parquet. A reading column is the one place a
//! reader hands on NaN (never ±inf: refused, naming the file, the column and the row); `t_s` stays a
//! plain number column.
//!
//! Rerun: `cargo test --workspace --locked --test main sensor_log` (a few seconds; not `-p`, which
//! rebuilds polars with another feature set).

use millcomp_datasets::contracts::{
    COMMANDS_COLUMNS, CommandColumns, SENSOR_LOG_COLUMNS, SensorLog, commands_table,
    read_sensor_log, read_sensor_log_str, sensor_log_table,
};
use millcomp_datasets::{Column, ColumnData, Table, write_table};
use proptest::prelude::*;

/// A reading: any finite f64 (every bit pattern that is not ±inf or NaN), or no reading (NaN).
fn reading() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => any::<u64>()
            .prop_map(f64::from_bits)
            .prop_filter("finite", |x| x.is_finite()),
        2 => -50.0f64..50.0,
        1 => Just(f64::NAN),
        1 => prop::sample::select(vec![0.0, -0.0, f64::MIN_POSITIVE, 5e-324, f64::MAX, 0.1 + 0.2]),
    ]
}

fn log() -> impl Strategy<Value = SensorLog> {
    (1usize..40).prop_flat_map(|n| {
        (
            prop::collection::vec(reading(), n),
            prop::collection::vec(reading(), n),
            prop::collection::vec(reading(), n),
        )
            .prop_map(move |(x_mm, force_n, gauge_um)| SensorLog {
                t_s: (0..n).map(|k| k as f64 * 5e-5).collect(),
                x_mm,
                force_n,
                gauge_um,
            })
    })
}

fn bits(v: &[f64]) -> Vec<u64> {
    // every NaN is "no reading": one bit pattern for the comparison
    v.iter()
        .map(|x| if x.is_nan() { u64::MAX } else { x.to_bits() })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn a_written_sensor_log_reads_back_bit_for_bit(log in log()) {
        let dir = tempfile::tempdir().unwrap();
        for ext in ["csv", "parquet"] {
            let path = dir.path().join(format!("log.{ext}"));
            write_table(&sensor_log_table("log", &log).unwrap(), &path).unwrap();
            let back = read_sensor_log(&path).unwrap();
            prop_assert_eq!(bits(&back.t_s), bits(&log.t_s), "{} t_s", ext);
            prop_assert_eq!(bits(&back.x_mm), bits(&log.x_mm), "{} x_mm", ext);
            prop_assert_eq!(bits(&back.force_n), bits(&log.force_n), "{} force_n", ext);
            prop_assert_eq!(bits(&back.gauge_um), bits(&log.gauge_um), "{} gauge_um", ext);
            back.check_rate("log", 5e-5).unwrap();
        }
    }
}

#[test]
fn empty_and_nan_cells_are_no_reading_inf_is_refused() {
    let head = SENSOR_LOG_COLUMNS.join(",");
    let log =
        read_sensor_log_str("log.csv", &format!("{head}\n0,,NaN,nan\n5e-5,1.5,-0,2\n")).unwrap();
    assert!(log.x_mm[0].is_nan() && log.force_n[0].is_nan() && log.gauge_um[0].is_nan());
    assert_eq!(log.x_mm[1], 1.5);
    assert!(log.force_n[1] == 0.0 && log.force_n[1].is_sign_negative());
    for (row, column) in [
        ("0,inf,0,0", "x_mm"),
        ("0,0,-inf,0", "force_n"),
        ("0,0,0,1e400", "gauge_um"),
    ] {
        let e = read_sensor_log_str("log.csv", &format!("{head}\n{row}\n"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("log.csv") && e.contains(column) && e.contains("row 1"),
            "{e}"
        );
    }
    // t_s is a time, not a reading: no NaN, no blank
    for row in ["NaN,0,0,0", ",0,0,0"] {
        let e = read_sensor_log_str("log.csv", &format!("{head}\n{row}\n"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("log.csv") && e.contains("t_s") && e.contains("row 1"),
            "{e}"
        );
    }
    // a missing column is named
    let e = read_sensor_log_str("log.csv", "t_s,x_mm,force_n\n0,0,0\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("log.csv") && e.contains("gauge_um"), "{e}");
}

#[test]
fn parquet_infinity_in_a_reading_is_refused_naming_the_row() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("log.parquet");
    let column = |name: &str, v: Vec<f64>| Column {
        name: name.into(),
        data: ColumnData::Float(v),
    };
    let t = Table::from_columns(
        "log",
        vec![
            column("t_s", vec![0.0, 5e-5, 1e-4]),
            column("x_mm", vec![0.0, 0.0, 0.0]),
            column("force_n", vec![0.1, f64::NAN, f64::INFINITY]),
            column("gauge_um", vec![0.0, 0.0, 0.0]),
        ],
    )
    .unwrap();
    write_table(&t, &path).unwrap();
    let e = read_sensor_log(&path).unwrap_err().to_string();
    assert!(
        e.contains("log.parquet") && e.contains("force_n") && e.contains("row 3"),
        "{e}"
    );
}

#[test]
fn a_log_whose_times_skip_a_period_is_refused_at_the_skip() {
    let log = SensorLog {
        t_s: vec![0.0, 5e-5, 1e-4, 2e-4],
        x_mm: vec![0.0; 4],
        force_n: vec![0.0; 4],
        gauge_um: vec![0.0; 4],
    };
    log.check_rate("log.csv", 5e-5 * 1.005).unwrap_err();
    let e = log.check_rate("log.csv", 5e-5).unwrap_err().to_string();
    assert!(
        e.contains("log.csv") && e.contains("t_s") && e.contains("row 4"),
        "{e}"
    );
    let e = SensorLog::default()
        .check_rate("log.csv", 5e-5)
        .unwrap_err()
        .to_string();
    assert!(e.contains("log.csv"), "{e}");
}

#[test]
fn the_commands_table_has_one_row_per_controller_and_sample() {
    let runs = [
        CommandColumns {
            controller: "mpc".into(),
            voltage_v: vec![0.0, 12.5, 13.0],
            flags: vec![9, 1, 1],
            iterations: vec![0, 7, 6],
        },
        CommandColumns {
            controller: "none".into(),
            voltage_v: vec![0.0; 3],
            flags: vec![0; 3],
            iterations: vec![0; 3],
        },
    ];
    let t = commands_table("out.csv", &[0.0, 5e-5, 1e-4], &runs).unwrap();
    assert_eq!(t.names(), COMMANDS_COLUMNS);
    assert_eq!(t.n_rows(), 6);
    assert_eq!(t.i64s("cycle").unwrap(), [0, 1, 2, 0, 1, 2]);
    assert_eq!(t.f64s("t_s").unwrap()[4], 5e-5);
    assert_eq!(t.i64s("iterations").unwrap()[1], 7);
    // more commands than sample times, or ragged columns: refused naming t_s
    let long = CommandColumns {
        controller: "pid".into(),
        voltage_v: vec![0.0; 4],
        flags: vec![0; 4],
        iterations: vec![0; 4],
    };
    let e = commands_table("out.csv", &[0.0; 3], &[long])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("out.csv") && e.contains("t_s") && e.contains("pid"),
        "{e}"
    );
    let ragged = CommandColumns {
        controller: "pid".into(),
        voltage_v: vec![0.0; 2],
        flags: vec![0; 1],
        iterations: vec![0; 2],
    };
    assert!(commands_table("out.csv", &[0.0; 3], &[ragged]).is_err());
}
