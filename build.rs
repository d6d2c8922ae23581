//! The `firecast` binary finds libtorch and libduckdb through its RPATH: users never
//! export LD_LIBRARY_PATH. Both folders come from `cargo xtask setup` via .cargo/config.toml.
fn main() {
    println!("cargo:rerun-if-env-changed=LIBTORCH");
    println!("cargo:rerun-if-env-changed=DUCKDB_LIB_DIR");
    if let Ok(libtorch) = std::env::var("LIBTORCH") {
        let lib = std::path::Path::new(&libtorch).join("lib");
        // The real path: libtorch's own RPATH ($ORIGIN/../../nvidia/...) must resolve from it.
        let lib = lib.canonicalize().unwrap_or(lib);
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib.display());
    }
    if let Ok(dir) = std::env::var("DUCKDB_LIB_DIR") {
        println!("cargo:rustc-link-arg=-Wl,-rpath,{dir}");
    }
}
