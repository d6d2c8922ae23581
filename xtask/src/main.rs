//! FireCast's bootstrap, so a fresh machine with only Rust and python3 needs two commands:
//!
//! - `cargo xtask demo`: set up, build, run `pipelines/demo.yaml`, list the runs, print the
//!   demo's Table III (forecasting) and Table IV (helitack agents);
//! - `cargo xtask test`: set up, build, run the whole test suite.
//!
//! Setup is idempotent: it installs the pinned Python packages (torch 2.13.0 brings
//! libtorch for tch) into `.venv`, downloads the official `libduckdb.so` 1.5.1 into
//! `.firecast/deps/duckdb`, and links `.firecast/deps/{libtorch,nvidia}` to the wheel's
//! folders; `.cargo/config.toml` points the build at them. It builds the Python package
//! `firecast` (crates/firecast-py) with maturin and installs it into `.venv` when its sources
//! changed. Peers that FireCast is benchmarked against and that cannot share `.venv`'s pins
//! get their own venvs under `.venv-peers/` (pyretechnics, for `firecast bench behavior|spread`).
//! A second run reuses all of it.
//! No third-party crates: this must build before anything else exists.

use std::env;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

/// The official DuckDB 1.5.1 shared library, as npm's Node bindings ship it.
const DUCKDB_TARBALL_URL: &str =
    "https://registry.npmjs.org/@duckdb/node-bindings-linux-x64/-/node-bindings-linux-x64-1.5.1-r.2.tgz";
const DUCKDB_TARBALL_SHA256: &str = "69d9dd8fb539b9fcac3eeaa4b63a5b3b8cf73ba0c95d751195192bf078fabe55";

fn main() -> ExitCode {
    let args: Vec<String> = env::args().skip(1).collect();
    let command = args.first().map_or("help", String::as_str);
    let rest = args.get(1..).unwrap_or_default();
    let result = match command {
        "setup" => setup().map(|_| ()),
        "build" => setup().and_then(|ctx| build(&ctx)),
        "demo" => setup().and_then(|ctx| demo(&ctx, rest)),
        "test" => setup().and_then(|ctx| test(&ctx, rest)),
        "ci" => setup().and_then(|ctx| ci(&ctx)),
        "env" => setup().map(|ctx| print_env(&ctx)),
        _ => {
            eprintln!(
                "usage: cargo xtask <command>\n\n\
                 commands:\n  \
                 setup   install .venv (torch 2.13.0, rerun-sdk 0.36.3, test tools), .venv-peers/pyretechnics and libduckdb 1.5.1\n  \
                 build   setup, then build the firecast binary (release)\n  \
                 demo    setup, build, run pipelines/demo.yaml, list the runs, print Tables III and IV\n  \
                 test    setup, build, run every test (extra args go to `cargo test`)\n  \
                 ci      test, then cargo fmt --check and cargo clippy -D warnings\n  \
                 env     setup, then print the environment the build uses"
            );
            return if command == "help" {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(2)
            };
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("xtask: error: {message}");
            ExitCode::FAILURE
        }
    }
}

struct Context {
    root: PathBuf,
    target_dir: PathBuf,
    venv_python: PathBuf,
}

fn workspace_root() -> PathBuf {
    // xtask/Cargo.toml lives one level below the workspace root.
    // Cargo sets CARGO_MANIFEST_DIR when it runs us; prefer it to the compile-time value,
    // because a build in a shared target dir may come from another clone of the repository.
    let manifest_dir = env::var_os("CARGO_MANIFEST_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")));
    manifest_dir
        .parent()
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

fn setup() -> Result<Context, String> {
    let root = workspace_root();
    let target_dir = match env::var_os("CARGO_TARGET_DIR") {
        Some(dir) => PathBuf::from(dir),
        None => home()?.join(".cache/firecast/target"),
    };
    let deps = root.join(".firecast/deps");
    std::fs::create_dir_all(&deps).map_err(|e| format!("cannot create {}: {e}", deps.display()))?;

    let venv_python = ensure_venv(&root)?;
    ensure_peer_venvs(&root);
    ensure_duckdb(&deps, &venv_python)?;
    link_libtorch(&deps, &venv_python)?;
    ensure_python_package(&root, &target_dir, &venv_python)?;
    ensure_browser()?;
    Ok(Context {
        root,
        target_dir,
        venv_python,
    })
}

fn on_path(name: &str) -> bool {
    env::var_os("PATH").is_some_and(|p| env::split_paths(&p).any(|d| d.join(name).is_file()))
}

/// Debian's Chromium (the report's PDF is its print of the HTML, and the report tests render
/// the HTML in it) and poppler-utils (the tests read the PDF back), from the distribution's
/// packages.
fn ensure_browser() -> Result<(), String> {
    let have_browser =
        env::var_os("FIRECAST_CHROMIUM").is_some() || on_path("chromium") || on_path("chromium-browser");
    if have_browser && on_path("pdfinfo") && on_path("pdftotext") {
        return Ok(());
    }
    let root = Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| o.stdout.starts_with(b"0"));
    let apt = |args: &[&str]| {
        let mut c = if root {
            Command::new("apt-get")
        } else {
            let mut c = Command::new("sudo");
            c.args(["-n", "apt-get"]);
            c
        };
        c.args(args).env("DEBIAN_FRONTEND", "noninteractive");
        c
    };
    eprintln!("xtask: installing Debian's chromium and poppler-utils (reports: PDF printing and tests)");
    let packages = [
        "install",
        "-y",
        "--no-install-recommends",
        "chromium",
        "poppler-utils",
    ];
    if run(&mut apt(&packages), "apt-get install chromium poppler-utils").is_err() {
        run(&mut apt(&["update"]), "apt-get update")?;
        run(&mut apt(&packages), "apt-get install chromium poppler-utils")?;
    }
    Ok(())
}

fn home() -> Result<PathBuf, String> {
    env::var_os("HOME")
        .map(PathBuf::from)
        .ok_or_else(|| "HOME is not set; set CARGO_TARGET_DIR instead".to_string())
}

fn ensure_venv(root: &Path) -> Result<PathBuf, String> {
    install_venv(
        &root.join(".venv"),
        &root.join("xtask/requirements.txt"),
        false,
        "installing Python packages (torch 2.13.0 is large; this happens once)",
    )
}

/// Creates `venv` if needed and installs `requirements` into it, once per content of the file
/// (a stamp inside the venv holds the content it was installed from); `constrain` also passes
/// the file as pip's constraints, so packages pip builds from source build with the same pins.
fn install_venv(venv: &Path, requirements: &Path, constrain: bool, what: &str) -> Result<PathBuf, String> {
    let python = venv.join("bin/python");
    let wanted = std::fs::read_to_string(requirements)
        .map_err(|e| format!("cannot read {}: {e}", requirements.display()))?;
    let stamp = venv.join("firecast-requirements.txt");
    if std::fs::read_to_string(&stamp).ok().as_deref() == Some(wanted.as_str()) && python.exists() {
        return Ok(python);
    }
    if !python.exists() {
        eprintln!("xtask: creating {}", venv.display());
        run(
            Command::new("python3").args(["-m", "venv"]).arg(venv),
            "python3 -m venv",
        )?;
    }
    eprintln!("xtask: {what}");
    let mut pip = Command::new(&python);
    if constrain {
        pip.env("PIP_CONSTRAINT", requirements);
    }
    run(
        pip.args(["-m", "pip", "install", "--disable-pip-version-check", "-q", "-r"])
            .arg(requirements),
        &format!("pip install -r {}", requirements.display()),
    )?;
    std::fs::write(&stamp, wanted).map_err(|e| format!("cannot write {}: {e}", stamp.display()))?;
    Ok(python)
}

/// References FireCast is benchmarked against that cannot share `.venv`'s pins, each in its
/// own venv under `.venv-peers/` (ignored by git), pinned by its requirements file.
/// pyretechnics (`firecast bench behavior|spread`) needs numpy 1.26 where `.venv` has numpy 2.
const PEER_VENVS: [(&str, &str); 1] = [("pyretechnics", "xtask/requirements-pyretechnics.txt")];

/// Install every peer venv of [`PEER_VENVS`] that is missing or whose requirements changed.
/// A peer only serves a benchmark, so one that fails to install is a warning (the benchmark
/// then says to run `cargo xtask setup`), not a failed setup.
fn ensure_peer_venvs(root: &Path) {
    for (name, requirements) in PEER_VENVS {
        if let Err(message) = ensure_peer_venv(root, name, requirements) {
            eprintln!(
                "xtask: warning: the peer venv .venv-peers/{name} is not installed ({message}); \
                 the benchmarks beside {name} will ask for `cargo xtask setup` again"
            );
        }
    }
}

/// One peer venv, stamped like `.venv`: installed once per content of its requirements file.
/// The file's pins are also passed as constraints (`PIP_CONSTRAINT`), so a package pip builds
/// from source (pyretechnics compiles its Cython modules) builds with the same pinned versions.
fn ensure_peer_venv(root: &Path, name: &str, requirements: &str) -> Result<(), String> {
    let venv = root.join(".venv-peers").join(name);
    let what = format!(
        "installing the peer {name} into {} (it compiles; this happens once)",
        venv.display()
    );
    install_venv(&venv, &root.join(requirements), true, &what).map(|_| ())
}

/// Download and check the official libduckdb.so (python3 does the HTTP, so no curl is needed).
fn ensure_duckdb(deps: &Path, python: &Path) -> Result<(), String> {
    let dir = deps.join("duckdb");
    if dir.join("libduckdb.so").exists() {
        return Ok(());
    }
    eprintln!("xtask: downloading libduckdb.so 1.5.1");
    let script = r#"
import hashlib, io, os, sys, tarfile, urllib.request
url, sha, dest = sys.argv[1], sys.argv[2], sys.argv[3]
data = urllib.request.urlopen(url, timeout=120).read()
got = hashlib.sha256(data).hexdigest()
if got != sha:
    sys.exit(f"checksum mismatch for {url}: {got}")
os.makedirs(dest, exist_ok=True)
with tarfile.open(fileobj=io.BytesIO(data)) as tar:
    member = tar.extractfile("package/libduckdb.so")
    tmp = os.path.join(dest, ".libduckdb.so.part")
    with open(tmp, "wb") as out:
        out.write(member.read())
    os.replace(tmp, os.path.join(dest, "libduckdb.so"))
"#;
    run(
        Command::new(python)
            .arg("-c")
            .arg(script)
            .arg(DUCKDB_TARBALL_URL)
            .arg(DUCKDB_TARBALL_SHA256)
            .arg(&dir),
        "download libduckdb",
    )
}

/// `.firecast/deps/libtorch` and `.firecast/deps/nvidia` point into the torch wheel. Both
/// are needed: libtorch's own RPATH finds CUDA at `$ORIGIN/../../nvidia/...`.
fn link_libtorch(deps: &Path, python: &Path) -> Result<(), String> {
    let output = Command::new(python)
        .args(["-c", "import os, torch; print(os.path.dirname(torch.__file__))"])
        .output()
        .map_err(|e| format!("cannot run {}: {e}", python.display()))?;
    if !output.status.success() {
        return Err(format!(
            "torch is not importable from {}: {}",
            python.display(),
            String::from_utf8_lossy(&output.stderr)
        ));
    }
    let torch_dir = PathBuf::from(String::from_utf8_lossy(&output.stdout).trim());
    let site_packages = torch_dir.parent().ok_or("torch has no parent folder")?;
    replace_symlink(&torch_dir, &deps.join("libtorch"))?;
    replace_symlink(&site_packages.join("nvidia"), &deps.join("nvidia"))
}

/// What the Python package `firecast` is built from: its crate (Rust and Python sources)
/// and the crates it embeds. A change to any of them rebuilds and reinstalls the wheel.
const PY_PACKAGE_SOURCES: [&str; 10] = [
    "Cargo.toml",
    "Cargo.lock",
    "crates/firecast-py/Cargo.toml",
    "crates/firecast-py/pyproject.toml",
    "crates/firecast-py/src",
    "crates/firecast-py/python",
    "crates/firecast-sim/Cargo.toml",
    "crates/firecast-sim/src",
    "crates/firecast-landscape/Cargo.toml",
    "crates/firecast-landscape/src",
];

/// Builds the Python package `firecast` (crates/firecast-py) with maturin into
/// `$CARGO_TARGET_DIR/python-wheel` and installs the wheel into .venv; skipped while the
/// stamp in .venv matches the hash of [`PY_PACKAGE_SOURCES`].
fn ensure_python_package(root: &Path, target_dir: &Path, python: &Path) -> Result<(), String> {
    let stamp = root.join(".venv/firecast-py.stamp");
    let mut files = Vec::new();
    for source in PY_PACKAGE_SOURCES {
        collect_files(&root.join(source), &mut files)?;
    }
    files.sort();
    // FNV-1a over (path, length, content) of every file: stable across toolchains.
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for file in &files {
        let content = std::fs::read(file).map_err(|e| format!("cannot read {}: {e}", file.display()))?;
        let rel = file
            .strip_prefix(root)
            .unwrap_or(file)
            .to_string_lossy()
            .into_owned();
        for chunk in [rel.as_bytes(), &content.len().to_le_bytes(), &content] {
            for &b in chunk {
                hash = (hash ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
            }
        }
    }
    let wanted = format!("{hash:016x}\n");
    let installed = || {
        Command::new(python)
            // -I: not the working directory's modules, only the venv's.
            .args([
                "-I",
                "-c",
                "import importlib.util as u, sys; sys.exit(u.find_spec('firecast') is None)",
            ])
            .status()
            .is_ok_and(|s| s.success())
    };
    if std::fs::read_to_string(&stamp).ok().as_deref() == Some(wanted.as_str()) && installed() {
        return Ok(());
    }
    eprintln!("xtask: building the Python package firecast (crates/firecast-py) with maturin");
    let build_dir = target_dir.join("python-wheel");
    let wheels = build_dir.join("wheels");
    let _ignored = std::fs::remove_dir_all(&wheels);
    run(
        Command::new(python)
            .current_dir(root)
            // Its own target folder: maturin's PyO3 settings differ from the plain build's,
            // and sharing one would rebuild PyO3 back and forth.
            .env("CARGO_TARGET_DIR", &build_dir)
            .args([
                "-m",
                "maturin",
                "build",
                "--release",
                "--locked",
                "--manifest-path",
            ])
            .arg("crates/firecast-py/Cargo.toml")
            .arg("--interpreter")
            .arg(python)
            .arg("--out")
            .arg(&wheels)
            // A wheel for this machine only: the native tag, no manylinux audit.
            .args(["--compatibility", "linux", "--auditwheel", "skip"]),
        "maturin build (crates/firecast-py)",
    )?;
    let wheel = std::fs::read_dir(&wheels)
        .map_err(|e| format!("cannot list {}: {e}", wheels.display()))?
        .filter_map(Result::ok)
        .map(|entry| entry.path())
        .find(|path| path.extension().is_some_and(|ext| ext == "whl"))
        .ok_or_else(|| format!("maturin left no wheel in {}", wheels.display()))?;
    run(
        Command::new(python)
            .args([
                "-m",
                "pip",
                "install",
                "--disable-pip-version-check",
                "-q",
                "--no-deps",
                "--force-reinstall",
            ])
            .arg(&wheel),
        "pip install the firecast wheel",
    )?;
    std::fs::write(&stamp, wanted).map_err(|e| format!("cannot write {}: {e}", stamp.display()))
}

/// Every file under `path` (or `path` itself), skipping caches.
fn collect_files(path: &Path, out: &mut Vec<PathBuf>) -> Result<(), String> {
    if path.is_file() {
        out.push(path.to_path_buf());
        return Ok(());
    }
    let entries = std::fs::read_dir(path).map_err(|e| format!("cannot list {}: {e}", path.display()))?;
    for entry in entries {
        let entry = entry.map_err(|e| format!("cannot list {}: {e}", path.display()))?;
        let p = entry.path();
        if p.is_dir() {
            if entry.file_name() != "__pycache__" {
                collect_files(&p, out)?;
            }
        } else if p.extension().is_none_or(|ext| ext != "pyc") {
            out.push(p);
        }
    }
    Ok(())
}

fn replace_symlink(target: &Path, link: &Path) -> Result<(), String> {
    if std::fs::read_link(link).ok().as_deref() == Some(target) {
        return Ok(());
    }
    let _ignored = std::fs::remove_file(link);
    std::os::unix::fs::symlink(target, link)
        .map_err(|e| format!("cannot link {} -> {}: {e}", link.display(), target.display()))
}

fn cargo(ctx: &Context) -> Command {
    let mut command = Command::new(env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
    command
        .current_dir(&ctx.root)
        .env("CARGO_TARGET_DIR", &ctx.target_dir);
    command
}

/// Cargo arguments shared by the build and the tests. Building through `cargo test
/// --no-run` gives the `firecast` binary exactly the features the test build resolves
/// (dev-dependencies unify features of shared crates), so `demo` and `test` share one build
/// instead of compiling the heavy stack twice.
const TEST_ARGS: [&str; 6] = [
    "test",
    "--release",
    "--locked",
    "--workspace",
    "--exclude",
    "xtask",
];

fn build(ctx: &Context) -> Result<(), String> {
    run(cargo(ctx).args(TEST_ARGS).arg("--no-run"), "cargo build")
}

fn demo(ctx: &Context, args: &[String]) -> Result<(), String> {
    build(ctx)?;
    let firecast = ctx.target_dir.join("release/firecast");
    let mut pipeline = Command::new(&firecast);
    pipeline
        .current_dir(&ctx.root)
        .args(["pipeline", "run", "pipelines/demo.yaml"])
        .args(args);
    run(&mut pipeline, "firecast pipeline run pipelines/demo.yaml")?;
    run(
        Command::new(&firecast)
            .current_dir(&ctx.root)
            .args(["runs", "list", "--limit", "15"]),
        "firecast runs list",
    )?;
    // Table III of the demo's forecasting experiment (stage forecast_table3).
    run(
        Command::new(&firecast)
            .current_dir(&ctx.root)
            .args(["experiment", "compare", "build/demo/table3"]),
        "firecast experiment compare build/demo/table3",
    )?;
    // Table IV of the demo's PPO helitack agent (stages helitack_agent, helitack_table4).
    let table4 = ctx.root.join("build/demo/helitack_table4/table4.md");
    let text = std::fs::read_to_string(&table4).map_err(|e| format!("reading {}: {e}", table4.display()))?;
    println!("\n{}", text.trim_end());
    Ok(())
}

fn test(ctx: &Context, args: &[String]) -> Result<(), String> {
    run(cargo(ctx).args(TEST_ARGS).args(args), "cargo test")
}

fn ci(ctx: &Context) -> Result<(), String> {
    test(ctx, &[])?;
    run(cargo(ctx).args(["fmt", "--all", "--check"]), "cargo fmt --check")?;
    run(
        cargo(ctx).args([
            "clippy",
            "--release",
            "--locked",
            "--workspace",
            "--all-targets",
            "--",
            "-D",
            "warnings",
        ]),
        "cargo clippy",
    )
}

fn print_env(ctx: &Context) {
    println!("CARGO_TARGET_DIR={}", ctx.target_dir.display());
    println!("FIRECAST_PYTHON={}", ctx.venv_python.display());
    println!("LIBTORCH={}", ctx.root.join(".firecast/deps/libtorch").display());
    println!(
        "DUCKDB_LIB_DIR={}",
        ctx.root.join(".firecast/deps/duckdb").display()
    );
}

fn run(command: &mut Command, what: &str) -> Result<(), String> {
    let status = command
        .status()
        .map_err(|e| format!("{what}: cannot start: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("{what} failed ({status})"))
    }
}
