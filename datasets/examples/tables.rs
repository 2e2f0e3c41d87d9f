//! Tables at millcomp's edges: a shipped dataset, a user's file checked against a schema (an error names
//! the file, the column and the 1-based data row), and an atomic write as CSV and Parquet, read back.
//!
//! Run: `cargo run -p millcomp-datasets --example tables`.

use millcomp_datasets::{DatasetError, dataset, load, read_table, write_table};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // A shipped table, validated against its schema on load.
    let doe = load("clayton_doe")?;
    let fx = doe.f64s("max_fx_n")?;
    println!(
        "clayton_doe: {} trials, columns {}",
        doe.n_rows(),
        doe.names().join(", ")
    );
    // 000_…txt Table 3-3: trial 1 (200 µm, 10 000 rpm, 20 µm/rev) had a max X force of 3.34 N.
    assert_eq!(fx[0], 3.34);
    let mean = fx.iter().sum::<f64>() / fx.len() as f64;
    println!("mean max X force: {mean:.4} N");

    // Written atomically as CSV and as Parquet, and read back against the same schema.
    let dir = tempfile::tempdir()?;
    let schema = dataset("clayton_doe")?.schema();
    for name in ["clayton_doe.csv", "clayton_doe.parquet"] {
        let path = dir.path().join(name);
        write_table(&doe, &path)?;
        let back = read_table(&path, &schema)?;
        assert_eq!(back.f64s("max_fx_n")?, fx);
        println!(
            "{name}: {} bytes, read back equal",
            std::fs::metadata(&path)?.len()
        );
    }

    // A user's copy with a typo in trial 3's upfeed: the error names the file, column and row.
    let text = std::fs::read_to_string(dir.path().join("clayton_doe.csv"))?;
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    let col = header.iter().position(|h| *h == "upfeed_um").unwrap();
    let mut cells: Vec<String> = lines[3].split(',').map(String::from).collect();
    cells[col] = "ten".into();
    lines[3] = cells.join(",");
    let bad = dir.path().join("my_doe.csv");
    std::fs::write(&bad, lines.join("\n") + "\n")?;
    let err = read_table(&bad, &schema).unwrap_err();
    println!("error: {err}");
    assert!(matches!(&err, DatasetError::BadCell { row: 3, column, .. } if column == "upfeed_um"));
    Ok(())
}
