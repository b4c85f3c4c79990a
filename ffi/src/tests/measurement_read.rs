//! Measurement CSV from C: the two calls give the file's numbers in SI units (checked against
//! values written by hand and an independent rotation formula), its text in the documented
//! order, and refusals with the CLI's message, line and cell number.

use core::ffi::{CStr, c_char};
use core::ptr::{null, null_mut};

use crate::kinematics::kincal_joint_aux;
use crate::measurement_read::*;
use crate::model_read::*;
use crate::robot::*;
use crate::status::*;

fn blank_read_error() -> kincal_read_error {
    kincal_read_error {
        line: 99,
        column: 99,
        message: [1; KINCAL_READ_MESSAGE_LEN],
    }
}

fn message(re: &kincal_read_error) -> String {
    unsafe { CStr::from_ptr(re.message.as_ptr()) }
        .to_string_lossy()
        .into_owned()
}

fn sizes(
    text: &str,
    robot: Option<&kincal_robot>,
    flags: u32,
) -> (kincal_status, kincal_measurement_sizes, kincal_read_error) {
    let mut out = kincal_measurement_sizes::default();
    let mut re = blank_read_error();
    let s = unsafe {
        kincal_measurements_read_buffer_sizes(
            text.as_ptr().cast(),
            text.len(),
            robot.map_or(null(), |r| r as *const _),
            flags,
            &mut out,
            &mut re,
            null_mut(),
        )
    };
    (s, out, re)
}

struct Read {
    q: Vec<f64>,
    poses: Vec<f64>,
    masks: Vec<u8>,
    aux: Vec<kincal_joint_aux>,
    lines: Vec<usize>,
    text: Vec<String>,
}

fn read(text: &str, robot: Option<&kincal_robot>) -> (kincal_measurement_sizes, Read) {
    let (s, z, re) = sizes(text, robot, 0);
    assert_eq!(s, kincal_status::Ok, "{}", message(&re));
    let aux0 = kincal_joint_aux {
        has_approach: 7,
        has_temp: 7,
        approach: [9.0; KINCAL_MAX_JOINTS],
        temp_c: 9.0,
    };
    let (l, n) = (z.n_rows, z.n_joints);
    let (mut q, mut poses, mut masks) = (vec![9.0; l * n], vec![9.0; 16 * l], vec![9u8; l]);
    let (mut aux, mut lines, mut chars) = (
        vec![aux0; l],
        vec![0usize; l],
        vec![1 as c_char; z.text_len],
    );
    let b = kincal_measurement_buffers {
        q: q.as_mut_ptr(),
        q_len: q.len(),
        poses: poses.as_mut_ptr(),
        poses_len: poses.len(),
        masks: masks.as_mut_ptr(),
        masks_len: masks.len(),
        aux: aux.as_mut_ptr(),
        aux_len: aux.len(),
        lines: lines.as_mut_ptr(),
        lines_len: lines.len(),
        text: chars.as_mut_ptr(),
        text_len: chars.len(),
    };
    let mut re = blank_read_error();
    let s = unsafe {
        kincal_measurements_read_buffer(
            text.as_ptr().cast(),
            text.len(),
            robot.map_or(null(), |r| r as *const _),
            0,
            &b,
            &mut re,
            null_mut(),
        )
    };
    assert_eq!(s, kincal_status::Ok, "{}", message(&re));
    assert_eq!((re.line, re.column, re.message[0]), (0, 0, 0));
    let bytes: Vec<u8> = chars.iter().map(|&c| c as u8).collect();
    assert_eq!(bytes.last(), Some(&0), "the text ends with a NUL");
    let text = bytes
        .split(|&b| b == 0)
        .take(bytes.iter().filter(|&&b| b == 0).count())
        .map(|s| String::from_utf8(s.to_vec()).unwrap())
        .collect();
    (
        z,
        Read {
            q,
            poses,
            masks,
            aux,
            lines,
            text,
        },
    )
}

/// R = Rz(yaw)·Ry(pitch)·Rx(roll), written out (not the core's code).
fn rpy_matrix(r: f64, p: f64, y: f64) -> [[f64; 3]; 3] {
    let (sr, cr, sp, cp, sy, cy) = (r.sin(), r.cos(), p.sin(), p.cos(), y.sin(), y.cos());
    [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
}

#[test]
fn a_file_reads_in_si_units_with_its_text_in_order() {
    let csv = "# robot: test\n\npose_id,q2_deg,q1,x_mm,y,z,roll_deg,pitch,yaw,extra_op,temp_c,s1,s2\n\
               a,90,0.5,100,0.2,0.3,30,0.2,-0.4,ann,21.5,1,-1\n\n\
               b,-45,-0.25,-50,0,1,0,0,0,bob,22,0,1\n";
    let (z, r) = read(csv, None);
    assert_eq!(
        (
            z.n_rows,
            z.n_joints,
            z.n_columns,
            z.n_comments,
            z.n_extra,
            z.header_line
        ),
        (2, 2, 13, 1, 1, 3)
    );
    assert_eq!(
        (
            z.orientation,
            z.has_position,
            z.has_pose_id,
            z.has_approach,
            z.has_temperature,
            z.has_contacts
        ),
        (1, 1, 1, 1, 1, 0)
    );
    assert_eq!(r.q, [0.5, 90f64.to_radians(), -0.25, (-45f64).to_radians()]);
    assert_eq!(r.lines, [4, 6]);
    assert_eq!(r.masks, [0x3f, 0x3f]);
    let want = rpy_matrix(30f64.to_radians(), 0.2, -0.4);
    for (row, want_row) in want.iter().enumerate() {
        for (col, w) in want_row.iter().enumerate() {
            assert!(
                (r.poses[4 * col + row] - w).abs() < 1e-15,
                "R[{row}][{col}]"
            );
        }
    }
    assert_eq!(&r.poses[12..16], &[0.1, 0.2, 0.3, 1.0]);
    assert_eq!(&r.poses[16 + 12..32], &[-0.05, 0.0, 1.0, 1.0]);
    assert_eq!(
        (r.aux[0].has_approach, r.aux[0].has_temp, r.aux[0].temp_c),
        (1, 1, 21.5)
    );
    assert_eq!(&r.aux[1].approach[..2], &[0.0, 1.0]);
    let mut want_text = vec![" robot: test".to_string()];
    want_text.extend(
        "pose_id,q2_deg,q1,x_mm,y,z,roll_deg,pitch,yaw,extra_op,temp_c,s1,s2"
            .split(',')
            .map(str::to_string),
    );
    want_text.extend(["a", "ann", "b", "bob"].map(str::to_string));
    assert_eq!(r.text, want_text);
    assert_eq!(
        z.text_len,
        want_text.iter().map(|t| t.len() + 1).sum::<usize>()
    );
}

#[test]
fn rows_without_a_pose_come_out_as_identity_with_mask_zero_and_partial_ones_with_their_bits() {
    let (z, r) = read("q1,x,y,z\n0.1,,2,\n0.2,1,2,3\n", None);
    assert_eq!((z.n_rows, z.orientation, z.has_position), (2, 0, 1));
    assert_eq!(r.masks, [0b010, 0x07]);
    assert_eq!(&r.poses[12..15], &[0.0, 2.0, 0.0]);
    assert_eq!(&r.poses[16 + 12..16 + 15], &[1.0, 2.0, 3.0]);
    let (z, r) = read("q1\n0.1\n", None);
    assert_eq!((z.has_position, r.masks[0]), (0, 0));
    assert_eq!(
        r.poses,
        [
            1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0
        ]
    );
}

#[test]
fn the_robot_sets_the_joint_count_and_its_limits_are_checked() {
    let mut aria = kincal_robot::ZERO;
    assert_eq!(
        unsafe { crate::aria::kincal_robot_aria(&mut aria, 0, null_mut()) },
        kincal_status::Ok
    );
    let h = "q1,q2,q3,q4,q5,q6\n";
    let (s, _, re) = sizes(&format!("{h}0,4,0,0,0,0\n"), Some(&aria), 0);
    assert_eq!(s, kincal_status::BadFile);
    assert_eq!((re.line, re.column), (2, 2), "{}", message(&re));
    assert!(
        message(&re).starts_with("buffer:2: column 'q2': "),
        "{}",
        message(&re)
    );
    let (s, z, _) = sizes(
        &format!("{h}0,4,0,0,0,0\n"),
        Some(&aria),
        KINCAL_READ_ALLOW_OUT_OF_LIMITS,
    );
    assert_eq!((s, z.n_joints), (kincal_status::Ok, 6));
    let (s, _, re) = sizes("q1,q2\n0,0\n", Some(&aria), 0);
    assert_eq!(
        (s, re.line, re.column),
        (kincal_status::BadFile, 1, 0),
        "{}",
        message(&re)
    );
    assert!(
        message(&re).contains("column 'q3': missing required column"),
        "{}",
        message(&re)
    );
}

#[test]
fn refusals_name_line_and_cell_and_arguments_are_checked() {
    for (csv, line, column, part) in [
        ("", 1, 0, "empty file"),
        (
            "x,y,z\n1,2,3\n",
            1,
            0,
            "column 'q1': missing required column",
        ),
        (
            "q1,q2,colour\n0,0,red\n",
            1,
            3,
            "column 'colour': unknown column",
        ),
        (
            "q1,q2\n0,0\n0,abc\n",
            3,
            2,
            "column 'q2': expected a number",
        ),
        (
            "q1,x,y,z,qw,qx,qy,qz\n0,0,0,0,1.001,0,0,0\n",
            2,
            5,
            "quaternion",
        ),
    ] {
        let (s, _, re) = sizes(csv, None, 0);
        assert_eq!(s, kincal_status::BadFile, "{csv:?}");
        assert_eq!(
            (re.line, re.column),
            (line, column),
            "{csv:?}: {}",
            message(&re)
        );
        assert!(message(&re).contains(part), "{csv:?}: {}", message(&re));
    }
    let (s, _, re) = sizes("q1\n0\n", None, KINCAL_READ_REQUIRE_POSE);
    assert_eq!(s, kincal_status::BadFile, "{}", message(&re));
    let (s, _, _) = sizes("q1\n0\n", None, 4);
    assert_eq!(s, kincal_status::InvalidArgument);
    // A buffer of the wrong length is refused before anything is written.
    let mut q = [7.0; 3];
    let b = kincal_measurement_buffers {
        q: q.as_mut_ptr(),
        q_len: 3,
        poses: null_mut(),
        poses_len: 0,
        masks: null_mut(),
        masks_len: 0,
        aux: null_mut(),
        aux_len: 0,
        lines: null_mut(),
        lines_len: 0,
        text: null_mut(),
        text_len: 0,
    };
    let text = "q1,q2\n1,2\n";
    let s = unsafe {
        kincal_measurements_read_buffer(
            text.as_ptr().cast(),
            text.len(),
            null(),
            0,
            &b,
            null_mut(),
            null_mut(),
        )
    };
    assert_eq!((s, q), (kincal_status::BadLength, [7.0; 3]));
}

#[test]
fn a_path_reads_as_its_bytes_and_a_missing_file_is_a_bad_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.csv");
    std::fs::write(&path, "q1,q2\n1,2\n").unwrap();
    let c = std::ffi::CString::new(path.to_str().unwrap()).unwrap();
    let mut z = kincal_measurement_sizes::default();
    let s = unsafe {
        kincal_measurements_read_sizes(c.as_ptr(), null(), 0, &mut z, null_mut(), null_mut())
    };
    assert_eq!((s, z.n_rows, z.n_joints), (kincal_status::Ok, 1, 2));
    let mut q = [0.0; 2];
    let mut b = kincal_measurement_buffers {
        q: q.as_mut_ptr(),
        q_len: 2,
        poses: null_mut(),
        poses_len: 0,
        masks: null_mut(),
        masks_len: 0,
        aux: null_mut(),
        aux_len: 0,
        lines: null_mut(),
        lines_len: 0,
        text: null_mut(),
        text_len: 0,
    };
    let s = unsafe { kincal_measurements_read(c.as_ptr(), null(), 0, &b, null_mut(), null_mut()) };
    assert_eq!((s, q), (kincal_status::Ok, [1.0, 2.0]));
    b.q = null_mut();
    let missing = std::ffi::CString::new(dir.path().join("no.csv").to_str().unwrap()).unwrap();
    let mut re = blank_read_error();
    let s =
        unsafe { kincal_measurements_read(missing.as_ptr(), null(), 0, &b, &mut re, null_mut()) };
    assert_eq!(s, kincal_status::BadFile);
    assert!(
        message(&re).contains("cannot open the file"),
        "{}",
        message(&re)
    );
}
