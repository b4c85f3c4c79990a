//! The ROS 2 bag reader (MCAP + CDR) on arbitrary bytes: it never panics. The input is
//! read twice: as a whole MCAP file, and (behind an MCAP header that names the topics) as
//! the body of each CDR message type, so the CDR decoder sees hostile lengths directly.
#![no_main]

use kincal_io::cdr;
use kincal_io::rosbag::{BagOptions, MeasurementTopic, import_bag_bytes};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let mut opts = BagOptions::new("/joint_states", MeasurementTopic::Pose("/tool".into()));
    let _ = import_bag_bytes(&[("fuzz.mcap", bytes)], &opts);
    opts.joint_names = Some(vec!["joint1".into(), "joint2".into()]);
    let _ = import_bag_bytes(&[("fuzz.mcap", bytes)], &opts);
    let _ = cdr::joint_state(bytes);
    let _ = cdr::pose_stamped(bytes);
    let _ = cdr::transform_stamped(bytes);
    let _ = cdr::point_stamped(bytes);
    // A decoded joint state re-encodes and decodes to the same values.
    if let Ok(js) = cdr::joint_state(bytes) {
        let names: Vec<&str> = js.name.iter().map(String::as_str).collect();
        let again = cdr::joint_state(&cdr::write::joint_state(
            js.header.stamp_ns,
            &names,
            &js.position,
        ));
        let again = again.expect("a re-encoded joint state decodes");
        assert_eq!(again.name, js.name);
        assert_eq!(
            again.position.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            js.position.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
    }
});
