//! The RIB reader's tests, by topic; the helpers here parse text as a file `t.rib` in `/base`.

mod archive;
mod camera;
mod classic;
mod encoding;
mod frames;
mod geometry;
mod lex;
mod options;
mod pattern;
mod requests;
mod shading;
mod transform;

use std::path::Path;

use glam::Vec3;
use proptest::test_runner::Config as ProptestConfig;

use super::{RibError, parse_str};
use crate::test_support::camera_point;
use crate::types::{Object, Scene};

/// No regression files: these tests write nothing outside their temporary directories.
fn no_persistence() -> ProptestConfig {
    ProptestConfig {
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

const HERE: &str = "/base";

fn parse(text: &str) -> Result<Scene, RibError> {
    parse_str(text, "t.rib", Path::new(HERE))
}

fn ok(text: &str) -> Scene {
    parse(text).unwrap_or_else(|e| panic!("{e}"))
}

fn fail(text: &str) -> String {
    match parse(text) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// The one object a world block holding `body` makes.
fn only_object(body: &str) -> Object {
    let scene = ok(&format!("WorldBegin\n{body}\nWorldEnd\n"));
    assert_eq!(scene.objects.len(), 1, "{:?}", scene.objects);
    scene.objects[0].clone()
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

/// Asserts that camera motion sample `sample` sends the world point `p` to `expected` (within 1e-5).
fn assert_camera_point(scene: &Scene, sample: usize, p: Vec3, expected: Vec3) {
    let got = camera_point(scene, sample, p);
    assert!(
        close(got, expected),
        "sample {sample}: {p} went to {got}, expected {expected}"
    );
}
