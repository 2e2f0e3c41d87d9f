//! The C program `examples/replay.c`, compiled with `-Wall -Wextra -Wpedantic -Werror` against the
//! committed header and the static library, drives the MPC through a recorded sensor log: its commands
//! equal the Rust runtime's bit for bit, and the allocator calls inside its step loop (malloc, calloc,
//! realloc, free, posix_memalign, aligned_alloc wrapped at link time) are counted.

use std::path::{Path, PathBuf};
use std::process::Command as Process;

use millcomp_runtime::{Controller, flags, replay::replay};

use crate::common;

/// The static library cargo built with this test: `target/<profile>/deps/libmillcomp_ffi.a`, beside
/// this test's executable (or one level up, where `cargo build` puts it).
fn static_lib() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap();
    [deps, deps.parent().unwrap()]
        .iter()
        .map(|d| d.join("libmillcomp_ffi.a"))
        .find(|p| p.exists())
        .unwrap_or_else(|| panic!("libmillcomp_ffi.a not built beside {}", deps.display()))
}

/// Compile `examples/replay.c` into `dir`; the executable.
fn compile(dir: &Path) -> PathBuf {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    let exe = dir.join("replay");
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let out = Process::new(&cc)
        .args(["-std=c11", "-O2", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-I"])
        .arg(manifest.join("include"))
        .arg(manifest.join("examples/replay.c"))
        .arg(static_lib())
        .arg("-Wl,--wrap=malloc,--wrap=calloc,--wrap=realloc,--wrap=free,--wrap=posix_memalign,--wrap=aligned_alloc")
        .args(["-lgcc_s", "-lutil", "-lrt", "-lpthread", "-lm", "-ldl", "-lc", "-o"])
        .arg(&exe)
        .output()
        .unwrap_or_else(|e| panic!("{cc}: {e}"));
    assert!(
        out.status.success(),
        "{cc} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    exe
}

#[test]
fn the_c_program_sends_the_rust_commands_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let program = common::data("cut_40um.toml");
    let bundle = common::data("bundle_s7.toml");
    let log = common::record(&program, 10_000);
    let log_path = dir.path().join("sensors.csv");
    let mut text = String::from("t_s,x_mm,force_n,gauge_um\n");
    for (k, m) in log.iter().enumerate() {
        // Rust's shortest round-trip form: strtod reads back the same double
        text.push_str(&format!(
            "{},{},{},{}\n",
            k as f64 * 5e-5,
            m.x_mm,
            m.force_n,
            m.gauge_um
        ));
    }
    std::fs::write(&log_path, text).unwrap();

    // the Rust runtime on the same log
    let mut ctl = Controller::from_files(&bundle, &program).unwrap();
    let rust = replay(&mut ctl, &log).commands;

    let exe = compile(dir.path());
    let out = Process::new(&exe)
        .args([&bundle, &program, &log_path])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let stdout = String::from_utf8(out.stdout).unwrap();
    let rows: Vec<&str> = stdout.lines().skip(1).collect();
    assert_eq!(rows.len(), rust.len());
    for (k, (row, r)) in rows.iter().zip(&rust).enumerate() {
        let f: Vec<&str> = row.split(',').collect();
        let v: f64 = f[1].parse().unwrap();
        assert_eq!(
            (
                v.to_bits(),
                f[2].parse::<u32>().unwrap(),
                f[3].parse::<u32>().unwrap()
            ),
            (r.voltage_v.to_bits(), r.flags, r.iterations),
            "cycle {k}: C {row}, Rust {r:?}"
        );
    }
    // the allocator calls inside the C program's step loop: none, the QP solves' included
    let planned = rust.iter().filter(|c| c.has(flags::PLANNED)).count() as u64;
    let calls: u64 = stderr
        .split(", ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no count in {stderr}"));
    println!("{stderr}");
    println!(
        "{} steps, {planned} QP solves: {calls} allocator calls in the step loop",
        rust.len()
    );
    assert!(planned >= 900, "{planned}");
    assert_eq!(calls, 0, "{stderr}");
}
