//! Learning for FireCast: the only crate that links libtorch (through `tch`).
//!
//! This first part answers "where does training run": [`default_device`] picks CUDA when
//! a GPU is visible and the CPU otherwise, and [`torch_info`] reports what libtorch sees.
//!
//! libtorch's CUDA backend (`libtorch_cuda.so`, with cuDNN, cuBLAS, NCCL) is loaded on
//! first use rather than at program start: linking it eagerly doubles the start-up time
//! of every `firecast` command (0.30 s to 0.67 s measured), most of which never train.

pub mod layers;

use std::sync::OnceLock;

use serde::Serialize;

/// What libtorch reports about this machine.
#[derive(Debug, Clone, Serialize)]
pub struct TorchInfo {
    /// `libtorch_cuda.so` was found and loaded (it ships with the PyPI torch wheel).
    pub cuda_backend_loaded: bool,
    pub cuda_available: bool,
    pub cuda_device_count: i64,
    pub cudnn_available: bool,
    pub device: String,
    pub threads: i32,
}

/// Load libtorch's CUDA backend once. Must run before the first CUDA query: libtorch
/// caches the answer of its CUDA hooks registry on first use.
pub fn load_cuda_backend() -> bool {
    static LOADED: OnceLock<bool> = OnceLock::new();
    *LOADED.get_or_init(dlopen_torch_cuda)
}

#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
fn dlopen_torch_cuda() -> bool {
    // Found through the binary's RUNPATH (set to libtorch's folder by the build scripts).
    // SAFETY: dlopen with a valid C string; the handle is intentionally never closed so
    // the backend's registrations stay valid for the life of the process.
    let handle = unsafe { libc::dlopen(c"libtorch_cuda.so".as_ptr(), libc::RTLD_NOW | libc::RTLD_GLOBAL) };
    !handle.is_null()
}

#[cfg(not(target_os = "linux"))]
fn dlopen_torch_cuda() -> bool {
    false
}

/// CUDA device 0 when available, else the CPU.
pub fn default_device() -> tch::Device {
    load_cuda_backend();
    tch::Device::cuda_if_available()
}

pub fn torch_info() -> TorchInfo {
    let cuda_backend_loaded = load_cuda_backend();
    let device = default_device();
    TorchInfo {
        cuda_backend_loaded,
        cuda_available: tch::Cuda::is_available(),
        cuda_device_count: tch::Cuda::device_count(),
        cudnn_available: tch::Cuda::cudnn_is_available(),
        device: format!("{device:?}"),
        threads: tch::get_num_threads(),
    }
}

/// libtorch threads (and XGBoost's `nthread`) of a stage that names none. The count changes
/// how reductions are split, so it changes results: it is a stage param (in the cache key)
/// with this fixed default, never the machine's core count, so the same config and seed
/// give the same bytes on every machine. One thread is also the fastest measured for
/// FireCast's small networks on a shared 2-core machine.
pub const DEFAULT_THREADS: usize = 1;

/// serde default for a `threads` param.
pub fn default_threads() -> usize {
    DEFAULT_THREADS
}

/// Checks a `threads` param: 1 to 1,024.
pub fn check_threads(n: usize) -> Result<(), String> {
    if (1..=1024).contains(&n) {
        Ok(())
    } else {
        Err(format!("{n} threads: must be 1 to 1024"))
    }
}

/// Intra-op threads of libtorch (at least 1). Set once per command so a 2-core machine is not
/// oversubscribed and the same settings give the same numbers. Every command and stage that
/// uses libtorch calls this first, so it also keeps freed tensor memory in the process
/// ([`keep_freed_memory`]).
pub fn set_threads(n: usize) {
    keep_freed_memory();
    tch::set_num_threads(n.max(1) as i32);
}

/// Makes glibc's malloc keep the memory libtorch frees instead of handing it back to the
/// kernel. libtorch's CPU allocator has no cache: each tensor is a `malloc` and a `free`, and
/// glibc serves big blocks (every activation of a minibatch on a 240 × 160 map) with a fresh
/// `mmap` that it unmaps on free, so each minibatch page-faults its activations in anew —
/// about 10 million page faults in 2,048 training steps on 240 × 160, a quarter of the CPU
/// time (`perf`). With no `mmap`, no trimming of the heap's top and a 64 MiB pad, freed
/// blocks are reused; the process keeps its peak heap until it exits. Results do not change
/// (libtorch aligns its blocks itself). Called once; later calls do nothing.
pub fn keep_freed_memory() {
    static DONE: OnceLock<()> = OnceLock::new();
    DONE.get_or_init(tune_malloc);
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
#[allow(unsafe_code)]
fn tune_malloc() {
    // SAFETY: mallopt only changes glibc's allocation parameters; it is thread-safe and
    // takes plain integers.
    unsafe {
        libc::mallopt(libc::M_MMAP_MAX, 0);
        libc::mallopt(libc::M_TRIM_THRESHOLD, i32::MAX);
        libc::mallopt(libc::M_TOP_PAD, 64 << 20);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn tune_malloc() {}

/// Seeds libtorch's generators (CPU and every CUDA device) and turns off cuDNN's
/// benchmark mode, whose algorithm choice is not reproducible.
pub fn seed_everything(seed: u64) {
    tch::manual_seed(seed as i64);
    if tch::Cuda::is_available() {
        tch::Cuda::manual_seed_all(seed);
        tch::Cuda::cudnn_set_benchmark(false);
    }
}

/// Parses `auto`, `cpu`, `cuda` or `cuda:N`. `cuda` without a GPU (or without libtorch's
/// CUDA backend) is an error, never a silent fall-back to the CPU.
pub fn parse_device(s: &str) -> Result<tch::Device, String> {
    match s {
        "auto" => Ok(default_device()),
        "cpu" => Ok(tch::Device::Cpu),
        _ => {
            let index = match s.strip_prefix("cuda") {
                Some("") => 0,
                Some(rest) => rest
                    .strip_prefix(':')
                    .and_then(|n| n.parse::<usize>().ok())
                    .ok_or_else(|| format!("`{s}` is not auto, cpu, cuda or cuda:N"))?,
                None => return Err(format!("`{s}` is not auto, cpu, cuda or cuda:N")),
            };
            let loaded = load_cuda_backend();
            let count = tch::Cuda::device_count();
            if !loaded || (index as i64) >= count {
                return Err(format!(
                    "`{s}` was asked for but libtorch sees {count} CUDA device(s) (CUDA backend loaded: {loaded})"
                ));
            }
            Ok(tch::Device::Cuda(index))
        }
    }
}

/// Runs `f` alone among the callers of this function in the process. libtorch has one CPU
/// generator per process and draws from it for weight initialisation and dropout, so two
/// pipeline stages training at once would take each other's random numbers and neither
/// would be reproducible; every stage kind that uses libtorch runs its work inside this.
/// Not reentrant: `f` must not call it again.
pub fn exclusive<T>(f: impl FnOnce() -> T) -> T {
    static STAGE_LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _guard = STAGE_LOCK.lock().unwrap_or_else(|e| e.into_inner());
    f()
}

/// Runs `f` with libtorch's global generator seeded with `seed`, holding a process-wide lock
/// so that weights drawn inside `f` do not depend on other threads drawing at the same time
/// (libtorch has one CPU generator per process).
pub fn with_seed<T>(seed: u64, f: impl FnOnce() -> T) -> T {
    static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _guard = LOCK.lock().unwrap_or_else(|e| e.into_inner());
    tch::manual_seed(seed as i64);
    f()
}
