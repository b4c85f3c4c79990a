//! The one floating-point shim: `core` has no `f64::sin`, so every transcendental call in the
//! crate goes through here (backed by `libm`, deterministic across targets).

#[inline(always)]
pub(crate) fn sin(x: f64) -> f64 {
    libm::sin(x)
}
#[inline(always)]
pub(crate) fn cos(x: f64) -> f64 {
    libm::cos(x)
}
/// `(sin x, cos x)`, bit-identical to `libm::sincos` (FreeBSD's algorithm): the same
/// reduction by π/2 and the same kernel polynomials, inlined, with the quadrant chosen by bit
/// masks instead of branches (random joint angles make libm's quadrant branches mispredict)
/// and the rare extra reduction rounds out of line. Measured on the loaded 2-core build
/// machine (CPU time, random angles over ±2π): a plain loop 13–16 ns against libm's 16–19 ns
/// per call, but criterion's `sincos6_*` bench 88 ns against 66 ns per six: one at a time it
/// is no gain; FK takes its angles together through [`sin_cos_lanes`], which is. Arguments
/// beyond `2^20·π/2` and non-finite ones go to libm.
/// `sin_cos_is_bit_identical_to_libm` (unit test) checks it on over 3·10^6 arguments; the
/// `sincos6_*` benches compare the two.
#[inline(always)]
pub fn sin_cos(x: f64) -> (f64, f64) {
    let ix = ((x.to_bits() >> 32) as u32) & 0x7fff_ffff;
    if ix >= 0x4139_21fb {
        return libm::sincos(x);
    }
    let (n, y0, y1) = reduce_pio2(x, ix);
    let direct = ix <= 0x3fe9_21fb;
    let (s, c) = sincos_kernels(y0, y1, direct);
    // |x| < 2^-27·√2: libm returns x itself (keeps the sign of −0).
    let s = if ix < 0x3e46_a09e { x } else { s };
    // n mod 4: 0 → (s, c), 1 → (c, −s), 2 → (−s, −c), 3 → (−c, s).
    let swap = 0u64.wrapping_sub((n & 1) as u64);
    let (sb, cb) = (s.to_bits(), c.to_bits());
    let first = (sb & !swap) | (cb & swap);
    let second = (cb & !swap) | (sb & swap);
    let sin_sign = ((n & 2) as u64) << 62;
    let cos_sign = ((n.wrapping_add(1) & 2) as u64) << 62;
    (
        f64::from_bits(first ^ sin_sign),
        f64::from_bits(second ^ cos_sign),
    )
}

/// `(sin x_i, cos x_i)` of every lane, each within 1 ulp of libm's (most lanes bit for bit),
/// computed together and without a branch so the compiler evaluates two lanes per SSE2
/// register: FK takes all its joint angles at once. It is libm's algorithm for the "medium"
/// arguments with the branches taken out: n = round(x·2/π) for every lane (libm picks n by
/// magnitude thresholds below 9π/4, which agree except at the thresholds' edges), one round
/// of libm's reduction `x = n·π/2 + y0 + y1`, libm's kernels `k_sin(y0, y1, 1)` and
/// `k_cos(y0, y1)` (below π/4 libm calls `k_sin(x, 0, 0)`, which rounds differently), and the
/// quadrant by bit masks. Against libm's branchy path this halves the six sines and cosines
/// of an FK (criterion `sincos6_lanes` 37 → 21 ns against `sincos6_libm`'s 58 ns on the build
/// machine), which brings the prepared FK of the C ABI to about half Pinocchio's time.
///
/// If any lane needs what one round does not give (|x| ≥ 2^20·π/2, a non-finite x, or a
/// reduced argument that cancelled by more than 16 bits, `|y0| < |x|·2^-16`, where libm takes
/// further rounds: about one lane in 10^4 over ±2π), every lane takes [`sin_cos`], libm's
/// bits. Pure IEEE multiplies and adds, so the same bits on every target.
/// `sin_cos_lanes_is_within_one_ulp_of_libm` checks the bound on the arguments of
/// `sin_cos`'s own libm test and counts the lanes that differ.
#[inline(always)]
pub fn sin_cos_lanes<const N: usize>(x: &[f64; N]) -> [(f64, f64); N] {
    sin_cos_lanes_one_round(x).unwrap_or_else(|| x.map(sin_cos))
}

/// The select-only path of [`sin_cos_lanes`]; `None` when a lane needs [`sin_cos`]'s.
#[inline(always)]
fn sin_cos_lanes_one_round<const N: usize>(x: &[f64; N]) -> Option<[(f64, f64); N]> {
    const TO_INT: f64 = 1.5 / f64::EPSILON;
    const INV_PIO2: f64 = f64::from_bits(0x3FE4_5F30_6DC9_C883);
    const PIO2_1: f64 = f64::from_bits(0x3FF9_21FB_5440_0000);
    const PIO2_1T: f64 = f64::from_bits(0x3DD0_B461_1A62_6331);
    let mut out = [(0.0, 1.0); N];
    let mut one_round = true;
    for (o, &x) in out.iter_mut().zip(x) {
        let ax = x.abs();
        // A NaN fails the comparison too.
        one_round &= ax < f64::from_bits(0x4139_21fb << 32);
        // n = round(x·2/π) in the low bits of `t`, as libm rounds it.
        let t = x * INV_PIO2 + TO_INT;
        let n = t.to_bits();
        let f_n = t - TO_INT;
        let r = x - f_n * PIO2_1;
        let w = f_n * PIO2_1T;
        let y0 = r - w;
        one_round &= y0.abs() >= ax * f64::from_bits(0x3EF0_0000_0000_0000);
        let y1 = (r - y0) - w;
        let (s, c) = sincos_kernels(y0, y1, false);
        // n mod 4: 0 → (s, c), 1 → (c, −s), 2 → (−s, −c), 3 → (−c, s).
        let swap = 0u64.wrapping_sub(n & 1);
        let (sb, cb) = (s.to_bits(), c.to_bits());
        let first = (sb & !swap) | (cb & swap);
        let second = (cb & !swap) | (sb & swap);
        let sin_sign = (n & 2) << 62;
        let cos_sign = (n.wrapping_add(1) & 2) << 62;
        *o = (
            f64::from_bits(first ^ sin_sign),
            f64::from_bits(second ^ cos_sign),
        );
    }
    one_round.then_some(out)
}

/// libm's `rem_pio2` for `|x| < 2^20·π/2` (`ix` = high word of `|x|`): `x = n·π/2 + y0 + y1`.
/// Up to 9π/4 libm picks n by magnitude thresholds, beyond by rounding `x·2/π`; both are
/// reproduced, as is its rule for the second and third rounds (only on the "medium" path).
/// The constants here and in the kernels are libm's (FreeBSD's), bit for bit.
#[inline(always)]
fn reduce_pio2(x: f64, ix: u32) -> (i32, f64, f64) {
    const TO_INT: f64 = 1.5 / f64::EPSILON;
    const INV_PIO2: f64 = f64::from_bits(0x3FE4_5F30_6DC9_C883);
    const PIO2_1: f64 = f64::from_bits(0x3FF9_21FB_5440_0000);
    const PIO2_1T: f64 = f64::from_bits(0x3DD0_B461_1A62_6331);
    let small = ix <= 0x401c_463b;
    let by_threshold = i32::from(ix > 0x3fe9_21fb)
        + i32::from(ix > 0x4002_d97c)
        + i32::from(ix > 0x400f_6a7a)
        + i32::from(ix > 0x4015_fdbc);
    let by_threshold = if x.is_sign_negative() {
        -by_threshold
    } else {
        by_threshold
    };
    let f_n = if small {
        f64::from(by_threshold)
    } else {
        (x * INV_PIO2 + TO_INT) - TO_INT
    };
    let n = f_n as i32;
    let r = x - f_n * PIO2_1;
    let w = f_n * PIO2_1T;
    let y0 = r - w;
    // libm sends these near-multiples of π/2 below 9π/4 to its medium path too.
    let medium = !small
        || (ix <= 0x400f_6a7a && (ix & 0xfffff) == 0x921fb)
        || ix == 0x4012_d97c
        || ix == 0x4019_21fb;
    let ey = ((y0.to_bits() >> 52) & 0x7ff) as i32;
    let ex = (ix >> 20) as i32;
    if medium && ex - ey > 16 {
        return reduce_more(f_n, n, r, ex);
    }
    (n, y0, (r - y0) - w)
}

/// The second (and third) round of libm's medium reduction, for results that cancelled.
#[cold]
#[inline(never)]
fn reduce_more(f_n: f64, n: i32, mut r: f64, ex: i32) -> (i32, f64, f64) {
    const PIO2_2: f64 = f64::from_bits(0x3DD0_B461_1A60_0000);
    const PIO2_2T: f64 = f64::from_bits(0x3BA3_198A_2E03_7073);
    const PIO2_3: f64 = f64::from_bits(0x3BA3_198A_2E00_0000);
    const PIO2_3T: f64 = f64::from_bits(0x397B_839A_2520_49C1);
    let t = r;
    let mut w = f_n * PIO2_2;
    r = t - w;
    w = f_n * PIO2_2T - ((t - r) - w);
    let mut y0 = r - w;
    let ey = ((y0.to_bits() >> 52) & 0x7ff) as i32;
    if ex - ey > 49 {
        let t = r;
        w = f_n * PIO2_3;
        r = t - w;
        w = f_n * PIO2_3T - ((t - r) - w);
        y0 = r - w;
    }
    (n, y0, (r - y0) - w)
}

/// libm's `k_sin(y0, y1, 1)` and `k_cos(y0, y1)` on `[−π/4, π/4]`; `direct` takes
/// `k_sin(y0, 0, 0)` as libm does for an unreduced argument.
#[inline(always)]
fn sincos_kernels(x: f64, y: f64, direct: bool) -> (f64, f64) {
    const S1: f64 = f64::from_bits(0xBFC5_5555_5555_5549);
    const S2: f64 = f64::from_bits(0x3F81_1111_1110_F8A6);
    const S3: f64 = f64::from_bits(0xBF2A_01A0_19C1_61D5);
    const S4: f64 = f64::from_bits(0x3EC7_1DE3_57B1_FE7D);
    const S5: f64 = f64::from_bits(0xBE5A_E5E6_8A2B_9CEB);
    const S6: f64 = f64::from_bits(0x3DE5_D93A_5ACF_D57C);
    const C1: f64 = f64::from_bits(0x3FA5_5555_5555_554C);
    const C2: f64 = f64::from_bits(0xBF56_C16C_16C1_5177);
    const C3: f64 = f64::from_bits(0x3EFA_01A0_19CB_1590);
    const C4: f64 = f64::from_bits(0xBE92_7E4F_809C_52AD);
    const C5: f64 = f64::from_bits(0x3E21_EE9E_BDB4_B1C4);
    const C6: f64 = f64::from_bits(0xBDA8_FAE9_BE88_38D4);
    let z = x * x;
    let w = z * z;
    let r = S2 + z * (S3 + z * S4) + z * w * (S5 + z * S6);
    let v = z * x;
    let s = if direct {
        x + v * (S1 + z * r)
    } else {
        x - ((z * (0.5 * y - v * r) - y) - v * S1)
    };
    let rc = z * (C1 + z * (C2 + z * C3)) + w * w * (C4 + z * (C5 + z * C6));
    let hz = 0.5 * z;
    let wc = 1.0 - hz;
    (s, wc + (((1.0 - wc) - hz) + (z * rc - x * y)))
}
#[inline(always)]
pub(crate) fn sqrt(x: f64) -> f64 {
    libm::sqrt(x)
}
#[inline(always)]
pub(crate) fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}
#[inline(always)]
pub(crate) fn hypot(x: f64, y: f64) -> f64 {
    libm::hypot(x, y)
}
#[inline(always)]
pub(crate) fn asin(x: f64) -> f64 {
    libm::asin(x)
}
#[inline(always)]
pub(crate) fn ln(x: f64) -> f64 {
    libm::log(x)
}
#[inline(always)]
pub(crate) fn exp(x: f64) -> f64 {
    libm::exp(x)
}
#[inline(always)]
pub(crate) fn cbrt(x: f64) -> f64 {
    libm::cbrt(x)
}

/// Column `k` (0, 1 or 2) of a 3×3 matrix, read from its column-major array; zeros for any
/// other `k`. nalgebra's `column(k)` asserts `k < 3` at run time, and where the optimiser does
/// not inline it (opt-level s/z, the firmware target) that assertion is a panic path.
#[inline(always)]
pub(crate) fn column3(m: &nalgebra::Matrix3<f64>, k: usize) -> nalgebra::Vector3<f64> {
    m.data.0.get(k).map_or(crate::fixed3::ZERO, |&[x, y, z]| {
        nalgebra::Vector3::new(x, y, z)
    })
}

#[cfg(test)]
mod tests {
    use super::sin_cos;
    use crate::rng::SplitMix64;

    fn same(x: f64) -> bool {
        let (s, c) = sin_cos(x);
        let (ls, lc) = libm::sincos(x);
        s.to_bits() == ls.to_bits() && c.to_bits() == lc.to_bits()
    }

    /// The arguments of the bit-identity tests: 10^6 uniform arguments over ±2π, 10^6 over
    /// ±100, 10^6 over ±2^21 (beyond the fast range), every double within 200 ulps of k·π/2
    /// for |k| ≤ 40 and of libm's thresholds, log-uniform magnitudes from 1e-300 (both
    /// signs), and the special values.
    fn arguments() -> std::vec::Vec<f64> {
        let mut rng = SplitMix64::new(0x51c0);
        let mut args = std::vec::Vec::new();
        for (count, half_width) in [
            (1_000_000, 2.0 * core::f64::consts::PI),
            (1_000_000, 100.0),
            (1_000_000, 2.0f64.powi(21)),
        ] {
            for _ in 0..count {
                args.push((2.0 * rng.uniform() - 1.0) * half_width);
            }
        }
        let mut centres: std::vec::Vec<f64> = (-40..=40)
            .map(|k| f64::from(k) * core::f64::consts::FRAC_PI_2)
            .collect();
        for hi in [
            0x3fe9_21fbu64,
            0x4002_d97c,
            0x400f_6a7a,
            0x4015_fdbc,
            0x401c_463b,
            0x4139_21fb,
            0x3e46_a09e,
        ] {
            for lo in [0u64, 0xffff_ffff] {
                let b = f64::from_bits((hi << 32) | lo);
                centres.extend([b, -b]);
            }
        }
        for c in centres {
            for d in -200i64..=200 {
                let x = f64::from_bits(c.to_bits().wrapping_add_signed(d));
                if x.is_finite() {
                    args.push(x);
                }
            }
        }
        for _ in 0..200_000 {
            let x = 10f64.powf(rng.uniform() * 306.0 - 300.0);
            args.extend([x, -x]);
        }
        args.extend([
            0.0,
            -0.0,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            5e-324,
            -5e-324,
            1e-9,
            -1e-9,
            f64::MAX,
            -f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ]);
        args
    }

    /// Bit for bit equal to libm (so every FK, Jacobian and calibration result is unchanged)
    /// on every argument of [`arguments`].
    #[test]
    fn sin_cos_is_bit_identical_to_libm() {
        let args = arguments();
        for &x in &args {
            assert!(same(x), "{x:e} ({:#x})", x.to_bits());
        }
        assert!(args.len() > 3_000_000);
        let (s, c) = sin_cos(f64::NAN);
        assert!(s.is_nan() && c.is_nan());
    }

    /// The distance in units in the last place between two doubles (0 for ±0).
    fn ulps(a: f64, b: f64) -> u64 {
        let ordered = |x: f64| {
            let bits = x.to_bits() as i64;
            if bits < 0 { i64::MIN - bits } else { bits }
        };
        ordered(a).abs_diff(ordered(b))
    }

    /// Within 1 ulp of `sin_cos` (libm's bits), or both NaN; counts the lanes that differ.
    fn check_within_one_ulp(x: f64, got: (f64, f64), differing: &mut usize) {
        let (s, c) = sin_cos(x);
        if s.is_nan() || got.0.is_nan() {
            assert!(
                s.is_nan() && c.is_nan() && got.0.is_nan() && got.1.is_nan(),
                "{x:e}"
            );
            return;
        }
        let (ds, dc) = (ulps(s, got.0), ulps(c, got.1));
        assert!(
            ds <= 1 && dc <= 1,
            "{x:e} ({:#x}): {ds} and {dc} ulps",
            x.to_bits()
        );
        *differing += usize::from(ds + dc > 0);
    }

    /// `sin_cos_lanes` is within 1 ulp of libm on every argument of the libm test, each taken
    /// as lane 0 to 5 beside ordinary angles (so one hard argument is checked on the one-round
    /// path whenever that path takes it) and six at a time; almost all lanes are libm's bits.
    /// The one-round path must take almost every random six of joint angles (or this would
    /// test the fallback).
    #[test]
    fn sin_cos_lanes_is_within_one_ulp_of_libm() {
        use super::{sin_cos_lanes, sin_cos_lanes_one_round};
        let args = arguments();
        let partners = [0.5, -1.25, 2.5, -3.0, 6.0, 1e-3];
        let (mut one_round, mut total, mut differing) = (0usize, 0usize, 0usize);
        for (k, &x) in args.iter().enumerate() {
            let mut lanes = partners;
            lanes[k % 6] = x;
            let got = sin_cos_lanes(&lanes);
            check_within_one_ulp(x, got[k % 6], &mut differing);
            total += 1;
            one_round += usize::from(sin_cos_lanes_one_round(&lanes).is_some());
        }
        for chunk in args.as_chunks::<6>().0 {
            let got = sin_cos_lanes(chunk);
            for (i, &v) in chunk.iter().enumerate() {
                check_within_one_ulp(v, got[i], &mut 0);
            }
        }
        // Over ±2π, six at a time: nearly always one round, nearly always libm's bits.
        let mut rng = SplitMix64::new(0x1a9e);
        let (mut one_round_joint, mut differing_joint) = (0usize, 0usize);
        for _ in 0..100_000 {
            let x: [f64; 6] = core::array::from_fn(|_| (2.0 * rng.uniform() - 1.0) * 6.3);
            one_round_joint += usize::from(sin_cos_lanes_one_round(&x).is_some());
            let got = sin_cos_lanes(&x);
            for (i, &v) in x.iter().enumerate() {
                check_within_one_ulp(v, got[i], &mut differing_joint);
            }
        }
        assert!(
            one_round_joint > 99_000,
            "one-round path on {one_round_joint} of 100000"
        );
        // Most single hard arguments too (all but the huge, non-finite and cancelling ones).
        assert!(
            one_round * 10 > total * 6,
            "one-round path on {one_round} of {total}"
        );
        std::println!(
            "one round: {one_round} of {total} single arguments, {one_round_joint} of 100000 \
             joint sixes; not libm's bits (1 ulp off): {differing} of {total} single arguments, \
             {differing_joint} of 600000 joint angles"
        );
    }
}
