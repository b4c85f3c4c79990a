//! The robot description reader (TOML) on arbitrary text: it never panics, and whatever it
//! accepts writes back (full precision) and reads back to the same robot.
#![no_main]

use kincal_io::robot_file::{parse_robot_description, write_robot_description};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|text: &str| {
    let Ok(desc) = parse_robot_description(text, "fuzz.toml") else {
        return;
    };
    let written = write_robot_description(&desc);
    match parse_robot_description(&written, "written.toml") {
        Ok(again) => assert_eq!(
            desc, again,
            "description changed by write → read\n{written}"
        ),
        Err(e) => panic!("written description does not read back: {e}\n{written}"),
    }
});
