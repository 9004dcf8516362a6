//! Helpers shared by the tests that run the real Gmsh and VTK.
//!
//! The Python interpreter is `$DEFORMESH_PYTHON`, else `.venv/bin/python` in
//! the crate; `scripts/test.sh` sets the latter up.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

/// The Python with `gmsh` and `vtk`, or a panic saying how to get one.
pub fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("DEFORMESH_PYTHON") {
        let p = PathBuf::from(p);
        assert!(p.exists(), "DEFORMESH_PYTHON={} does not exist", p.display());
        return p;
    }
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv/bin/python");
    assert!(
        venv.exists(),
        "no Python with gmsh and vtk: set DEFORMESH_PYTHON or run scripts/test.sh \
         (it creates {} and runs the tests)",
        venv.display()
    );
    venv
}

/// Runs `tests/python/<script> <file>` and parses the JSON it prints.
pub fn run_checker(script: &str, file: &Path) -> Value {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python").join(script);
    let out = Command::new(python()).arg(&script).arg(file).output().expect("cannot start Python");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{} failed: {stderr}", script.display());
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("bad JSON from {}: {e}\n{stderr}", script.display()))
}

/// The JSON array `v` as `f64`s.
pub fn floats(v: &Value) -> Vec<f64> {
    v.as_array().expect("array").iter().map(|x| x.as_f64().expect("number")).collect()
}
