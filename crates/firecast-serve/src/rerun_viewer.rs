//! Rerun's web viewer, of the same version as the recordings, served from this server's own
//! origin under `/rerun/` (a recording opens at `/rerun/?url=<its artifact URL>`).
//!
//! The viewer (HTML, JS, a ~40 MB wasm) ships inside the `rerun` CLI of PyPI's `rerun-sdk`,
//! which the setup installs into `.venv`. On first use the server starts that CLI's web
//! server on two free loopback ports, copies the files, stops it and keeps them under
//! `.firecast/serve/rerun-viewer-<version>/` (written to a temporary folder, then renamed, so
//! a half copy is never taken for the viewer). The page is served without its web-font links:
//! nothing is fetched from the internet.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::error::ApiError;

/// The viewer's files (all it loads from its own origin).
pub const FILES: [&str; 6] = [
    "index.html",
    "re_viewer.js",
    "re_viewer_bg.wasm",
    "favicon.ico",
    "apple-touch-icon.png",
    "sw.js",
];

/// Where the viewer is kept and which CLI provides it.
pub struct RerunViewer {
    dir: PathBuf,
    cli: PathBuf,
    ready: tokio::sync::OnceCell<Result<(), String>>,
}

impl RerunViewer {
    pub fn new(root: &Path, cli: PathBuf) -> Self {
        Self {
            dir: root
                .join(".firecast/serve")
                .join(format!("rerun-viewer-{}", firecast_recorder::RERUN_VERSION)),
            cli,
            ready: tokio::sync::OnceCell::new(),
        }
    }

    /// The viewer's folder, copied from the CLI first if needed.
    pub async fn dir(&self) -> Result<&Path, ApiError> {
        let dir = self.dir.clone();
        let cli = self.cli.clone();
        self.ready
            .get_or_init(|| async move {
                if dir.join(FILES[0]).is_file() {
                    return Ok(());
                }
                tokio::task::spawn_blocking(move || extract(&cli, &dir))
                    .await
                    .unwrap_or_else(|e| Err(e.to_string()))
            })
            .await
            .clone()
            .map_err(|e| {
                ApiError::new(
                    crate::error::Code::NotFound,
                    format!("Rerun's web viewer is not available: {e}"),
                )
            })?;
        Ok(&self.dir)
    }
}

/// The `rerun` CLI of the project's venv (`$FIRECAST_VENV`, else `.venv` under the root).
pub fn default_cli(root: &Path) -> PathBuf {
    std::env::var_os("FIRECAST_VENV")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join(".venv"))
        .join("bin/rerun")
}

struct Reaped(Child);

impl Drop for Reaped {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn free_port() -> Result<u16, String> {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .map_err(|e| format!("no free loopback port: {e}"))
}

/// The `rerun` executable itself: pip's `bin/rerun` is a Python script that starts the
/// binary shipped in `rerun_sdk/rerun_cli/` as its child, and stopping the script would leave
/// that child serving. Other paths are taken as given.
fn real_binary(cli: &Path) -> PathBuf {
    let is_script = std::fs::read(cli).is_ok_and(|b| b.starts_with(b"#!"));
    let venv = cli.parent().and_then(Path::parent);
    if let (true, Some(venv)) = (is_script, venv) {
        let lib = venv.join("lib");
        let mut found: Vec<PathBuf> = std::fs::read_dir(&lib)
            .into_iter()
            .flatten()
            .flatten()
            .map(|e| e.path().join("site-packages/rerun_sdk/rerun_cli/rerun"))
            .filter(|p| p.is_file())
            .collect();
        found.sort();
        if let Some(binary) = found.pop() {
            return binary;
        }
    }
    cli.to_path_buf()
}

fn extract(cli: &Path, dir: &Path) -> Result<(), String> {
    let binary = real_binary(cli);
    let cli = binary.as_path();
    let version = Command::new(cli)
        .arg("--version")
        .output()
        .map_err(|e| format!("cannot run {} ({e}): run `cargo xtask setup`", cli.display()))?;
    let version = String::from_utf8_lossy(&version.stdout);
    let want = firecast_recorder::RERUN_VERSION;
    if !version.split_whitespace().any(|w| w == want) {
        return Err(format!(
            "{} is `{}`, the recordings need {want} (run `cargo xtask setup`)",
            cli.display(),
            version.trim()
        ));
    }
    let web = free_port()?;
    let grpc = free_port()?;
    let _child = Reaped(
        Command::new(cli)
            .args(["--serve-web", "--bind", "127.0.0.1"])
            .args(["--web-viewer-port", &web.to_string(), "--port", &grpc.to_string()])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .map_err(|e| format!("cannot start {}: {e}", cli.display()))?,
    );
    if dir.parent().is_none() {
        return Err("the viewer folder has no parent".into());
    }
    // The staging folder is removed when dropped unpublished (any error below).
    let staged = firecast_fs::TempPath::dir(dir).map_err(|e| e.to_string())?;
    let tmp = staged.path();
    let deadline = Instant::now() + Duration::from_secs(30);
    for file in FILES {
        let bytes = loop {
            match http_get(web, file) {
                Ok(b) => break b,
                Err(e) if Instant::now() > deadline => {
                    return Err(format!("Rerun's web server did not give {file}: {e}"));
                }
                Err(_) => std::thread::sleep(Duration::from_millis(100)),
            }
        };
        let bytes = if file == "index.html" {
            offline_page(&bytes)
        } else {
            bytes
        };
        std::fs::write(tmp.join(file), bytes).map_err(|e| format!("{}: {e}", tmp.display()))?;
    }
    staged
        .publish()
        .map_err(|e| format!("{}: {}", dir.display(), e.source))
}

/// A plain HTTP/1.0 GET of `/<file>` from the viewer's loopback server.
fn http_get(port: u16, file: &str) -> Result<Vec<u8>, String> {
    use std::io::{Read, Write};
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).map_err(|e| e.to_string())?;
    s.set_read_timeout(Some(Duration::from_secs(20)))
        .map_err(|e| e.to_string())?;
    write!(s, "GET /{file} HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n").map_err(|e| e.to_string())?;
    let mut raw = Vec::new();
    s.read_to_end(&mut raw).map_err(|e| e.to_string())?;
    let split = raw
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .ok_or("no HTTP header")?;
    let head = String::from_utf8_lossy(&raw[..split]);
    if !head.starts_with("HTTP/1.1 200") && !head.starts_with("HTTP/1.0 200") {
        return Err(head.lines().next().unwrap_or_default().to_string());
    }
    Ok(raw[split + 4..].to_vec())
}

/// The viewer's page without the `<link>` elements that reach for web fonts on the internet.
fn offline_page(html: &[u8]) -> Vec<u8> {
    let text = String::from_utf8_lossy(html);
    let mut out = String::with_capacity(text.len());
    let mut rest: &str = &text;
    while let Some(at) = rest.find("<link") {
        let Some(len) = rest[at..].find('>') else { break };
        let element = &rest[at..at + len + 1];
        if element.contains("fonts.googleapis") || element.contains("fonts.gstatic") {
            out.push_str(rest[..at].trim_end_matches([' ', '\t']));
            rest = rest[at + len + 1..]
                .strip_prefix('\n')
                .unwrap_or(&rest[at + len + 1..]);
        } else {
            out.push_str(&rest[..at + len + 1]);
            rest = &rest[at + len + 1..];
        }
    }
    out.push_str(rest);
    out.into_bytes()
}

/// Content type of a viewer file.
pub fn content_type(file: &str) -> &'static str {
    match file.rsplit('.').next().unwrap_or_default() {
        "html" => "text/html; charset=utf-8",
        "js" => "text/javascript",
        "wasm" => "application/wasm",
        "ico" => "image/x-icon",
        "png" => "image/png",
        _ => "application/octet-stream",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pip_script_leads_to_the_binary_it_starts() {
        let venv = tempfile::tempdir().expect("temp dir");
        let bin = venv.path().join("bin");
        let real = venv
            .path()
            .join("lib/python3.11/site-packages/rerun_sdk/rerun_cli");
        std::fs::create_dir_all(&bin).expect("bin");
        std::fs::create_dir_all(&real).expect("lib");
        std::fs::write(bin.join("rerun"), "#!/usr/bin/python\n").expect("script");
        std::fs::write(real.join("rerun"), b"\x7fELF").expect("binary");
        assert_eq!(real_binary(&bin.join("rerun")), real.join("rerun"));
        // A binary is itself.
        assert_eq!(real_binary(&real.join("rerun")), real.join("rerun"));
    }

    #[test]
    fn the_page_loses_its_font_links() {
        let page = "<head>\n    <link rel=\"icon\" href=\"favicon.ico\" />\n    <link rel=\"preconnect\" href=\"https://fonts.googleapis.com\" />\n    <link rel=\"preconnect\" href=\"https://fonts.gstatic.com\" crossorigin />\n    <link\n      href=\"https://fonts.googleapis.com/css2?family=Inter\"\n      rel=\"stylesheet\"\n    />\n    <title>Rerun Viewer</title>\n";
        let out = String::from_utf8(offline_page(page.as_bytes())).expect("utf-8");
        assert!(!out.contains("fonts.g"), "{out}");
        assert!(out.contains("favicon.ico") && out.contains("<title>"), "{out}");
        assert!(!out.contains("<link\n"), "{out}");
    }
}
