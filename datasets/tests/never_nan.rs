//! Property tests: a reader never accepts a file and returns NaN (or ±inf) in a column it validated.
//! Random CSV files whose cells mix ordinary numbers with every spelling of a non-finite or
//! half-number a user's tool may write (`NaN`, `nan`, `-inf`, `Infinity`, `1e400`, `1,5`, `NA`, blanks,
//! quoted cells, padding), and random Parquet (and CSV) files written from float columns with NaN and ±inf,
//! read with a schema, without one, and as the measured-groove contract: when a reader accepts, every
//! number it hands on is finite; and a file of finite numbers is accepted with the same numbers. (The
//! one exception is by contract: a column of kind `Reading`, the sensor log's readings, hands on NaN
//! for "no reading in this sample" and still refuses ±inf — sensor_log.rs.)
//!
//! Rerun: `cargo test -p millcomp-datasets --test main never_nan` (a few seconds).

use millcomp_datasets::contracts::{MEASURED_GROOVE_COLUMNS, read_measured_groove};
use millcomp_datasets::{
    Column, ColumnData, ColumnKind, ColumnSpec, Schema, Table, read_any, read_csv_str, read_table,
    write_table,
};
use proptest::prelude::*;

fn schema() -> Schema {
    Schema::new(
        "nan",
        vec![
            ColumnSpec::required("x_um", ColumnKind::Float, "a number"),
            ColumnSpec::required("n", ColumnKind::Int, "an integer"),
            ColumnSpec::optional("on", ColumnKind::Flag, "a flag"),
            ColumnSpec::optional("note", ColumnKind::Text, "text"),
        ],
    )
}

/// Cells: ordinary numbers written as a tool would, and the troublemakers.
fn cell() -> impl Strategy<Value = String> {
    prop_oneof![
        3 => (-1e6f64..1e6).prop_map(|x| format!("{x}")),
        1 => (-1000i64..1000).prop_map(|i| i.to_string()),
        3 => prop::sample::select(vec![
            "NaN", "nan", "-nan", "+NaN", "NAN", "inf", "-inf", "+inf", "Inf", "INF", "infinity",
            "-Infinity", "1e400", "-1e309", "1e-400", "0x10", "1,5", "1.5.2", "NA", "N/A", "null",
            "", " ", "  3.5  ", "\"2.5\"", "\"NaN\"", "\"1,5\"", "1_000", "+3", "-0", "1e", ".",
            "-.5", "5.", "true", "FALSE", "1.0", "0.0",
        ])
        .prop_map(str::to_string),
    ]
}

fn csv(rows: &[Vec<String>]) -> String {
    let mut s = String::from("x_um,n,on,note\n");
    for r in rows {
        s.push_str(&r.join(","));
        s.push('\n');
    }
    s
}

fn assert_finite(t: &Table, what: &str) {
    for c in &t.columns {
        if let ColumnData::Float(v) = &c.data {
            assert!(
                v.iter().all(|x| x.is_finite()),
                "{what}: accepted column `{}` holds {v:?}",
                c.name
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn csv_readers_accept_only_finite_numbers(rows in prop::collection::vec(prop::collection::vec(cell(), 4), 1..6)) {
        let text = csv(&rows);
        if let Ok(t) = read_csv_str("n.csv", &text, &schema()) {
            assert_finite(&t, &text);
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("n.csv");
        std::fs::write(&path, &text).unwrap();
        if let Ok(t) = read_table(&path, &schema()) {
            assert_finite(&t, &text);
        }
        if let Ok(t) = read_any(&path) {
            assert_finite(&t, &text);
        }
    }

    #[test]
    fn measured_groove_accepts_only_finite_numbers(rows in prop::collection::vec(prop::collection::vec(cell(), 11), 1..5)) {
        let mut text = MEASURED_GROOVE_COLUMNS.join(",");
        text.push('\n');
        for r in &rows {
            text.push_str(&r.join(","));
            text.push('\n');
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.csv");
        std::fs::write(&path, &text).unwrap();
        if let Ok(m) = read_measured_groove(&path) {
            for p in &m.points {
                let v = [p.t_s, p.x_mm, p.cut_length_mm, p.speed_rpm, p.feed_mm_min, p.upfeed_um,
                         p.tilt_deg, p.depth_cmd_um, p.depth_meas_um];
                prop_assert!(v.iter().all(|x| x.is_finite()), "{text}");
            }
        }
    }

    /// Parquet with typed float columns: NaN, ±inf and nulls are refused; finite numbers come back
    /// bit for bit.
    #[test]
    fn parquet_readers_accept_only_finite_numbers(
        xs in prop::collection::vec(prop_oneof![
            4 => prop::num::f64::NORMAL | prop::num::f64::ZERO | prop::num::f64::SUBNORMAL,
            1 => prop::sample::select(vec![f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -f64::NAN]),
        ], 1..8),
        ext in prop::sample::select(vec!["parquet", "csv"]),
    ) {
        let n = xs.len();
        let t = Table::from_columns("mem", vec![
            Column { name: "x_um".into(), data: ColumnData::Float(xs.clone()) },
            Column { name: "n".into(), data: ColumnData::Int((0..n as i64).collect()) },
        ]).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(format!("n.{ext}"));
        write_table(&t, &path).unwrap();
        let all_finite = xs.iter().all(|x| x.is_finite());
        match read_table(&path, &schema()) {
            Ok(back) => {
                assert_finite(&back, ext);
                prop_assert!(all_finite);
                let got = back.f64s("x_um").unwrap();
                prop_assert_eq!(got.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                                xs.iter().map(|x| x.to_bits()).collect::<Vec<_>>());
            }
            Err(e) => prop_assert!(!all_finite, "finite numbers refused: {e}"),
        }
        if let Ok(back) = read_any(&path) {
            assert_finite(&back, ext);
        }
    }
}
