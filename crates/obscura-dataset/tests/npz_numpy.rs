//! The `.npz` files of tracks and correspondences read back by NumPy (a reader we did not write):
//! names, dtypes, shapes and every value. `python3` must have NumPy; with OBSCURA_REQUIRE_NUMPY=1 (as
//! `test.sh` sets) a missing NumPy fails the test rather than skipping it.

use std::path::Path;
use std::process::Command;

use glam::Vec3A;
use obscura_dataset::annotate::Status;
use obscura_dataset::annotate::correspondences::Correspondences;
use obscura_dataset::annotate::tracks::{TrackFrame, TrackPoints, write_tracks_npz};
use obscura_render::flow::ObjectPoint;

/// Runs `script` with `python3`, returning its stdout; `None` (a skip) when NumPy is missing and not
/// required.
fn numpy(script: &str) -> Option<String> {
    let has = Command::new("python3")
        .args(["-c", "import numpy"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !has {
        assert!(
            std::env::var("OBSCURA_REQUIRE_NUMPY").is_err(),
            "OBSCURA_REQUIRE_NUMPY is set but python3 has no numpy"
        );
        eprintln!("skipped: python3 has no numpy");
        return None;
    }
    let out = Command::new("python3").args(["-c", script]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    Some(String::from_utf8(out.stdout).unwrap())
}

fn load(path: &Path, script: &str) -> Option<serde_json::Value> {
    let script = format!(
        "import json, numpy as np\nd = np.load({:?})\n{script}",
        path.to_str().unwrap()
    );
    numpy(&script).map(|s| serde_json::from_str(&s).unwrap())
}

#[test]
fn numpy_reads_the_tracks_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cam.npz");
    let tracks = TrackPoints {
        points: vec![
            ObjectPoint {
                instance: 0,
                position: Vec3A::new(0.25, -1.5, 3.0),
            },
            ObjectPoint {
                instance: 2,
                position: Vec3A::new(1.0, 2.0, -0.125),
            },
        ],
        object_ids: vec![1, 2],
    };
    let frames = vec![
        TrackFrame {
            points: vec![[10.5, 20.25], [f32::NAN, f32::NAN]],
            status: vec![Status::Visible, Status::OutsideDomain],
        },
        TrackFrame {
            points: vec![[-3.0, 7.75], [64.0, 0.5]],
            status: vec![Status::OutOfFrame, Status::Occluded],
        },
        TrackFrame {
            points: vec![[1.0, 2.0], [3.0, 4.0]],
            status: vec![Status::Occluded, Status::Visible],
        },
    ];
    write_tracks_npz(&path, &tracks, &frames, &[1, 2, 5]).unwrap();
    let Some(v) = load(
        &path,
        "print(json.dumps({k: {'dtype': str(d[k].dtype), 'shape': list(d[k].shape), \
         'values': [None if x != x else float(x) for x in d[k].ravel().tolist()]} for k in d.files}))",
    ) else {
        return;
    };
    let array = |k: &str| (&v[k]["dtype"], &v[k]["shape"], &v[k]["values"]);
    let (dtype, shape, values) = array("points");
    assert_eq!(
        (dtype.as_str().unwrap(), shape.to_string().as_str()),
        ("float32", "[2,3,2]")
    );
    // Point-major: point 0's three frames, then point 1's.
    assert_eq!(
        values.to_string(),
        "[10.5,20.25,-3.0,7.75,1.0,2.0,null,null,64.0,0.5,3.0,4.0]"
    );
    let (dtype, shape, values) = array("status");
    assert_eq!(
        (dtype.as_str().unwrap(), shape.to_string().as_str()),
        ("uint8", "[2,3]")
    );
    assert_eq!(values.to_string(), "[0.0,2.0,1.0,3.0,1.0,0.0]");
    let (dtype, _, values) = array("object");
    assert_eq!(
        (dtype.as_str().unwrap(), values.to_string().as_str()),
        ("uint32", "[1.0,2.0]")
    );
    let (_, _, values) = array("instance");
    assert_eq!(values.to_string(), "[1.0,3.0]");
    let (dtype, shape, values) = array("local");
    assert_eq!(
        (dtype.as_str().unwrap(), shape.to_string().as_str()),
        ("float32", "[2,3]")
    );
    assert_eq!(values.to_string(), "[0.25,-1.5,3.0,1.0,2.0,-0.125]");
    let (dtype, _, values) = array("frames");
    assert_eq!(
        (dtype.as_str().unwrap(), values.to_string().as_str()),
        ("int32", "[1.0,2.0,5.0]")
    );
}

#[test]
fn numpy_reads_the_correspondences_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("0001.npz");
    let (w, h) = (5u32, 3u32);
    let c = Correspondences {
        width: w,
        height: h,
        target: (0..w * h).map(|i| [i as f32 + 0.5, -(i as f32)]).collect(),
        status: (0..w * h)
            .map(|i| match i % 5 {
                0 => Status::Visible,
                1 => Status::Occluded,
                2 => Status::OutOfFrame,
                3 => Status::OutsideDomain,
                _ => Status::NoSurface,
            })
            .collect(),
    };
    c.write_npz(&path).unwrap();
    let Some(v) = load(
        &path,
        "t, s = d['target'], d['status']\n\
         print(json.dumps({'files': sorted(d.files), 't': [str(t.dtype), list(t.shape), float(t[2, 1, 0]), float(t[2, 1, 1])], \
         's': [str(s.dtype), list(s.shape), s[:, 4].tolist(), s[1].tolist()]}))",
    ) else {
        return;
    };
    assert_eq!(v["files"].to_string(), r#"["status","target"]"#);
    // Row 2, column 1 is pixel 11.
    assert_eq!(v["t"].to_string(), r#"["float32",[3,5,2],11.5,-11.0]"#);
    assert_eq!(v["s"].to_string(), r#"["uint8",[3,5],[4,4,4],[0,1,2,3,4]]"#);
}
