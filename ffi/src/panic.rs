//! The panic boundary around every export, and the panic handler of the `panic-never` build.
//!
//! Every export is written as a plain `#[unsafe(no_mangle)] pub extern "C" fn` (so cbindgen
//! sees it) whose body is `ffi_boundary! { ... }` (rustls-ffi style). With `std` the body runs
//! under `catch_unwind`: a panic becomes `KINCAL_STATUS_PANIC` (status exports) or the
//! export's documented default value, and never unwinds into C. Without `std` there is no
//! unwinding at all (`panic = "abort"`), and the `panic-never` handler turns any remaining
//! panic path into a link error.

/// Runs an export's body inside the panic boundary.
///
/// - `ffi_boundary!(err = err_ptr; { ... })`: the body evaluates to `FfiResult` (use `?`); the
///   detail goes to `*err_ptr` when it is not NULL and the status is returned.
/// - `ffi_boundary!(on_panic = value; { ... })`: the body evaluates to the return value;
///   `value` is returned if it panics.
macro_rules! ffi_boundary {
    (err = $err:expr; $body:block) => {{
        let err_out: *mut $crate::status::kincal_error = $err;
        let result: $crate::status::FfiResult = $crate::panic::guard(
            || {
                Err($crate::status::kincal_error::new(
                    $crate::status::kincal_status::Panic,
                ))
            },
            move || -> $crate::status::FfiResult { $body },
        );
        $crate::status::finish(err_out, result)
    }};
    (on_panic = $default:expr; $body:block) => {{ $crate::panic::guard(|| $default, move || $body) }};
}

/// Runs `body`; with `std`, a panic in it returns `on_panic()` instead of unwinding.
#[cfg(feature = "std")]
#[inline]
pub(crate) fn guard<T>(on_panic: impl FnOnce() -> T, body: impl FnOnce() -> T) -> T {
    // AssertUnwindSafe: after a panic the export returns an error status and documents that
    // the caller's buffers may hold partial results; no Rust state outlives the call.
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(body)).unwrap_or_else(|_| on_panic())
}

/// Runs `body` (no unwinding without `std`: a panic aborts, and the `panic-never` build proves
/// at link time that none can happen).
#[cfg(not(feature = "std"))]
#[inline(always)]
pub(crate) fn guard<T>(_on_panic: impl FnOnce() -> T, body: impl FnOnce() -> T) -> T {
    body()
}

#[cfg(all(not(feature = "std"), not(test)))]
unsafe extern "C" {
    /// Deliberately defined nowhere: if the optimised, `--gc-sections`-linked program still
    /// references the panic handler, this symbol is undefined and the link fails.
    fn kincal_panic_path_remains() -> !;
}

#[cfg(all(not(feature = "std"), not(test)))]
#[panic_handler]
fn panic(_info: &core::panic::PanicInfo<'_>) -> ! {
    // SAFETY: never resolved; reaching this line is made impossible by the link check.
    unsafe { kincal_panic_path_remains() }
}

/// Panics on purpose inside the panic boundary; returns `KINCAL_STATUS_PANIC` (and fills `err`)
/// in `std` builds. Exists only with the cargo feature `test-panic`, to prove from C that no
/// panic crosses the ABI; in the `panic-never` build it is the canary whose reference must
/// make the link fail.
///
/// # Safety
/// `err` must be NULL or point to a writable `kincal_error`.
#[cfg(feature = "test-panic")]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_test_panic(
    err: *mut crate::status::kincal_error,
) -> crate::status::kincal_status {
    ffi_boundary!(err = err; {
        let v: u32 = core::hint::black_box(7);
        if v == 7 {
            panic!("kincal_test_panic: deliberate panic");
        }
        Ok(())
    })
}
