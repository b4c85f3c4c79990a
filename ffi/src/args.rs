//! Argument checks at the boundary: NULL, alignment, length and finiteness are checked before
//! any reference or slice is formed (the hyper `hyper_error_print` bug this avoids: a slice
//! built from an unchecked pointer). The macros derive the argument name reported in
//! `kincal_error.argument` from the parameter's identifier, so it always matches the header.
//!
//! Inputs are copied into Rust values before any output buffer is touched, and outputs are
//! written at the end through [`Out`], so an output buffer may overlap an input.

use core::ffi::{CStr, c_char};

use crate::status::{FfiResult, kincal_error, kincal_status};

/// The static C string of an identifier or literal, checked at compile time.
macro_rules! cname {
    ($s:expr) => {
        const {
            match ::core::ffi::CStr::from_bytes_with_nul(concat!($s, "\0").as_bytes()) {
                Ok(c) => c,
                Err(_) => panic!("argument name contains a NUL byte"),
            }
        }
    };
}

/// `&T` from a required pointer argument.
macro_rules! arg_ref {
    ($p:ident) => {
        // SAFETY: the export's contract: `$p` is NULL or points to a valid value.
        unsafe { $crate::args::req($p, cname!(stringify!($p))) }?
    };
}

/// `Option<&T>` from an optional pointer argument (NULL = `None`).
macro_rules! arg_opt {
    ($p:ident) => {
        // SAFETY: the export's contract: `$p` is NULL or points to a valid value.
        unsafe { $crate::args::opt($p, cname!(stringify!($p))) }?
    };
}

/// `&[T]` of exactly `expected` elements from a required array argument and its length.
macro_rules! arg_slice {
    ($p:ident, $len:expr, $expected:expr) => {
        // SAFETY: the export's contract: `$p` is NULL or readable for `$len` elements.
        unsafe { $crate::args::slice($p, $len, $expected, cname!(stringify!($p))) }?
    };
}

/// Like `arg_slice!` for `double` arrays, also checking that every element is finite.
macro_rules! arg_f64s {
    ($p:ident, $len:expr, $expected:expr) => {{
        let s = arg_slice!($p, $len, $expected);
        $crate::args::finite(s, cname!(stringify!($p)))?;
        s
    }};
}

/// An output buffer of exactly `expected` elements, written later with [`Out::write`].
macro_rules! arg_out {
    ($p:ident, $len:expr, $expected:expr) => {
        $crate::args::Out::new($p, $len, $expected, cname!(stringify!($p)))?
    };
}

/// A single-value output argument.
macro_rules! arg_out1 {
    ($p:ident) => {
        $crate::args::Out::new($p, 1, 1, cname!(stringify!($p)))?
    };
}

/// An optional output buffer (NULL = not wanted) of exactly `expected` elements.
macro_rules! arg_out_opt {
    ($p:ident, $len:expr, $expected:expr) => {
        if $p.is_null() {
            None
        } else {
            Some(arg_out!($p, $len, $expected))
        }
    };
}

/// A NUL-terminated UTF-8 string argument as `&str`.
macro_rules! arg_str {
    ($p:ident) => {
        // SAFETY: the export's contract: `$p` is NULL or a NUL-terminated string.
        unsafe { $crate::args::c_str($p, cname!(stringify!($p))) }?
    };
}

pub(crate) fn null(name: &'static CStr) -> kincal_error {
    kincal_error::new(kincal_status::NullPointer).arg(name)
}

fn check_ptr<T>(p: *const T, name: &'static CStr) -> FfiResult {
    if p.is_null() {
        Err(null(name))
    } else if !p.is_aligned() {
        Err(kincal_error::new(kincal_status::MisalignedPointer).arg(name))
    } else {
        Ok(())
    }
}

/// Reference from a required pointer.
///
/// # Safety
/// `p` is NULL or points to a valid `T` that stays unmodified for `'a`.
pub(crate) unsafe fn req<'a, T>(p: *const T, name: &'static CStr) -> FfiResult<&'a T> {
    check_ptr(p, name)?;
    // SAFETY: non-NULL and aligned (checked); valid by the caller's contract.
    Ok(unsafe { &*p })
}

/// Reference from an optional pointer.
///
/// # Safety
/// As [`req`].
pub(crate) unsafe fn opt<'a, T>(p: *const T, name: &'static CStr) -> FfiResult<Option<&'a T>> {
    if p.is_null() {
        return Ok(None);
    }
    // SAFETY: forwarded contract.
    unsafe { req(p, name) }.map(Some)
}

/// Slice of exactly `expected` elements.
///
/// # Safety
/// `p` is NULL or readable for `len` elements, unmodified for `'a`.
pub(crate) unsafe fn slice<'a, T>(
    p: *const T,
    len: usize,
    expected: usize,
    name: &'static CStr,
) -> FfiResult<&'a [T]> {
    check_ptr(p, name)?;
    if len != expected {
        return Err(bad_length(name, expected, len));
    }
    // `expected` may derive from a caller's count (poses): keep within `from_raw_parts`' limit.
    if len > isize::MAX as usize / core::mem::size_of::<T>().max(1) {
        return Err(bad_length(
            name,
            isize::MAX as usize / core::mem::size_of::<T>().max(1),
            len,
        ));
    }
    // SAFETY: non-NULL, aligned, `len` elements readable (contract); `len * size_of::<T>()`
    // fits `isize` (checked above).
    Ok(unsafe { core::slice::from_raw_parts(p, len) })
}

pub(crate) fn bad_length(name: &'static CStr, expected: usize, found: usize) -> kincal_error {
    kincal_error::new(kincal_status::BadLength)
        .arg(name)
        .counts(expected, found)
}

/// Every element finite, else `NON_FINITE` naming the argument and the element.
pub(crate) fn finite(v: &[f64], name: &'static CStr) -> FfiResult {
    match v.iter().position(|x| !x.is_finite()) {
        None => Ok(()),
        Some(i) => Err(kincal_error::new(kincal_status::NonFinite)
            .arg(name)
            .at(i)
            .value(v.get(i).copied().unwrap_or(f64::NAN))),
    }
}

/// Every element of a result finite, else `NON_FINITE_RESULT` naming the output and the
/// element: finite inputs can still overflow (lengths near 1e308), and an OK call must never
/// hand a NaN or infinity to a controller.
pub(crate) fn finite_result(v: &[f64], name: &'static CStr) -> FfiResult {
    match v.iter().position(|x| !x.is_finite()) {
        None => Ok(()),
        Some(i) => Err(kincal_error::new(kincal_status::NonFiniteResult)
            .arg(name)
            .at(i)
            .value(v.get(i).copied().unwrap_or(f64::NAN))),
    }
}

/// A NUL-terminated UTF-8 string. A string that is not UTF-8 cannot be a label or name, so it
/// reports `UNKNOWN_LABEL`.
///
/// # Safety
/// `p` is NULL or points to a NUL-terminated string unmodified for `'a`.
pub(crate) unsafe fn c_str<'a>(p: *const c_char, name: &'static CStr) -> FfiResult<&'a str> {
    if p.is_null() {
        return Err(null(name));
    }
    // SAFETY: non-NULL and NUL-terminated by contract.
    let s = unsafe { CStr::from_ptr(p) };
    s.to_str()
        .map_err(|_| kincal_error::new(kincal_status::UnknownLabel).arg(name))
}

/// A checked output buffer: validated when the call starts, written when it succeeds.
#[derive(Debug)]
pub(crate) struct Out<T> {
    ptr: *mut T,
    len: usize,
    name: &'static CStr,
}

impl<T: Copy> Out<T> {
    /// Checks NULL, alignment and `len == expected`; forms no reference.
    pub(crate) fn new(
        ptr: *mut T,
        len: usize,
        expected: usize,
        name: &'static CStr,
    ) -> FfiResult<Self> {
        check_ptr(ptr.cast_const(), name)?;
        if len != expected {
            return Err(bad_length(name, expected, len));
        }
        if len > isize::MAX as usize / core::mem::size_of::<T>().max(1) {
            return Err(bad_length(
                name,
                isize::MAX as usize / core::mem::size_of::<T>().max(1),
                len,
            ));
        }
        Ok(Out { ptr, len, name })
    }

    /// Copies `src` (exactly `len` elements by construction) into the buffer.
    ///
    /// # Safety
    /// The buffer given to [`Out::new`] is writable for `len` elements, and no reference into
    /// it is alive.
    pub(crate) unsafe fn write(&self, src: &[T]) {
        let n = self.len.min(src.len());
        // SAFETY: `ptr` is non-NULL, aligned and writable for `len >= n` elements (contract);
        // `src` is a Rust value, so it does not overlap a live reference into the buffer
        // (inputs were copied before outputs are written).
        unsafe { core::ptr::copy(src.as_ptr(), self.ptr, n) };
    }

    /// Writes one value into a single-value output.
    ///
    /// # Safety
    /// As [`Out::write`].
    pub(crate) unsafe fn put(&self, value: T) {
        // SAFETY: forwarded contract.
        unsafe { self.write(core::slice::from_ref(&value)) };
    }

    /// The buffer as a mutable slice, for core functions that write in place.
    ///
    /// # Safety
    /// As [`Out::write`], and no other reference into the buffer exists while the slice lives.
    pub(crate) unsafe fn as_mut_slice<'a>(&mut self) -> &'a mut [T] {
        // SAFETY: forwarded contract; length checked in `new`.
        unsafe { core::slice::from_raw_parts_mut(self.ptr, self.len) }
    }
}

impl Out<f64> {
    /// `NON_FINITE_RESULT` naming this output if `src` holds a NaN or infinity: call it for
    /// every output before writing any (outputs are written on success only).
    pub(crate) fn check_finite(&self, src: &[f64]) -> FfiResult {
        finite_result(src, self.name)
    }

    /// [`Out::check_finite`], then [`Out::write`]: the one output of a call.
    ///
    /// # Safety
    /// As [`Out::write`].
    pub(crate) unsafe fn write_finite(&self, src: &[f64]) -> FfiResult {
        self.check_finite(src)?;
        // SAFETY: forwarded contract.
        unsafe { self.write(src) };
        Ok(())
    }
}
