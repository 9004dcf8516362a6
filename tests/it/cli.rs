//! End-to-end tests of the `deformesh` command line: the real binary is run
//! on case files written into a temporary folder.
//!
//! Every bad input must fail with exit code 1 (2 is kept for tangled or
//! invalid meshes), say on stderr which field, part, file or line is wrong,
//! and leave nothing behind: no output folder, no stray files.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;
use tempfile::TempDir;

/// The file name every case is written under.
const CASE: &str = "case.toml";

/// A small valid case: the unit square onto the quarter disk of radius 1.25,
/// 6×6 cells, 10 steps, no frames. Bad cases are edits of it.
const SMALL: &str = r#"name = "small"

[mesh]
lower = [0.0, 0.0]
upper = [1.0, 1.0]
cells = [6, 6]

[[boundary]]
name = "axes"
sides = ["left", "bottom"]
kind = "slip"

[[boundary]]
name = "arc"
sides = ["right", "top"]
kind = "move"
shape = { type = "circle", centre = [0.0, 0.0], radius = 1.25 }
correspondence = "radial"
centre = [0.0, 0.0]

[time]
steps = 10
"#;

/// What a run of the binary gave.
struct Ran {
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

/// Runs `deformesh ARGS` inside `dir` (so a default `out/` would land there).
fn deformesh(dir: &Path, args: &[&str]) -> Ran {
    let out = Command::new(env!("CARGO_BIN_EXE_deformesh"))
        .args(args)
        .current_dir(dir)
        .env_remove("RUST_LOG")
        .output()
        .expect("cannot start deformesh");
    Ran {
        code: out.status.code(),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// `text` with `from` replaced by `to`; `from` must occur.
fn edit(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "`{from}` is not in the case");
    text.replacen(from, to, 1)
}

/// `"line N"` for the first line of `text` containing `needle`.
fn line_of(text: &str, needle: &str) -> String {
    let n = text.lines().position(|l| l.contains(needle)).expect("needle in text") + 1;
    format!("line {n}")
}

/// Writes `text` as the case file of `dir`.
fn write_case(dir: &Path, text: &str) -> PathBuf {
    let path = dir.join(CASE);
    std::fs::write(&path, text).unwrap();
    path
}

/// Sorted names of everything in `dir`, hidden files included.
fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    names
}

fn path_str(p: &Path) -> &str {
    p.to_str().expect("temp paths are UTF-8")
}

/// A clean failure: exit code 1, no panic, every `needle` on stderr, and
/// `dir` holding exactly `inputs` (so no output folder and no temp files).
fn assert_clean_failure(ran: &Ran, dir: &Path, needles: &[&str], inputs: &[&str]) {
    let err = &ran.stderr;
    assert_eq!(ran.code, Some(1), "exit code; stderr:\n{err}");
    assert!(!err.contains("panicked"), "panic:\n{err}");
    for needle in needles {
        assert!(err.contains(needle), "stderr lacks `{needle}`:\n{err}");
    }
    let mut expected: Vec<String> = inputs.iter().map(|s| s.to_string()).collect();
    expected.sort();
    assert_eq!(files_in(dir), expected, "files left behind; stderr:\n{err}");
}

/// Writes `extra` files and the case into a fresh folder, runs
/// `deformesh run case.toml -o out` and checks it fails cleanly, naming
/// the case file and every `needle`.
fn run_bad_case_with(text: &str, extra: &[(&str, &[u8])], needles: &[&str]) {
    let dir = TempDir::new().unwrap();
    for (name, bytes) in extra {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    let case = write_case(dir.path(), text);
    let out = dir.path().join("out");
    let ran = deformesh(dir.path(), &["run", path_str(&case), "-o", path_str(&out)]);
    let inputs: Vec<&str> = extra.iter().map(|e| e.0).chain([CASE]).collect();
    assert_clean_failure(&ran, dir.path(), needles, &inputs);
    assert!(!out.exists());
}

fn run_bad_case(text: &str, needles: &[&str]) {
    run_bad_case_with(text, &[], needles);
}

/// SMALL with a `[jacobian]` table appended.
fn with_jacobian(table: &str) -> String {
    format!("{SMALL}\n[jacobian]\n{table}")
}

/// The number after `min` on the line of `text` starting with `label`.
fn min_on_line(text: &str, label: &str) -> f64 {
    let line = text.lines().find(|l| l.starts_with(label)).unwrap_or_else(|| panic!("no `{label}` line in:\n{text}"));
    let after = line.split("min").nth(1).expect("`min` on the line");
    after.split_whitespace().next().unwrap().parse().unwrap_or_else(|e| panic!("bad number in `{line}`: {e}"))
}

fn read_json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).expect("valid JSON")
}

// ------------------------------------------------------------ bad cases

#[test]
fn unknown_field_in_shape() {
    let text = edit(SMALL, "radius = 1.25", "radiuss = 1.25");
    run_bad_case(&text, &[CASE, &line_of(&text, "radiuss"), "unknown field `radiuss`", "`radius`"]);
}

#[test]
fn unknown_top_level_key() {
    let text = edit(SMALL, "name = \"small\"\n", "name = \"small\"\ncolour = \"red\"\n");
    run_bad_case(&text, &[CASE, &line_of(&text, "colour"), "unknown field `colour`"]);
}

#[test]
fn wrong_type() {
    let text = edit(SMALL, "cells = [6, 6]", "cells = \"20\"");
    run_bad_case(&text, &[CASE, &line_of(&text, "cells"), "cells = \"20\"", "invalid type: string \"20\""]);
}

#[test]
fn move_part_without_shape() {
    let text = edit(SMALL, "shape = { type = \"circle\", centre = [0.0, 0.0], radius = 1.25 }\n", "");
    run_bad_case(&text, &[CASE, "boundary[1] (`arc`)", "needs a `shape`"]);
}

#[test]
fn side_named_twice() {
    let text = edit(SMALL, r#"sides = ["right", "top"]"#, r#"sides = ["right", "left"]"#);
    run_bad_case(&text, &[CASE, "`arc`", "side `left` is named twice", "`axes`"]);
}

#[test]
fn unknown_side() {
    let text = edit(SMALL, r#""top""#, r#""tpo""#);
    run_bad_case(&text, &[CASE, "boundary[1] (`arc`)", "unknown side `tpo`"]);
}

#[test]
fn non_positive_jacobian() {
    let text = with_jacobian("type = \"expression\"\nf = \"x - 0.5\"\n");
    run_bad_case(&text, &["not positive", "at (x, y, z) = ("]);
}

#[test]
fn expression_syntax_error() {
    let text = with_jacobian("type = \"expression\"\nf = \"1 + * x\"\n");
    run_bad_case(&text, &[CASE, "field `jacobian.f`", "column 5"]);
}

#[test]
fn image_file_missing() {
    let text = with_jacobian("type = \"image\"\nfile = \"missing.png\"\nlower = [0.0, 0.0]\nupper = [1.0, 1.0]\njacobian_ratio = 0.2\n");
    run_bad_case(&text, &[CASE, "field `jacobian.file`", "missing.png"]);
}

#[test]
fn image_file_not_png() {
    let text = with_jacobian("type = \"image\"\nfile = \"garbage.png\"\nlower = [0.0, 0.0]\nupper = [1.0, 1.0]\njacobian_ratio = 0.2\n");
    let garbage: Vec<u8> = (0..300u32).map(|i| (i * 37 % 251) as u8).collect();
    run_bad_case_with(&text, &[("garbage.png", &garbage)], &[CASE, "field `jacobian.file`", "garbage.png"]);
}

const CIRCLE_BAND: &str = "type = \"interface\"\nshape = { type = \"circle\", centre = [0.5, 0.5], radius = 0.3 }\n";

#[test]
fn interface_width_not_positive() {
    for w in ["0.0", "-0.1"] {
        let text = with_jacobian(&format!("{CIRCLE_BAND}width = {w}\nsize_ratio = 0.5\n"));
        run_bad_case(&text, &[CASE, "field `jacobian`", "interface width must be a positive number"]);
    }
}

#[test]
fn interface_ratio_missing_twice_or_not_positive() {
    let text = with_jacobian(&format!("{CIRCLE_BAND}width = 0.1\n"));
    run_bad_case(&text, &[CASE, "field `jacobian`", "needs `size_ratio`"]);
    let text = with_jacobian(&format!("{CIRCLE_BAND}width = 0.1\nsize_ratio = 0.5\njacobian_ratio = 0.25\n"));
    run_bad_case(&text, &[CASE, "not both"]);
    let text = with_jacobian(&format!("{CIRCLE_BAND}width = 0.1\nsize_ratio = -0.5\n"));
    run_bad_case(&text, &[CASE, "field `jacobian`", "must be a positive number, got -0.5"]);
}

#[test]
fn interface_needs_one_locus_and_a_valid_shape() {
    let text = with_jacobian("type = \"interface\"\nwidth = 0.1\nsize_ratio = 0.5\n");
    run_bad_case(&text, &[CASE, "exactly one of `shape` and `level_set`"]);
    let text = with_jacobian("type = \"interface\"\nshape = { type = \"circle\", centre = [0.5, 0.5], radius = -0.3 }\nwidth = 0.1\nsize_ratio = 0.5\n");
    run_bad_case(&text, &[CASE, "field `jacobian.shape`", "radius"]);
    let text = with_jacobian("type = \"interface\"\nlevel_set = \"x^2 + * y\"\nwidth = 0.1\nsize_ratio = 0.5\n");
    run_bad_case(&text, &[CASE, "field `jacobian.level_set`"]);
}

#[test]
fn combination_errors_name_the_nested_field() {
    let text = with_jacobian("type = \"min\"\nof = []\n");
    run_bad_case(&text, &[CASE, "field `jacobian.of`: lists no fields"]);
    let text = with_jacobian("type = \"product\"\n[[jacobian.of]]\ntype = \"expression\"\nf = \"1 + x\"\n[[jacobian.of]]\ntype = \"interface\"\nlevel_set = \"x - 0.5\"\nwidth = -1.0\nsize_ratio = 0.5\n");
    run_bad_case(&text, &[CASE, "field `jacobian.of[1]`", "width must be a positive number"]);
    let text = with_jacobian("type = \"min\"\n[[jacobian.of]]\ntype = \"expression\"\nf = \"1 + t\"\n");
    run_bad_case(&text, &[CASE, "t may only appear"]);
    // path and floor belong to the whole field, not to a part of it
    let text = with_jacobian("type = \"min\"\n[[jacobian.of]]\ntype = \"expression\"\nf = \"1 + x\"\npath = \"linear\"\n");
    run_bad_case(&text, &[CASE, "unknown field `path`"]);
    // a field that is not positive inside a product is found
    let text = with_jacobian("type = \"product\"\n[[jacobian.of]]\ntype = \"expression\"\nf = \"x - 0.5\"\n[[jacobian.of]]\ntype = \"uniform\"\n");
    run_bad_case(&text, &["not positive", "at (x, y, z) = ("]);
}

#[test]
fn a_floor_keeps_a_field_positive() {
    // the field of `non_positive_jacobian`, floored: the run goes through
    let dir = TempDir::new().unwrap();
    let case = write_case(dir.path(), &with_jacobian("type = \"expression\"\nf = \"x - 0.5\"\nfloor = 0.3\n"));
    let out = dir.path().join("out");
    let ran = deformesh(dir.path(), &["run", path_str(&case), "-o", path_str(&out)]);
    assert_eq!(ran.code, Some(0), "{}", ran.stderr);
    let report = read_json(&out.join("report.json"));
    assert_eq!(report["invalid_cells"], 0);
    assert!(report["jf"]["equidistribution_cov"].as_f64().unwrap() < 0.1);
    let bad = with_jacobian("type = \"expression\"\nf = \"x - 0.5\"\nfloor = -0.3\n");
    run_bad_case(&bad, &[CASE, "field `jacobian.floor`"]);
}

#[test]
fn radial_rays_miss_the_target() {
    let text = edit(SMALL, "centre = [0.0, 0.0], radius = 1.25", "centre = [-10.0, -10.0], radius = 1.0");
    run_bad_case(&text, &["boundary part `arc`", "misses the target"]);
}

#[test]
fn case_file_does_not_exist() {
    let dir = TempDir::new().unwrap();
    let case = dir.path().join("does_not_exist.toml");
    let out = dir.path().join("out");
    let ran = deformesh(dir.path(), &["run", path_str(&case), "-o", path_str(&out)]);
    assert_clean_failure(&ran, dir.path(), &["does_not_exist.toml", "cannot read"], &[]);
}

#[test]
fn quality_of_missing_file() {
    let dir = TempDir::new().unwrap();
    let mesh = dir.path().join("missing.msh");
    let ran = deformesh(dir.path(), &["quality", path_str(&mesh)]);
    assert_clean_failure(&ran, dir.path(), &["missing.msh"], &[]);
    assert!(ran.stdout.is_empty(), "{}", ran.stdout);
}

#[test]
fn quality_of_truncated_msh() {
    let dir = TempDir::new().unwrap();
    let full = deformesh::io::msh::msh_string(&deformesh::mesh::QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 2, 2));
    let cut = &full[..full.find("$EndNodes").unwrap() - 20];
    std::fs::write(dir.path().join("cut.msh"), cut).unwrap();
    let ran = deformesh(dir.path(), &["quality", path_str(&dir.path().join("cut.msh"))]);
    let line = format!("line {}: file truncated", cut.lines().count());
    assert_clean_failure(&ran, dir.path(), &["cut.msh", &line], &["cut.msh"]);
}

/// The same message must not be printed twice (an error whose Display
/// already shows its source, and which also reports it as `source()`).
#[test]
fn quality_of_missing_file_says_it_once() {
    let dir = TempDir::new().unwrap();
    let ran = deformesh(dir.path(), &["quality", "missing.msh"]);
    let cause = ran.stderr.trim().rsplit(": ").next().unwrap().to_string();
    assert_eq!(ran.stderr.matches(cause.as_str()).count(), 1, "repeated cause:\n{}", ran.stderr);
}

// ------------------------------------------------------------ good runs

#[test]
fn small_case_runs_and_quality_agrees() {
    let dir = TempDir::new().unwrap();
    let case = write_case(dir.path(), SMALL);
    let out = dir.path().join("out");
    let ran = deformesh(dir.path(), &["run", path_str(&case), "-o", path_str(&out)]);
    assert_eq!(ran.code, Some(0), "stderr:\n{}", ran.stderr);
    assert_eq!(files_in(dir.path()), [CASE, "out"]);
    assert_eq!(files_in(&out), ["mesh.msh", "mesh.png", "mesh.vtu", "report.json"]);
    assert!(std::fs::read(out.join("mesh.png")).unwrap().starts_with(b"\x89PNG\r\n\x1a\n"));

    let report = read_json(&out.join("report.json"));
    assert_eq!(report["invalid_cells"], 0, "{report:#}");
    assert_eq!(report["cells"], 36);
    let det_min = report["quality"]["det_j"]["min"].as_f64().expect("quality.det_j.min");
    assert!(det_min > 0.0);
    assert!((min_on_line(&ran.stdout, "det J") - det_min).abs() <= 1e-6 * det_min, "run printed:\n{}", ran.stdout);

    let q = deformesh(dir.path(), &["quality", path_str(&out.join("mesh.msh"))]);
    assert_eq!(q.code, Some(0), "stderr:\n{}", q.stderr);
    let printed = min_on_line(&q.stdout, "det J");
    assert!((printed - det_min).abs() <= 1e-6 * det_min, "quality says {printed}, report.json {det_min}:\n{}", q.stdout);
}

#[test]
fn demo_writes_frames_and_animation() {
    let dir = TempDir::new().unwrap();
    let out = dir.path().join("demo");
    let ran = deformesh(dir.path(), &["demo", "-o", path_str(&out)]);
    assert_eq!(ran.code, Some(0), "stderr:\n{}", ran.stderr);
    let files = files_in(&out);
    for name in ["mesh.msh", "mesh.vtu", "mesh.png", "report.json", "deformation.gif"] {
        assert!(files.iter().any(|f| f == name), "no {name} in {files:?}");
    }
    for t in ["0.00", "0.30", "0.60", "1.00"] {
        let png = std::fs::read(out.join(format!("frame_t{t}.png"))).unwrap_or_else(|e| panic!("frame t = {t}: {e}; files {files:?}"));
        assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"), "frame t = {t} is not a PNG");
    }
    assert!(std::fs::read(out.join("deformation.gif")).unwrap().starts_with(b"GIF89a"));
    assert_eq!(read_json(&out.join("report.json"))["invalid_cells"], 0);
}

#[test]
fn too_many_cells() {
    let text = edit(SMALL, "cells = [6, 6]", "cells = [4000000000, 4000000000]");
    run_bad_case(&text, &[CASE, "field `mesh.cells`", "more than this tool handles"]);
}

#[test]
fn infinite_bounds() {
    let text = edit(SMALL, "upper = [1.0, 1.0]", "upper = [inf, 1.0]");
    run_bad_case(&text, &[CASE, "must be finite"]);
}

#[test]
fn frames_with_one_file_name() {
    let text = format!("{SMALL}\n[output]\nframes = [0.301, 0.304]\n");
    run_bad_case(&text, &[CASE, "field `output.frames`", "frame_t0.30.png"]);
}

#[test]
fn mismatched_dimensions() {
    let text = edit(SMALL, "cells = [6, 6]", "cells = [6, 6, 6]");
    run_bad_case(&text, &[CASE, "expected two numbers each (2D) or three each (3D)"]);
}

#[test]
fn a_case_name_cannot_leave_the_output_folder() {
    let dir = TempDir::new().unwrap();
    let text = edit(SMALL, "name = \"small\"", "name = \"../../escaped\"");
    write_case(dir.path(), &text);
    let ran = deformesh(dir.path(), &["run", CASE]);
    assert_eq!(ran.code, Some(0), "{}", ran.stderr);
    assert!(dir.path().join("out").join(".._.._escaped").join("report.json").exists(), "{:?}", files_in(&dir.path().join("out")));
}

// ------------------------------------------------------------ curve

fn cylinder() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/cylinder_bl_coarse.msh")
}

use crate::common::WALL_CIRCLE as WALL;

#[test]
fn curve_writes_a_certified_mesh_that_quality_reads() {
    let dir = TempDir::new().unwrap();
    std::fs::write(dir.path().join("geo.toml"), WALL).unwrap();
    let cyl = cylinder();
    let ran = deformesh(dir.path(), &["curve", path_str(&cyl), "--geometry", "geo.toml", "--order", "2", "-o", "out/cyl.msh"]);
    assert_eq!(ran.code, Some(0), "{}", ran.stderr);
    assert!(ran.stderr.contains("group `farfield` is not in the geometry file"), "{}", ran.stderr);
    assert!(ran.stdout.contains("invalid elements: 0"), "{}", ran.stdout);
    // `--snap auto` is the default: on this thin wall layer the snap
    // leaves elements not certified valid, and says so, and what mended
    // them: a patch around them (issue 42)
    assert!(ran.stdout.contains("snap: not kept as it was (") && ran.stdout.contains("\nwritten: patch: the snap left "), "{}", ran.stdout);
    assert_eq!(files_in(&dir.path().join("out")), vec!["cyl.msh", "cyl.png", "cyl.report.json", "cyl.vtu"]);
    let q = deformesh(dir.path(), &["quality", "out/cyl.msh"]);
    assert_eq!(q.code, Some(0), "{}", q.stderr);
    assert!(q.stdout.starts_with("order 2 elements 368"), "{}", q.stdout);
}

#[test]
fn curve_bad_arguments_are_clean_errors() {
    let dir = TempDir::new().unwrap();
    std::fs::write(dir.path().join("geo.toml"), WALL.replace("\"wall\"", "\"hull\"")).unwrap();
    let cyl = cylinder();
    let ran = deformesh(dir.path(), &["curve", path_str(&cyl), "--geometry", "geo.toml", "-o", "out/cyl.msh"]);
    assert_eq!(ran.code, Some(1));
    assert!(ran.stderr.contains("geo.toml") && ran.stderr.contains("no boundary group `hull`"), "{}", ran.stderr);
    for (flag, value, needle) in [("--order", "5", "order 5 is not supported"), ("--spacing", "chebyshev", "--spacing must be"), ("--mode", "glide", "--mode must be"), ("--snap", "always", "--snap must be auto or never, got `always`")] {
        let ran = deformesh(dir.path(), &["curve", path_str(&cyl), "--geometry", "geo.toml", flag, value, "-o", "out/cyl.msh"]);
        assert_eq!(ran.code, Some(64), "{flag}: a usage error");
        assert!(ran.stderr.contains(needle) && !ran.stderr.contains("panicked"), "{}", ran.stderr);
    }
    assert!(!dir.path().join("out").exists());
}

#[test]
fn each_exit_code_means_one_thing() {
    let dir = TempDir::new().unwrap();
    std::fs::write(dir.path().join("geo.toml"), WALL).unwrap();
    let cyl = cylinder();
    let curve = |extra: &[&str]| {
        let mut args = vec!["curve", path_str(&cyl)];
        args.extend_from_slice(extra);
        deformesh(dir.path(), &args)
    };
    // clap's own errors are usage errors (64), not an invalid mesh (2)
    for (args, needle) in [
        (&["--geometry", "geo.toml", "--order", "-1", "-o", "out/c.msh"][..], "unexpected argument '-1'"),
        (&["--order", "2", "-o", "out/c.msh"][..], "--geometry"),
        (&["--geometry", "geo.toml", "--colour", "red", "-o", "out/c.msh"][..], "--colour"),
    ] {
        let ran = curve(args);
        assert_eq!(ran.code, Some(64), "{args:?}: {}", ran.stderr);
        assert!(ran.stderr.contains(needle), "{}", ran.stderr);
    }
    // the output: an extension that names a format, not the input itself
    for (out, format, needle) in [
        ("out/c", None, "has no extension: the extension chooses the format"),
        ("out/c.vtk", None, "the extension `.vtk`"),
        ("out/c.msh", Some("mfem"), "--format mfem writes `.mesh` files"),
        ("out/c.msh", Some("stl"), "--format must be msh41, msh22, mfem or abaqus"),
    ] {
        let mut args = vec!["--geometry", "geo.toml", "--order", "2", "-o", out];
        if let Some(f) = format {
            args.extend_from_slice(&["--format", f]);
        }
        let ran = curve(&args);
        assert_eq!(ran.code, Some(64), "{out} {format:?}: {}", ran.stderr);
        assert!(ran.stderr.contains(needle), "{}", ran.stderr);
    }
    // the input itself, by another spelling of its path (a copy: the
    // suite's data must survive a failing check)
    std::fs::copy(&cyl, dir.path().join("in.msh")).unwrap();
    let ran = deformesh(dir.path(), &["curve", "in.msh", "--geometry", "geo.toml", "-o", "./in.msh"]);
    assert_eq!(ran.code, Some(64), "{}", ran.stderr);
    assert!(ran.stderr.contains("is the input mesh"), "{}", ran.stderr);
    assert_eq!(std::fs::read(dir.path().join("in.msh")).unwrap(), std::fs::read(&cyl).unwrap(), "the input is untouched");
    // a geometry file that binds nothing is bad input (1), named
    std::fs::write(dir.path().join("empty.toml"), "# nothing\n").unwrap();
    let ran = curve(&["--geometry", "empty.toml", "--order", "2", "-o", "out/c.msh"]);
    assert_eq!(ran.code, Some(1), "{}", ran.stderr);
    assert!(ran.stderr.contains("empty.toml") && ran.stderr.contains("binds no group"), "{}", ran.stderr);
    assert!(!dir.path().join("out").exists(), "nothing written");
    // help and version succeed and list the codes
    let help = deformesh(dir.path(), &["--help"]);
    assert_eq!(help.code, Some(0));
    assert!(help.stdout.contains("Exit codes: 0 success; 1 bad input") && help.stdout.contains("64 a usage error"), "{}", help.stdout);
}

// ------------------------------------------------------------ the output folder

/// `deformesh run case.toml -o out` started in the background, with the
/// debug-build pause after each staged file and rename.
fn spawn_run(dir: &Path, case: &str, pause_ms: u64) -> std::process::Child {
    Command::new(env!("CARGO_BIN_EXE_deformesh"))
        .args(["run", case, "-o", "out"])
        .current_dir(dir)
        .env_remove("RUST_LOG")
        .env("DEFORMESH_TEST_WRITE_PAUSE_MS", pause_ms.to_string())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("cannot start deformesh")
}

/// Waits until a staged file shows in `out` (the run is writing).
fn wait_for_staging(out: &Path) {
    let start = std::time::Instant::now();
    while start.elapsed().as_secs() < 120 {
        if out.is_dir() && files_in(out).iter().any(|f| f.contains(".staged-")) {
            return;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    panic!("the run never started writing");
}

/// The files a report says were written, sorted.
fn listed_outputs(out: &Path) -> Vec<String> {
    let mut v: Vec<String> = read_json(&out.join("report.json"))["outputs"].as_array().unwrap().iter().map(|v| v.as_str().unwrap().to_string()).collect();
    v.sort();
    v
}

#[test]
fn an_output_folder_that_is_a_file_fails_before_computing() {
    let dir = TempDir::new().unwrap();
    write_case(dir.path(), SMALL);
    std::fs::write(dir.path().join("out"), "a file").unwrap();
    let ran = deformesh(dir.path(), &["run", CASE, "-o", "out"]);
    assert_clean_failure(&ran, dir.path(), &["output folder `out`", "is a file"], &[CASE, "out"]);
    // neither blamed on the case file nor found after computing
    assert!(!ran.stderr.contains(CASE) && !ran.stderr.contains("algorithm 1"), "{}", ran.stderr);
    // `curve -o` naming a folder: at once too, not blamed on the mesh
    std::fs::write(dir.path().join("geo.toml"), WALL).unwrap();
    std::fs::create_dir(dir.path().join("dir.msh")).unwrap();
    let cyl = cylinder();
    let ran = deformesh(dir.path(), &["curve", path_str(&cyl), "--geometry", "geo.toml", "-o", "dir.msh"]);
    assert_clean_failure(&ran, dir.path(), &["output `dir.msh` is a folder"], &[CASE, "out", "geo.toml", "dir.msh"]);
    assert!(!ran.stderr.contains("cylinder") && !ran.stderr.contains("algorithm 2"), "{}", ran.stderr);
}

#[test]
fn a_rerun_removes_the_earlier_runs_frames_and_a_foreign_folder_is_refused() {
    let dir = TempDir::new().unwrap();
    let with_frames = format!("{SMALL}\n[output]\nframes = [0.0, 1.0]\nanimation = true\n");
    write_case(dir.path(), &with_frames);
    assert_eq!(deformesh(dir.path(), &["run", CASE, "-o", "out"]).code, Some(0));
    let out = dir.path().join("out");
    assert!(files_in(&out).contains(&"deformation.gif".to_string()));
    write_case(dir.path(), SMALL);
    let ran = deformesh(dir.path(), &["run", CASE, "-o", "out"]);
    assert_eq!(ran.code, Some(0), "{}", ran.stderr);
    assert_eq!(files_in(&out), ["mesh.msh", "mesh.png", "mesh.vtu", "report.json"]);
    // a folder with someone's files and no report is not ours to fill
    let theirs = dir.path().join("theirs");
    std::fs::create_dir(&theirs).unwrap();
    std::fs::write(theirs.join("notes.txt"), "mine").unwrap();
    let ran = deformesh(dir.path(), &["run", CASE, "-o", "theirs"]);
    assert_eq!(ran.code, Some(1), "{}", ran.stderr);
    assert!(ran.stderr.contains("`theirs` is not empty") && ran.stderr.contains("notes.txt"), "{}", ran.stderr);
    assert_eq!(files_in(&theirs), ["notes.txt"]);
}

#[test]
fn a_failed_write_leaves_no_staged_files() {
    let dir = TempDir::new().unwrap();
    write_case(dir.path(), SMALL);
    assert_eq!(deformesh(dir.path(), &["run", CASE, "-o", "out"]).code, Some(0));
    // a folder where mesh.png goes: the write fails after staging
    let out = dir.path().join("out");
    std::fs::remove_file(out.join("mesh.png")).unwrap();
    std::fs::create_dir(out.join("mesh.png")).unwrap();
    std::fs::write(out.join("mesh.png").join("x"), "x").unwrap();
    let ran = deformesh(dir.path(), &["run", CASE, "-o", "out"]);
    assert_eq!(ran.code, Some(1), "{}", ran.stderr);
    assert!(ran.stderr.contains("mesh.png") && !ran.stderr.contains("panicked"), "{}", ran.stderr);
    assert_eq!(files_in(&out), ["mesh.msh", "mesh.png", "mesh.vtu", "report.json"]);
}

#[cfg(unix)]
#[test]
fn ctrl_c_during_the_write_leaves_nothing() {
    use std::os::unix::process::ExitStatusExt;
    let dir = TempDir::new().unwrap();
    write_case(dir.path(), SMALL);
    let child = spawn_run(dir.path(), CASE, 300);
    wait_for_staging(&dir.path().join("out"));
    // SAFETY: signalling our own child process
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGINT) }, 0);
    let done = child.wait_with_output().unwrap();
    assert_eq!(done.status.signal(), Some(libc::SIGINT), "{}", String::from_utf8_lossy(&done.stderr));
    assert_eq!(files_in(dir.path()), [CASE], "the folder this run created is gone too");
}

#[test]
fn two_runs_into_one_folder_do_not_mix_their_files() {
    let dir = TempDir::new().unwrap();
    std::fs::write(dir.path().join("a.toml"), SMALL).unwrap();
    let b = edit(SMALL, "cells = [6, 6]", "cells = [8, 8]");
    std::fs::write(dir.path().join("b.toml"), format!("{b}\n[output]\nframes = [0.0, 1.0]\n")).unwrap();
    // a writes slowly; b starts while a is writing and must wait for it
    let a = spawn_run(dir.path(), "a.toml", 250);
    let out = dir.path().join("out");
    wait_for_staging(&out);
    let b = spawn_run(dir.path(), "b.toml", 0);
    for child in [a, b] {
        let done = child.wait_with_output().unwrap();
        assert!(done.status.success(), "{}", String::from_utf8_lossy(&done.stderr));
    }
    // the folder is one run's set: b's, the later writer
    assert_eq!(files_in(&out), listed_outputs(&out));
    assert_eq!(read_json(&out.join("report.json"))["cells"], 64);
    assert!(files_in(&out).contains(&"frame_t1.00.png".to_string()));
    let q = deformesh(dir.path(), &["quality", "out/mesh.msh", "--json"]);
    assert_eq!(read_json_text(&q.stdout)["cells"], 64, "{}", q.stdout);
}

fn read_json_text(text: &str) -> Value {
    serde_json::from_str(text).expect("valid JSON")
}

// ------------------------------------------------------------ messages

/// A 2×2 box as MSH text; cell `c` is element `8 + c + 1` in it.
fn box_msh() -> String {
    deformesh::io::msh::msh_string(&deformesh::mesh::QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 2, 2))
}

#[test]
fn invalid_cells_are_named_by_their_element_tags() {
    let dir = TempDir::new().unwrap();
    let text = box_msh();
    // turn cell 2 (element 11) inside out: swap two of its nodes
    let line = text.lines().find(|l| l.starts_with("11 ")).expect("element 11").to_string();
    let f: Vec<&str> = line.split_whitespace().collect();
    let swapped = format!("{} {} {} {} {}", f[0], f[2], f[1], f[3], f[4]);
    std::fs::write(dir.path().join("bad.msh"), text.replacen(&line, &swapped, 1)).unwrap();
    let q = deformesh(dir.path(), &["quality", "bad.msh"]);
    assert_eq!(q.code, Some(2), "{}", q.stderr);
    assert!(q.stdout.contains("invalid cells: 1 [11]"), "{}", q.stdout);
    std::fs::write(dir.path().join("geo.toml"), "[[group]]\nname = \"top\"\nkind = \"fixed\"\n").unwrap();
    let ran = deformesh(dir.path(), &["curve", "bad.msh", "--geometry", "geo.toml", "--order", "2", "-o", "c.msh"]);
    assert_eq!(ran.code, Some(2), "{}", ran.stderr);
    assert!(ran.stderr.contains("already has invalid cells") && ran.stderr.contains("by their tags in the file: [11]"), "{}", ran.stderr);
}

#[test]
fn a_bound_group_that_no_element_carries_is_an_error() {
    let dir = TempDir::new().unwrap();
    let text = std::fs::read_to_string(cylinder()).unwrap();
    let ghost = text.replacen("$PhysicalNames\n3\n", "$PhysicalNames\n4\n1 7 \"ghost\"\n", 1);
    assert_ne!(ghost, text);
    std::fs::write(dir.path().join("cyl.msh"), ghost).unwrap();
    std::fs::write(dir.path().join("geo.toml"), format!("{WALL}[[group]]\nname = \"ghost\"\nkind = \"fixed\"\n")).unwrap();
    let ran = deformesh(dir.path(), &["curve", "cyl.msh", "--geometry", "geo.toml", "--order", "2", "-o", "c.msh"]);
    assert_clean_failure(&ran, dir.path(), &["geo.toml", "`ghost`", "no boundary element carries it"], &["cyl.msh", "geo.toml"]);
}

#[test]
fn triangles_and_mixed_plane_meshes_are_read_and_serendipity_pyramids_refused_naming_the_block() {
    let dir = TempDir::new().unwrap();
    let tri = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 3 1 3\n2 1 0 3\n1\n2\n3\n0 0 0\n1 0 0\n0 1 0\n$EndNodes\n$Elements\n1 1 1 1\n2 1 2 1\n1 1 2 3\n$EndElements\n";
    std::fs::write(dir.path().join("tri.msh"), tri).unwrap();
    let ran = deformesh(dir.path(), &["quality", "tri.msh"]);
    // the reference triangle itself: det J 1, corners of 90°, 45°, 45°:
    // Gmsh's minSIGE, the mean corner sine over sin 60°, (2/√3)(1 + √2)/3
    // = 0.9292
    assert_eq!(ran.code, Some(0), "{}", ran.stderr);
    assert!(ran.stdout.contains("cells 1  nodes 3") && ran.stdout.contains("min 1.000000e0  max 1.000000e0") && ran.stdout.contains("min 0.9292"), "{}", ran.stdout);
    // a unit square and the triangle (1,0), (2,0), (1,1) in one surface:
    // det J 1 on both, scaled Jacobians 1 (the square) and 0.9292
    let mixed = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 5 1 5\n2 1 0 5\n1\n2\n3\n4\n5\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 0 0\n$EndNodes\n$Elements\n2 2 1 2\n2 1 3 1\n1 1 2 3 4\n2 1 2 1\n2 2 5 3\n$EndElements\n";
    std::fs::write(dir.path().join("mixed.msh"), mixed).unwrap();
    let ran = deformesh(dir.path(), &["quality", "mixed.msh"]);
    assert_eq!(ran.code, Some(0), "{}", ran.stderr);
    assert!(ran.stdout.contains("elements 2  nodes 5") && ran.stdout.contains("min >= 1.000000e0") && ran.stdout.contains("min 0.9292  max 1.0000"), "{}", ran.stdout);
    std::fs::write(dir.path().join("pyramid.msh"), tri.replace("2 1 2 1", "2 1 19 1")).unwrap();
    let ran = deformesh(dir.path(), &["quality", "pyramid.msh"]);
    assert_clean_failure(&ran, dir.path(), &["pyramid.msh", "line 16", "element type 19", "13-node (serendipity) pyramid"], &["mixed.msh", "pyramid.msh", "tri.msh"]);
}

#[test]
fn a_garbage_file_is_not_echoed() {
    let dir = TempDir::new().unwrap();
    let garbage: Vec<u8> = (0..4000u32).map(|i| (i.wrapping_mul(2654435761) >> 13) as u8).collect();
    std::fs::write(dir.path().join("junk.msh"), &garbage).unwrap();
    std::fs::write(dir.path().join("geo.toml"), WALL).unwrap();
    for args in [vec!["quality", "junk.msh"], vec!["curve", "junk.msh", "--geometry", "geo.toml", "-o", "c.msh"]] {
        let ran = deformesh(dir.path(), &args);
        assert_clean_failure(&ran, dir.path(), &["junk.msh"], &["junk.msh", "geo.toml"]);
        let printable = |c: char| c == '\n' || (' '..='~').contains(&c) || "²³·φ∂∇≤≥−…".contains(c);
        assert!(ran.stderr.chars().all(printable), "raw bytes echoed:\n{:?}", ran.stderr);
        assert!(ran.stderr.len() < 600, "{}", ran.stderr);
    }
}

#[test]
fn a_missing_mesh_is_said_once() {
    let dir = TempDir::new().unwrap();
    std::fs::write(dir.path().join("geo.toml"), WALL).unwrap();
    let ran = deformesh(dir.path(), &["curve", "missing.msh", "--geometry", "geo.toml", "-o", "c.msh"]);
    assert_clean_failure(&ran, dir.path(), &["missing.msh"], &["geo.toml"]);
    let cause = ran.stderr.trim().rsplit(": ").next().unwrap().to_string();
    assert_eq!(ran.stderr.matches(cause.as_str()).count(), 1, "repeated cause:\n{}", ran.stderr);
}

#[test]
fn the_help_names_every_element_kind() {
    let dir = TempDir::new().unwrap();
    let ran = deformesh(dir.path(), &["--help"]);
    assert_eq!(ran.code, Some(0));
    let first = ran.stdout.lines().next().unwrap_or_default();
    for kind in ["triangles", "quads", "tetrahedra", "hexes", "prisms", "pyramids", "mixed"] {
        assert!(first.contains(kind), "{kind} missing from: {first}");
    }
}

#[test]
fn curve_cad_without_gmsh_says_how_to_install_it_and_exits_69() {
    let dir = TempDir::new().unwrap();
    let mesh = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/cylinder_bl_coarse.msh");
    let step = dir.path().join("model.step");
    std::fs::write(&step, "ISO-10303-21;\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_deformesh"))
        .args(["curve", mesh.to_str().unwrap(), "--cad", step.to_str().unwrap(), "-o"])
        .arg(dir.path().join("out.msh"))
        .env("DEFORMESH_GMSH_LIB", dir.path().join("nowhere/libgmsh.so"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(69), "{err}");
    assert!(err.contains("DEFORMESH_GMSH_LIB") && err.contains("pip install gmsh") && err.contains("nowhere"), "{err}");
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|f| f.unwrap().file_name()).collect();
    assert_eq!(left, vec![std::ffi::OsString::from("model.step")], "nothing written");
}
