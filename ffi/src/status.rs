//! Status codes, the positional error detail, and their text.
//!
//! Every fallible export returns a [`kincal_status`] and fills an optional caller-owned
//! [`kincal_error`]. Both are plain data: nothing is allocated, the strings are static.

use core::ffi::{CStr, c_char};
use core::fmt;

use kincal::{Error, Quantity};

/// Result of every fallible export. `KINCAL_STATUS_OK` (0) is success.
///
/// The numbers are part of the ABI and never reused: argument errors are 100–199, numerical
/// failures 200–299, internal errors 900–999 (`KINCAL_STATUS_PANIC` last). A retired code stays
/// listed here as a comment. The type is 32 bits wide whatever the C compiler's enum size
/// (`-fshort-enums` is the default of bare-metal ARM GCC), so in C it is `uint32_t`.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_status {
    /// Success.
    Ok = 0,
    /// A required pointer argument was NULL (`kincal_error.argument` names it).
    NullPointer = 100,
    /// A buffer length or count disagreed with what the call needs (`expected`, `found`);
    /// this includes a joint vector whose length is not the robot's joint count.
    BadLength = 101,
    /// A number that must be finite was NaN or infinite (`argument`, `index`, `quantity`).
    NonFinite = 102,
    /// A joint reading lies outside the joint limits (`joint`, `value`, `lower`, `upper`).
    OutOfLimits = 103,
    /// `kincal_robot.n_joints` is not in 1..=KINCAL_MAX_JOINTS (`found`).
    BadJointCount = 104,
    /// Joint limits with lower > upper or a non-finite bound (`joint`).
    InvalidLimits = 105,
    /// A model parameter the model cannot use, e.g. a negative mass or a zero quaternion
    /// (`index`, `value`).
    InvalidParameter = 106,
    /// An input the model needs is missing: approach directions for a model with backlash,
    /// temperature for a model with thermal expansion (`quantity`).
    MissingInput = 107,
    /// A parameter label or effect name is not known for this robot.
    UnknownLabel = 108,
    /// A parameter, link or pose index is out of range (`index`, `expected` = the count).
    IndexOutOfRange = 109,
    /// A 4×4 matrix is not a rigid transform: bottom row not (0, 0, 0, 1), or the rotation
    /// not orthonormal with determinant +1 within 1e-6 (`argument`).
    InvalidTransform = 110,
    /// An enumeration, flag or option value outside its domain (`argument`, `index`, `value`).
    InvalidArgument = 111,
    /// A fixed capacity is too small (`found` = needed, `expected` = capacity).
    CapacityExceeded = 112,
    /// Not enough data for the operation (`found`, `expected` = at least).
    TooFewData = 113,
    /// A pose could not be used, e.g. a degenerate measurement (`pose`).
    BadPose = 114,
    /// A pointer argument is not aligned for its type (`argument`).
    MisalignedPointer = 115,
    /// A joint axis was given with a zero (or non-normalisable) direction (`joint`).
    DegenerateAxis = 116,
    /// A `kincal_prepared` handle was not filled by `kincal_prepare` of this library build, or
    /// has been overwritten or corrupted since (`argument`): prepare it again.
    BadHandle = 117,
    /// A group of constraint rows (target or plane) cannot be used: not contiguous, too
    /// few rows, or a bad known normal (`index` = group).
    BadGroup = 118,
    /// A plane's contact points are collinear: its normal is undetermined (`index` = group).
    DegenerateGroup = 119,
    /// A known distance names a missing or non-target group, or has a bad length or
    /// weight (`index` = distance).
    BadDistance = 120,
    /// A file could not be read or its reader refused it (std builds: `kincal_model_read`);
    /// the reason and its line and column are in the call's `kincal_read_error`.
    BadFile = 121,
    /// Inverse kinematics found no configuration within the limits that reaches the pose
    /// (`residual_pos_m`, `residual_rot_rad`: the best residual found).
    Unreachable = 200,
    /// An iterative method stopped at its iteration limit (`iterations`).
    NotConverged = 201,
    /// The data do not determine enough parameters (`found` = rank, `expected` = required).
    RankDeficient = 202,
    /// A parameter fitted under bounds ended outside them (`index`, `value`).
    BoundViolated = 203,
    /// Every input was finite but a result is not (NaN or infinite): the inputs are too large
    /// for double precision, e.g. link lengths near 1e308 (`argument` = the output, `index` =
    /// its first bad element, `value`). Nothing is written: an OK call never leaves a
    /// non-finite number in an output.
    NonFiniteResult = 204,
    /// The core reported an error this version of the C ABI does not know: a bug, please
    /// report it.
    Internal = 900,
    /// A panic was caught at the boundary: a bug, please report it. The robot and output
    /// buffers passed to the call may hold partial results.
    Panic = 999,
}

impl kincal_status {
    /// Every status, in numeric order (used by the tests and `kincal_status_str`).
    pub(crate) const ALL: [kincal_status; 30] = [
        kincal_status::Ok,
        kincal_status::NullPointer,
        kincal_status::BadLength,
        kincal_status::NonFinite,
        kincal_status::OutOfLimits,
        kincal_status::BadJointCount,
        kincal_status::InvalidLimits,
        kincal_status::InvalidParameter,
        kincal_status::MissingInput,
        kincal_status::UnknownLabel,
        kincal_status::IndexOutOfRange,
        kincal_status::InvalidTransform,
        kincal_status::InvalidArgument,
        kincal_status::CapacityExceeded,
        kincal_status::TooFewData,
        kincal_status::BadPose,
        kincal_status::MisalignedPointer,
        kincal_status::DegenerateAxis,
        kincal_status::BadHandle,
        kincal_status::BadGroup,
        kincal_status::DegenerateGroup,
        kincal_status::BadDistance,
        kincal_status::BadFile,
        kincal_status::Unreachable,
        kincal_status::NotConverged,
        kincal_status::RankDeficient,
        kincal_status::BoundViolated,
        kincal_status::NonFiniteResult,
        kincal_status::Internal,
        kincal_status::Panic,
    ];

    /// The status with number `code`, if any.
    pub(crate) fn from_u32(code: u32) -> Option<Self> {
        Self::ALL.iter().copied().find(|s| *s as u32 == code)
    }

    /// Static text: the C name followed by a short explanation.
    pub(crate) const fn text(self) -> &'static CStr {
        match self {
            kincal_status::Ok => c"KINCAL_STATUS_OK: success",
            kincal_status::NullPointer => c"KINCAL_STATUS_NULL_POINTER: a required pointer was NULL",
            kincal_status::BadLength => {
                c"KINCAL_STATUS_BAD_LENGTH: a buffer length or joint count does not match"
            }
            kincal_status::NonFinite => c"KINCAL_STATUS_NON_FINITE: a number was NaN or infinite",
            kincal_status::OutOfLimits => {
                c"KINCAL_STATUS_OUT_OF_LIMITS: a joint reading lies outside its limits"
            }
            kincal_status::BadJointCount => {
                c"KINCAL_STATUS_BAD_JOINT_COUNT: n_joints must be 1..KINCAL_MAX_JOINTS"
            }
            kincal_status::InvalidLimits => {
                c"KINCAL_STATUS_INVALID_LIMITS: joint limits with lower > upper or non-finite"
            }
            kincal_status::InvalidParameter => {
                c"KINCAL_STATUS_INVALID_PARAMETER: a parameter value the model cannot use"
            }
            kincal_status::MissingInput => {
                c"KINCAL_STATUS_MISSING_INPUT: approach directions or temperature missing"
            }
            kincal_status::UnknownLabel => {
                c"KINCAL_STATUS_UNKNOWN_LABEL: unknown parameter label or effect name"
            }
            kincal_status::IndexOutOfRange => {
                c"KINCAL_STATUS_INDEX_OUT_OF_RANGE: an index is out of range"
            }
            kincal_status::InvalidTransform => {
                c"KINCAL_STATUS_INVALID_TRANSFORM: a 4x4 matrix is not a rigid transform"
            }
            kincal_status::InvalidArgument => {
                c"KINCAL_STATUS_INVALID_ARGUMENT: an enumeration, flag or option is out of its domain"
            }
            kincal_status::CapacityExceeded => {
                c"KINCAL_STATUS_CAPACITY_EXCEEDED: a fixed capacity is too small"
            }
            kincal_status::TooFewData => c"KINCAL_STATUS_TOO_FEW_DATA: not enough data",
            kincal_status::BadPose => c"KINCAL_STATUS_BAD_POSE: a pose could not be used",
            kincal_status::MisalignedPointer => {
                c"KINCAL_STATUS_MISALIGNED_POINTER: a pointer is not aligned for its type"
            }
            kincal_status::DegenerateAxis => {
                c"KINCAL_STATUS_DEGENERATE_AXIS: a joint axis has a zero direction"
            }
            kincal_status::BadHandle => {
                c"KINCAL_STATUS_BAD_HANDLE: a kincal_prepared was not filled by kincal_prepare or is corrupted"
            }
            kincal_status::BadGroup => {
                c"KINCAL_STATUS_BAD_GROUP: a target or plane group cannot be used"
            }
            kincal_status::DegenerateGroup => {
                c"KINCAL_STATUS_DEGENERATE_GROUP: a plane's contact points are collinear"
            }
            kincal_status::BadDistance => {
                c"KINCAL_STATUS_BAD_DISTANCE: a known distance is invalid"
            }
            kincal_status::BadFile => {
                c"KINCAL_STATUS_BAD_FILE: a file could not be read or was refused (see kincal_read_error)"
            }
            kincal_status::Unreachable => {
                c"KINCAL_STATUS_UNREACHABLE: no configuration within the limits reaches the pose"
            }
            kincal_status::NotConverged => {
                c"KINCAL_STATUS_NOT_CONVERGED: iteration limit reached before convergence"
            }
            kincal_status::RankDeficient => {
                c"KINCAL_STATUS_RANK_DEFICIENT: the data do not determine enough parameters"
            }
            kincal_status::BoundViolated => {
                c"KINCAL_STATUS_BOUND_VIOLATED: a bounded parameter ended outside its bounds"
            }
            kincal_status::NonFiniteResult => {
                c"KINCAL_STATUS_NON_FINITE_RESULT: a result overflowed to NaN or infinity (inputs too large)"
            }
            kincal_status::Internal => {
                c"KINCAL_STATUS_INTERNAL: unexpected core error (a bug, please report it)"
            }
            kincal_status::Panic => {
                c"KINCAL_STATUS_PANIC: a panic was caught at the boundary (a bug, please report it)"
            }
        }
    }
}

/// Which input held a bad number or is missing (`kincal_error.quantity`).
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum kincal_quantity {
    /// Not applicable or not known.
    None = 0,
    /// A joint reading `q`.
    JointReading = 1,
    /// A model parameter (link, base, tool or effect).
    Parameter = 2,
    /// A measured or target position.
    Position = 3,
    /// A measured or target orientation.
    Orientation = 4,
    /// A weight, tolerance, bound or other option.
    Setting = 5,
    /// Approach directions (backlash).
    ApproachDirection = 6,
    /// Arm temperature (thermal effect).
    Temperature = 7,
}

impl From<Quantity> for kincal_quantity {
    fn from(q: Quantity) -> Self {
        match q {
            Quantity::JointReading => kincal_quantity::JointReading,
            Quantity::Parameter => kincal_quantity::Parameter,
            Quantity::Position => kincal_quantity::Position,
            Quantity::Orientation => kincal_quantity::Orientation,
            Quantity::Setting => kincal_quantity::Setting,
            Quantity::ApproachDirection => kincal_quantity::ApproachDirection,
            Quantity::Temperature => kincal_quantity::Temperature,
            _ => kincal_quantity::None,
        }
    }
}

/// "No index" marker of the `size_t` fields of [`kincal_error`]: `SIZE_MAX` (the header
/// defines it in `after_includes` of cbindgen.toml, as cbindgen cannot write `usize::MAX`).
pub(crate) const KINCAL_NO_INDEX: usize = usize::MAX;

/// Where and why a call failed: a caller-owned plain struct (pass NULL when the detail is not
/// wanted; it need not be initialised). Every export that takes one overwrites all of it before
/// returning: `status` = the returned code, the fields that code documents set, the others
/// cleared (indices `KINCAL_NO_INDEX`, numbers NaN, `argument` NULL, `iterations` 0).
/// Indices are zero-based.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(non_camel_case_types)]
pub struct kincal_error {
    /// The status the call returned (a `kincal_status` value).
    pub status: u32,
    /// Which input held the bad number or is missing (a `kincal_quantity` value; 0 = none).
    pub quantity: u32,
    /// Name of the offending argument or struct field as in the header (e.g. `"q"`,
    /// `"robot->params"`): a static NUL-terminated string, or NULL when not known. Never free it.
    pub argument: *const c_char,
    /// Element index within that argument, or the parameter index (`KINCAL_NO_INDEX` if none).
    pub index: usize,
    /// Joint (zero-based; `KINCAL_NO_INDEX` if none).
    pub joint: usize,
    /// Pose (zero-based; `KINCAL_NO_INDEX` if none).
    pub pose: usize,
    /// Length, count, rank or capacity that was needed (`KINCAL_NO_INDEX` if none).
    pub expected: usize,
    /// Length, count or rank that was given or found (`KINCAL_NO_INDEX` if none).
    pub found: usize,
    /// The offending value (NaN if none).
    pub value: f64,
    /// Lower limit [rad] for `KINCAL_STATUS_OUT_OF_LIMITS` (NaN otherwise).
    pub lower: f64,
    /// Upper limit [rad] for `KINCAL_STATUS_OUT_OF_LIMITS` (NaN otherwise).
    pub upper: f64,
    /// Best position residual [m] for `KINCAL_STATUS_UNREACHABLE` (NaN otherwise).
    pub residual_pos_m: f64,
    /// Best orientation residual [rad] for `KINCAL_STATUS_UNREACHABLE` (NaN otherwise).
    pub residual_rot_rad: f64,
    /// Iterations performed, for `KINCAL_STATUS_NOT_CONVERGED` (0 otherwise).
    pub iterations: u32,
}

/// Result of an export's body; the error carries the detail written to `kincal_error`.
pub(crate) type FfiResult<T = ()> = Result<T, kincal_error>;

impl kincal_error {
    /// No error, no detail.
    pub(crate) const CLEAR: kincal_error = kincal_error {
        status: kincal_status::Ok as u32,
        quantity: kincal_quantity::None as u32,
        argument: core::ptr::null(),
        index: KINCAL_NO_INDEX,
        joint: KINCAL_NO_INDEX,
        pose: KINCAL_NO_INDEX,
        expected: KINCAL_NO_INDEX,
        found: KINCAL_NO_INDEX,
        value: f64::NAN,
        lower: f64::NAN,
        upper: f64::NAN,
        residual_pos_m: f64::NAN,
        residual_rot_rad: f64::NAN,
        iterations: 0,
    };

    /// An error with `status` and no detail.
    pub(crate) const fn new(status: kincal_status) -> Self {
        let mut e = Self::CLEAR;
        e.status = status as u32;
        e
    }

    /// This error naming the argument `name`.
    pub(crate) const fn arg(mut self, name: &'static CStr) -> Self {
        self.argument = name.as_ptr();
        self
    }

    /// This error with an element index.
    pub(crate) const fn at(mut self, index: usize) -> Self {
        self.index = index;
        self
    }

    /// This error with expected and found counts.
    pub(crate) const fn counts(mut self, expected: usize, found: usize) -> Self {
        self.expected = expected;
        self.found = found;
        self
    }

    /// This error with the offending value.
    pub(crate) const fn value(mut self, value: f64) -> Self {
        self.value = value;
        self
    }

    /// The status as the enum (`Internal` for a number this version does not know).
    pub(crate) fn kind(&self) -> kincal_status {
        kincal_status::from_u32(self.status).unwrap_or(kincal_status::Internal)
    }
}

impl From<Error> for kincal_error {
    fn from(e: Error) -> Self {
        use kincal_status as S;
        match e {
            Error::NonFinite { what, index } => {
                let mut k = kincal_error::new(S::NonFinite).at(index);
                k.quantity = kincal_quantity::from(what) as u32;
                k
            }
            Error::DimensionMismatch { expected, found } => {
                kincal_error::new(S::BadLength).counts(expected, found)
            }
            Error::OutOfLimits {
                joint,
                value,
                lower,
                upper,
            } => {
                let mut k = kincal_error::new(S::OutOfLimits).value(value);
                k.joint = joint.0;
                k.lower = lower;
                k.upper = upper;
                k
            }
            Error::MissingInput { what } => {
                let mut k = kincal_error::new(S::MissingInput);
                k.quantity = kincal_quantity::from(what) as u32;
                k
            }
            Error::InvalidLimits { joint } => {
                let mut k = kincal_error::new(S::InvalidLimits);
                k.joint = joint.0;
                k
            }
            Error::InvalidParameter { index, value } => kincal_error::new(S::InvalidParameter)
                .at(index)
                .value(value),
            Error::Unreachable {
                residual_pos_m,
                residual_rot_rad,
            } => {
                let mut k = kincal_error::new(S::Unreachable);
                k.residual_pos_m = residual_pos_m;
                k.residual_rot_rad = residual_rot_rad;
                k
            }
            Error::NotConverged { iterations } => {
                let mut k = kincal_error::new(S::NotConverged);
                k.iterations = iterations;
                k
            }
            Error::RankDeficient { rank, required } => {
                kincal_error::new(S::RankDeficient).counts(required, rank)
            }
            Error::CapacityExceeded { needed, capacity } => {
                kincal_error::new(S::CapacityExceeded).counts(capacity, needed)
            }
            Error::TooFewData { found, needed } => {
                kincal_error::new(S::TooFewData).counts(needed, found)
            }
            Error::BadPose { pose } => {
                let mut k = kincal_error::new(S::BadPose);
                k.pose = pose.0;
                k
            }
            Error::BoundViolated { param, value } => {
                kincal_error::new(S::BoundViolated).at(param.0).value(value)
            }
            Error::InvalidOption { option, value } => kincal_error::new(S::InvalidArgument)
                .arg(option_name(option))
                .value(value),
            Error::DegenerateAxis { joint } => {
                let mut k = kincal_error::new(S::DegenerateAxis);
                k.joint = joint.0;
                k
            }
            Error::BadGroup { group } => kincal_error::new(S::BadGroup).at(group),
            Error::DegenerateGroup { group } => kincal_error::new(S::DegenerateGroup).at(group),
            Error::BadDistance { distance } => kincal_error::new(S::BadDistance).at(distance),
            // A variant added to the core after this mapping: the test
            // `every_core_error_variant_has_a_status` names it.
            _ => kincal_error::new(S::Internal),
        }
    }
}

/// The header's name of a core option (`kincal_error.argument`): the options structs are
/// passed as `opts`, so a field is `opts->field`.
fn option_name(option: &str) -> &'static CStr {
    match option {
        "max_iterations" => c"opts->max_iterations",
        "extra_seeds" => c"opts->extra_seeds",
        "tol_pos_m" => c"opts->tol_pos_m",
        "tol_rot_rad" => c"opts->tol_rot_rad",
        "first_solution" => c"opts->first_solution",
        _ => c"opts",
    }
}

/// Writes `err` (if not NULL) and returns its status; the epilogue of every status export.
pub(crate) fn finish(err_out: *mut kincal_error, result: FfiResult) -> kincal_status {
    let detail = match result {
        Ok(()) => kincal_error::CLEAR,
        Err(e) => e,
    };
    if !err_out.is_null() && err_out.is_aligned() {
        // SAFETY: the caller passes either NULL or a writable kincal_error (documented on
        // every export); NULL and misalignment are checked above.
        unsafe { err_out.write(detail) };
    }
    detail.kind()
}

/// Static text of a status code: `"KINCAL_STATUS_<NAME>: <explanation>"`, or
/// `"unknown kincal status code"` for a number that is not a status.
///
/// Takes a `uint32_t` rather than the enum because C may pass any integer. The returned string
/// is static and NUL-terminated: never free or modify it. Never returns NULL.
#[unsafe(no_mangle)]
pub extern "C" fn kincal_status_str(status: u32) -> *const c_char {
    ffi_boundary!(on_panic = c"KINCAL_STATUS_PANIC".as_ptr(); {
        match kincal_status::from_u32(status) {
            Some(s) => s.text().as_ptr(),
            None => c"unknown kincal status code".as_ptr(),
        }
    })
}

/// Version of the library (`"MAJOR.MINOR.PATCH"`, from the crate version): a static
/// NUL-terminated string; never free it. Compare it with the version your build expects.
#[unsafe(no_mangle)]
pub extern "C" fn kincal_version() -> *const c_char {
    const VERSION: &CStr =
        match CStr::from_bytes_with_nul(concat!(env!("CARGO_PKG_VERSION"), "\0").as_bytes()) {
            Ok(v) => v,
            Err(_) => panic!("the crate version contains a NUL byte"),
        };
    ffi_boundary!(on_panic = VERSION.as_ptr(); { VERSION.as_ptr() })
}

/// A byte-buffer writer that truncates silently and counts the full length (snprintf style).
struct Truncating<'a> {
    buf: &'a mut [u8],
    written: usize,
    total: usize,
}

impl fmt::Write for Truncating<'_> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        for &b in s.as_bytes() {
            // Keep one byte for the NUL.
            if self.written + 1 < self.buf.len() {
                if let Some(slot) = self.buf.get_mut(self.written) {
                    *slot = b;
                }
                self.written += 1;
            }
            self.total += 1;
        }
        Ok(())
    }
}

fn describe(e: &kincal_error, w: &mut impl fmt::Write) -> fmt::Result {
    let name = match kincal_status::from_u32(e.status) {
        Some(s) => s.text(),
        None => c"unknown kincal status code",
    };
    w.write_str(name.to_str().unwrap_or("?"))?;
    if !e.argument.is_null() {
        // SAFETY: `argument` is only ever set from a `&'static CStr`.
        let arg = unsafe { CStr::from_ptr(e.argument) };
        write!(w, "; argument '{}'", arg.to_str().unwrap_or("?"))?;
    }
    let quantity = match e.quantity {
        1 => "joint reading",
        2 => "parameter",
        3 => "position",
        4 => "orientation",
        5 => "setting",
        6 => "approach direction",
        7 => "temperature",
        _ => "",
    };
    if !quantity.is_empty() {
        write!(w, "; quantity: {quantity}")?;
    }
    for (label, v) in [("index", e.index), ("joint", e.joint), ("pose", e.pose)] {
        if v != KINCAL_NO_INDEX {
            write!(w, "; {label} {v}")?;
        }
    }
    if e.expected != KINCAL_NO_INDEX {
        write!(w, "; expected {}", e.expected)?;
    }
    if e.found != KINCAL_NO_INDEX {
        write!(w, "; found {}", e.found)?;
    }
    // Floating-point formatting keeps panic paths in core::fmt: the firmware (no_std) build
    // leaves the numbers out of the text (they are in the struct).
    #[cfg(feature = "std")]
    {
        if !e.value.is_nan() {
            write!(w, "; value {:?}", e.value)?;
        }
        if !e.lower.is_nan() || !e.upper.is_nan() {
            write!(w, "; limits [{:?}, {:?}]", e.lower, e.upper)?;
        }
        if !e.residual_pos_m.is_nan() || !e.residual_rot_rad.is_nan() {
            write!(
                w,
                "; best residual {:?} m, {:?} rad",
                e.residual_pos_m, e.residual_rot_rad
            )?;
        }
    }
    if e.iterations != 0 {
        write!(w, "; iterations {}", e.iterations)?;
    }
    Ok(())
}

/// Formats `error` as one line of text into the caller's buffer, like `snprintf`: writes at most
/// `buf_len` bytes including the terminating NUL and returns the length of the whole message
/// (excluding the NUL), so a return value `>= buf_len` means the text was truncated. 512 bytes
/// always suffice. The no_std (firmware) build leaves the floating-point fields out of the text.
///
/// `error` NULL: returns 0 and writes nothing. `buf` may be NULL only when `buf_len` is 0 (to
/// ask for the length). Nothing is allocated.
///
/// # Safety
/// `error` must be NULL or point to a `kincal_error` filled by this library (or reset by the
/// caller with `argument` NULL); `buf` must be writable for `buf_len` bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn kincal_error_describe(
    error: *const kincal_error,
    buf: *mut c_char,
    buf_len: usize,
) -> usize {
    ffi_boundary!(on_panic = 0; {
        if error.is_null() || !error.is_aligned() || (buf.is_null() && buf_len != 0) {
            return 0;
        }
        // SAFETY: checked non-NULL and aligned above; the caller guarantees validity.
        let e = unsafe { error.read() };
        let mut empty = [0u8; 0];
        // Messages are shorter than this, so a longer buffer is never written beyond it (and
        // the slice stays far below `from_raw_parts_mut`'s size limit).
        const MAX_TEXT: usize = 4096;
        let out: &mut [u8] = if buf_len == 0 {
            &mut empty
        } else {
            // SAFETY: `buf` is non-NULL (checked) and writable for `buf_len >= len` bytes
            // (contract).
            unsafe { core::slice::from_raw_parts_mut(buf.cast::<u8>(), buf_len.min(MAX_TEXT)) }
        };
        let mut w = Truncating { buf: out, written: 0, total: 0 };
        let _ = describe(&e, &mut w);
        let (written, total) = (w.written, w.total);
        if let Some(nul) = w.buf.get_mut(written) {
            *nul = 0;
        }
        total
    })
}
