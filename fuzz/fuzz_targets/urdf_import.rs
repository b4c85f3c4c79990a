//! URDF import on arbitrary text: it never panics; an imported chain gives a model whose
//! FK at the zero configuration is computed without a panic, and which exports back to URDF
//! (or is refused with an error).
#![no_main]

use kincal::with_any_robot;
use kincal_io::urdf::{ChainSelection, UrdfExport, export_urdf, import_urdf_str};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|text: &str| {
    let Ok(imp) = import_urdf_str(text, "fuzz.urdf", &ChainSelection::default()) else {
        return;
    };
    with_any_robot!(&imp.robot, r => {
        let _ = r.fk_q(&core::array::from_fn(|_| 0.0));
    });
    let spec = UrdfExport {
        robot_name: &imp.robot_name,
        base_link: &imp.base_link,
        tip_link: &imp.tip_link,
        joint_names: Some(&imp.joint_names),
        allow_dropping_effects: false,
    };
    let _ = export_urdf(&imp.robot, &spec);
});
