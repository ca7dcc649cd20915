//! PETSc start-up, shutdown, options and errors.
//!
//! Every PETSc call goes through [`check`], which turns a non-zero `PetscErrorCode` into a
//! [`PetscError`] carrying the message PETSc produced (caught by our own error handler, so PETSc
//! prints nothing and the caller decides what to report).
use petsc_sys as sys;
use std::ffi::{CStr, CString};
use std::os::raw::{c_char, c_int};
use std::sync::Mutex;

/// A PETSc call failed: the code and PETSc's own message.
#[derive(Debug, Clone, thiserror::Error)]
#[error("PETSc error {code} in {call}: {message}")]
pub struct PetscError {
    /// PETSc's error code.
    pub code: i32,
    /// The Rust-side call that failed.
    pub call: &'static str,
    /// PETSc's message (from its error handler), or the generic text for the code.
    pub message: String,
}

/// The last message PETSc's error handler was given (first line of the traceback).
static LAST_MESSAGE: Mutex<String> = Mutex::new(String::new());

/// Error handler installed at start-up: records the message instead of printing it.
unsafe extern "C" fn record_error(
    _comm: mpi_sys::MPI_Comm,
    line: c_int,
    func: *const c_char,
    file: *const c_char,
    n: sys::PetscErrorCode,
    _p: sys::PetscErrorType,
    mess: *const c_char,
    _ctx: *mut std::os::raw::c_void,
) -> sys::PetscErrorCode {
    let s = |p: *const c_char| {
        if p.is_null() {
            String::new()
        } else {
            // SAFETY: PETSc passes NUL-terminated strings.
            unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
        }
    };
    let msg = s(mess);
    if let Ok(mut last) = LAST_MESSAGE.lock() {
        // Keep the innermost (first reported) message: later calls are the traceback.
        if last.is_empty() {
            *last = format!("{} ({}:{}): {}", s(func), s(file), line, msg.trim());
        }
    }
    n
}

/// Turns a PETSc return code into a `Result`.
pub fn check(code: sys::PetscErrorCode, call: &'static str) -> Result<(), PetscError> {
    if code == 0 {
        return Ok(());
    }
    let mut message = LAST_MESSAGE
        .lock()
        .map(|mut m| std::mem::take(&mut *m))
        .unwrap_or_default();
    if message.is_empty() {
        let mut text: *const c_char = std::ptr::null();
        // SAFETY: PetscErrorMessage only writes the static text pointer.
        unsafe { sys::PetscErrorMessage(code, &mut text, std::ptr::null_mut()) };
        if !text.is_null() {
            // SAFETY: static NUL-terminated string owned by PETSc.
            message = unsafe { CStr::from_ptr(text) }
                .to_string_lossy()
                .into_owned();
        }
    }
    Err(PetscError {
        code,
        call,
        message,
    })
}

/// Calls a PETSc function and converts its error code, naming the call. Every argument is an
/// FFI value handed straight to PETSc: the whole call is the unsafe operation.
#[macro_export]
#[allow(clippy::macro_metavars_in_unsafe)]
macro_rules! petsc_call {
    ($f:ident ( $($arg:expr),* $(,)? )) => {
        $crate::petsc::check(unsafe { petsc_sys::$f($($arg),*) }, stringify!($f))
    };
}

/// PETSc is initialised for the life of this value; dropping it calls `PetscFinalize`.
/// Create it after MPI is initialised (rsmpi's universe) and drop it before the universe.
pub struct Petsc {
    _argv: Vec<CString>,
}

impl Petsc {
    /// Initialises PETSc on `comm` with the given command-line options (e.g. `-log_view`,
    /// `-petscpartitioner_type simple`). `-no_signal_handler` is always added: PETSc's handler
    /// would replace Rust's and hide stack overflows.
    pub fn init(comm: mpi_sys::MPI_Comm, options: &[String]) -> Result<Petsc, PetscError> {
        let mut argv: Vec<CString> = vec![CString::new("tdyn").unwrap()];
        for o in options {
            argv.push(CString::new(o.as_str()).unwrap_or_else(|_| CString::new("").unwrap()));
        }
        argv.push(CString::new("-no_signal_handler").unwrap());
        let mut ptrs: Vec<*mut c_char> = argv.iter().map(|a| a.as_ptr() as *mut c_char).collect();
        ptrs.push(std::ptr::null_mut());
        let mut argc = argv.len() as c_int;
        let mut argvp = ptrs.as_mut_ptr();
        // SAFETY: PETSC_COMM_WORLD must be set before PetscInitialize (PETSc manual); argv
        // outlives PETSc (kept in the returned value).
        unsafe {
            sys::PETSC_COMM_WORLD = comm;
        }
        check(
            unsafe {
                sys::PetscInitialize(&mut argc, &mut argvp, std::ptr::null(), std::ptr::null())
            },
            "PetscInitialize",
        )?;
        check(
            unsafe { sys::PetscPushErrorHandler(Some(record_error), std::ptr::null_mut()) },
            "PetscPushErrorHandler",
        )?;
        std::mem::forget(ptrs);
        Ok(Petsc { _argv: argv })
    }

    /// True when the option (e.g. `-petscpartitioner_type`) was given.
    pub fn has_option(name: &str) -> bool {
        let c = CString::new(name).unwrap();
        let mut set: sys::PetscBool = 0;
        let code = unsafe {
            sys::PetscOptionsHasName(std::ptr::null_mut(), std::ptr::null(), c.as_ptr(), &mut set)
        };
        code == 0 && set != 0
    }

    /// The options in PETSc's database (the command line's and `PETSC_OPTIONS`') that nothing
    /// has read so far on this rank, as `(name, value)`, the name with its dash
    /// (`PetscOptionsLeftGet`).
    pub fn unused_options() -> Vec<(String, Option<String>)> {
        let mut n: sys::PetscInt = 0;
        let mut names: *mut *mut c_char = std::ptr::null_mut();
        let mut values: *mut *mut c_char = std::ptr::null_mut();
        // SAFETY: PETSc allocates the two arrays of n strings; they are given back below.
        let code = unsafe {
            sys::PetscOptionsLeftGet(std::ptr::null_mut(), &mut n, &mut names, &mut values)
        };
        if code != 0 {
            return Vec::new();
        }
        let text = |p: *mut c_char| {
            // SAFETY: NUL-terminated strings owned by PETSc, or null.
            (!p.is_null()).then(|| unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned())
        };
        let mut left = Vec::new();
        for i in 0..n.max(0) as usize {
            // SAFETY: both arrays hold n entries.
            let (name, value) = unsafe { (*names.add(i), *values.add(i)) };
            let Some(name) = text(name) else { continue };
            let name = if name.starts_with('-') {
                name
            } else {
                format!("-{name}")
            };
            left.push((name, text(value).filter(|v| !v.is_empty())));
        }
        // SAFETY: the arrays PetscOptionsLeftGet gave.
        unsafe {
            sys::PetscOptionsLeftRestore(std::ptr::null_mut(), &mut n, &mut names, &mut values)
        };
        left
    }

    /// True when the option `name` (with its dash) has been read on this rank
    /// (`PetscOptionsUsed`; an option not given reads as unused).
    pub fn option_used(name: &str) -> bool {
        let c = CString::new(name.trim_start_matches('-')).unwrap_or_default();
        let mut used: sys::PetscBool = 0;
        let code = unsafe { sys::PetscOptionsUsed(std::ptr::null_mut(), c.as_ptr(), &mut used) };
        code == 0 && used != 0
    }

    /// Memory PETSc and the process hold now (resident set size), bytes.
    pub fn memory_usage() -> f64 {
        let mut m: sys::PetscLogDouble = 0.0;
        unsafe { sys::PetscMemoryGetCurrentUsage(&mut m) };
        m
    }
}

impl Drop for Petsc {
    fn drop(&mut self) {
        // SAFETY: every PETSc object is destroyed by its owner's Drop before this runs.
        unsafe {
            sys::PetscFinalize();
        }
    }
}
