//! The `terraslip_msgs` interface package (ros/terraslip_msgs) defines the
//! custom messages exactly as the node and `estimate --mcap` write them.

use std::path::PathBuf;

use terraslip_ros2::out::{
    estimate_messages, EstimateSample, Frames, ICR_DEF, ICR_TYPE, INNOVATION_DEF, INNOVATION_TYPE,
};

fn package() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../ros/terraslip_msgs")
}

/// The field and constant lines of a `.msg` text: comments and blank lines
/// dropped, spaces normalised.
fn fields(text: &str) -> Vec<String> {
    text.lines()
        .map(|l| l.split('#').next().unwrap_or(""))
        .map(|l| l.split_whitespace().collect::<Vec<_>>().join(" "))
        .filter(|l| !l.is_empty())
        .collect()
}

fn msg_file(ty: &str) -> (PathBuf, String) {
    let name = ty.rsplit('/').next().unwrap();
    let p = package().join("msg").join(format!("{name}.msg"));
    let text = std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    (p, text)
}

#[test]
fn the_msg_files_equal_the_written_definitions() {
    for (ty, def) in [(ICR_TYPE, ICR_DEF), (INNOVATION_TYPE, INNOVATION_DEF)] {
        let (p, text) = msg_file(ty);
        assert_eq!(fields(&text), fields(def), "{} against {ty}", p.display());
        assert!(ty.starts_with("terraslip_msgs/msg/"), "{ty}");
    }
}

#[test]
fn every_custom_type_written_is_in_the_package_and_built_by_it() {
    let mut last = None;
    let s = EstimateSample::default();
    let msgs = estimate_messages(&s, &Frames::default(), Some("grass"), &mut last);
    let cmake = std::fs::read_to_string(package().join("CMakeLists.txt")).unwrap();
    let xml = std::fs::read_to_string(package().join("package.xml")).unwrap();
    assert!(xml.contains("<name>terraslip_msgs</name>"));
    let mut custom = 0;
    for m in &msgs {
        if !m.ty.starts_with("terraslip_msgs/") {
            continue;
        }
        custom += 1;
        let (p, text) = msg_file(m.ty);
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        assert!(
            cmake.contains(&format!("\"msg/{name}\"")),
            "{name} not in CMakeLists.txt"
        );
        // The schema a reader sees: the .msg's fields first, then the
        // dependencies' sections.
        let def = m.definition();
        let own = def.split("====").next().unwrap();
        assert_eq!(fields(own), fields(&text), "{}", m.ty);
        terraslip_ros2::msg::Registry::parse(m.ty, &def, None).unwrap();
    }
    assert_eq!(custom, 2, "the custom types written: Icr and Innovation");
    let files = std::fs::read_dir(package().join("msg")).unwrap().count();
    assert_eq!(files, custom, "a .msg file no writer uses");
}
