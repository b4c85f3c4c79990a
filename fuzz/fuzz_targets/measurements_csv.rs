//! The measurement CSV reader on arbitrary bytes: it never panics, and whatever it accepts
//! writes back and reads back to the same rows (spec/measurements.md: write → read is
//! bit-exact). The first byte picks the reader's options.
#![no_main]

use kincal_io::measurements::{ReadOptions, parse_measurements, write_measurements_csv};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&sel, text)) = data.split_first() else {
        return;
    };
    // Joint count 1..=9: bits 0-2, and bit 6 with bits 0-2 all set for 9.
    let n = match sel & 7 {
        7 if sel & 64 != 0 => 9,
        k => 1 + usize::from(k),
    };
    let mut opts = ReadOptions::new(n);
    opts.require_pose = sel & 8 != 0;
    if sel & 16 != 0 {
        opts.joint_limits = Some(vec![(-3.2, 3.2); n]);
        opts.allow_out_of_limits = sel & 32 != 0;
    }
    let Ok(set) = parse_measurements(text, "fuzz.csv", &opts) else {
        return;
    };
    let mut out = Vec::new();
    write_measurements_csv(&mut out, &set).expect("an accepted set must write");
    let again = match parse_measurements(&out[..], "fuzz.csv", &opts) {
        Ok(s) => s,
        Err(e) => panic!(
            "written set does not read back: {e}\n{}",
            String::from_utf8_lossy(&out)
        ),
    };
    assert_eq!(set.comments, again.comments);
    assert_eq!(set.extra_columns, again.extra_columns);
    assert_eq!(set.orientation_form, again.orientation_form);
    assert_eq!(set.rows.len(), again.rows.len());
    for (a, b) in set.rows.iter().zip(again.rows.iter()) {
        let mut b = b.clone();
        b.line = a.line;
        assert_eq!(*a, b, "row changed by write → read");
    }
});
