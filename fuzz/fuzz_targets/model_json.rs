//! The model file reader (JSON, schema_version) on arbitrary text: it never panics; an
//! accepted file converts to a robot, its effects and its stored variants or says why not,
//! and serialises back to a file that parses to the same content.
#![no_main]

use kincal_io::model_file::parse;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|text: &str| {
    let Ok(mut m) = parse(text, "fuzz.json") else {
        return;
    };
    // Run times are read from older files but never written (bit-identical outputs).
    if let Some(c) = m.calibration.as_mut() {
        for r in &mut c.results {
            r.seconds = 0.0;
        }
    }
    // What `resolve_model` (every MODEL argument) does with it.
    let _ = m.robot.any_robot();
    let _ = m.robot.nominal_robot::<6>();
    let _ = m.effects();
    let _ = m.algorithm();
    let _ = m.variants::<6>();
    let json = m.to_json();
    match parse(&json, "written.json") {
        Ok(again) => assert_eq!(m, again, "model changed by write → read\n{json}"),
        Err(e) => panic!("written model does not read back: {}\n{json}", e.message),
    }
});
