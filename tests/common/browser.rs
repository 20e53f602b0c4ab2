//! Headless Chromium for the tests: found on the PATH (or `MINOS_CHROMIUM`), started on a
//! URL with a DevTools port, and driven over the DevTools protocol (evaluate, poll, key
//! presses as a keyboard sends them).

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use futures_util::{SinkExt, StreamExt};
use minos::run::agents::Decision;
use serde_json::{json, Value};
use tokio_tungstenite::tungstenite::Message;

use super::serve::{http, Ws};

/// The Chromium binary: `MINOS_CHROMIUM`, or `chromium` / `chromium-browser` on the PATH.
pub fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("MINOS_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .flat_map(|d| ["chromium", "chromium-browser"].map(|n| d.join(n)))
        .find(|p| p.is_file())
}

/// Kills the browser when the test ends, however it ends.
pub struct Browser(Child);

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A DevTools protocol connection to one page.
pub struct Cdp {
    ws: Ws,
    next: u64,
}

impl Cdp {
    /// Connects to the first page of the browser whose DevTools listen on `port`.
    pub async fn first_page(port: u16) -> Cdp {
        let devtools: SocketAddr = format!("127.0.0.1:{port}").parse().unwrap();
        let (_, targets) = http(devtools, "GET", "/json/list", &[], None);
        let targets: Value = serde_json::from_str(&targets).expect("DevTools targets");
        let page = targets
            .as_array()
            .unwrap()
            .iter()
            .find(|t| t["type"] == "page")
            .expect("a page")["webSocketDebuggerUrl"]
            .as_str()
            .unwrap()
            .to_string();
        let (ws, _) = tokio_tungstenite::connect_async(page)
            .await
            .expect("DevTools socket");
        Cdp { ws, next: 0 }
    }

    /// Calls `method` and returns its result.
    pub async fn call(&mut self, method: &str, params: Value) -> Value {
        self.next += 1;
        let id = self.next;
        let msg = json!({"id": id, "method": method, "params": params}).to_string();
        self.ws.send(Message::Text(msg.into())).await.expect("send");
        loop {
            let m = tokio::time::timeout(Duration::from_secs(60), self.ws.next())
                .await
                .expect("DevTools answers")
                .expect("open")
                .expect("message");
            if let Message::Text(t) = m {
                let v: Value = serde_json::from_str(t.as_str()).expect("JSON");
                if v["id"] == id {
                    assert!(v.get("error").is_none(), "{method}: {v}");
                    return v["result"].clone();
                }
            }
        }
    }

    /// Evaluates `expr` in the page and returns its value.
    pub async fn eval(&mut self, expr: &str) -> Value {
        let r = self
            .call(
                "Runtime.evaluate",
                json!({"expression": expr, "returnByValue": true}),
            )
            .await;
        r["result"]["value"].clone()
    }

    /// Polls `expr` until it is true (fails the test after 60 s).
    pub async fn until(&mut self, expr: &str) {
        let t = Instant::now();
        while self.eval(expr).await != Value::Bool(true) {
            assert!(t.elapsed() < Duration::from_secs(60), "never true: {expr}");
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }

    /// Presses and releases a key as a keyboard would.
    pub async fn press(&mut self, key: &str, code: &str, key_code: u32) {
        let text = if key.chars().count() == 1 { key } else { "" };
        for kind in ["keyDown", "keyUp"] {
            self.call(
                "Input.dispatchKeyEvent",
                json!({"type": kind, "key": key, "code": code, "text": if kind == "keyDown" { text } else { "" },
                       "windowsVirtualKeyCode": key_code, "nativeVirtualKeyCode": key_code}),
            )
            .await;
        }
    }

    /// Presses the key of each decision in turn, each after the previous one's frame (the
    /// episode's result after `stop`); `results` is how many results the page holds before.
    pub async fn play(&mut self, decisions: &[Decision], results: usize) {
        for d in decisions {
            let frames = self.eval("window.minos.frames").await.as_u64().unwrap();
            let (key, code, kc) = key_of(d);
            self.press(key, code, kc).await;
            if *d == Decision::Stop {
                self.until(&format!("window.minos.results.length === {}", results + 1))
                    .await;
            } else {
                self.until(&format!("window.minos.frames > {frames}")).await;
            }
        }
    }
}

/// The key the page maps to a decision.
pub fn key_of(d: &Decision) -> (&'static str, &'static str, u32) {
    match d.name().as_str() {
        "forward" => ("ArrowUp", "ArrowUp", 38),
        "backward" => ("ArrowDown", "ArrowDown", 40),
        "turn_left" => ("ArrowLeft", "ArrowLeft", 37),
        "turn_right" => ("ArrowRight", "ArrowRight", 39),
        "strafe_left" => ("q", "KeyQ", 81),
        "strafe_right" => ("e", "KeyE", 69),
        "look_up" => ("r", "KeyR", 82),
        "look_down" => ("f", "KeyF", 70),
        "stop" => (" ", "Space", 32),
        other => panic!("no key for {other}"),
    }
}

/// Starts Chromium on `url`; returns it and its DevTools port.
pub fn launch(browser: &Path, profile: &Path, url: &str) -> (Browser, u16) {
    std::fs::create_dir_all(profile).expect("the browser profile's folder");
    let mut child = Command::new(browser)
        .args([
            "--headless=new",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--disable-extensions",
            "--window-size=1280,1000",
            "--remote-debugging-port=0",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(url)
        // Chromium makes its singleton-socket folder in TMPDIR and leaves it when killed: in
        // the profile, it goes with the test's temporary folder.
        .env("TMPDIR", profile)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("chromium starts");
    // Chromium writes its port into the profile's DevToolsActivePort.
    let t = Instant::now();
    let port = loop {
        if let Ok(text) = std::fs::read_to_string(profile.join("DevToolsActivePort")) {
            if let Some(p) = text.lines().next().and_then(|l| l.trim().parse().ok()) {
                break p;
            }
        }
        if let Ok(Some(status)) = child.try_wait() {
            panic!("chromium exited: {status}");
        }
        assert!(
            t.elapsed() < Duration::from_secs(60),
            "chromium gave no DevTools port"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    (Browser(child), port)
}
