//! The documentation's outputs stay true: the console blocks of README.md and docs/ whose commands are
//! fast and deterministic are run as the page shows them and their output is compared with what it
//! shows; and every relative link of README.md, ARCHITECTURE.md and docs/ leads to a file (and, with a
//! `#fragment` into a Markdown page, to one of its headings).
//!
//! A block is a run of `$ COMMAND` lines, each followed by the output the page shows for it. A page's
//! checked blocks run in the order `CHECKED` lists them, in one scratch directory per page holding a
//! copy of `datasets/` (so `--report`, `--save` and `--out` write there, and a page reads only what
//! its own commands wrote, as a reader following it would), through `bash -c` with this build's
//! `millcomp` first on the PATH, stdout and stderr together (the pages show both). An output line
//! `...` (indented or not) or a parenthesised remark `(…)` stands for output left out: the other lines
//! must then appear in that order; a block without one must match line for line. Trailing spaces do
//! not count.
//!
//! The closed-loop blocks are checked too. What the machine's speed decides is compared only up to
//! where it starts: a `solver:` line up to its solve count, a batch's `simulated … of machining in`
//! line up to `in`, a `QP solve:` line up to that label, and the demo's `report:` line up to its
//! wall time. A `simulate` of a scenario runs with
//! `--no-realtime`: its MPC's cycle budget is then not enforced, so every cycle uses its fresh plan,
//! as batches, `compare` and the tests do, and the result does not depend on how busy the machine is
//! (a deadline miss's fallback can move the third decimal). The pages' closed-loop runs must
//! therefore be recordings without a deadline miss.
//!
//! Every console block whose first command is a `millcomp` one is either checked (`CHECKED`) or says
//! why not (`NOT_CHECKED`), so a new block cannot go unchecked by being forgotten. Left out, and why:
//! the full demo (about 260 closed-loop runs), `parts` (a minute and more unoptimised), the 128-run designed batches, the thermal identifications
//! of the full FL record (a minute each unoptimised), the studies run through `cargo run --release`
//! or `bash bench/…` (minutes).

use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::process::Command;

use pulldown_cmark::{Event, Options, Parser, Tag, TagEnd};

/// The checked blocks, page by page: the first command of each block as the page writes it, in the
/// order they run (a block may read what an earlier one of its page wrote).
const CHECKED: &[(&str, &[&str])] = &[
    (
        "README.md",
        &[
            "millcomp pipeline datasets/pipeline/plan.toml --out my-machine",
            "millcomp identify spindle datasets/runs/spindle_step_synthetic.csv --save spindle.toml",
            "millcomp datasets list",
            "millcomp doe design --design fractional --factors depth_um=100:200,speed_rpm=10000:20000,upfeed_um=10:20,wearland_um=4:12 --resolution 4 --seed 3",
            "millcomp doe analyze datasets/data/clayton_doe.csv --response max_fx_n --factors depth_um,speed_rpm,upfeed_um",
            "millcomp identify force datasets/data/clayton_doe.csv --material 6061",
            "millcomp simulate datasets/scenarios/groove_s7_30deg.toml --controller mpc --out trace.csv --plot trace.svg",
            "millcomp commission datasets/scenarios/groove_s7_20deg_commissioned.toml --out models.toml",
            "millcomp batch --doe \"--design fractional --factors tilt_deg=20:40,upfeed_um=8:12,wearland_um=4:10 --resolution 3 --seed 1\" --controllers pid,mpc --out results",
            "millcomp diagnose datasets/synthetic/real_tool_wear.toml datasets/synthetic/real_tool_wear.csv",
        ],
    ),
    (
        "docs/datasets.md",
        &[
            "millcomp datasets list",
            r"printf 'groove_id,t_s,x_mm,cut_length_mm,spindle_rpm,feed_mm_min,upfeed_um,tilt_deg,coolant_on,depth_cmd_um,depth_meas_um\n0,0,0,0,10000,100,ten,20,1,0,0\n' > bad.csv",
            "millcomp datasets figures",
        ],
    ),
    (
        "docs/doe.md",
        &[
            "millcomp doe design --design fractional --factors depth_um=100:200,speed_rpm=10000:20000,upfeed_um=10:20,wearland_um=4:12 --resolution 4 --seed 3",
            "millcomp doe analyze datasets/data/clayton_doe.csv --response max_fx_n --factors depth_um,speed_rpm,upfeed_um",
        ],
    ),
    (
        "docs/identify.md",
        &[
            "millcomp identify force datasets/data/clayton_doe.csv --material 6061",
            "millcomp identify spindle datasets/runs/spindle_step_synthetic.csv",
            "millcomp identify wear datasets/real/phm2010_c1/per_cut_force_features_c1.csv --join datasets/real/phm2010_c1/per_cut_wear_c1.csv --also datasets/real/phm2010_c4/per_cut_force_features_c4.csv --join datasets/real/phm2010_c4/per_cut_wear_c4.csv --on run --columns 'cut=run,force_n=force_y__rms,vb_um=VB_flute_*,unit=case' --laws linear",
        ],
    ),
    (
        "docs/simulate.md",
        &[
            "millcomp simulate datasets/sessions/example.toml --out run.csv --plot run.svg",
            "millcomp simulate datasets/scenarios/groove_s7_30deg.toml --controller mpc --out trace.csv --plot trace.svg",
            "millcomp simulate datasets/scenarios/groove_s7_20deg_feed_step.toml --controller mpc --plot feed_step.svg",
        ],
    ),
    (
        "docs/nc-axis.md",
        &[
            "millcomp simulate datasets/scenarios/nc_c45_feed_step.toml --controller reactive --out reactive.csv --plot reactive.svg",
            "millcomp batch --scenarios datasets/scenarios/nc_axis_batch.csv --controllers none,reactive,proactive,mpc --out ncbatch",
        ],
    ),
    (
        "docs/commission.md",
        &[
            "millcomp identify spindle datasets/runs/spindle_step_synthetic.csv --save spindle.toml",
            r#"sed -e 's/^name = .*/name = "own_6061"/' -e 's/^material = "S7"/material = "6061"/' -e 's/^\[control\]/[control]\nbundle = "models.toml"/' datasets/scenarios/groove_s7_20deg.toml > own.toml"#,
            "millcomp commission datasets/scenarios/groove_s7_20deg_commissioned.toml --out models.toml",
        ],
    ),
    (
        "docs/demo.md",
        &["millcomp demo --quick --out millcomp-demo"],
    ),
    (
        "docs/pipeline.md",
        &[
            "millcomp pipeline datasets/pipeline/plan.toml --out my-machine",
            r#"printf 'name = "empty"\n' > empty.toml"#,
        ],
    ),
    (
        "docs/batch.md",
        &[
            "millcomp batch --doe \"--design fractional --factors tilt_deg=20:40,upfeed_um=8:12,wearland_um=4:10 --resolution 3 --seed 1\" --controllers pid,mpc --out results",
            "millcomp batch --doe \"--design fractional --resolution 5 --seed 1 --factors tilt_deg=20:40,depth_um=40:80,wearland_um=4:12,stiffness_error_pct=-10:10,noise_scale=0.5:2,material=S7:6061,feed_step=0:1,depth_step=0:1\" --controllers pid-tuned,mpc --out b128 --threads 2 --dry-run",
        ],
    ),
    (
        "docs/diagnose.md",
        &[
            "millcomp diagnose datasets/synthetic/real_tool_wear.toml datasets/synthetic/real_tool_wear.csv",
            "millcomp diagnose datasets/synthetic/plan_cannot_separate.toml datasets/synthetic/plan_cannot_separate.csv",
            "millcomp diagnose datasets/synthetic/real_coolant_thermal_drift+tool_wear.toml datasets/synthetic/real_coolant_thermal_drift+tool_wear.csv | grep -E '^(look-alike|named)'",
            "millcomp diagnose datasets/synthetic/real_coolant_thermal_drift+tool_wear.toml datasets/synthetic/real_coolant_thermal_drift+tool_wear.csv --next-plan next.toml | grep -A8 '^next plan'",
        ],
    ),
    (
        "docs/studies/published-forces.md",
        &["millcomp identify force datasets/data/clayton_doe.csv --material 6061 --diagnose"],
    ),
    (
        "docs/real-machines.md",
        &[
            "millcomp diagnose --record datasets/real/fl_thermal/thermal_drift.csv --columns 't_s=time_s,speed_rpm=spindle_rpm,temp_c=temp_t*_C,drift_um=disp_ch1_um'",
            "millcomp diagnose --record datasets/real/phm2010_c1/per_cut_force_features_c1.csv --columns 'cut=run,force_n=force_*__rms' --report datasets/real/plots",
            "millcomp diagnose --record datasets/real/phm2010_c1/per_cut_force_features_c1.csv --columns 'cut=run,t_s=run,speed_rpm=10400,force_n=force_z__rms'",
            "millcomp identify wear datasets/real/phm2010_c1/per_cut_force_features_c1.csv --join datasets/real/phm2010_c1/per_cut_wear_c1.csv --on run --columns 'cut=run,force_n=force_*__rms,vb_um=VB_flute_*' --train 1:199 --test 200:315 --plots datasets/real/plots",
            "millcomp identify flutes datasets/real/phm2010_c1/c1_cut001_mid.csv --also datasets/real/phm2010_c1/c1_cut315_mid.csv --columns 'force_n=force_x_N+force_y_N+force_z_N' --flutes 3 --speed-rpm 10400 --sample-rate-hz 50000 --plots datasets/real/plots",
            "millcomp identify thermal datasets/real/fl_thermal/thermal_drift.csv --columns 't_s=time_s,drift_um=disp_ch9_um' --train 0:50%",
        ],
    ),
];

/// The `millcomp` blocks left unchecked: the page, the start of the block's first command, and why.
const NOT_CHECKED: &[(&str, &str, &str)] = &[
    (
        "README.md",
        "millcomp demo ",
        "the full demo: about 260 closed-loop runs, minutes even optimised; the quick demo's block in docs/demo.md \
         is checked, and the pipeline block above it gives the same answer from the demo's files",
    ),
    (
        "README.md",
        "millcomp parts ",
        "a minute and more unoptimised",
    ),
    (
        "docs/parts.md",
        "millcomp parts ",
        "a minute and more unoptimised",
    ),
    (
        "docs/real-machines.md",
        "millcomp identify thermal datasets/real/fl_thermal/thermal_drift.csv --columns 't_s=time_s,speed_rpm=spindle_rpm,temp_c=temp_t*_C,drift_um=disp_ch*_um'",
        "the full FL record, five channels: minutes unoptimised",
    ),
    (
        "docs/real-machines.md",
        "millcomp diagnose --record datasets/real/fl_thermal/thermal_drift.csv --columns 't_s=time_s,speed_rpm=spindle_rpm,temp_c=temp_t*_C,drift_um=disp_ch*_um'",
        "the full FL record, five channels: minutes unoptimised",
    ),
    (
        "docs/studies/designed-batch.md",
        "millcomp batch --doe ",
        "640 runs: minutes even optimised",
    ),
];

/// The command as the check runs it: a scenario's `simulate` without real-time priority, so the
/// MPC's cycle budget is not enforced and no deadline miss replaces a plan (see the module's note).
fn as_run(command: &str) -> String {
    if command.starts_with("millcomp simulate datasets/scenarios/") && !command.contains('|') {
        format!("{command} --no-realtime")
    } else {
        command.to_string()
    }
}

/// The part of a line the machine's speed does not decide, for the lines where it decides the rest:
/// the MPC's cycle times and deadline misses, a batch's wall time, its progress lines' time left and
/// speed, its QP solve times, the demo's wall time.
fn timing_free(line: &str) -> Option<&str> {
    let upto = |marker: &str| line.find(marker).map(|i| &line[..i + marker.len()]);
    if line.starts_with("solver: ") {
        upto(" solves,")
    } else if line.starts_with("batch: ") && line.contains(" runs | ") {
        // a batch's progress line: runs done of the total, then the time left and the speed
        upto(" runs |")
    } else if line.starts_with("report: ") {
        line.rfind(" (").map(|i| &line[..i])
    } else if line.starts_with("simulated ") {
        upto(" of machining in")
    } else {
        upto(" QP solve:")
    }
}

/// Whether `actual` prints what `shown` shows: the same line, or the same up to where the machine's
/// speed decides the rest ([`timing_free`]).
fn same_line(shown: &str, actual: &str) -> bool {
    shown == actual || timing_free(shown).is_some_and(|s| timing_free(actual) == Some(s))
}

/// One `$ COMMAND` of a block and the output lines the page shows after it.
struct Step {
    command: String,
    shown: Vec<String>,
}

/// A console block (```` ```console ````): the 1-based line of its opening fence, and its steps.
struct Block {
    line: usize,
    steps: Vec<Step>,
}

/// A page's console blocks.
fn console_blocks(page: &str) -> Vec<Block> {
    let mut blocks = Vec::new();
    let mut current: Option<Block> = None;
    for (i, line) in page.lines().enumerate() {
        match current.as_mut() {
            None if line.starts_with("```console") => {
                current = Some(Block {
                    line: i + 1,
                    steps: Vec::new(),
                })
            }
            None => {}
            Some(_) if line.starts_with("```") => blocks.extend(current.take()),
            Some(block) => {
                if let Some(cmd) = line.strip_prefix("$ ") {
                    block.steps.push(Step {
                        command: cmd.to_string(),
                        shown: Vec::new(),
                    });
                } else if let Some(step) = block.steps.last_mut() {
                    step.shown.push(line.trim_end().to_string());
                }
            }
        }
    }
    blocks
}

/// The pages whose blocks and links are checked, relative to the repository: README.md,
/// ARCHITECTURE.md and every Markdown file under docs/, sorted.
fn pages(root: &Path) -> Vec<String> {
    fn walk(dir: &Path, root: &Path, out: &mut Vec<String>) {
        for entry in std::fs::read_dir(dir).expect("docs/ readable") {
            let path = entry.expect("directory entry").path();
            if path.is_dir() {
                walk(&path, root, out);
            } else if path.extension().is_some_and(|e| e == "md") {
                let rel = path.strip_prefix(root).expect("under the repository");
                out.push(rel.to_string_lossy().replace('\\', "/"));
            }
        }
    }
    let mut out = vec!["README.md".to_string(), "ARCHITECTURE.md".to_string()];
    walk(&root.join("docs"), root, &mut out);
    out[2..].sort();
    out
}

/// A shown line that stands for output left out.
fn is_elision(line: &str) -> bool {
    let t = line.trim();
    t == "..." || t == "…" || (t.starts_with('(') && t.ends_with(')'))
}

/// `None` when `actual` shows what `shown` says; else what is wrong. Blank lines at the end of
/// either do not count; a command shown without output is run but not compared.
fn mismatch(shown: &[String], actual: &[String]) -> Option<String> {
    let trim = |v: &[String]| v.len() - v.iter().rev().take_while(|l| l.is_empty()).count();
    let (shown, actual) = (&shown[..trim(shown)], &actual[..trim(actual)]);
    if shown.is_empty() {
        return None;
    }
    if !shown.iter().any(|l| is_elision(l)) {
        let same =
            shown.len() == actual.len() && shown.iter().zip(actual).all(|(s, a)| same_line(s, a));
        return (!same).then(|| "the output differs line for line".to_string());
    }
    let mut rest = actual.iter();
    let missing: Vec<&String> = shown
        .iter()
        .filter(|l| !is_elision(l))
        .filter(|l| !rest.any(|a| same_line(l, a)))
        .collect();
    // after a missing line the search has run to the end: report the first one only
    missing
        .first()
        .map(|l| format!("this shown line is not in the output (in order): {l}"))
}

/// Copies `from` into `to` recursively.
fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("scratch directory");
    for entry in std::fs::read_dir(from).expect("datasets/ readable") {
        let entry = entry.expect("directory entry");
        let target = to.join(entry.file_name());
        if entry.file_type().expect("file type").is_dir() {
            copy_dir(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), &target).expect("copy");
        }
    }
}

#[test]
fn the_readme_blocks_show_what_the_commands_print() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let bin = assert_cmd::cargo::cargo_bin("millcomp");
    let path = format!(
        "{}:{}",
        bin.parent().expect("the binary's directory").display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut scratch: HashMap<&str, tempfile::TempDir> = HashMap::new();
    let mut failures = Vec::new();
    let checked = CHECKED
        .iter()
        .flat_map(|(page, firsts)| firsts.iter().map(move |f| (*page, *f)));
    for (page, first) in checked {
        let text = std::fs::read_to_string(root.join(page))
            .unwrap_or_else(|e| panic!("{page}: {e} (named in CHECKED, tests/readme.rs)"));
        let blocks = console_blocks(&text);
        let Some(block) = blocks
            .iter()
            .find(|b| b.steps.first().is_some_and(|s| s.command == *first))
        else {
            failures.push(format!(
                "no console block in {page} starts with `$ {first}`: update CHECKED in tests/readme.rs"
            ));
            continue;
        };
        let dir = scratch.entry(page).or_insert_with(|| {
            let dir = tempfile::tempdir().expect("scratch directory");
            copy_dir(&root.join("datasets"), &dir.path().join("datasets"));
            dir
        });
        for step in &block.steps {
            let out = Command::new("bash")
                .arg("-c")
                .arg(format!("{} 2>&1", as_run(&step.command)))
                .current_dir(dir.path())
                .env("PATH", &path)
                .env("RAYON_NUM_THREADS", "2")
                .env_remove("SLURM_ARRAY_TASK_ID")
                .env_remove("JOB_COMPLETION_INDEX")
                .output()
                .expect("bash runs");
            let actual: Vec<String> = String::from_utf8_lossy(&out.stdout)
                .lines()
                .map(|l| l.trim_end().to_string())
                .collect();
            if let Some(why) = mismatch(&step.shown, &actual) {
                failures.push(format!(
                    "{page}:{} (the block's opening line)\n$ {}\n{why}\nthe page shows:\n{}\nit prints:\n{}",
                    block.line,
                    step.command,
                    step.shown.join("\n"),
                    actual.join("\n")
                ));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} output(s) shown in the docs are no longer true (re-run the command and update the page):\n\n{}",
        failures.len(),
        failures.join("\n\n")
    );
}

#[test]
fn every_millcomp_block_is_checked_or_says_why_not() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut unlisted = Vec::new();
    let mut used = BTreeSet::new();
    for page in pages(root) {
        let text = std::fs::read_to_string(root.join(&page)).expect("page readable");
        for block in console_blocks(&text) {
            let Some(first) = block.steps.first().map(|s| s.command.as_str()) else {
                continue;
            };
            if !first.starts_with("millcomp ") {
                continue;
            }
            if CHECKED
                .iter()
                .any(|(p, firsts)| *p == page && firsts.contains(&first))
            {
                continue;
            } else if let Some(i) = NOT_CHECKED
                .iter()
                .position(|(p, c, _)| *p == page && first.starts_with(c))
            {
                used.insert(i);
            } else {
                unlisted.push(format!("{page}:{}: $ {first}", block.line));
            }
        }
    }
    assert!(
        unlisted.is_empty(),
        "console blocks of `millcomp` commands neither checked nor said why not: add each to CHECKED \
         (or, if it cannot run in the test, to NOT_CHECKED with the reason) in tests/readme.rs:\n{}",
        unlisted.join("\n")
    );
    let stale: Vec<String> = NOT_CHECKED
        .iter()
        .enumerate()
        .filter(|(i, _)| !used.contains(i))
        .map(|(_, (p, c, _))| format!("{p}: {c}"))
        .collect();
    assert!(
        stale.is_empty(),
        "NOT_CHECKED names blocks no page has any more (tests/readme.rs):\n{}",
        stale.join("\n")
    );
}

/// GitHub's anchor of a heading: lower case, punctuation other than `-` and `_` dropped, spaces as `-`.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || matches!(c, ' ' | '-' | '_'))
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// What a page offers and points to.
struct Outline {
    /// Its headings' anchors (a repeated heading gets `-1`, `-2`, … as on GitHub).
    anchors: BTreeSet<String>,
    /// Its links and images, with the 1-based line each starts on.
    links: Vec<(usize, String)>,
}

/// A page's [`Outline`].
fn outline(text: &str) -> Outline {
    let mut anchors = BTreeSet::new();
    let mut seen: HashMap<String, usize> = HashMap::new();
    let mut links = Vec::new();
    let mut heading: Option<String> = None;
    let line_of = |offset: usize| text[..offset].matches('\n').count() + 1;
    for (event, range) in Parser::new_ext(text, Options::ENABLE_TABLES).into_offset_iter() {
        match event {
            Event::Start(Tag::Heading { .. }) => heading = Some(String::new()),
            Event::End(TagEnd::Heading(_)) => {
                if let Some(h) = heading.take() {
                    let base = slug(&h);
                    let n = seen.entry(base.clone()).or_insert(0);
                    anchors.insert(if *n == 0 {
                        base.clone()
                    } else {
                        format!("{base}-{n}")
                    });
                    *n += 1;
                }
            }
            Event::Text(t) | Event::Code(t) => {
                if let Some(h) = heading.as_mut() {
                    h.push_str(&t);
                }
            }
            Event::Start(Tag::Link { dest_url, .. } | Tag::Image { dest_url, .. }) => {
                links.push((line_of(range.start), dest_url.to_string()));
            }
            _ => {}
        }
    }
    Outline { anchors, links }
}

#[test]
fn every_relative_link_in_the_docs_leads_to_a_file() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let pages = pages(root);
    let parsed: HashMap<PathBuf, Outline> = pages
        .iter()
        .map(|p| {
            let text = std::fs::read_to_string(root.join(p)).expect("page readable");
            (root.join(p), outline(&text))
        })
        .collect();
    let mut broken = Vec::new();
    for page in &pages {
        let here = root.join(page);
        for (line, url) in &parsed[&here].links {
            if url.contains("://") || url.starts_with("mailto:") {
                continue;
            }
            let (file, fragment) = url.split_once('#').unwrap_or((url, ""));
            let target = if file.is_empty() {
                here.clone()
            } else {
                here.parent().expect("a page's directory").join(file)
            };
            if !target.exists() {
                broken.push(format!("{page}:{line}: {url}: no such file"));
                continue;
            }
            if fragment.is_empty() || target.extension().is_none_or(|e| e != "md") {
                continue;
            }
            let anchors = match parsed.get(&target) {
                Some(o) => o.anchors.clone(),
                None => {
                    let text = std::fs::read_to_string(&target).expect("linked page readable");
                    outline(&text).anchors
                }
            };
            if !anchors.contains(fragment) {
                broken.push(format!("{page}:{line}: {url}: no heading with that anchor"));
            }
        }
    }
    assert!(
        broken.is_empty(),
        "broken links in the docs:\n{}",
        broken.join("\n")
    );
}

#[test]
fn the_readme_check_tells_an_elided_block_from_a_changed_one() {
    let lines = |s: &str| s.lines().map(str::to_string).collect::<Vec<_>>();
    let actual = lines("a\nb\nc\nd");
    // line for line
    assert!(mismatch(&lines("a\nb\nc\nd"), &actual).is_none());
    assert!(mismatch(&lines("a\nb\nc"), &actual).is_some());
    assert!(mismatch(&lines("a\nb\nc\nd\n"), &actual).is_none());
    // nothing shown: not compared
    assert!(mismatch(&[], &actual).is_none());
    // elisions: the shown lines in order
    assert!(mismatch(&lines("a\n...\nd"), &actual).is_none());
    assert!(mismatch(&lines("a\n  ...\nc\n(the rest)"), &actual).is_none());
    assert!(mismatch(&lines("c\n...\nb"), &actual).is_some());
    assert!(mismatch(&lines("a\n...\nx"), &actual).is_some());
    assert!(mismatch(&lines("a\n…\nd"), &actual).is_none());
    // what the machine's speed decides
    let timed = lines(
        "solver: 9 solves, cycle time median 33.0 us (0 deadline misses)\nsimulated 6.0 s of machining in 2.5 s on 2 threads\nmpc  QP solve: median 34.3 us\nrms 0.068 um",
    );
    assert!(
        mismatch(
            &lines("solver: 9 solves, cycle time median 40.1 us (2 deadline misses)\nsimulated 6.0 s of machining in 3.1 s on 2 threads\nmpc  QP solve: median 30.0 us\nrms 0.068 um"),
            &timed
        )
        .is_none()
    );
    assert!(mismatch(&lines("solver: 8 solves, cycle time median 33.0 us (0 deadline misses)\nsimulated 6.0 s of machining in 2.5 s on 2 threads\nmpc  QP solve: median 34.3 us\nrms 0.068 um"), &timed).is_some());
    assert!(mismatch(&lines("solver: 9 solves, cycle time median 33.0 us (0 deadline misses)\nsimulated 7.0 s of machining in 2.5 s on 2 threads\nmpc  QP solve: median 34.3 us\nrms 0.068 um"), &timed).is_some());
    assert!(mismatch(&lines("solver: 9 solves, cycle time median 33.0 us (0 deadline misses)\nsimulated 6.0 s of machining in 2.5 s on 2 threads\nmpc  QP solve: median 34.3 us\nrms 0.069 um"), &timed).is_some());
    assert_eq!(
        as_run("millcomp simulate datasets/scenarios/a.toml --controller mpc"),
        "millcomp simulate datasets/scenarios/a.toml --controller mpc --no-realtime"
    );
    assert_eq!(
        as_run("millcomp simulate datasets/sessions/example.toml"),
        "millcomp simulate datasets/sessions/example.toml"
    );
    // blocks: commands, their shown output, and a block's end
    let readme = "text\n```console\n$ one\nout 1  \n$ two\n```\n```\n$ not a console block\n```\n";
    let blocks = console_blocks(readme);
    assert_eq!(blocks.len(), 1);
    assert_eq!(blocks[0].line, 2);
    assert_eq!(blocks[0].steps.len(), 2);
    assert_eq!(
        (
            blocks[0].steps[0].command.as_str(),
            &blocks[0].steps[0].shown
        ),
        ("one", &vec!["out 1".to_string()])
    );
    assert!(blocks[0].steps[1].shown.is_empty());
    // anchors as GitHub makes them, links with their lines
    assert_eq!(
        slug("`doe analyze` — effects, ANOVA, Lenth"),
        "doe-analyze--effects-anova-lenth"
    );
    let Outline { anchors, links } =
        outline("# A b\n\n## A b\n\nsee [x](y.md#a-b) and\n![p](../p.svg)\n");
    assert!(anchors.contains("a-b") && anchors.contains("a-b-1"));
    assert_eq!(
        links,
        vec![(5, "y.md#a-b".to_string()), (6, "../p.svg".to_string())]
    );
}

/// README's figure table ("The published figures millcomp touches") is the output of
/// `millcomp datasets figures --markdown`, line for line: the table is generated, never typed.
#[test]
fn the_readme_figure_table_is_the_commands_markdown() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = Command::new(assert_cmd::cargo::cargo_bin("millcomp"))
        .args(["datasets", "figures", "--markdown"])
        .current_dir(root)
        .output()
        .expect("run millcomp");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let table = String::from_utf8(out.stdout).expect("utf-8");
    let readme = std::fs::read_to_string(root.join("README.md")).expect("README.md");
    let start = readme
        .find("\n| figure (source) |")
        .expect("README.md has the figure table");
    let shown: String = readme[start + 1..]
        .lines()
        .take_while(|l| l.starts_with('|'))
        .map(|l| format!("{l}\n"))
        .collect();
    assert!(
        shown == table,
        "README.md's figure table is not `millcomp datasets figures --markdown`: regenerate it\n\
         --- README\n{shown}--- the command\n{table}"
    );
}
