//! Every line of FFI in this crate: `dlopen`/`dlsym` of `libxgboost.so` and safe wrappers
//! around the handful of XGBoost C API functions FireCast uses.
//!
//! Signatures follow `include/xgboost/c_api.h` of XGBoost 3.2.0 (`bst_ulong` is `uint64_t`,
//! handles are `void *`). The library is opened once per process with
//! `RTLD_NOW | RTLD_LOCAL` and never closed (OpenMP worker threads it starts may outlive
//! any point where unloading would be safe).
#![allow(unsafe_code)]

use std::ffi::{CStr, CString, c_char, c_int, c_void};
use std::os::unix::ffi::OsStrExt as _;
use std::path::Path;
use std::ptr;
use std::sync::{OnceLock, PoisonError, RwLock};

use crate::XgbError;

type Handle = *mut c_void;

/// The oldest XGBoost whose C API and defaults this crate is written against.
const MIN_MAJOR: i32 = 3;

/// Declares [`Api`] (one function pointer per C function) and its loader from one list of
/// `field = "CSymbol": fn(args) -> ret;` entries, so each prototype is written once.
macro_rules! xgboost_api {
    ($($field:ident = $name:literal : fn($($arg:ty),* $(,)?) $(-> $ret:ty)?;)*) => {
        /// Function pointers into one loaded `libxgboost.so`.
        pub(crate) struct Api {
            $($field: unsafe extern "C" fn($($arg),*) $(-> $ret)?,)*
        }

        impl Api {
            fn load_symbols(lib: *mut c_void, path: &Path) -> Result<Api, XgbError> {
                Ok(Api {
                    $($field: {
                        let sym = symbol(lib, path, $name)?;
                        // SAFETY: `sym` is the address of the exported C function `$name`,
                        // whose prototype in XGBoost 3.2's c_api.h is exactly this
                        // function-pointer type (`bst_ulong` = u64, handles = void *); on the
                        // supported (Unix) targets data and function pointers have the same
                        // size and representation, which dlsym relies on.
                        unsafe {
                            std::mem::transmute::<*mut c_void, unsafe extern "C" fn($($arg),*) $(-> $ret)?>(sym)
                        }
                    },)*
                })
            }
        }
    };
}

xgboost_api! {
    get_last_error = c"XGBGetLastError": fn() -> *const c_char;
    version = c"XGBoostVersion": fn(*mut c_int, *mut c_int, *mut c_int);
    dmatrix_create_from_mat = c"XGDMatrixCreateFromMat":
        fn(*const f32, u64, u64, f32, *mut Handle) -> c_int;
    dmatrix_set_float_info = c"XGDMatrixSetFloatInfo":
        fn(Handle, *const c_char, *const f32, u64) -> c_int;
    dmatrix_free = c"XGDMatrixFree": fn(Handle) -> c_int;
    booster_create = c"XGBoosterCreate": fn(*const Handle, u64, *mut Handle) -> c_int;
    booster_free = c"XGBoosterFree": fn(Handle) -> c_int;
    booster_set_param = c"XGBoosterSetParam": fn(Handle, *const c_char, *const c_char) -> c_int;
    booster_update_one_iter = c"XGBoosterUpdateOneIter": fn(Handle, c_int, Handle) -> c_int;
    booster_predict_from_dmatrix = c"XGBoosterPredictFromDMatrix": fn(
        Handle,
        Handle,
        *const c_char,
        *mut *const u64,
        *mut u64,
        *mut *const f32,
    ) -> c_int;
    booster_save_model_to_buffer = c"XGBoosterSaveModelToBuffer":
        fn(Handle, *const c_char, *mut u64, *mut *const c_char) -> c_int;
    booster_load_model_from_buffer = c"XGBoosterLoadModelFromBuffer":
        fn(Handle, *const c_void, u64) -> c_int;
    booster_save_json_config = c"XGBoosterSaveJsonConfig":
        fn(Handle, *mut u64, *mut *const c_char) -> c_int;
    booster_get_num_feature = c"XGBoosterGetNumFeature": fn(Handle, *mut u64) -> c_int;
    booster_boosted_rounds = c"XGBoosterBoostedRounds": fn(Handle, *mut c_int) -> c_int;
}

static API: OnceLock<Result<Api, XgbError>> = OnceLock::new();

/// The process-wide library, located by [`crate::library_path`] and opened on first use.
pub(crate) fn api() -> Result<&'static Api, XgbError> {
    API.get_or_init(|| crate::locate::library_path().and_then(|path| Api::open(&path)))
        .as_ref()
        .map_err(Clone::clone)
}

/// Opens `path` (without caching it as the process-wide library) and returns its version.
pub(crate) fn probe(path: &Path) -> Result<(i32, i32, i32), XgbError> {
    Api::open(path).map(|api| api.version())
}

fn dlerror_message() -> String {
    // SAFETY: dlerror takes no arguments; it returns null or a pointer to a NUL-terminated
    // thread-local message that stays valid until the next dl* call on this thread, and we
    // copy it out immediately.
    let msg = unsafe { libc::dlerror() };
    if msg.is_null() {
        "unknown dlopen error".to_owned()
    } else {
        // SAFETY: non-null, NUL-terminated, valid until the next dl* call (see above).
        unsafe { CStr::from_ptr(msg) }.to_string_lossy().into_owned()
    }
}

fn symbol(lib: *mut c_void, path: &Path, name: &CStr) -> Result<*mut c_void, XgbError> {
    // SAFETY: `lib` is a live handle returned by dlopen (never closed) and `name` is a
    // NUL-terminated C string.
    let sym = unsafe { libc::dlsym(lib, name.as_ptr()) };
    if sym.is_null() {
        return Err(XgbError::Library(format!(
            "{} has no symbol {} (is it XGBoost >= {MIN_MAJOR}.0? {}); run `cargo xtask setup`",
            path.display(),
            name.to_string_lossy(),
            dlerror_message()
        )));
    }
    Ok(sym)
}

impl Api {
    fn open(path: &Path) -> Result<Api, XgbError> {
        let c_path = CString::new(path.as_os_str().as_bytes()).map_err(|_| {
            XgbError::Library(format!("library path contains a NUL byte: {}", path.display()))
        })?;
        // SAFETY: `c_path` is NUL-terminated. Loading runs the library's static initialisers,
        // which only set up XGBoost's own registries; RTLD_LOCAL keeps its symbols (and its
        // bundled libgomp) out of the global namespace.
        let lib = unsafe { libc::dlopen(c_path.as_ptr(), libc::RTLD_NOW | libc::RTLD_LOCAL) };
        if lib.is_null() {
            return Err(XgbError::Library(format!(
                "cannot load the XGBoost library {}: {}; run `cargo xtask setup`",
                path.display(),
                dlerror_message()
            )));
        }
        let api = Api::load_symbols(lib, path)?;
        let (major, minor, patch) = api.version();
        if major < MIN_MAJOR {
            return Err(XgbError::Library(format!(
                "{} is XGBoost {major}.{minor}.{patch}; FireCast needs >= {MIN_MAJOR}.0 \
                 (run `cargo xtask setup`, which installs xgboost==3.2.0)",
                path.display()
            )));
        }
        Ok(api)
    }

    /// `XGBoostVersion`.
    pub(crate) fn version(&self) -> (i32, i32, i32) {
        let (mut major, mut minor, mut patch) = (0, 0, 0);
        // SAFETY: XGBoostVersion writes three ints through the given non-null pointers,
        // which point at live locals.
        unsafe { (self.version)(&mut major, &mut minor, &mut patch) };
        (major, minor, patch)
    }

    fn last_error(&self) -> String {
        // SAFETY: XGBGetLastError takes no arguments and returns null or a NUL-terminated
        // thread-local string, valid until the next XGBoost call on this thread.
        let msg = unsafe { (self.get_last_error)() };
        if msg.is_null() {
            return "(XGBoost gave no message)".to_owned();
        }
        // SAFETY: non-null and NUL-terminated (see above); copied out at once.
        unsafe { CStr::from_ptr(msg) }.to_string_lossy().trim().to_owned()
    }

    fn check(&self, call: &'static str, rc: c_int) -> Result<(), XgbError> {
        if rc == 0 {
            Ok(())
        } else {
            Err(XgbError::Api {
                call,
                message: self.last_error(),
            })
        }
    }
}

fn c_string(what: &str, value: &str) -> Result<CString, XgbError> {
    CString::new(value).map_err(|_| XgbError::Param {
        key: what.to_owned(),
        message: "contains a NUL byte".to_owned(),
    })
}

fn to_u64(n: usize) -> u64 {
    // usize is at most 64 bits on every supported target.
    n as u64
}

/// An owned `DMatrixHandle`; freed on drop.
pub(crate) struct DMatrix {
    handle: Handle,
    api: &'static Api,
}

impl DMatrix {
    /// `XGDMatrixCreateFromMat` over a row-major `rows x cols` matrix; NaN marks missing.
    pub(crate) fn from_dense(
        api: &'static Api,
        x: &[f32],
        rows: usize,
        cols: usize,
    ) -> Result<DMatrix, XgbError> {
        // Soundness: XGBoost reads exactly rows * cols floats from `x`.
        if rows.checked_mul(cols) != Some(x.len()) {
            return Err(XgbError::Input(format!(
                "x has {} values, expected rows * cols = {rows} * {cols}",
                x.len()
            )));
        }
        let mut out: Handle = ptr::null_mut();
        // SAFETY: `x` holds exactly rows * cols initialised floats (checked above), which
        // XGBoost copies into its own storage before returning; `out` points at a live local.
        let rc = unsafe {
            (api.dmatrix_create_from_mat)(x.as_ptr(), to_u64(rows), to_u64(cols), f32::NAN, &mut out)
        };
        api.check("XGDMatrixCreateFromMat", rc)?;
        Ok(DMatrix { handle: out, api })
    }

    /// `XGDMatrixSetFloatInfo(handle, "label", ...)`.
    pub(crate) fn set_labels(&mut self, labels: &[f32]) -> Result<(), XgbError> {
        self.set_float_info(c"label", labels)
    }

    /// `XGDMatrixSetFloatInfo(handle, "base_margin", ...)`: each row's starting log-odds,
    /// used instead of `base_score` in training and prediction.
    pub(crate) fn set_base_margin(&mut self, margin: &[f32]) -> Result<(), XgbError> {
        self.set_float_info(c"base_margin", margin)
    }

    fn set_float_info(&mut self, field: &CStr, values: &[f32]) -> Result<(), XgbError> {
        // SAFETY: `handle` is a live DMatrix; `field` is NUL-terminated and `values` is
        // valid for values.len() floats, which XGBoost copies.
        let rc = unsafe {
            (self.api.dmatrix_set_float_info)(
                self.handle,
                field.as_ptr(),
                values.as_ptr(),
                to_u64(values.len()),
            )
        };
        self.api.check("XGDMatrixSetFloatInfo", rc)
    }
}

impl Drop for DMatrix {
    fn drop(&mut self) {
        // SAFETY: `handle` came from XGDMatrixCreateFromMat, is owned by this value and is
        // freed exactly once, here. A booster that cached it holds its own shared_ptr.
        let _ = unsafe { (self.api.dmatrix_free)(self.handle) };
    }
}

/// An owned `BoosterHandle`; freed on drop.
///
/// Concurrency: XGBoost documents prediction on a tree booster as thread safe since 1.4
/// (doc/prediction.rst, "Thread Safety"; the C++ learner guards lazy configuration and the
/// prediction cache with mutexes, and C API return buffers are thread-local). Everything
/// else (training, parameter changes, loading, saving) must not overlap with anything.
/// `&mut self` methods are exclusive by construction; of the `&self` methods, `predict`
/// takes the read side of `lock` and every other one the write side, so concurrent calls
/// through a shared reference only ever overlap predictions with predictions.
pub(crate) struct RawBooster {
    handle: Handle,
    api: &'static Api,
    lock: RwLock<()>,
}

// SAFETY: the handle points at a heap-allocated C++ `Learner` with no thread affinity: any
// thread may call into it or free it (per-thread C API scratch buffers are keyed by the
// learner pointer and only hold returned data we have already copied).
unsafe impl Send for RawBooster {}
// SAFETY: shared access is limited to predictions overlapping other predictions, which
// XGBoost guarantees thread safe; all other `&self` calls are serialised by `lock` (see the
// type's documentation).
unsafe impl Sync for RawBooster {}

impl RawBooster {
    /// `XGBoosterCreate` with `cache` as the cached (training) matrices.
    pub(crate) fn create(api: &'static Api, cache: &[&DMatrix]) -> Result<RawBooster, XgbError> {
        let handles: Vec<Handle> = cache.iter().map(|d| d.handle).collect();
        let mut out: Handle = ptr::null_mut();
        // SAFETY: `handles` holds handles.len() live DMatrix handles (XGBoost takes shared
        // ownership of each); `out` points at a live local.
        let rc = unsafe { (api.booster_create)(handles.as_ptr(), to_u64(handles.len()), &mut out) };
        api.check("XGBoosterCreate", rc)?;
        Ok(RawBooster {
            handle: out,
            api,
            lock: RwLock::new(()),
        })
    }

    /// `XGBoosterSetParam`.
    pub(crate) fn set_param(&mut self, name: &str, value: &str) -> Result<(), XgbError> {
        let c_name = c_string(name, name)?;
        let c_value = c_string(name, value)?;
        // SAFETY: live handle, exclusive (&mut self); both strings are NUL-terminated and
        // outlive the call (XGBoost copies them).
        let rc = unsafe { (self.api.booster_set_param)(self.handle, c_name.as_ptr(), c_value.as_ptr()) };
        self.api.check("XGBoosterSetParam", rc)
    }

    /// `XGBoosterUpdateOneIter`: one boosting round on `train`.
    pub(crate) fn update_one_iter(&mut self, iter: i32, train: &DMatrix) -> Result<(), XgbError> {
        // SAFETY: live booster (exclusive) and live DMatrix handles.
        let rc = unsafe { (self.api.booster_update_one_iter)(self.handle, iter, train.handle) };
        self.api.check("XGBoosterUpdateOneIter", rc)
    }

    /// `XGBoosterPredictFromDMatrix` with a JSON `config`; returns the flattened output.
    pub(crate) fn predict(&self, data: &DMatrix, config: &CStr) -> Result<Vec<f32>, XgbError> {
        let _shared = self.lock.read().unwrap_or_else(PoisonError::into_inner);
        let mut shape: *const u64 = ptr::null();
        let mut dim: u64 = 0;
        let mut result: *const f32 = ptr::null();
        // SAFETY: live booster and DMatrix handles; `config` is NUL-terminated; the three
        // out-pointers point at live locals. Only predictions run concurrently (see above).
        let rc = unsafe {
            (self.api.booster_predict_from_dmatrix)(
                self.handle,
                data.handle,
                config.as_ptr(),
                &mut shape,
                &mut dim,
                &mut result,
            )
        };
        self.api.check("XGBoosterPredictFromDMatrix", rc)?;
        let dim = usize::try_from(dim).map_err(|_| bad_output("dimension overflows usize"))?;
        if dim == 0 || shape.is_null() || result.is_null() {
            return Err(bad_output("empty shape or null result"));
        }
        // SAFETY: on success XGBoost points `shape` at `dim` u64 values in this thread's
        // scratch buffer, valid until this thread's next call on this booster; copied now.
        let shape = unsafe { std::slice::from_raw_parts(shape, dim) }.to_vec();
        let len = shape.iter().try_fold(1usize, |acc, &n| {
            usize::try_from(n).ok().and_then(|n| acc.checked_mul(n))
        });
        let len = len.ok_or_else(|| bad_output("shape overflows usize"))?;
        // SAFETY: `result` points at the product of `shape` floats in the same thread-local
        // buffer (valid until the next call on this thread); copied now.
        Ok(unsafe { std::slice::from_raw_parts(result, len) }.to_vec())
    }

    /// `XGBoosterSaveModelToBuffer` with a JSON `config` such as `{"format": "json"}`.
    pub(crate) fn save_model(&self, config: &CStr) -> Result<Vec<u8>, XgbError> {
        let _exclusive = self.lock.write().unwrap_or_else(PoisonError::into_inner);
        let mut len: u64 = 0;
        let mut data: *const c_char = ptr::null();
        // SAFETY: live handle, no concurrent call (write lock); NUL-terminated config;
        // out-pointers point at live locals.
        let rc = unsafe {
            (self.api.booster_save_model_to_buffer)(self.handle, config.as_ptr(), &mut len, &mut data)
        };
        self.api.check("XGBoosterSaveModelToBuffer", rc)?;
        copy_bytes(data, len)
    }

    /// `XGBoosterLoadModelFromBuffer` (format detected by XGBoost: JSON or UBJSON).
    pub(crate) fn load_model(&mut self, buf: &[u8]) -> Result<(), XgbError> {
        // SAFETY: live handle, exclusive; `buf` is valid for buf.len() bytes and only read.
        let rc = unsafe {
            (self.api.booster_load_model_from_buffer)(self.handle, buf.as_ptr().cast(), to_u64(buf.len()))
        };
        self.api.check("XGBoosterLoadModelFromBuffer", rc)
    }

    /// `XGBoosterSaveJsonConfig`: the learner's full internal configuration as JSON.
    pub(crate) fn save_config(&self) -> Result<String, XgbError> {
        let _exclusive = self.lock.write().unwrap_or_else(PoisonError::into_inner);
        let mut len: u64 = 0;
        let mut data: *const c_char = ptr::null();
        // SAFETY: live handle, no concurrent call (write lock); out-pointers are live locals.
        let rc = unsafe { (self.api.booster_save_json_config)(self.handle, &mut len, &mut data) };
        self.api.check("XGBoosterSaveJsonConfig", rc)?;
        String::from_utf8(copy_bytes(data, len)?).map_err(|_| bad_output("config is not UTF-8"))
    }

    /// `XGBoosterGetNumFeature`.
    pub(crate) fn num_features(&self) -> Result<u64, XgbError> {
        let _exclusive = self.lock.write().unwrap_or_else(PoisonError::into_inner);
        let mut out: u64 = 0;
        // SAFETY: live handle, no concurrent call (write lock); `out` is a live local.
        let rc = unsafe { (self.api.booster_get_num_feature)(self.handle, &mut out) };
        self.api.check("XGBoosterGetNumFeature", rc)?;
        Ok(out)
    }

    /// `XGBoosterBoostedRounds`.
    pub(crate) fn boosted_rounds(&self) -> Result<i32, XgbError> {
        let _exclusive = self.lock.write().unwrap_or_else(PoisonError::into_inner);
        let mut out: c_int = 0;
        // SAFETY: live handle, no concurrent call (write lock); `out` is a live local.
        let rc = unsafe { (self.api.booster_boosted_rounds)(self.handle, &mut out) };
        self.api.check("XGBoosterBoostedRounds", rc)?;
        Ok(out)
    }
}

impl Drop for RawBooster {
    fn drop(&mut self) {
        // SAFETY: `handle` came from XGBoosterCreate, is owned by this value and is freed
        // exactly once, here; `&mut self` guarantees no call is in flight.
        let _ = unsafe { (self.api.booster_free)(self.handle) };
    }
}

fn bad_output(what: &str) -> XgbError {
    XgbError::Api {
        call: "XGBoosterPredictFromDMatrix",
        message: format!("unexpected output: {what}"),
    }
}

/// Copies a (pointer, length) byte buffer returned by the C API.
fn copy_bytes(data: *const c_char, len: u64) -> Result<Vec<u8>, XgbError> {
    let len = usize::try_from(len).map_err(|_| XgbError::Api {
        call: "XGBoosterSaveModelToBuffer",
        message: "buffer length overflows usize".to_owned(),
    })?;
    if len == 0 {
        return Ok(Vec::new());
    }
    if data.is_null() {
        return Err(XgbError::Api {
            call: "XGBoosterSaveModelToBuffer",
            message: "null buffer".to_owned(),
        });
    }
    // SAFETY: XGBoost returned `data` valid for `len` bytes in a thread-local buffer that
    // lives until the next call on this thread; we copy it out before returning.
    Ok(unsafe { std::slice::from_raw_parts(data.cast::<u8>(), len) }.to_vec())
}
