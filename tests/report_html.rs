//! The report in a browser: `report.html` rendered by headless Chromium (Debian's `chromium`, installed
//! by `tools/install-chromium`; `$CHROMIUM` names another binary), driven over the DevTools protocol on
//! a pipe (`--remote-debugging-pipe`: NUL-separated JSON on file descriptors 3 and 4, no network).
//! Checked: the screenshot is not blank, every figure renders with a non-zero size, no console error
//! or exception, no broken link. Without Chromium the check is skipped with a message — except in CI
//! (`CI` set), where it must run.

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

use serde_json::{Value, json};

/// The Chromium binary: `$CHROMIUM`, else `chromium` on PATH.
fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join("chromium"))
            .find(|p| p.is_file())
    })
}

/// A DevTools-protocol session over the browser's pipe.
struct Cdp {
    to: std::fs::File,
    from: BufReader<std::fs::File>,
    next: u64,
    events: Vec<Value>,
}

impl Cdp {
    fn read(&mut self) -> Value {
        let mut buf = Vec::new();
        let n = self
            .from
            .read_until(0, &mut buf)
            .expect("read from chromium");
        assert!(n > 0, "chromium closed its pipe");
        buf.pop();
        serde_json::from_slice(&buf).expect("a DevTools message")
    }

    fn call(&mut self, method: &str, params: Value, session: Option<&str>) -> Value {
        self.next += 1;
        let mut msg = json!({"id": self.next, "method": method, "params": params});
        if let Some(s) = session {
            msg["sessionId"] = json!(s);
        }
        let mut bytes = serde_json::to_vec(&msg).unwrap();
        bytes.push(0);
        self.to.write_all(&bytes).expect("write to chromium");
        loop {
            let m = self.read();
            if m["id"].as_u64() == Some(self.next) {
                assert!(m.get("error").is_none(), "{method}: {m}");
                return m["result"].clone();
            }
            self.events.push(m);
        }
    }

    fn wait_for(&mut self, method: &str) {
        if self.events.iter().any(|e| e["method"] == method) {
            return;
        }
        loop {
            let m = self.read();
            let done = m["method"] == method;
            self.events.push(m);
            if done {
                return;
            }
        }
    }
}

/// Starts Chromium headless with the protocol on a pipe and a fresh profile.
fn launch(bin: &Path, profile: &Path) -> (std::process::Child, Cdp) {
    use std::os::fd::FromRawFd;
    use std::os::unix::process::CommandExt;
    let mut to_child = [0i32; 2];
    let mut from_child = [0i32; 2];
    // SAFETY: pipe2 writes two descriptors into each array; both are checked.
    unsafe {
        assert_eq!(libc::pipe2(to_child.as_mut_ptr(), libc::O_CLOEXEC), 0);
        assert_eq!(libc::pipe2(from_child.as_mut_ptr(), libc::O_CLOEXEC), 0);
    }
    let (child_in, child_out) = (to_child[0], from_child[1]);
    let mut cmd = std::process::Command::new(bin);
    cmd.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--hide-scrollbars",
        "--remote-debugging-pipe",
    ])
    .arg(format!("--user-data-dir={}", profile.display()))
    .arg("about:blank")
    .stdin(std::process::Stdio::null())
    .stdout(std::process::Stdio::null())
    .stderr(std::process::Stdio::null());
    // SAFETY: between fork and exec only async-signal-safe fcntl, dup2 and close calls; they put the
    // pipe ends at the descriptors the protocol expects (3: commands in, 4: messages out), clearing
    // close-on-exec there. Each end is first copied above 10: a pipe end may itself be 3 or 4 (dup2
    // onto itself would keep close-on-exec, and the first dup2 could overwrite the other end).
    unsafe {
        cmd.pre_exec(move || {
            let a = libc::fcntl(child_in, libc::F_DUPFD, 10);
            let b = libc::fcntl(child_out, libc::F_DUPFD, 10);
            if a < 0 || b < 0 || libc::dup2(a, 3) < 0 || libc::dup2(b, 4) < 0 {
                return Err(std::io::Error::last_os_error());
            }
            libc::close(a);
            libc::close(b);
            Ok(())
        });
    }
    let child = cmd.spawn().expect("start chromium");
    // SAFETY: the parent's ends are open descriptors owned from here on; the child's ends are closed.
    let cdp = unsafe {
        libc::close(child_in);
        libc::close(child_out);
        Cdp {
            to: std::fs::File::from_raw_fd(to_child[1]),
            from: BufReader::new(std::fs::File::from_raw_fd(from_child[0])),
            next: 0,
            events: Vec::new(),
        }
    };
    (child, cdp)
}

/// Share of pixels that are not near-white, and the number of distinct colours, of a PNG.
fn ink(png_bytes: &[u8]) -> (f64, usize) {
    let decoder = png::Decoder::new(std::io::Cursor::new(png_bytes));
    let mut reader = decoder.read_info().expect("a PNG");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("a frame");
    let channels = info.color_type.samples();
    let px = &buf[..info.buffer_size()];
    let (mut inked, mut n) = (0usize, 0usize);
    let mut colours = std::collections::BTreeSet::new();
    for p in px.chunks(channels) {
        n += 1;
        if p.iter().take(3).any(|&c| c < 235) {
            inked += 1;
        }
        if colours.len() < 1000 {
            colours.insert(p[..3.min(channels)].to_vec());
        }
    }
    (inked as f64 / n.max(1) as f64, colours.len())
}

/// Renders `html` in headless Chromium and checks it; returns a one-line summary. The screenshot is
/// written to `screenshot`.
pub fn check_in_chromium(html: &Path, screenshot: &Path) -> Option<String> {
    let Some(bin) = chromium() else {
        let msg = "report.html not rendered: Chromium is absent (run tools/install-chromium, or set CHROMIUM)";
        assert!(
            std::env::var_os("CI").is_none(),
            "{msg} — in CI it must run (.ci/run installs it)"
        );
        eprintln!("skipped: {msg}");
        return None;
    };
    let profile = tempfile::tempdir().unwrap();
    let (mut child, mut cdp) = launch(&bin, profile.path());
    let pid = child.id();
    let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let watched = done.clone();
    let _watchdog = std::thread::spawn(move || {
        std::thread::sleep(Duration::from_secs(120));
        // only while the browser this test started has not been waited for (its pid is still its own)
        if !watched.load(std::sync::atomic::Ordering::SeqCst) {
            // SAFETY: a plain kill of the browser this test started, still running after 2 minutes.
            unsafe {
                libc::kill(pid as i32, libc::SIGKILL);
            }
        }
    });
    let target = cdp.call("Target.createTarget", json!({"url": "about:blank"}), None);
    let tid = target["targetId"].as_str().unwrap().to_string();
    let att = cdp.call(
        "Target.attachToTarget",
        json!({"targetId": tid, "flatten": true}),
        None,
    );
    let sid = att["sessionId"].as_str().unwrap().to_string();
    let s = Some(sid.as_str());
    for m in ["Page.enable", "Runtime.enable", "Log.enable"] {
        cdp.call(m, json!({}), s);
    }
    cdp.call(
        "Emulation.setDeviceMetricsOverride",
        json!({"width": 1280, "height": 1800, "deviceScaleFactor": 1, "mobile": false}),
        s,
    );
    let url = format!("file://{}", std::fs::canonicalize(html).unwrap().display());
    cdp.call("Page.navigate", json!({"url": url}), s);
    cdp.wait_for("Page.loadEventFired");
    let probe = r#"(() => {
        const figs = [...document.querySelectorAll('figure svg')].map(s => {
            const r = s.getBoundingClientRect();
            return {w: r.width, h: r.height, n: s.querySelectorAll('*').length};
        });
        const links = [...document.querySelectorAll('a[href]')].map(a => {
            const h = a.getAttribute('href');
            return {href: h, url: a.href, anchor: h.startsWith('#') ? !!document.getElementById(h.slice(1)) : null};
        });
        const imgs = [...document.images].map(i => ({src: i.src, ok: i.complete && i.naturalWidth > 0}));
        return JSON.stringify({figs, links, imgs, title: document.title});
    })()"#;
    let r = cdp.call(
        "Runtime.evaluate",
        json!({"expression": probe, "returnByValue": true}),
        s,
    );
    let page: Value = serde_json::from_str(r["result"]["value"].as_str().unwrap()).unwrap();
    let shot = cdp.call("Page.captureScreenshot", json!({"format": "png"}), s);
    use base64::Engine;
    let png_bytes = base64::engine::general_purpose::STANDARD
        .decode(shot["data"].as_str().unwrap())
        .unwrap();
    std::fs::write(screenshot, &png_bytes).unwrap();
    let _ = cdp.call("Browser.close", json!({}), None);
    let _ = child.kill();
    let _ = child.wait();
    done.store(true, std::sync::atomic::Ordering::SeqCst);

    let errors: Vec<String> = cdp
        .events
        .iter()
        .filter(|e| {
            e["method"] == "Runtime.exceptionThrown"
                || (e["method"] == "Runtime.consoleAPICalled" && e["params"]["type"] == "error")
                || (e["method"] == "Log.entryAdded" && e["params"]["entry"]["level"] == "error")
        })
        .map(|e| e.to_string())
        .collect();
    assert!(errors.is_empty(), "console errors: {errors:?}");
    let figs = page["figs"].as_array().unwrap();
    assert!(figs.len() >= 8, "{} figures", figs.len());
    for (i, f) in figs.iter().enumerate() {
        let (w, h, n) = (
            f["w"].as_f64().unwrap(),
            f["h"].as_f64().unwrap(),
            f["n"].as_u64().unwrap(),
        );
        assert!(
            w > 100.0 && h > 50.0 && n > 5,
            "figure {i} renders at {w}×{h} with {n} elements"
        );
    }
    let links = page["links"].as_array().unwrap();
    for l in links {
        match l["anchor"].as_bool() {
            Some(ok) => assert!(ok, "broken in-page link {l}"),
            None => {
                let u = l["url"].as_str().unwrap();
                let p = u
                    .strip_prefix("file://")
                    .unwrap_or_else(|| panic!("a link leaves the report's files: {u}"))
                    .replace("%20", " ");
                assert!(Path::new(&p).exists(), "broken link {u}");
            }
        }
    }
    for i in page["imgs"].as_array().unwrap() {
        assert!(i["ok"].as_bool().unwrap(), "broken image {i}");
    }
    let (share, colours) = ink(&png_bytes);
    assert!(
        share > 0.02 && colours > 8,
        "the screenshot looks blank: {:.1} % of it inked, {colours} colours",
        100.0 * share
    );
    Some(format!(
        "chromium rendered {}: {} figures (all with a size), {} links (none broken), no console error; \
         screenshot {} ({:.1} % inked, {colours}+ colours)",
        html.display(),
        figs.len(),
        links.len(),
        screenshot.display(),
        100.0 * share
    ))
}
