//! Model files from C: a model file reads into the robot struct exactly (every parameter
//! bit for bit), and files the CLI refuses are refused with the CLI's message and position.

use core::ffi::CStr;
use core::ptr::{null, null_mut};

use kincal::ParamIndex;
use kincal_io::model_file::ModelFile;

use crate::model_read::*;
use crate::robot::*;
use crate::status::*;

/// ARIA with links, base and tool moved off nominal: a model file of it and the struct the
/// reader must produce (built by the robot conversion, not by the reader).
fn moved_aria() -> (String, kincal_robot) {
    let mut r = kincal::aria::nominal();
    for (i, dv) in [(3, 0.01), (6, 1e-3), (31, 2e-3), (38, -0.004)] {
        let v = r.param(ParamIndex(i)).unwrap();
        r.set_param(ParamIndex(i), v + dv).unwrap();
    }
    let text = ModelFile::nominal("aria", &r).to_json();
    (text, from_robot(&r).unwrap())
}

fn read_buffer(
    text: &str,
    variant: Option<&CStr>,
) -> (kincal_status, kincal_robot, kincal_read_error) {
    let mut robot = kincal_robot::ZERO;
    let mut re = kincal_read_error {
        line: 99,
        column: 99,
        message: [1; KINCAL_READ_MESSAGE_LEN],
    };
    let s = unsafe {
        kincal_model_read_buffer(
            text.as_ptr().cast(),
            text.len(),
            variant.map_or(null(), CStr::as_ptr),
            &mut robot,
            &mut re,
            null_mut(),
        )
    };
    (s, robot, re)
}

fn message(re: &kincal_read_error) -> String {
    unsafe { CStr::from_ptr(re.message.as_ptr()) }
        .to_string_lossy()
        .into_owned()
}

#[test]
fn a_model_file_reads_into_the_robot_struct_exactly() {
    let (text, expected) = moved_aria();
    let (s, robot, re) = read_buffer(&text, None);
    assert_eq!(s, kincal_status::Ok, "{}", message(&re));
    assert_eq!(robot, expected);
    assert_eq!((re.line, re.column, message(&re).as_str()), (0, 0, ""));
    // The same file from disk.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("model.json");
    std::fs::write(&path, &text).unwrap();
    let cpath = std::ffi::CString::new(path.to_str().unwrap()).unwrap();
    let mut from_file = kincal_robot::ZERO;
    let s = unsafe {
        kincal_model_read(
            cpath.as_ptr(),
            null(),
            &mut from_file,
            null_mut(),
            null_mut(),
        )
    };
    assert_eq!(s, kincal_status::Ok);
    assert_eq!(from_file, expected);
    // NOM: every parameter at its nominal value, i.e. the moved values are not kept.
    let (s, nom, _) = read_buffer(&text, Some(c"nom"));
    assert_eq!(s, kincal_status::Ok);
    assert_eq!(nom.params[3], expected.params[3]); // the file's nominal is the moved robot
}

#[test]
fn refused_files_carry_the_readers_message_and_position() {
    let (text, _) = moved_aria();
    // A syntax error: line and column of serde_json.
    let broken = text.replacen("\"robot\":", "\"robot\":,", 1);
    let line = broken
        .lines()
        .position(|l| l.contains("\"robot\":,"))
        .unwrap()
        + 1;
    let (s, robot, re) = read_buffer(&broken, None);
    assert_eq!(s, kincal_status::BadFile);
    assert_eq!(robot, kincal_robot::ZERO, "nothing written on failure");
    assert_eq!(re.line, line, "{}", message(&re));
    assert!(re.column > 0);
    assert!(
        message(&re).starts_with(&format!("buffer:{line}:")),
        "{}",
        message(&re)
    );
    // A missing parameter (Octave used to keep its nominal value silently).
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["robot"]["parameters"]
        .as_array_mut()
        .unwrap()
        .retain(|p| p["label"] != "theta0_4");
    let (s, _, re) = read_buffer(&v.to_string(), None);
    assert_eq!(s, kincal_status::BadFile);
    assert!(message(&re).contains("theta0_4"), "{}", message(&re));
    // Not a model file at all.
    let (s, _, re) = read_buffer("", None);
    assert_eq!(s, kincal_status::BadFile);
    assert_eq!((re.line, re.column), (1, 1));
    // A run the file does not hold is a bad argument.
    let (s, _, re) = read_buffer(&text, Some(c"OPT2"));
    assert_eq!(s, kincal_status::InvalidArgument);
    assert!(message(&re).contains("NOM"), "{}", message(&re));
    // A missing file names it.
    let mut e = kincal_error::CLEAR;
    let mut re = kincal_read_error {
        line: 0,
        column: 0,
        message: [0; KINCAL_READ_MESSAGE_LEN],
    };
    let mut robot = kincal_robot::ZERO;
    let s = unsafe {
        kincal_model_read(
            c"/nonexistent/m.json".as_ptr(),
            null(),
            &mut robot,
            &mut re,
            &mut e,
        )
    };
    assert_eq!(s, kincal_status::BadFile);
    assert_eq!(e.status, kincal_status::BadFile as u32);
    assert!(
        message(&re).starts_with("/nonexistent/m.json: cannot read"),
        "{}",
        message(&re)
    );
}

#[test]
fn null_pointers_and_long_messages_are_safe() {
    let (text, _) = moved_aria();
    let mut robot = kincal_robot::ZERO;
    let s = unsafe { kincal_model_read(null(), null(), &mut robot, null_mut(), null_mut()) };
    assert_eq!(s, kincal_status::NullPointer);
    let s = unsafe {
        kincal_model_read_buffer(
            text.as_ptr().cast(),
            text.len(),
            null(),
            null_mut(),
            null_mut(),
            null_mut(),
        )
    };
    assert_eq!(s, kincal_status::NullPointer);
    // A message longer than the buffer is cut at a character boundary and NUL-terminated.
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["robot"]["parameters"][0]["label"] = serde_json::Value::from("é".repeat(600));
    let (s, _, re) = read_buffer(&v.to_string(), None);
    assert_eq!(s, kincal_status::BadFile);
    assert_eq!(re.message[KINCAL_READ_MESSAGE_LEN - 1], 0);
    let bytes = unsafe { CStr::from_ptr(re.message.as_ptr()) }.to_bytes();
    assert!(
        bytes.len() >= KINCAL_READ_MESSAGE_LEN - 2,
        "{}",
        message(&re)
    );
    assert!(std::str::from_utf8(bytes).is_ok());
}
