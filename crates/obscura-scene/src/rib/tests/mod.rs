//! The RIB reader's tests, by topic; the helpers here parse text as a file `t.rib` in `/base`.

mod archive;
mod geometry;
mod lex;
mod options;
mod requests;
mod shading;
mod transform;

use std::path::Path;

use glam::Vec3;
use obscura_sdk::Vec3 as SdkVec3;
use proptest::test_runner::Config as ProptestConfig;

use super::{RibError, parse_str};
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

fn camera_point(scene: &Scene, sample: usize, p: Vec3) -> Vec3 {
    let m = scene.camera.world_to_camera[sample].world_to_camera;
    let q = m.transform_point(SdkVec3::new(p.x, p.y, p.z));
    Vec3::new(q.x, q.y, q.z)
}
